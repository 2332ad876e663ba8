//! Plain descriptions of what a world holds: bodies, shapes, forces, joints and the
//! solver settings. A scene file parses into these; a Rust user may build them by hand.
//! They carry no derived state: [`crate::World`] computes mass, inertia and the rest.

use glam::Vec2;

/// How a body moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum BodyType {
    /// Never moves; infinite mass.
    Static,
    /// Moved by forces and contacts.
    #[default]
    Dynamic,
    /// Moves with its given velocity; infinite mass, pushes dynamic bodies.
    Kinematic,
}

/// Which degrees of freedom a body has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum BodyModel {
    /// Position, angle, linear and angular velocity.
    #[default]
    Rigid,
    /// Translation only (the seed's particle): no orientation, circle shapes only.
    Particle,
}

/// A collision shape in the body's local frame, before the centre of mass is found.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeDef {
    /// A circle of the given radius (m) centred on the body origin.
    Circle {
        /// Radius (m), > 0.
        radius: f32,
    },
    /// A box of full width and height (m) centred on the body origin.
    Box {
        /// Full size along the body's local x axis (m), > 0.
        width: f32,
        /// Full size along the body's local y axis (m), > 0.
        height: f32,
    },
    /// A convex polygon: the convex hull of these local points (m).
    Polygon {
        /// Local points (m), in any order; their hull has at most
        /// [`crate::shape::MAX_POLYGON_VERTICES`] vertices and an area.
        points: Vec<Vec2>,
    },
    /// A capsule along the body's local x axis: `length` end to end (m, more than
    /// `2 radius`), half circles of `radius` at its ends.
    Capsule {
        /// End to end along the local x axis (m), more than `2 radius`.
        length: f32,
        /// Radius of the end caps and half the capsule's thickness (m), > 0.
        radius: f32,
    },
    /// A box of outer size `width` x `height` (m) whose corners are rounded by `radius`
    /// (0: sharp; less than half the smaller side).
    RoundedBox {
        /// Outer size along the local x axis (m), > 0.
        width: f32,
        /// Outer size along the local y axis (m), > 0.
        height: f32,
        /// Corner radius (m): 0 for sharp corners, else less than half the smaller side.
        radius: f32,
    },
    /// The convex hull of `points` (m) with its outline moved out by `radius` (m) and
    /// its corners rounded.
    RoundedPolygon {
        /// Local points (m) whose convex hull is the core, as [`ShapeDef::Polygon`]'s.
        points: Vec<Vec2>,
        /// How far the outline lies out from the core (m), >= 0 (0: the plain polygon).
        radius: f32,
    },
    /// A segment between two local points (m), of no thickness: it has no area, so only
    /// a static or kinematic body can have one (terrain, walls).
    Segment {
        /// One end, in the body's local frame (m).
        a: Vec2,
        /// The other end (m), distinct from `a`.
        b: Vec2,
    },
    /// One segment `a`-`b` of a polyline (terrain), with the far ends of its neighbours
    /// (`prev` before `a`, `next` after `b`; `None` at an open end): shapes slide
    /// across its joints without catching on them. `one_sided`: only shapes on the left
    /// of `a` -> `b` collide with it (above, for a polyline drawn left to right). Static
    /// or kinematic bodies only; the scene file's `[[polyline]]` makes a row of them.
    ChainSegment {
        /// The segment's start, in the body's local frame (m).
        a: Vec2,
        /// The segment's end (m), distinct from `a`.
        b: Vec2,
        /// The previous segment's start (m); `None`: `a` is an open end.
        prev: Option<Vec2>,
        /// The next segment's end (m); `None`: `b` is an open end.
        next: Option<Vec2>,
        /// Only shapes on the left of `a` -> `b` collide with it.
        one_sided: bool,
    },
    /// A compound body: several convex parts (circles, boxes, polygons, capsules, each
    /// optionally rounded) fixed in one rigid frame, at most [`MAX_PARTS`]. Its mass,
    /// centre of mass and inertia come from the parts (parallel axis theorem); each part
    /// collides on its own, with its own friction, restitution and filter.
    Compound {
        /// The parts, 1 to [`MAX_PARTS`] of them, each placed in the body's frame.
        parts: Vec<PartDef>,
    },
}

/// The most parts a compound body has.
pub const MAX_PARTS: usize = 64;

/// One part of a compound body ([`ShapeDef::Compound`]): a shape placed in the body's
/// frame, and the material it has there.
#[derive(Clone, Debug, PartialEq)]
pub struct PartDef {
    /// The part's shape in its own frame (not a segment, a polyline or a compound).
    pub shape: ShapeDef,
    /// Where the part's frame origin lies in the body's description frame (m).
    pub offset: Vec2,
    /// The part frame's rotation in the body frame (rad).
    pub angle: f32,
    /// kg/m^2; `None`: the body's density. A given body `mass` scales every part alike.
    pub density: Option<f32>,
    /// `None`: the body's.
    pub friction: Option<f32>,
    /// `None`: the body's.
    pub restitution: Option<f32>,
    /// `None`: the body's.
    pub filter: Option<Filter>,
    /// A sensor part: it hears overlaps with other bodies' solid parts
    /// ([`crate::World::events`]) and never collides. It has mass by its density like
    /// any part; a density of 0 is allowed on a sensor part only (a massless zone).
    pub sensor: bool,
}

impl PartDef {
    /// A part of shape `shape` at `offset`, unrotated, with the body's material.
    pub fn new(shape: ShapeDef, offset: Vec2) -> Self {
        PartDef {
            shape,
            offset,
            angle: 0.0,
            density: None,
            friction: None,
            restitution: None,
            filter: None,
            sensor: false,
        }
    }
}

/// An RGBA colour, 8 bits a channel, sRGB.
pub type Color = [u8; 4];

/// Everything needed to create one body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyDef {
    /// Unique within a world; joints, forces and traces name bodies by it.
    pub name: String,
    /// Static, dynamic (the default) or kinematic.
    pub body_type: BodyType,
    /// Rigid (the default) or a particle (translation only, a circle shape).
    pub model: BodyModel,
    /// The collision shape, in the body's frame (default: a 1 m x 1 m box).
    pub shape: ShapeDef,
    /// World position of the shape's origin (m). The body's centre of mass is found from the shape.
    pub position: Vec2,
    /// Radians, counter-clockwise.
    pub angle: f32,
    /// m/s.
    pub velocity: Vec2,
    /// rad/s.
    pub angular_velocity: f32,
    /// kg/m^2; ignored when `mass` is set. Default 1.
    pub density: f32,
    /// kg; overrides the density.
    pub mass: Option<f32>,
    /// Coulomb friction coefficient. Default 0.6.
    pub friction: f32,
    /// Coefficient of restitution in [0, 1]. Default 0 (no bounce).
    pub restitution: f32,
    /// Drawing colour; `None` lets the renderer choose.
    pub color: Option<Color>,
    /// Which other bodies it may touch (default: all).
    pub filter: Filter,
    /// A sensor: its overlaps with other (non-static, non-sensor) bodies are reported as
    /// events ([`crate::World::events`]) and never resolved.
    pub sensor: bool,
    /// `false`: a dynamic body starts asleep, on an island of its own (Box2D's
    /// `isAwake`): not integrated, collided or solved until something wakes it, as any
    /// sleeping body wakes. Ignored (awake) when the world's `sleep` setting is off.
    pub awake: bool,
    /// Box2D's linear damping (1/s): each (sub)step of h multiplies the velocity by
    /// 1 / (1 + h c). 0: none.
    pub linear_damping: f32,
    /// Angular damping (1/s), as `linear_damping` for the spin.
    pub angular_damping: f32,
    /// The speed (m/s) below which the body counts as at rest for sleeping (also
    /// |w| r, r the shape's radius); Box2D's `sleepThreshold`, 0.05 m/s by default.
    pub sleep_threshold: f32,
}

/// The speed below which a body rests, unless it sets its own
/// ([`BodyDef::sleep_threshold`]): Box2D's default, 0.05 m/s.
pub const SLEEP_THRESHOLD: f32 = 0.05;

/// Collision filtering, Box2D's rule: two bodies of the same non-zero group always
/// collide when the group is positive and never when it is negative; otherwise each
/// body's category must be in the other's mask. A filtered pair never reaches the
/// narrow phase. The default (category 1, every bit in the mask, group 0) touches
/// everything.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Filter {
    /// The category bits this body belongs to.
    pub category: u32,
    /// The categories it collides with.
    pub mask: u32,
    /// Same non-zero group: positive always collides, negative never.
    pub group: i32,
}

impl Default for Filter {
    fn default() -> Self {
        Self {
            category: 1,
            mask: u32::MAX,
            group: 0,
        }
    }
}

impl Filter {
    /// Whether a body with this filter and one with `other` may touch.
    #[inline]
    pub fn collides(&self, other: &Filter) -> bool {
        if self.group != 0 && self.group == other.group {
            return self.group > 0;
        }
        self.category & other.mask != 0 && other.category & self.mask != 0
    }
}

impl Default for BodyDef {
    fn default() -> Self {
        Self {
            name: String::new(),
            body_type: BodyType::Dynamic,
            model: BodyModel::Rigid,
            shape: ShapeDef::Box {
                width: 1.0,
                height: 1.0,
            },
            position: Vec2::ZERO,
            angle: 0.0,
            velocity: Vec2::ZERO,
            angular_velocity: 0.0,
            density: 1.0,
            mass: None,
            friction: 0.6,
            restitution: 0.0,
            color: None,
            filter: Filter::default(),
            sensor: false,
            awake: true,
            linear_damping: 0.0,
            angular_damping: 0.0,
            sleep_threshold: SLEEP_THRESHOLD,
        }
    }
}

/// A constant force applied at a point of a body, every step.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceDef {
    /// Index of the body in creation order.
    pub body: usize,
    /// N, world frame.
    pub force: Vec2,
    /// Body-local point (relative to the shape origin) where the force acts.
    pub point: Vec2,
}

/// The kinds of joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum JointKind {
    /// Keeps an anchor on each body at a fixed distance (its `length`), or within a
    /// range (its `limits`: a rope).
    Distance,
    /// Pins the two bodies together at one anchor; they turn freely about it (a
    /// revolute joint), within `limits` if given.
    Hinge,
    /// b slides along an axis fixed in a and does not turn relative to a.
    Prismatic,
    /// Holds b fixed relative to a (position and angle), rigidly or with `compliance`.
    Weld,
    /// b (a wheel) slides along an axis fixed in a (a chassis) on a suspension spring,
    /// turns freely (or by a motor) and stays on the axis's line.
    Wheel,
    /// Drives b towards a target offset and angle relative to a, with bounded force
    /// and torque.
    Motor,
    /// Two bodies hung from two ground points: length_a + ratio length_b <= constant.
    Pulley,
}

/// A joint's spring (the wheel joint's suspension): k = m_eff (2 pi hertz)^2,
/// c = 2 m_eff damping_ratio (2 pi hertz), m_eff the row's effective mass.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpringDef {
    /// Hz, > 0.
    pub hertz: f32,
    /// 1 = critical, >= 0.
    pub damping_ratio: f32,
}

/// A motor: drive the joint's speed, with a bounded force or torque.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MotorDef {
    /// rad/s (hinge) or m/s (prismatic).
    pub speed: f32,
    /// N m (hinge) or N (prismatic).
    pub max_force: f32,
}

/// A servo: drive the joint's angle (or offset) to a target.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ServoDef {
    /// rad (hinge) or m (prismatic).
    pub target: f32,
}

/// Velocity-level damping of a joint's relative motion.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct DampingDef {
    /// 1/s: each (sub)step of h removes min(h c, 1) of the relative velocity along the
    /// joint's free direction (distance, prismatic and wheel joints). 0: none (default).
    pub linear: f32,
    /// 1/s: as `linear`, for the relative spin (hinge, prismatic and weld joints).
    /// 0: none (default).
    pub angular: f32,
}

/// Everything needed to create one joint.
#[derive(Clone, Debug, PartialEq)]
pub struct JointDef {
    /// What the joint holds (see [`JointKind`]).
    pub kind: JointKind,
    /// Indices of the two bodies in creation order.
    pub bodies: [usize; 2],
    /// World anchor at creation (hinge, weld, prismatic).
    pub anchor: Option<Vec2>,
    /// World anchors on each body at creation (distance).
    pub anchors: Option<[Vec2; 2]>,
    /// Rest length (distance); `None` = the distance at creation.
    pub length: Option<f32>,
    /// World axis at creation (prismatic).
    pub axis: Option<Vec2>,
    /// [min, max]: radians (hinge), metres (prismatic) or a length range (distance).
    pub limits: Option<[f32; 2]>,
    /// Hinge, prismatic and wheel: drive the joint's speed with a bounded force or
    /// torque; `None` = no motor.
    pub motor: Option<MotorDef>,
    /// Hinge and prismatic: hold the joint's angle (from its zero) or offset (along the
    /// axis, from where it was at creation) at a target; `None` = none. Not with a
    /// hinge's `spring`.
    pub servo: Option<ServoDef>,
    /// m/N (rad/(N m) for angles); 0 = rigid.
    pub compliance: f32,
    /// Damping of the joint's free relative motion; none by default.
    pub damping: DampingDef,
    /// Whether the two joined bodies still collide with each other (default `false`).
    pub collide_connected: bool,
    /// The wheel joint's suspension along its axis; a hinge's torsion spring, which pulls
    /// the hinge angle towards 0 (Box2D's revolute spring).
    pub spring: Option<SpringDef>,
    /// Motor joint: b's target position relative to a's (centres of mass), in a's frame;
    /// `None` = the offset at creation.
    pub offset: Option<Vec2>,
    /// Motor joint: target theta_b - theta_a (rad); `None` = the angle at creation.
    /// Hinge: the theta_b - theta_a at which the hinge angle reads 0 (its limits and
    /// spring are measured from it; Box2D's joint frames turned against each other);
    /// `None` = the angle at creation.
    pub angle: Option<f32>,
    /// Motor joint: largest force (N) and torque (N m) it applies.
    pub max_force: f32,
    /// Motor joint: largest torque (N m) it applies, >= 0.
    pub max_torque: f32,
    /// Motor joint: the share of the position error it corrects per step, in [0, 1].
    pub correction: f32,
    /// Pulley: the two ground points (world), the ropes' fixed ends.
    pub ground_anchors: Option<[Vec2; 2]>,
    /// Pulley: length_a + ratio length_b is kept at most its value at creation; > 0.
    pub ratio: f32,
    /// The joint breaks (is removed, with a [`crate::JointBreakEvent`]) after a
    /// step whose constraint force, the magnitude of its linear part (N), exceeds this;
    /// `None` (the default) = it never breaks. > 0.
    pub break_force: Option<f32>,
    /// The joint breaks after a step whose constraint torque, its angular rows' (N m),
    /// exceeds this in magnitude; `None` (the default) = never. > 0.
    pub break_torque: Option<f32>,
}

/// A rigid hinge with no anchor given (b's centre), between bodies 0 and 1: a base to
/// fill in with `..Default::default()` for [`crate::World::create_joint`], which names
/// the bodies by key.
impl Default for JointDef {
    fn default() -> Self {
        JointDef {
            anchor: None,
            ..JointDef::hinge(0, 1, Vec2::ZERO)
        }
    }
}

impl JointDef {
    /// A rigid hinge between bodies `a` and `b` at the world point `at`: no limits,
    /// motor, servo or damping; the two bodies do not collide.
    pub fn hinge(a: usize, b: usize, at: Vec2) -> JointDef {
        JointDef {
            kind: JointKind::Hinge,
            bodies: [a, b],
            anchor: Some(at),
            anchors: None,
            length: None,
            axis: None,
            limits: None,
            motor: None,
            servo: None,
            compliance: 0.0,
            damping: DampingDef::default(),
            collide_connected: false,
            spring: None,
            offset: None,
            angle: None,
            max_force: 0.0,
            max_torque: 0.0,
            correction: 0.0,
            ground_anchors: None,
            ratio: 1.0,
            break_force: None,
            break_torque: None,
        }
    }

    /// A rigid distance joint between the world points `pa` on `a` and `pb` on `b`,
    /// of their distance at creation.
    pub fn distance(a: usize, b: usize, pa: Vec2, pb: Vec2) -> JointDef {
        JointDef {
            kind: JointKind::Distance,
            anchor: None,
            anchors: Some([pa, pb]),
            length: Some(pa.distance(pb)),
            ..JointDef::hinge(a, b, pa)
        }
    }

    /// A rope between the world points `pa` on `a` and `pb` on `b`: the anchors are never
    /// more than `max_length` apart, and below it the rope is slack (it pulls, never
    /// pushes). A distance joint with limits [0, `max_length`], for a `max_length`
    /// above 0. Like [`JointDef::distance`] it is rigid at its limit, with no damping,
    /// and the two bodies do not collide.
    pub fn rope(a: usize, b: usize, pa: Vec2, pb: Vec2, max_length: f32) -> JointDef {
        JointDef {
            length: Some(max_length),
            limits: Some([0.0, max_length]),
            ..JointDef::distance(a, b, pa, pb)
        }
    }

    /// A wheel joint: `b` (the wheel) keeps its point `anchor` (world, at creation; usually
    /// the wheel's centre) on the line through it along `axis` (world, at creation; fixed
    /// in `a`, the chassis), sprung along that axis by a spring of `hertz` (> 0) and
    /// `damping_ratio` about where it is at creation, and turns freely. Add `motor`
    /// (on the wheel's rotation, rad/s and N m) or `limits` (on the offset along the axis,
    /// m) to the returned def as wanted.
    pub fn wheel(
        a: usize,
        b: usize,
        anchor: Vec2,
        axis: Vec2,
        hertz: f32,
        damping_ratio: f32,
    ) -> JointDef {
        JointDef {
            kind: JointKind::Wheel,
            axis: Some(axis),
            spring: Some(SpringDef {
                hertz,
                damping_ratio,
            }),
            ..JointDef::hinge(a, b, anchor)
        }
    }

    /// A motor joint: drives `b` towards the offset and relative angle it has to `a` at
    /// creation (set `offset` and `angle` on the returned def for other targets), with at
    /// most `max_force` (N) and `max_torque` (N m), correcting 0.3 of the error per step.
    pub fn motor_joint(a: usize, b: usize, max_force: f32, max_torque: f32) -> JointDef {
        JointDef {
            kind: JointKind::Motor,
            anchor: None,
            max_force,
            max_torque,
            correction: 0.3,
            ..JointDef::hinge(a, b, Vec2::ZERO)
        }
    }

    /// A pulley: the rope from the ground point `ground[0]` to `anchors[0]` (world, on `a`)
    /// and the one from `ground[1]` to `anchors[1]` (on `b`) keep
    /// length_a + `ratio` length_b at most its value at creation. Rigid, it only pulls.
    pub fn pulley(
        a: usize,
        b: usize,
        ground: [Vec2; 2],
        anchors: [Vec2; 2],
        ratio: f32,
    ) -> JointDef {
        JointDef {
            kind: JointKind::Pulley,
            anchor: None,
            anchors: Some(anchors),
            ground_anchors: Some(ground),
            ratio,
            ..JointDef::hinge(a, b, anchors[0])
        }
    }
}

/// Fluid drag. Each term that is zero costs nothing.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct DragDef {
    /// F = -linear * v
    pub linear: f32,
    /// F = -quadratic * |v| * v
    pub quadratic: f32,
    /// F = -1/2 * fluid_density * drag_coefficient * width * |v| * v
    pub fluid_density: f32,
    /// The dimensionless drag coefficient of that term (0: the term is off).
    pub drag_coefficient: f32,
}

/// Which solver steps the world. Each kind is one stepper (`Stepper`, in `src/step/`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum SolverKind {
    /// The soft step (the default): one collide per step, substeps that reuse its
    /// manifolds, soft contact and joint rows in the biased sweeps and rigid rows in a
    /// relax sweep (after Box2D v3's "soft step"). See `solver::soft`.
    #[default]
    Soft,
    /// The contact MLCP solved by projected Gauss-Seidel (sequential impulses) with
    /// caching, Baumgarte and slop, split impulse: the seed's method, the lab's reference.
    Pgs,
    /// Extended position-based dynamics with substeps.
    Xpbd,
}

impl SolverKind {
    /// Every kind, in the order the lab lists them.
    pub const ALL: [SolverKind; 3] = [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd];

    /// The name used in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Soft => "soft",
            SolverKind::Pgs => "pgs",
            SolverKind::Xpbd => "xpbd",
        }
    }

    /// The kind with this name (`soft`, `pgs`, `xpbd`).
    pub fn from_name(name: &str) -> Option<SolverKind> {
        SolverKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// What the panel and the tables call it.
    pub fn label(self) -> &'static str {
        match self {
            SolverKind::Soft => "Soft step",
            SolverKind::Pgs => "PGS",
            SolverKind::Xpbd => "XPBD",
        }
    }
}

fn yes() -> bool {
    true
}

/// The solver's settings, complete. See [`SolverOverrides`] for the partial form a scene
/// gives. One flat struct for every kind: the fields each kind reads are listed by
/// [`SolverSettings::keys`]; the others are kept (so switching kinds back and forth in the
/// window loses nothing) but ignored. Ranges are checked in one place,
/// [`SolverSettings::check`], which the scene loader, the command line, the panel and
/// [`crate::World::from_def`] all use.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolverSettings {
    /// Which solver steps the world (default: the soft step).
    pub kind: SolverKind,
    /// Step (s).
    pub dt: f32,
    /// Sub-steps per step.
    pub substeps: u32,
    /// PGS sweeps per (sub)step, soft sweeps per substep (soft step), or XPBD iterations
    /// per substep.
    pub iterations: u32,
    /// PGS stops early when every |delta lambda| of a sweep is below this (N s); 0 = never.
    pub tolerance: f32,
    /// Contact caching: last step's lambdas start this step's solve.
    pub warm_start: bool,
    /// PGS: Baumgarte factor beta in [0, 1].
    pub baumgarte: f32,
    /// Allowed penetration (m): S = min(sigma + slop, 0).
    pub slop: f32,
    /// PGS: solve the position error apart from the velocities (no energy added).
    pub split_impulse: bool,
    /// PGS and XPBD: a two-point manifold's normal rows solved together (the exact 2x2
    /// LCP, a block Gauss-Seidel step; for XPBD of the position rows) instead of one
    /// after the other.
    #[serde(default = "yes")]
    pub block_solve: bool,
    /// Islands of bodies at rest fall asleep and cost nothing until woken (every kind).
    #[serde(default = "yes")]
    pub sleep: bool,
    /// Impacts slower than this (m/s) do not bounce.
    pub restitution_threshold: f32,
    /// Soft step: the contact spring's frequency (Hz), capped at a quarter of the substep
    /// rate; contacts against static or kinematic bodies use twice it.
    pub contact_hertz: f32,
    /// Soft step: the contact spring's damping ratio.
    pub contact_damping_ratio: f32,
    /// Soft step: the fastest a contact pushes overlapping bodies apart (m/s).
    pub max_push_speed: f32,
    /// Soft step: the frequency (Hz) of a rigid joint row in the biased sweeps, capped at
    /// a quarter of the substep rate (the relax sweep solves it rigid).
    pub joint_hertz: f32,
    /// Soft step: the damping ratio of a rigid joint row in the biased sweeps.
    pub joint_damping_ratio: f32,
}

/// Upper bounds on the counts, so a typo cannot make a run that never ends.
pub const MAX_ITERATIONS: u32 = 10_000;
/// See [`MAX_ITERATIONS`].
pub const MAX_SUBSTEPS: u32 = 1_000;

impl SolverSettings {
    /// Soft-step defaults: dt 1/60, 8 substeps of 1 soft sweep and 1 relax sweep, warm
    /// start, slop 0.001 m (within the slop a contact has no spring, so each contact of a
    /// stack is that much free play: at 0.005 m a stack of 40 sways 1.16 m in 10 s, at
    /// 0.001 m 0.17 m, and the base-20 pyramid's top sinks 0.022 m instead of 0.092), contacts of 120 Hz (a quarter of the substep rate) with
    /// damping ratio 10 pushing out at most 3 m/s, rigid joints of 120 Hz with damping
    /// ratio 5 in the biased sweeps, restitution threshold 1 m/s. Chosen by measurement
    /// (docs/tradeoffs.md): at 4 substeps of 60 Hz a stack of 30 boxes topples within
    /// 10 s unless it falls asleep first, and a 200:1 ball on 20 links stretches its
    /// joints 0.10 m; at 8 substeps of 120 Hz the stack stands (0.05 m) and the chain
    /// stretches 0.03 m.
    pub fn soft() -> Self {
        Self {
            kind: SolverKind::Soft,
            substeps: 8,
            iterations: 1,
            slop: 0.001,
            contact_hertz: 120.0,
            joint_hertz: 120.0,
            ..Self::pgs()
        }
    }

    /// PGS defaults: dt 1/60, 1 substep, 10 iterations, tolerance 1e-4, warm start,
    /// beta 0.2, slop 0.005 m, split impulse, restitution threshold 1 m/s (the soft
    /// step's own values ride along unused, at their 4-substep levels).
    pub fn pgs() -> Self {
        Self {
            kind: SolverKind::Pgs,
            dt: 1.0 / 60.0,
            substeps: 1,
            iterations: 10,
            tolerance: 1e-4,
            warm_start: true,
            baumgarte: 0.2,
            slop: 0.005,
            split_impulse: true,
            block_solve: true,
            sleep: true,
            restitution_threshold: 1.0,
            contact_hertz: 30.0,
            contact_damping_ratio: 10.0,
            max_push_speed: 3.0,
            joint_hertz: 60.0,
            joint_damping_ratio: 5.0,
        }
    }

    /// XPBD defaults: the PGS values, but 20 substeps of 1 iteration.
    pub fn xpbd() -> Self {
        Self {
            kind: SolverKind::Xpbd,
            substeps: 20,
            iterations: 1,
            ..Self::pgs()
        }
    }

    /// The defaults of the given solver.
    pub fn defaults(kind: SolverKind) -> Self {
        match kind {
            SolverKind::Soft => Self::soft(),
            SolverKind::Pgs => Self::pgs(),
            SolverKind::Xpbd => Self::xpbd(),
        }
    }

    /// The settings the given kind reads, by their scene-file names (the panel shows
    /// these and only these).
    pub fn keys(kind: SolverKind) -> &'static [&'static str] {
        match kind {
            SolverKind::Soft => &[
                "dt",
                "substeps",
                "iterations",
                "warm_start",
                "slop",
                "restitution_threshold",
                "contact_hertz",
                "contact_damping_ratio",
                "max_push_speed",
                "joint_hertz",
                "joint_damping_ratio",
                "sleep",
            ],
            SolverKind::Pgs => &[
                "dt",
                "substeps",
                "iterations",
                "tolerance",
                "warm_start",
                "baumgarte",
                "slop",
                "split_impulse",
                "block_solve",
                "restitution_threshold",
                "sleep",
            ],
            SolverKind::Xpbd => &[
                "dt",
                "substeps",
                "iterations",
                "block_solve",
                "restitution_threshold",
                "max_push_speed",
                "sleep",
            ],
        }
    }

    /// The one place ranges are checked: `None` if `value` is allowed for the setting
    /// `key` (a scene-file name), else what is wrong. Counts are passed as f64.
    pub fn check_value(key: &str, value: f64) -> Option<String> {
        let finite = value.is_finite();
        let (ok, want) = match key {
            "dt" => (finite && value > 0.0 && value <= 1.0, "in (0, 1] s"),
            "iterations" => (
                value >= 1.0 && value <= MAX_ITERATIONS as f64,
                "an integer from 1 to 10000",
            ),
            "substeps" => (
                value >= 1.0 && value <= MAX_SUBSTEPS as f64,
                "an integer from 1 to 1000",
            ),
            "baumgarte" => (finite && (0.0..=1.0).contains(&value), "in [0, 1]"),
            "max_push_speed" => (finite && value > 0.0, "> 0"),
            "tolerance"
            | "slop"
            | "restitution_threshold"
            | "contact_hertz"
            | "contact_damping_ratio"
            | "joint_hertz"
            | "joint_damping_ratio" => (finite && value >= 0.0, ">= 0"),
            _ => (true, ""),
        };
        // printed as the f32 it came from (f64 would show -0.009999999776482582)
        (!ok).then(|| format!("{key} must be {want}, got {}", value as f32))
    }

    /// Every value checked by [`Self::check_value`]; the first problem found.
    pub fn check(&self) -> Result<(), String> {
        let values: [(&str, f64); 12] = [
            ("dt", self.dt as f64),
            ("substeps", self.substeps as f64),
            ("iterations", self.iterations as f64),
            ("tolerance", self.tolerance as f64),
            ("baumgarte", self.baumgarte as f64),
            ("slop", self.slop as f64),
            ("restitution_threshold", self.restitution_threshold as f64),
            ("contact_hertz", self.contact_hertz as f64),
            ("contact_damping_ratio", self.contact_damping_ratio as f64),
            ("max_push_speed", self.max_push_speed as f64),
            ("joint_hertz", self.joint_hertz as f64),
            ("joint_damping_ratio", self.joint_damping_ratio as f64),
        ];
        for (k, v) in values {
            if let Some(e) = Self::check_value(k, v) {
                return Err(e);
            }
        }
        Ok(())
    }
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self::soft()
    }
}

/// Solver settings where each may be absent: a scene's `[solver]` table, or command-line flags.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SolverOverrides {
    /// [`SolverSettings::kind`]; `None` = the soft step. The other fields left `None`
    /// take this kind's defaults.
    pub kind: Option<SolverKind>,
    /// [`SolverSettings::dt`] (s).
    pub dt: Option<f32>,
    /// [`SolverSettings::substeps`].
    pub substeps: Option<u32>,
    /// [`SolverSettings::iterations`].
    pub iterations: Option<u32>,
    /// [`SolverSettings::tolerance`] (N s).
    pub tolerance: Option<f32>,
    /// [`SolverSettings::warm_start`].
    pub warm_start: Option<bool>,
    /// [`SolverSettings::baumgarte`].
    pub baumgarte: Option<f32>,
    /// [`SolverSettings::slop`] (m).
    pub slop: Option<f32>,
    /// [`SolverSettings::split_impulse`].
    pub split_impulse: Option<bool>,
    /// [`SolverSettings::block_solve`].
    pub block_solve: Option<bool>,
    /// [`SolverSettings::sleep`].
    pub sleep: Option<bool>,
    /// [`SolverSettings::restitution_threshold`] (m/s).
    pub restitution_threshold: Option<f32>,
    /// [`SolverSettings::contact_hertz`] (Hz).
    pub contact_hertz: Option<f32>,
    /// [`SolverSettings::contact_damping_ratio`].
    pub contact_damping_ratio: Option<f32>,
    /// [`SolverSettings::max_push_speed`] (m/s).
    pub max_push_speed: Option<f32>,
    /// [`SolverSettings::joint_hertz`] (Hz).
    pub joint_hertz: Option<f32>,
    /// [`SolverSettings::joint_damping_ratio`].
    pub joint_damping_ratio: Option<f32>,
}

impl SolverOverrides {
    /// `other`'s values where it has them, else `self`'s.
    pub fn merged(self, other: SolverOverrides) -> SolverOverrides {
        SolverOverrides {
            kind: other.kind.or(self.kind),
            dt: other.dt.or(self.dt),
            substeps: other.substeps.or(self.substeps),
            iterations: other.iterations.or(self.iterations),
            tolerance: other.tolerance.or(self.tolerance),
            warm_start: other.warm_start.or(self.warm_start),
            baumgarte: other.baumgarte.or(self.baumgarte),
            slop: other.slop.or(self.slop),
            split_impulse: other.split_impulse.or(self.split_impulse),
            block_solve: other.block_solve.or(self.block_solve),
            sleep: other.sleep.or(self.sleep),
            restitution_threshold: other.restitution_threshold.or(self.restitution_threshold),
            contact_hertz: other.contact_hertz.or(self.contact_hertz),
            contact_damping_ratio: other.contact_damping_ratio.or(self.contact_damping_ratio),
            max_push_speed: other.max_push_speed.or(self.max_push_speed),
            joint_hertz: other.joint_hertz.or(self.joint_hertz),
            joint_damping_ratio: other.joint_damping_ratio.or(self.joint_damping_ratio),
        }
    }

    /// The complete settings: the chosen solver's defaults, overridden by what is set.
    pub fn resolve(self) -> SolverSettings {
        let d = SolverSettings::defaults(self.kind.unwrap_or_default());
        SolverSettings {
            kind: d.kind,
            dt: self.dt.unwrap_or(d.dt),
            substeps: self.substeps.unwrap_or(d.substeps),
            iterations: self.iterations.unwrap_or(d.iterations),
            tolerance: self.tolerance.unwrap_or(d.tolerance),
            warm_start: self.warm_start.unwrap_or(d.warm_start),
            baumgarte: self.baumgarte.unwrap_or(d.baumgarte),
            slop: self.slop.unwrap_or(d.slop),
            split_impulse: self.split_impulse.unwrap_or(d.split_impulse),
            block_solve: self.block_solve.unwrap_or(d.block_solve),
            sleep: self.sleep.unwrap_or(d.sleep),
            restitution_threshold: self
                .restitution_threshold
                .unwrap_or(d.restitution_threshold),
            contact_hertz: self.contact_hertz.unwrap_or(d.contact_hertz),
            contact_damping_ratio: self
                .contact_damping_ratio
                .unwrap_or(d.contact_damping_ratio),
            max_push_speed: self.max_push_speed.unwrap_or(d.max_push_speed),
            joint_hertz: self.joint_hertz.unwrap_or(d.joint_hertz),
            joint_damping_ratio: self.joint_damping_ratio.unwrap_or(d.joint_damping_ratio),
        }
    }
}

/// The largest side of a frame in pixels (a `[camera]` size, `render --size`).
pub const MAX_FRAME_SIDE: u32 = 16384;

/// The camera a scene asks for: the screen transform's centre and scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraDef {
    /// World point at the image centre (m).
    pub center: Vec2,
    /// The screen transform's scale s (zoom).
    pub pixels_per_meter: f32,
    /// Default frame size in pixels.
    pub size: [u32; 2],
}

impl Default for CameraDef {
    fn default() -> Self {
        Self {
            center: Vec2::new(0.0, 5.0),
            pixels_per_meter: 40.0,
            size: [1280, 720],
        }
    }
}

/// A whole world, described: what a scene file holds once parsed and validated.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct WorldDef {
    /// m/s^2; `None` = no gravity pass.
    pub gravity: Option<Vec2>,
    /// `None` = vacuum.
    pub drag: Option<DragDef>,
    /// What the scene sets of the solver.
    pub solver: SolverOverrides,
    /// In creation order (file order, generators expanded in place).
    pub bodies: Vec<BodyDef>,
    /// Constant forces on bodies, applied every step.
    pub forces: Vec<ForceDef>,
    /// Joints between the bodies (by index into `bodies`), made after the bodies.
    pub joints: Vec<JointDef>,
    /// Where the scene's (0, 0) is in the file's coordinates (m). Every position here
    /// (bodies, anchors, points, the camera) is relative to it, so a scene placed far
    /// from 0 keeps f32's precision near its bodies; (0, 0) for a scene within
    /// [`crate::scene::ORIGIN_SHIFT_BEYOND`] of 0. Outputs (traces) add it back.
    pub origin: glam::DVec2,
    /// Kinematic bodies that follow a path ([`MotionDef`]).
    pub motions: Vec<MotionDef>,
    /// Groups of bodies and joints added (and removed) as the world steps.
    pub spawns: Vec<SpawnDef>,
}

/// A kinematic body that sways along a line: at time t it is at
/// `p0 + amplitude (sin(angular_frequency t + phase) - sin(phase))`, p0 where it was
/// made. Before each step the world sets its velocity so that it arrives at the path's
/// point of the step's end (Box2D's `b2Body_SetTargetTransform`, once a step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionDef {
    /// Index of the body (kinematic) in creation order.
    pub body: usize,
    /// m.
    pub amplitude: Vec2,
    /// rad/s, > 0.
    pub angular_frequency: f32,
    /// rad.
    pub phase: f32,
}

/// A group of bodies and joints the world adds as it steps: before step `first`, and
/// every `every` steps after, `count` times in all (or without end), the k-th copy
/// shifted by `(k mod cycle) offset`. With `keep`, at most that many copies live: the
/// oldest is removed (bodies and joints) just before a new one is added. Spawned bodies
/// are named `NAME#k` (`k` from 0); the world's state hash covers them like any other
/// bodies, so a run with spawns is as deterministic as one without.
#[derive(Clone, Debug, PartialEq)]
pub struct SpawnDef {
    /// What messages call it (`spawn0`, ...).
    pub name: String,
    /// Steps between spawns, >= 1.
    pub every: u64,
    /// The step (0-based count of steps taken) before which the first copy is added.
    pub first: u64,
    /// Copies in all; `None` = one every `every` steps for as long as the world runs.
    pub count: Option<u64>,
    /// The most copies alive at once; `None` = no limit.
    pub keep: Option<u64>,
    /// How far (m) each copy is from the one before.
    pub offset: Vec2,
    /// The offsets start over every `cycle` copies (`None` = never).
    pub cycle: Option<u64>,
    /// The group as the first copy has it (names without the `#k`).
    pub bodies: Vec<BodyDef>,
    /// Joints between the group's bodies, by index into `bodies`.
    pub joints: Vec<JointDef>,
}

impl SpawnDef {
    /// The offset of copy `k` (from 0).
    pub fn offset_of(&self, k: u64) -> Vec2 {
        let i = match self.cycle {
            Some(c) if c > 0 => k % c,
            _ => k,
        };
        // in f64 and then f32, so a long run's offsets do not gather rounding
        Vec2::new(
            (self.offset.x as f64 * i as f64) as f32,
            (self.offset.y as f64 * i as f64) as f32,
        )
    }

    /// Whether a copy is due before the step numbered `step` (0-based), and which.
    pub fn due(&self, step: u64) -> Option<u64> {
        if step < self.first || !(step - self.first).is_multiple_of(self.every.max(1)) {
            return None;
        }
        let k = (step - self.first) / self.every.max(1);
        match self.count {
            Some(n) if k >= n => None,
            _ => Some(k),
        }
    }
}
