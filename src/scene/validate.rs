//! Checks on single values and on the tables that hold them, turning the spanned file
//! types of `format` into [`crate::defs`] types. Every check that fails gives one
//! [`SceneError`] pointing at the offending value.

use std::collections::HashMap;
use std::ops::Range;

use glam::Vec2;

use super::error::SceneError;
use super::format::*;
use crate::defs::*;
use crate::shape::MAX_POLYGON_VERTICES;
use crate::world::{BodyInput, BuildError, World};

mod body;

pub(crate) use body::Material;

/// The most points a `polygon` may list (its hull may have at most
/// [`MAX_POLYGON_VERTICES`] vertices).
pub const MAX_POLYGON_POINTS: usize = 64;

/// The bounds on iterations and substeps (defined with the other solver ranges).
pub use crate::defs::{MAX_ITERATIONS, MAX_SUBSTEPS};

/// The largest friction coefficient: two bodies' coefficients are mixed as sqrt(a b),
/// and the product must stay finite in f32 (real ones are below 2).
pub const MAX_FRICTION: f32 = 1e6;

/// Filter category names a scene may use, "default" included (one bit each of a u32).
pub const MAX_CATEGORIES: usize = 32;

/// Results of this module.
pub(crate) type R<T> = Result<T, SceneError>;

/// Where messages point: the file's name (as given) and its text.
pub(crate) struct Ctx<'a> {
    pub file: &'a str,
    pub text: &'a str,
    /// The scene's origin (m): taken off every point before it becomes f32
    /// ([`crate::defs::WorldDef::origin`]).
    pub origin: [f64; 2],
}

/// `[x, y]` as messages write it.
pub(crate) fn fmt_v2(v: [f32; 2]) -> String {
    format!("[{}, {}]", v[0], v[1])
}

impl Ctx<'_> {
    /// An error at the start of `span`.
    pub fn err(&self, span: Range<usize>, message: impl Into<String>) -> SceneError {
        SceneError::at_span(self.file, self.text, span, message)
    }

    /// Where element `k` of the array at `span` starts in the text (`span` itself when
    /// the text there is not an array, or has no such element): so that a bad component
    /// of `[x, y]` is pointed at, not the bracket before it.
    pub fn element(&self, span: Range<usize>, k: usize) -> Range<usize> {
        let b = self.text.as_bytes();
        if b.get(span.start) != Some(&b'[') {
            return span;
        }
        let end = span.end.min(b.len());
        let (mut i, mut depth, mut index) = (span.start + 1, 0usize, 0usize);
        let mut at_start = true;
        while i < end {
            let c = b[i];
            match c {
                b'#' => {
                    while i < end && b[i] != b'\n' {
                        i += 1;
                    }
                    continue;
                }
                b' ' | b'\t' | b'\n' | b'\r' => {}
                _ if at_start => {
                    if index == k {
                        return i..span.end;
                    }
                    at_start = false;
                    continue;
                }
                b'"' | b'\'' => {
                    // a string: skip to its closing quote
                    let q = c;
                    i += 1;
                    while i < end && b[i] != q {
                        i += if b[i] == b'\\' { 2 } else { 1 };
                    }
                }
                b'[' | b'{' => depth += 1,
                b']' | b'}' if depth == 0 => break,
                b']' | b'}' => depth -= 1,
                b',' if depth == 0 => {
                    index += 1;
                    at_start = true;
                }
                _ => {}
            }
            i += 1;
        }
        span
    }

    /// A finite number.
    pub fn finite(&self, who: &str, key: &str, v: &S<f32>) -> R<f32> {
        let x = *v.get_ref();
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(
                v.span(),
                format!("{who}: {key} must be a finite number, got {x}"),
            ))
        }
    }

    /// A finite number > 0.
    pub fn positive(&self, who: &str, key: &str, v: &S<f32>) -> R<f32> {
        let x = self.finite(who, key, v)?;
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(v.span(), format!("{who}: {key} must be > 0, got {x}")))
        }
    }

    /// A finite number >= 0.
    pub fn non_negative(&self, who: &str, key: &str, v: &S<f32>) -> R<f32> {
        let x = self.finite(who, key, v)?;
        if x >= 0.0 {
            Ok(x)
        } else {
            Err(self.err(v.span(), format!("{who}: {key} must be >= 0, got {x}")))
        }
    }

    /// A number in [0, 1].
    pub fn unit(&self, who: &str, key: &str, v: &S<f32>) -> R<f32> {
        let x = self.finite(who, key, v)?;
        if (0.0..=1.0).contains(&x) {
            Ok(x)
        } else {
            Err(self.err(v.span(), format!("{who}: {key} must be in [0, 1], got {x}")))
        }
    }

    /// An optional value checked by `check`, or `default`.
    pub fn opt<T: Copy>(
        &self,
        v: Option<&S<f32>>,
        default: T,
        check: impl FnOnce(&S<f32>) -> R<T>,
    ) -> R<T> {
        match v {
            Some(v) => check(v),
            None => Ok(default),
        }
    }

    /// A count >= 1.
    pub fn count(&self, who: &str, key: &str, v: &S<u32>) -> R<u32> {
        let n = *v.get_ref();
        if n >= 1 {
            Ok(n)
        } else {
            Err(self.err(v.span(), format!("{who}: {key} must be >= 1, got {n}")))
        }
    }

    /// A vector with finite components.
    pub fn vec2(&self, who: &str, key: &str, v: &S<V2>) -> R<Vec2> {
        let a = v.get_ref().0;
        if a.iter().all(|x| x.is_finite()) {
            Ok(Vec2::from(a))
        } else {
            let k = a.iter().position(|x| !x.is_finite()).unwrap_or(0);
            Err(self.err(
                self.element(v.span(), k),
                format!(
                    "{who}: {key} must have finite components, got {}",
                    fmt_v2(a)
                ),
            ))
        }
    }

    /// A point in the world, relative to the scene's origin: finite, and within f32's
    /// range once the origin is taken off.
    pub fn point(&self, who: &str, key: &str, v: &S<P2>) -> R<Vec2> {
        let a = v.get_ref().0;
        let local = Vec2::new(
            (a[0] - self.origin[0]) as f32,
            (a[1] - self.origin[1]) as f32,
        );
        if a.iter().all(|x| x.is_finite()) && local.is_finite() {
            Ok(local)
        } else {
            let k = if a[0].is_finite() && local.x.is_finite() {
                1
            } else {
                0
            };
            Err(self.err(
                self.element(v.span(), k),
                format!(
                    "{who}: {key} must have finite components, got [{}, {}]",
                    a[0], a[1]
                ),
            ))
        }
    }

    /// A world point given in f32 (a default), relative to the scene's origin.
    pub fn local(&self, p: Vec2) -> Vec2 {
        Vec2::new(
            (p.x as f64 - self.origin[0]) as f32,
            (p.y as f64 - self.origin[1]) as f32,
        )
    }

    /// An optional point, or `default` (a world point, made relative here).
    pub fn opt_point(&self, who: &str, key: &str, v: Option<&S<P2>>, default: Vec2) -> R<Vec2> {
        v.map_or(Ok(self.local(default)), |v| self.point(who, key, v))
    }

    /// An optional vector, or `default`.
    pub fn opt_vec2(&self, who: &str, key: &str, v: Option<&S<V2>>, default: Vec2) -> R<Vec2> {
        v.map_or(Ok(default), |v| self.vec2(who, key, v))
    }

    /// A size: both components finite and > 0.
    pub fn size(&self, who: &str, key: &str, v: &S<V2>) -> R<Vec2> {
        let s = self.vec2(who, key, v)?;
        if s.x > 0.0 && s.y > 0.0 {
            Ok(s)
        } else {
            Err(self.err(
                self.element(v.span(), if s.x > 0.0 { 1 } else { 0 }),
                format!(
                    "{who}: {key} size must be > 0, got {}",
                    fmt_v2(v.get_ref().0)
                ),
            ))
        }
    }

    /// One of a fixed set of strings.
    pub fn choice<T: Copy>(
        &self,
        who: &str,
        key: &str,
        v: &S<String>,
        options: &[(&str, T)],
    ) -> R<T> {
        let s = v.get_ref().as_str();
        match options.iter().find(|(name, _)| *name == s) {
            Some((_, t)) => Ok(*t),
            None => {
                let allowed: Vec<String> =
                    options.iter().map(|(n, _)| format!("\"{n}\"")).collect();
                Err(self.err(
                    v.span(),
                    format!(
                        "{who}: unknown {key} {s:?}; expected one of {}",
                        allowed.join(", ")
                    ),
                ))
            }
        }
    }

    /// A colour `"#rrggbb"` or `"#rrggbbaa"`.
    pub fn color(&self, who: &str, v: &S<String>) -> R<Color> {
        let s = v.get_ref().as_str();
        let bad = || {
            self.err(
                v.span(),
                format!(
                    "{who}: color must be \"#rrggbb\" or \"#rrggbbaa\" (hex digits), got {s:?}"
                ),
            )
        };
        let hex = s.strip_prefix('#').ok_or_else(bad)?;
        if !(hex.len() == 6 || hex.len() == 8) || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(bad());
        }
        let mut c = [0, 0, 0, 255];
        for (i, byte) in c.iter_mut().enumerate().take(hex.len() / 2) {
            *byte = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).map_err(|_| bad())?;
        }
        Ok(c)
    }

    /// `[world]`: gravity and drag.
    pub fn world(&self, w: &FileWorld) -> R<(Option<Vec2>, Option<DragDef>)> {
        let gravity = w
            .gravity
            .as_ref()
            .map(|g| self.vec2("world", "gravity", g))
            .transpose()?;
        let drag = match &w.drag {
            None => None,
            Some(d) => {
                let who = "world.drag";
                let f = d.get_ref();
                let nn = |v: Option<&S<f32>>, key: &str| {
                    self.opt(v, 0.0, |v| self.non_negative(who, key, v))
                };
                let drag = DragDef {
                    linear: nn(f.linear.as_ref(), "linear")?,
                    quadratic: nn(f.quadratic.as_ref(), "quadratic")?,
                    fluid_density: nn(f.fluid_density.as_ref(), "fluid_density")?,
                    drag_coefficient: nn(f.drag_coefficient.as_ref(), "drag_coefficient")?,
                };
                // One of the pair alone gives no force: surely a mistake.
                match (&f.fluid_density, &f.drag_coefficient) {
                    (Some(v), None) | (None, Some(v)) => {
                        return Err(self.err(
                            v.span(),
                            format!("{who}: fluid drag needs both `fluid_density` and `drag_coefficient`"),
                        ));
                    }
                    _ => {}
                }
                Some(drag)
            }
        };
        Ok((gravity, drag))
    }

    /// `[solver]`. Ranges come from [`SolverSettings::check_value`], the one place
    /// they are defined. `soft_step = true` is the old spelling of `kind = "soft"` (and
    /// `soft_step = false` of `kind = "pgs"`).
    pub fn solver(&self, s: &FileSolver) -> R<SolverOverrides> {
        let who = "solver";
        let checked = |key: &str, span: std::ops::Range<usize>, value: f64| -> R<()> {
            match SolverSettings::check_value(key, value) {
                None => Ok(()),
                Some(e) => Err(self.err(span, format!("{who}: {e}"))),
            }
        };
        let count = |v: &Option<S<u32>>, key: &str| -> R<Option<u32>> {
            v.as_ref()
                .map(|v| checked(key, v.span(), *v.get_ref() as f64).map(|_| *v.get_ref()))
                .transpose()
        };
        let f = |v: &Option<S<f32>>, key: &str| -> R<Option<f32>> {
            v.as_ref()
                .map(|v| checked(key, v.span(), *v.get_ref() as f64).map(|_| *v.get_ref()))
                .transpose()
        };
        let names: Vec<(&str, SolverKind)> =
            SolverKind::ALL.iter().map(|&k| (k.name(), k)).collect();
        let mut kind = s
            .kind
            .as_ref()
            .map(|k| self.choice(who, "kind", k, &names))
            .transpose()?;
        if let Some(v) = &s.soft_step {
            let old = if *v.get_ref() {
                SolverKind::Soft
            } else {
                SolverKind::Pgs
            };
            match kind {
                Some(k) if k != old => {
                    return Err(self.err(
                        v.span(),
                        format!(
                            "{who}: soft_step = {} contradicts kind = \"{}\" (soft_step is the old spelling of kind = \"{}\")",
                            v.get_ref(),
                            k.name(),
                            old.name()
                        ),
                    ));
                }
                _ => kind = Some(old),
            }
        }
        Ok(SolverOverrides {
            kind,
            dt: f(&s.dt, "dt")?,
            substeps: count(&s.substeps, "substeps")?,
            iterations: count(&s.iterations, "iterations")?,
            tolerance: f(&s.tolerance, "tolerance")?,
            warm_start: s.warm_start.as_ref().map(|v| *v.get_ref()),
            baumgarte: f(&s.baumgarte, "baumgarte")?,
            slop: f(&s.slop, "slop")?,
            split_impulse: s.split_impulse.as_ref().map(|v| *v.get_ref()),
            block_solve: s.block_solve.as_ref().map(|v| *v.get_ref()),
            sleep: s.sleep.as_ref().map(|v| *v.get_ref()),
            restitution_threshold: f(&s.restitution_threshold, "restitution_threshold")?,
            contact_hertz: f(&s.contact_hertz, "contact_hertz")?,
            contact_damping_ratio: f(&s.contact_damping_ratio, "contact_damping_ratio")?,
            max_push_speed: f(&s.max_push_speed, "max_push_speed")?,
            joint_hertz: f(&s.joint_hertz, "joint_hertz")?,
            joint_damping_ratio: f(&s.joint_damping_ratio, "joint_damping_ratio")?,
        })
    }

    /// `[camera]`.
    pub fn camera(&self, c: &FileCamera) -> R<CameraDef> {
        let who = "camera";
        let d = CameraDef::default();
        let size = match &c.size {
            None => d.size,
            Some(s) => {
                let [w, h] = s.get_ref().0;
                let max = crate::defs::MAX_FRAME_SIDE;
                if let Some(k) = [w, h].iter().position(|&x| !(1..=max).contains(&x)) {
                    return Err(self.err(
                        self.element(s.span(), k),
                        format!("{who}: size must be 1..={max} pixels each way, got [{w}, {h}]"),
                    ));
                }
                [w, h]
            }
        };
        Ok(CameraDef {
            center: self.opt_point(who, "center", c.center.as_ref(), d.center)?,
            pixels_per_meter: self.opt(c.pixels_per_meter.as_ref(), d.pixels_per_meter, |v| {
                self.positive(who, "pixels_per_meter", v)
            })?,
            size,
        })
    }
}

/// Where a body's values are in the file, to point at the one that makes a derived
/// quantity (mass, inertia, centre of mass, energy) unusable. A value the table does
/// not give points at what it is derived from, or at the table.
#[derive(Clone, Debug)]
pub(crate) struct Places {
    pub shape: Range<usize>,
    pub mass: Range<usize>,
    pub position: Range<usize>,
    pub velocity: Range<usize>,
    pub angular_velocity: Range<usize>,
}

impl Places {
    /// Every value at `span`.
    pub fn all(span: Range<usize>) -> Places {
        Places {
            shape: span.clone(),
            mass: span.clone(),
            position: span.clone(),
            velocity: span.clone(),
            angular_velocity: span,
        }
    }

    fn of(&self, input: BodyInput) -> Range<usize> {
        match input {
            BodyInput::Shape => self.shape.clone(),
            BodyInput::Mass => self.mass.clone(),
            BodyInput::Position => self.position.clone(),
            BodyInput::Velocity => self.velocity.clone(),
            BodyInput::AngularVelocity => self.angular_velocity.clone(),
        }
    }
}

/// The bodies made so far, in creation order, with where each was declared, and the
/// names already taken.
#[derive(Default)]
pub(crate) struct Bodies {
    pub defs: Vec<BodyDef>,
    /// Index by name.
    pub index: HashMap<String, usize>,
    /// Where each body was declared (its name, or its generator's table).
    pub spans: Vec<Range<usize>>,
    /// The world's gravity (for the potential energy check).
    pub gravity: Option<Vec2>,
    /// Each body's box, whether it is dynamic, and its filter: for the count of the
    /// pairs the world starts with ([`crate::world::count_start_pairs`]).
    pub boxes: Vec<crate::math::Aabb>,
    pub dynamic: Vec<bool>,
    pub filters: Vec<Filter>,
}

impl Bodies {
    /// Add a body; refuses a name already taken, or a body whose derived quantities
    /// (mass, inertia, centre of mass, energy) the world could not use, pointing at the
    /// value in `places` that makes them.
    pub fn push(
        &mut self,
        ctx: &Ctx,
        body: BodyDef,
        span: Range<usize>,
        places: &Places,
    ) -> R<usize> {
        if let Some(&first) = self.index.get(&body.name) {
            let (line, _) = super::error::line_col(ctx.text, self.spans[first].start);
            return Err(ctx.err(
                span,
                format!(
                    "duplicate body name {:?} (first used at line {line})",
                    body.name
                ),
            ));
        }
        if self.defs.len() as u64 >= super::MAX_GENERATED {
            return Err(ctx.err(
                span,
                format!(
                    "too many bodies: at most {} in one file",
                    super::MAX_GENERATED
                ),
            ));
        }
        let made = check_body(ctx, &body, self.gravity, places)?;
        self.boxes.push(made.aabb());
        self.dynamic.push(made.is_dynamic());
        self.filters.push(made.filter);
        let i = self.defs.len();
        self.index.insert(body.name.clone(), i);
        self.defs.push(body);
        self.spans.push(span);
        Ok(i)
    }

    /// The index of the body named by `v`, or an error naming `who`.
    pub fn find(&self, ctx: &Ctx, who: &str, v: &S<String>) -> R<usize> {
        self.index
            .get(v.get_ref())
            .copied()
            .ok_or_else(|| ctx.err(v.span(), format!("{who}: no body named {:?}", v.get_ref())))
    }
}

/// Builds `body` as the world will ([`World::make_body`]) and turns a refusal into an
/// error at the value that caused it.
pub(crate) fn check_body(
    ctx: &Ctx,
    body: &BodyDef,
    gravity: Option<Vec2>,
    places: &Places,
) -> R<crate::body::Body> {
    match World::make_body(body, gravity) {
        Ok(b) => Ok(b),
        Err(e) => {
            let span = match &e {
                BuildError::Derived { input, .. } => places.of(*input),
                BuildError::Shape { .. } | BuildError::ParticleShape(_) => places.shape.clone(),
                BuildError::NotPositive { .. } => places.mass.clone(),
                _ => places.position.clone(),
            };
            Err(ctx.err(span, e.to_string()))
        }
    }
}

/// Builds `joint` between the bodies it names as the world will, and refuses one whose
/// derived values (length, anchor offsets) are not finite, at `span`. Returns the
/// joint's length as built (`None` if its bodies could not be made, which their own
/// checks refuse first).
pub(crate) fn check_joint(
    ctx: &Ctx,
    bodies: &Bodies,
    who: &str,
    joint: &JointDef,
    span: Range<usize>,
) -> R<Option<f32>> {
    let make = |i: usize| World::make_body(&bodies.defs[i], bodies.gravity);
    let (Ok(a), Ok(b)) = (make(joint.bodies[0]), make(joint.bodies[1])) else {
        // both were checked when they were added
        return Ok(None);
    };
    let pair = JointDef {
        bodies: [0, 1],
        ..joint.clone()
    };
    let j = crate::joint::Joint::from_def(&pair, &[a, b]);
    match j.not_finite() {
        None => Ok(Some(j.length)),
        Some(what) => Err(ctx.err(
            span,
            format!("{who}: the joint's {what} is not finite (its bodies or anchors are too far apart for f32)"),
        )),
    }
}

/// A `[[force]]` table.
pub(crate) fn force(ctx: &Ctx, bodies: &Bodies, f: &FileForce) -> R<ForceDef> {
    let who = "force";
    Ok(ForceDef {
        body: bodies.find(ctx, who, &f.body)?,
        force: ctx.vec2(who, "force", &f.force)?,
        point: ctx.opt_point(who, "point", f.point.as_ref(), Vec2::ZERO)?,
    })
}

/// A `[[joint]]` table. Keys that do not apply to the joint's type are refused
/// rather than ignored. A `rope` is a distance joint with limits [0, length].
pub(crate) fn joint(ctx: &Ctx, bodies: &Bodies, j: &FileJoint) -> R<JointDef> {
    use JointKind::*;
    let (kind, rope) = ctx.choice(
        "joint",
        "type",
        &j.type_,
        &[
            ("distance", (Distance, false)),
            ("hinge", (Hinge, false)),
            ("prismatic", (Prismatic, false)),
            ("weld", (Weld, false)),
            ("rope", (Distance, true)),
            ("wheel", (Wheel, false)),
            ("motor", (Motor, false)),
            ("pulley", (Pulley, false)),
        ],
    )?;
    let kind_name = j.type_.get_ref().as_str();
    let [a, b] = &j.bodies.get_ref().0;
    let who = format!("{kind_name} joint {:?}-{:?}", a.get_ref(), b.get_ref());
    let who = who.as_str();
    let ia = bodies.find(ctx, who, a)?;
    let ib = bodies.find(ctx, who, b)?;
    if ia == ib {
        return Err(ctx.err(
            j.bodies.span(),
            format!(
                "{who}: a joint cannot join body {:?} to itself",
                a.get_ref()
            ),
        ));
    }
    // Refuse a key that `kind` does not take.
    let not_for = |span: Option<Range<usize>>, key: &str, takes: &str| -> R<()> {
        match span {
            Some(span) => Err(ctx.err(
                span,
                format!("{who}: `{key}` does not apply to a {kind_name} joint{takes}"),
            )),
            None => Ok(()),
        }
    };
    let span_of = |v: Option<Range<usize>>, applies: bool| if applies { None } else { v };
    let point_like = matches!(kind, Hinge | Weld | Prismatic | Wheel);
    not_for(
        span_of(j.anchor.as_ref().map(|v| v.span()), point_like),
        "anchor",
        match kind {
            _ if rope => " (a rope takes `anchors`)",
            Distance => " (a distance joint takes `anchors`)",
            Pulley => " (a pulley takes `anchors` and `ground_anchors`)",
            _ => " (a motor joint takes `offset`)",
        },
    )?;
    not_for(
        span_of(
            j.anchors.as_ref().map(|v| v.span()),
            matches!(kind, Distance | Pulley),
        ),
        "anchors",
        if kind == Motor {
            " (a motor joint takes `offset`)"
        } else {
            " (it takes `anchor`)"
        },
    )?;
    not_for(
        span_of(j.length.as_ref().map(|v| v.span()), kind == Distance),
        "length",
        if kind == Pulley {
            " (its length_a + ratio length_b is the one at creation)"
        } else {
            ""
        },
    )?;
    not_for(
        span_of(
            j.axis.as_ref().map(|v| v.span()),
            matches!(kind, Prismatic | Wheel),
        ),
        "axis",
        "",
    )?;
    not_for(
        span_of(
            j.limits.as_ref().map(|v| v.span()),
            matches!(kind, Hinge | Prismatic | Distance | Wheel) && !rope,
        ),
        "limits",
        if rope {
            " (its `length` is the max length; it is slack below)"
        } else {
            ""
        },
    )?;
    // A rope's max length is a hard limit: the limit rows of PGS and the soft step
    // are rigid, so a compliance would not mean the same under every solver. A motor
    // joint is bounded by its max force and torque, a pulley is rigid like a rope.
    not_for(
        span_of(
            j.compliance.as_ref().map(|v| v.span()),
            !rope && kind != Motor && kind != Pulley,
        ),
        "compliance",
        match kind {
            _ if rope => " (a rope is rigid at its max length)",
            Pulley => " (a pulley is rigid when taut)",
            _ => " (it is bounded by `max_force` and `max_torque`)",
        },
    )?;
    let driven = matches!(kind, Hinge | Prismatic | Wheel);
    not_for(
        span_of(j.motor.as_ref().map(|v| v.span()), driven),
        "motor",
        if kind == Motor {
            " (a motor joint takes `max_force` and `max_torque`)"
        } else {
            ""
        },
    )?;
    not_for(
        span_of(
            j.servo.as_ref().map(|v| v.span()),
            matches!(kind, Hinge | Prismatic),
        ),
        "servo",
        "",
    )?;
    not_for(
        span_of(
            j.damping.as_ref().map(|v| v.span()),
            !matches!(kind, Wheel | Motor | Pulley),
        ),
        "damping",
        if kind == Wheel {
            " (its suspension's damping is `spring.damping_ratio`)"
        } else {
            ""
        },
    )?;
    not_for(
        span_of(
            j.spring.as_ref().map(|v| v.span()),
            matches!(kind, Wheel | Hinge),
        ),
        "spring",
        "",
    )?;
    not_for(
        span_of(j.reference_angle.as_ref().map(|v| v.span()), kind == Hinge),
        "reference_angle",
        "",
    )?;
    if let (Some(_), Some(sp)) = (&j.servo, &j.spring) {
        return Err(ctx.err(
            sp.span(),
            format!(
                "{who}: a hinge takes a `servo` (rigid, to a target) or a `spring` (soft, to its zero angle), not both"
            ),
        ));
    }
    for (key, v) in [
        ("offset", j.offset.as_ref().map(|v| v.span())),
        ("angle", j.angle.as_ref().map(|v| v.span())),
        ("max_force", j.max_force.as_ref().map(|v| v.span())),
        ("max_torque", j.max_torque.as_ref().map(|v| v.span())),
        ("correction", j.correction.as_ref().map(|v| v.span())),
    ] {
        let takes = if driven {
            " (its `motor` takes them)"
        } else {
            ""
        };
        let takes = if key == "max_force" || key == "max_torque" {
            takes
        } else {
            ""
        };
        not_for(span_of(v, kind == Motor), key, takes)?;
    }
    not_for(
        span_of(j.ground_anchors.as_ref().map(|v| v.span()), kind == Pulley),
        "ground_anchors",
        "",
    )?;
    not_for(
        span_of(j.ratio.as_ref().map(|v| v.span()), kind == Pulley),
        "ratio",
        "",
    )?;

    let anchor = j
        .anchor
        .as_ref()
        .map(|v| ctx.point(who, "anchor", v))
        .transpose()?;
    let anchors = match &j.anchors {
        Some(v) => {
            let [p, q] = &v.get_ref().0;
            Some([ctx.point(who, "anchors", p)?, ctx.point(who, "anchors", q)?])
        }
        None => None,
    };
    let length = j
        .length
        .as_ref()
        .map(|v| ctx.positive(who, "length", v))
        .transpose()?;
    let axis = match &j.axis {
        Some(v) => {
            let axis = ctx.vec2(who, "axis", v)?;
            if axis.length() <= 1e-6 {
                return Err(ctx.err(
                    v.span(),
                    format!(
                        "{who}: axis must have a non-zero length, got {}",
                        fmt_v2(axis.into())
                    ),
                ));
            }
            Some(axis)
        }
        None => None,
    };
    let limits = match &j.limits {
        Some(v) => {
            let l = ctx.vec2(who, "limits", v)?;
            if l.x > l.y {
                return Err(ctx.err(
                    v.span(),
                    format!(
                        "{who}: limits must have min <= max, got {}",
                        fmt_v2(l.into())
                    ),
                ));
            }
            if kind == Distance && l.x < 0.0 {
                return Err(ctx.err(
                    v.span(),
                    format!(
                        "{who}: length limits must be >= 0, got {}",
                        fmt_v2(l.into())
                    ),
                ));
            }
            Some([l.x, l.y])
        }
        None => None,
    };
    let motor = match &j.motor {
        Some(m) => {
            let f = m.get_ref();
            let (key, other, given, wrong) = if kind == Hinge || kind == Wheel {
                ("max_torque", "max_force", &f.max_torque, &f.max_force)
            } else {
                ("max_force", "max_torque", &f.max_force, &f.max_torque)
            };
            if let Some(w) = wrong {
                return Err(ctx.err(
                    w.span(),
                    format!("{who}: a {kind_name} motor takes `{key}`, not `{other}`"),
                ));
            }
            let Some(max) = given else {
                return Err(ctx.err(m.span(), format!("{who}: motor needs `{key}`")));
            };
            Some(MotorDef {
                speed: ctx.finite(who, "motor speed", &f.speed)?,
                max_force: ctx.non_negative(who, &format!("motor {key}"), max)?,
            })
        }
        None => None,
    };
    let servo = match &j.servo {
        Some(s) => Some(ServoDef {
            target: ctx.finite(who, "servo target", &s.get_ref().target)?,
        }),
        None => None,
    };
    let damping = match &j.damping {
        Some(d) => {
            let d = d.get_ref();
            DampingDef {
                linear: ctx.opt(d.linear.as_ref(), 0.0, |v| {
                    ctx.non_negative(who, "damping linear", v)
                })?,
                angular: ctx.opt(d.angular.as_ref(), 0.0, |v| {
                    ctx.non_negative(who, "damping angular", v)
                })?,
            }
        }
        None => DampingDef::default(),
    };
    let spring = match &j.spring {
        Some(sp) => {
            let f = sp.get_ref();
            Some(SpringDef {
                hertz: ctx.positive(who, "spring hertz", &f.hertz)?,
                damping_ratio: ctx.non_negative(who, "spring damping_ratio", &f.damping_ratio)?,
            })
        }
        None if kind == Wheel => {
            return Err(ctx.err(
                j.type_.span(),
                format!("{who}: a wheel joint needs `spring = {{ hertz, damping_ratio }}` (its suspension; hertz > 0)"),
            ));
        }
        None => None,
    };
    let offset = j
        .offset
        .as_ref()
        .map(|v| ctx.vec2(who, "offset", v))
        .transpose()?;
    let angle = match (&j.angle, &j.reference_angle) {
        (Some(v), _) => Some(ctx.finite(who, "angle", v)?),
        (None, Some(v)) => Some(ctx.finite(who, "reference_angle", v)?),
        (None, None) => None,
    };
    let (mut max_force, mut max_torque) = (0.0, 0.0);
    let mut correction = 0.0;
    if kind == Motor {
        for (key, v, out) in [
            ("max_force", &j.max_force, &mut max_force),
            ("max_torque", &j.max_torque, &mut max_torque),
        ] {
            let Some(v) = v else {
                return Err(ctx.err(
                    j.type_.span(),
                    format!("{who}: a motor joint needs `{key}` (>= 0)"),
                ));
            };
            *out = ctx.non_negative(who, key, v)?;
        }
        correction = ctx.opt(j.correction.as_ref(), 0.3, |v| {
            ctx.unit(who, "correction", v)
        })?;
    }
    let ground_anchors = match &j.ground_anchors {
        Some(v) => {
            let [p, q] = &v.get_ref().0;
            Some([
                ctx.point(who, "ground_anchors", p)?,
                ctx.point(who, "ground_anchors", q)?,
            ])
        }
        None if kind == Pulley => {
            return Err(ctx.err(
                j.type_.span(),
                format!("{who}: a pulley needs `ground_anchors = [[x, y], [x, y]]` (where its two ropes hang from)"),
            ));
        }
        None => None,
    };
    let ratio = j
        .ratio
        .as_ref()
        .map(|v| ctx.positive(who, "ratio", v))
        .transpose()?
        .unwrap_or(1.0);
    // a wheel's axis defaults to straight up (a suspension)
    let axis = if kind == Wheel {
        axis.or(Some(Vec2::Y))
    } else {
        axis
    };
    let mut def = JointDef {
        kind,
        bodies: [ia, ib],
        anchor,
        anchors,
        length,
        axis,
        limits,
        motor,
        servo,
        compliance: ctx.opt(j.compliance.as_ref(), 0.0, |v| {
            ctx.non_negative(who, "compliance", v)
        })?,
        damping,
        collide_connected: j.collide_connected.as_ref().is_some_and(|v| *v.get_ref()),
        spring,
        offset,
        angle,
        max_force,
        max_torque,
        correction,
        ground_anchors,
        ratio,
        break_force: j
            .break_force
            .as_ref()
            .map(|v| ctx.positive(who, "break_force", v))
            .transpose()?,
        break_torque: j
            .break_torque
            .as_ref()
            .map(|v| ctx.positive(who, "break_torque", v))
            .transpose()?,
    };
    // A length at creation comes from the anchors, or from the bodies' positions.
    let span = j
        .anchors
        .as_ref()
        .map(|v| v.span())
        .or(j.anchor.as_ref().map(|v| v.span()))
        .unwrap_or(j.bodies.span());
    let built = check_joint(ctx, bodies, who, &def, span.clone())?;
    if rope {
        // `length` (checked > 0 above) or the anchors' distance at creation (`built`
        // is only `None` for bodies already refused).
        let max = length.or(built).unwrap_or(0.0);
        if max <= 0.0 {
            return Err(ctx.err(
                span,
                format!(
                    "{who}: a rope's length must be > 0, got {max} (its anchors are at one point at creation; give `length`)"
                ),
            ));
        }
        def.length = Some(max);
        def.limits = Some([0.0, max]);
    }
    Ok(def)
}
