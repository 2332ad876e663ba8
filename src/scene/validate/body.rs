//! Shapes, materials and bodies: the body tables of a scene file checked and turned
//! into [`crate::defs`] types.

use super::*;

impl Ctx<'_> {
    /// A shape table with exactly one of `box`, `circle`, `polygon`, checked.
    /// Sizes must be > 0 whatever the body's type: a shape with no extent cannot collide.
    pub fn shape(&self, who: &str, s: &S<FileShape>) -> R<ShapeDef> {
        const KINDS: &str = "`box`, `circle`, `polygon`, `capsule`, `segment`";
        let f = s.get_ref();
        let given: Vec<&str> = [
            f.box_.as_ref().map(|_| "box"),
            f.circle.as_ref().map(|_| "circle"),
            f.polygon.as_ref().map(|_| "polygon"),
            f.capsule.as_ref().map(|_| "capsule"),
            f.segment.as_ref().map(|_| "segment"),
        ]
        .into_iter()
        .flatten()
        .collect();
        if given.len() != 1 {
            let what = if given.is_empty() {
                format!("shape has none of {KINDS}; give exactly one")
            } else {
                format!(
                    "shape has {}; give exactly one of {KINDS}",
                    given.join(" and ")
                )
            };
            return Err(self.err(s.span(), format!("{who}: {what}")));
        }
        let radius = match &f.radius {
            None => None,
            Some(r) => {
                if f.box_.is_none() && f.polygon.is_none() {
                    return Err(self.err(
                        r.span(),
                        format!(
                            "{who}: `radius` rounds a box or a polygon; a {} takes none",
                            given[0]
                        ),
                    ));
                }
                let v = self.finite(who, "radius", r)?;
                if v < 0.0 {
                    return Err(self.err(r.span(), format!("{who}: radius must be >= 0, got {v}")));
                }
                Some((v, r.span()))
            }
        };
        if let Some(b) = &f.box_ {
            let size = self.size(who, "box", b)?;
            let Some((r, span)) = radius else {
                return Ok(ShapeDef::Box {
                    width: size.x,
                    height: size.y,
                });
            };
            let half = 0.5 * size.x.min(size.y);
            if r >= half {
                return Err(self.err(
                    span,
                    format!(
                        "{who}: a box's radius must be less than half its smaller side ({half}), got {r}"
                    ),
                ));
            }
            return Ok(ShapeDef::RoundedBox {
                width: size.x,
                height: size.y,
                radius: r,
            });
        }
        if let Some(c) = &f.circle {
            let r = self.finite(who, "circle radius", c)?;
            if r <= 0.0 {
                return Err(self.err(
                    c.span(),
                    format!("{who}: circle radius must be > 0, got {r}"),
                ));
            }
            return Ok(ShapeDef::Circle { radius: r });
        }
        if let Some(c) = &f.capsule {
            let c = c.get_ref();
            let r = self.finite(who, "capsule radius", &c.radius)?;
            if r <= 0.0 {
                return Err(self.err(
                    c.radius.span(),
                    format!("{who}: capsule radius must be > 0, got {r}"),
                ));
            }
            let l = self.finite(who, "capsule length", &c.length)?;
            if !(l > 2.0 * r) {
                return Err(self.err(
                    c.length.span(),
                    format!(
                        "{who}: capsule length (end to end) must be more than twice its radius ({}), got {l}",
                        2.0 * r
                    ),
                ));
            }
            return Ok(ShapeDef::Capsule {
                length: l,
                radius: r,
            });
        }
        if let Some(g) = &f.segment {
            let ends = g.get_ref();
            if ends.len() != 2 {
                return Err(self.err(
                    g.span(),
                    format!(
                        "{who}: segment needs exactly 2 points [[x1, y1], [x2, y2]], got {}",
                        ends.len()
                    ),
                ));
            }
            let a = self.vec2(who, "segment end", &ends[0])?;
            let b = self.vec2(who, "segment end", &ends[1])?;
            if a.distance(b) < 1e-4 {
                return Err(self.err(
                    g.span(),
                    format!("{who}: segment's ends must be at least 1e-4 m apart, got {a} and {b}"),
                ));
            }
            return Ok(ShapeDef::Segment { a, b });
        }
        match &f.polygon {
            Some(p) => {
                let def = self.polygon(who, p)?;
                match (def, radius) {
                    (ShapeDef::Polygon { points }, Some((r, _))) if r > 0.0 => {
                        Ok(ShapeDef::RoundedPolygon { points, radius: r })
                    }
                    (def, _) => Ok(def),
                }
            }
            None => Err(self.err(s.span(), format!("{who}: shape is empty"))),
        }
    }

    /// `shapes = [ { box = [w, h], offset = [x, y], angle = a, density = d }, ... ]`: a
    /// compound's parts, 1 to [`MAX_PARTS`], each a shape (no segment) with where it sits
    /// in the body and what it is made of (absent keys: the body's).
    pub fn parts(
        &self,
        who: &str,
        parts: &S<Vec<S<FilePart>>>,
        categories: &[String],
    ) -> R<ShapeDef> {
        let list = parts.get_ref();
        if list.is_empty() || list.len() > MAX_PARTS {
            return Err(self.err(
                parts.span(),
                format!(
                    "{who}: `shapes` takes 1 to {MAX_PARTS} parts, got {}",
                    list.len()
                ),
            ));
        }
        let mut out = Vec::with_capacity(list.len());
        for (i, p) in list.iter().enumerate() {
            let pw = format!("{who} part {}", i + 1);
            let pw = pw.as_str();
            let f = p.get_ref();
            if let Some(s) = &f.segment {
                return Err(self.err(
                    s.span(),
                    format!("{pw}: a part needs an area; a segment has none (use a capsule)"),
                ));
            }
            let sensor = f.sensor.as_ref().is_some_and(|v| *v.get_ref());
            let shape = self.shape(
                pw,
                &S::new(
                    p.span(),
                    FileShape {
                        box_: f.box_.clone(),
                        circle: f.circle.clone(),
                        polygon: f.polygon.clone(),
                        capsule: f.capsule.clone(),
                        segment: None,
                        radius: f.radius.clone(),
                    },
                ),
            )?;
            let density = match &f.density {
                Some(d) => {
                    let x = self.finite(pw, "density", d)?;
                    // a sensor part may be a massless zone
                    if x < 0.0 || (x == 0.0 && !sensor) {
                        return Err(self.err(
                            d.span(),
                            format!("{pw}: density must be > 0 (or 0 on a sensor part), got {x}"),
                        ));
                    }
                    Some(x)
                }
                None => None,
            };
            let friction = match &f.friction {
                Some(v) => {
                    let x = self.non_negative(pw, "friction", v)?;
                    if x > MAX_FRICTION {
                        return Err(self.err(
                            v.span(),
                            format!("{pw}: friction must be at most {MAX_FRICTION:e}, got {x}"),
                        ));
                    }
                    Some(x)
                }
                None => None,
            };
            out.push(PartDef {
                shape,
                offset: self.opt_vec2(pw, "offset", f.offset.as_ref(), Vec2::ZERO)?,
                angle: self.opt(f.angle.as_ref(), 0.0, |v| self.finite(pw, "angle", v))?,
                density,
                friction,
                restitution: f
                    .restitution
                    .as_ref()
                    .map(|v| self.unit(pw, "restitution", v))
                    .transpose()?,
                filter: f
                    .filter
                    .as_ref()
                    .map(|v| self.filter(pw, Some(v), categories))
                    .transpose()?,
                sensor,
            });
        }
        Ok(ShapeDef::Compound { parts: out })
    }

    /// A polygon: finite points, at least 3 distinct, a convex hull with area.
    fn polygon(&self, who: &str, p: &S<Vec<S<V2>>>) -> R<ShapeDef> {
        let given = p.get_ref().len();
        if given > MAX_POLYGON_POINTS {
            return Err(self.err(
                p.span(),
                format!(
                    "{who}: polygon has {given} points; at most {MAX_POLYGON_POINTS} may be given (and its hull may have at most {MAX_POLYGON_VERTICES} vertices)"
                ),
            ));
        }
        let mut points = Vec::with_capacity(given);
        for q in p.get_ref() {
            points.push(self.vec2(who, "polygon point", q)?);
        }
        // Points closer than this (m) count as one.
        const SAME: f32 = 1e-6;
        let mut distinct: Vec<Vec2> = Vec::new();
        for &q in &points {
            if !distinct.iter().any(|d| d.distance(q) <= SAME) {
                distinct.push(q);
            }
        }
        if distinct.len() < 3 {
            return Err(self.err(
                p.span(),
                format!(
                    "{who}: polygon needs at least 3 distinct points, got {}",
                    distinct.len()
                ),
            ));
        }
        let (area, extent) = hull_area(&distinct);
        // No area relative to its size: the points are (nearly) collinear.
        if area <= 1e-6 * extent * extent {
            return Err(self.err(
                p.span(),
                format!("{who}: polygon has no area (its points are collinear)"),
            ));
        }
        let def = ShapeDef::Polygon { points };
        // The engine's own hull (which welds points closer than 1e-4 m) must agree.
        if let Err(e) = crate::shape::Shape::from_def(&def) {
            return Err(self.err(p.span(), format!("{who}: {e}")));
        }
        Ok(def)
    }

    /// The material of a body: density or mass (> 0 on a dynamic body, finite on
    /// others; not both), friction >= 0, restitution in [0, 1], colour.
    #[allow(clippy::too_many_arguments)]
    pub fn material(
        &self,
        who: &str,
        dynamic: bool,
        density: Option<&S<f32>>,
        mass: Option<&S<f32>>,
        friction: Option<&S<f32>>,
        restitution: Option<&S<f32>>,
        color: Option<&S<String>>,
    ) -> R<Material> {
        let check = |key: &str, v: &S<f32>| {
            if dynamic {
                let x = self.finite(who, key, v)?;
                if x > 0.0 {
                    Ok(x)
                } else {
                    Err(self.err(
                        v.span(),
                        format!("{who}: {key} must be > 0 on a dynamic body, got {x}"),
                    ))
                }
            } else {
                self.finite(who, key, v)
            }
        };
        if let (Some(_), Some(m)) = (density, mass) {
            return Err(self.err(
                m.span(),
                format!("{who}: give `density` or `mass`, not both"),
            ));
        }
        let density = self.opt(density, 1.0, |v| check("density", v))?;
        let mass = match mass {
            Some(m) => Some(check("mass", m)?),
            None => None,
        };
        Ok(Material {
            density,
            mass,
            friction: self.opt(friction, 0.6, |v| {
                let f = self.non_negative(who, "friction", v)?;
                // the world mixes two bodies' friction as sqrt(a b): the product must fit f32
                if f > MAX_FRICTION {
                    return Err(self.err(
                        v.span(),
                        format!("{who}: friction must be at most {MAX_FRICTION:e}, got {f}"),
                    ));
                }
                Ok(f)
            })?,
            restitution: self.opt(restitution, 0.0, |v| self.unit(who, "restitution", v))?,
            color: color.map(|c| self.color(who, c)).transpose()?,
        })
    }

    /// `type = "static" | "dynamic" | "kinematic"`, default dynamic.
    pub fn body_type(&self, who: &str, v: Option<&S<String>>) -> R<BodyType> {
        v.map_or(Ok(BodyType::Dynamic), |v| {
            self.choice(
                who,
                "type",
                v,
                &[
                    ("static", BodyType::Static),
                    ("dynamic", BodyType::Dynamic),
                    ("kinematic", BodyType::Kinematic),
                ],
            )
        })
    }

    /// `model = "rigid" | "particle"`, default rigid.
    pub fn body_model(&self, who: &str, v: Option<&S<String>>) -> R<BodyModel> {
        v.map_or(Ok(BodyModel::Rigid), |v| {
            self.choice(
                who,
                "model",
                v,
                &[
                    ("rigid", BodyModel::Rigid),
                    ("particle", BodyModel::Particle),
                ],
            )
        })
    }

    /// A particle has translation only: it needs a circle; a segment has no area, so
    /// no dynamic body can have one.
    pub fn shape_fits(
        &self,
        who: &str,
        model: BodyModel,
        dynamic: bool,
        shape: &ShapeDef,
        span: Range<usize>,
    ) -> R<()> {
        if dynamic
            && matches!(
                shape,
                ShapeDef::Segment { .. } | ShapeDef::ChainSegment { .. }
            )
        {
            return Err(self.err(
                span,
                format!(
                    "{who}: a segment has no area, so only a static or kinematic body can have one (a dynamic body could use a capsule)"
                ),
            ));
        }
        let kind = match shape {
            ShapeDef::Circle { .. } => return Ok(()),
            ShapeDef::Box { .. } => "a box",
            ShapeDef::Polygon { .. } => "a polygon",
            ShapeDef::Capsule { .. } => "a capsule",
            ShapeDef::RoundedBox { .. } => "a box",
            ShapeDef::RoundedPolygon { .. } => "a polygon",
            ShapeDef::Segment { .. } | ShapeDef::ChainSegment { .. } => "a segment",
            ShapeDef::Compound { .. } => "a compound",
        };
        if model == BodyModel::Particle {
            Err(self.err(
                span,
                format!("{who}: a particle body needs a circle shape, got {kind}"),
            ))
        } else {
            Ok(())
        }
    }

    /// A body's `filter`: its category's bit (the scene's category names in order, the
    /// implicit "default" first), the mask's bits (every category when absent) and the
    /// group. A mask naming a category no body has is refused.
    pub fn filter(&self, who: &str, f: Option<&S<FileFilter>>, categories: &[String]) -> R<Filter> {
        let Some(f) = f else {
            return Ok(Filter::default());
        };
        let bit = |name: &S<String>| -> R<u32> {
            match categories.iter().position(|c| c == name.get_ref()) {
                Some(i) => Ok(1u32 << i),
                None => Err(self.err(
                    name.span(),
                    format!(
                        "{who}: filter names an unknown category {:?} (known: {})",
                        name.get_ref(),
                        categories.join(", ")
                    ),
                )),
            }
        };
        let f = f.get_ref();
        let category = match &f.category {
            Some(c) => bit(c)?,
            None => Filter::default().category,
        };
        let mask = match &f.mask {
            Some(list) => {
                let mut m = 0u32;
                for name in list.get_ref() {
                    m |= bit(name)?;
                }
                m
            }
            None => u32::MAX,
        };
        let group = match &f.group {
            Some(g) => i32::try_from(*g.get_ref()).map_err(|_| {
                self.err(
                    g.span(),
                    format!(
                        "{who}: filter group must be an integer from {} to {}, got {}",
                        i32::MIN,
                        i32::MAX,
                        g.get_ref()
                    ),
                )
            })?,
            None => 0,
        };
        Ok(Filter {
            category,
            mask,
            group,
        })
    }

    /// A `[[body]]` table, named `name`; `categories` are the scene's filter categories.
    /// `table` is where the table is, for a shape that is missing.
    pub fn body(
        &self,
        b: &FileBody,
        name: String,
        categories: &[String],
        table: Range<usize>,
    ) -> R<BodyDef> {
        let who = format!("body {name:?}");
        let who = who.as_str();
        let body_type = self.body_type(who, b.type_.as_ref())?;
        let model = self.body_model(who, b.model.as_ref())?;
        let (shape, shape_span) = match (&b.shape, &b.shapes) {
            (Some(s), None) => (self.shape(who, s)?, s.span()),
            (None, Some(parts)) => {
                let shape = self.parts(who, parts, categories)?;
                if body_type == BodyType::Dynamic
                    && let ShapeDef::Compound { parts: list } = &shape
                    && list.iter().all(|p| p.density == Some(0.0))
                {
                    return Err(self.err(
                        parts.span(),
                        format!(
                            "{who}: every part is a massless sensor (density 0); a moving body needs a part with mass"
                        ),
                    ));
                }
                (shape, parts.span())
            }
            (Some(_), Some(parts)) => {
                return Err(self.err(
                    parts.span(),
                    format!(
                        "{who}: give `shape` (one shape) or `shapes` (a compound's parts), not both"
                    ),
                ));
            }
            (None, None) => {
                return Err(self.err(
                    table,
                    format!(
                        "{who}: missing field `shape` (one shape) or `shapes` (a compound's parts)"
                    ),
                ));
            }
        };
        self.shape_fits(
            who,
            model,
            body_type == BodyType::Dynamic,
            &shape,
            shape_span,
        )?;
        let m = self.material(
            who,
            body_type == BodyType::Dynamic,
            b.density.as_ref(),
            b.mass.as_ref(),
            b.friction.as_ref(),
            b.restitution.as_ref(),
            b.color.as_ref(),
        )?;
        let velocity = self.opt_vec2(who, "velocity", b.velocity.as_ref(), Vec2::ZERO)?;
        let angular_velocity = self.opt(b.angular_velocity.as_ref(), 0.0, |v| {
            self.finite(who, "angular_velocity", v)
        })?;
        let awake = self.awake(who, b.awake.as_ref(), body_type)?;
        if !awake && (velocity != Vec2::ZERO || angular_velocity != 0.0) {
            let span = b.awake.as_ref().map_or(table.clone(), |v| v.span());
            return Err(self.err(
                span,
                format!("{who}: a body that starts asleep (awake = false) has no velocity"),
            ));
        }
        let dynamic = body_type == BodyType::Dynamic;
        let mut damping = [0.0f32; 2];
        for (out, key, v) in damping
            .iter_mut()
            .zip([
                ("linear_damping", b.linear_damping.as_ref()),
                ("angular_damping", b.angular_damping.as_ref()),
            ])
            .map(|(o, (k, v))| (o, k, v))
        {
            if let Some(v) = v {
                if !dynamic {
                    return Err(self.err(
                        v.span(),
                        format!("{who}: `{key}` applies to a dynamic body only"),
                    ));
                }
                *out = self.non_negative(who, key, v)?;
            }
        }
        let sleep_threshold = match &b.sleep_threshold {
            Some(v) if !dynamic => {
                return Err(self.err(
                    v.span(),
                    format!("{who}: `sleep_threshold` applies to a dynamic body only"),
                ));
            }
            Some(v) => self.non_negative(who, "sleep_threshold", v)?,
            None => SLEEP_THRESHOLD,
        };
        Ok(BodyDef {
            name,
            body_type,
            model,
            shape,
            position: self.opt_point(who, "position", b.position.as_ref(), Vec2::ZERO)?,
            angle: self.opt(b.angle.as_ref(), 0.0, |v| self.finite(who, "angle", v))?,
            velocity,
            angular_velocity,
            density: m.density,
            mass: m.mass,
            friction: m.friction,
            restitution: m.restitution,
            color: m.color,
            filter: self.filter(who, b.filter.as_ref(), categories)?,
            sensor: b.sensor.as_ref().is_some_and(|v| *v.get_ref()),
            awake,
            linear_damping: damping[0],
            angular_damping: damping[1],
            sleep_threshold,
        })
    }

    /// `awake = true | false` (default true); false only on a dynamic body.
    pub fn awake(&self, who: &str, v: Option<&S<bool>>, body_type: BodyType) -> R<bool> {
        match v {
            None => Ok(true),
            Some(v) if !*v.get_ref() && body_type != BodyType::Dynamic => Err(self.err(
                v.span(),
                format!(
                    "{who}: only a dynamic body can start asleep (awake = false); a static or kinematic one never sleeps"
                ),
            )),
            Some(v) => Ok(*v.get_ref()),
        }
    }

    /// A kinematic body's `oscillate = { amplitude, angular_frequency, phase }`.
    pub fn oscillate(
        &self,
        who: &str,
        o: &S<FileOscillate>,
        body: usize,
        body_type: BodyType,
    ) -> R<MotionDef> {
        if body_type != BodyType::Kinematic {
            return Err(self.err(
                o.span(),
                format!(
                    "{who}: only a kinematic body follows a path (`oscillate`); give it type = \"kinematic\""
                ),
            ));
        }
        let f = o.get_ref();
        Ok(MotionDef {
            body,
            amplitude: self.vec2(who, "oscillate amplitude", &f.amplitude)?,
            angular_frequency: self.positive(
                who,
                "oscillate angular_frequency",
                &f.angular_frequency,
            )?,
            phase: self.opt(f.phase.as_ref(), 0.0, |v| {
                self.finite(who, "oscillate phase", v)
            })?,
        })
    }
}

/// What [`Ctx::material`] gives.
pub(crate) struct Material {
    pub density: f32,
    pub mass: Option<f32>,
    pub friction: f32,
    pub restitution: f32,
    pub color: Option<Color>,
}

/// The area of the convex hull of `points` (monotone chain, in f64) and the larger
/// side of their bounding box.
fn hull_area(points: &[Vec2]) -> (f32, f32) {
    let mut p: Vec<(f64, f64)> = points.iter().map(|q| (q.x as f64, q.y as f64)).collect();
    p.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    let n = hull.len();
    let mut twice = 0.0;
    for i in 0..n {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        twice += a.0 * b.1 - b.0 * a.1;
    }
    let (mut lo, mut hi) = (points[0], points[0]);
    for q in points {
        lo = lo.min(*q);
        hi = hi.max(*q);
    }
    let ext = hi - lo;
    ((twice.abs() / 2.0) as f32, ext.x.max(ext.y))
}
