//! Plain descriptions of what a world holds: bodies, shapes, forces, joints and the
//! solver settings. A scene file parses into these; a Rust user may build them by hand.
//! They carry no derived state: [`crate::World`] computes mass, inertia and the rest.

use glam::Vec2;

/// How a body moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
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
    Circle { radius: f32 },
    /// A box of full width and height (m) centred on the body origin.
    Box { width: f32, height: f32 },
    /// A convex polygon: the convex hull of these local points (m).
    Polygon { points: Vec<Vec2> },
}

/// An RGBA colour, 8 bits a channel, sRGB.
pub type Color = [u8; 4];

/// Everything needed to create one body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyDef {
    /// Unique within a world; joints, forces and traces name bodies by it.
    pub name: String,
    pub body_type: BodyType,
    pub model: BodyModel,
    pub shape: ShapeDef,
    /// World position of the shape's origin (m). The body's centre of mass is found from the shape.
    pub position: Vec2,
    /// Radians, counter-clockwise.
    pub angle: f32,
    /// m/s.
    pub velocity: Vec2,
    /// rad/s.
    pub angular_velocity: f32,
    /// kg/m^2; ignored when `mass` is set.
    pub density: f32,
    /// kg; overrides the density.
    pub mass: Option<f32>,
    /// Coulomb friction coefficient.
    pub friction: f32,
    /// Coefficient of restitution in [0, 1].
    pub restitution: f32,
    /// Drawing colour; `None` lets the renderer choose.
    pub color: Option<Color>,
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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    Distance,
    Hinge,
    Prismatic,
    Weld,
}

/// A motor: drive the joint's speed, with a bounded force or torque.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorDef {
    /// rad/s (hinge) or m/s (prismatic).
    pub speed: f32,
    /// N m (hinge) or N (prismatic).
    pub max_force: f32,
}

/// A servo: drive the joint's angle (or offset) to a target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoDef {
    /// rad (hinge) or m (prismatic).
    pub target: f32,
}

/// Velocity-level damping of a joint's relative motion.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct DampingDef {
    pub linear: f32,
    pub angular: f32,
}

/// Everything needed to create one joint.
#[derive(Clone, Debug, PartialEq)]
pub struct JointDef {
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
    pub motor: Option<MotorDef>,
    pub servo: Option<ServoDef>,
    /// m/N (rad/(N m) for angles); 0 = rigid.
    pub compliance: f32,
    pub damping: DampingDef,
    pub collide_connected: bool,
}

/// Fluid drag. Each term that is zero costs nothing.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct DragDef {
    /// F = -linear * v
    pub linear: f32,
    /// F = -quadratic * |v| * v
    pub quadratic: f32,
    /// F = -1/2 * fluid_density * drag_coefficient * width * |v| * v
    pub fluid_density: f32,
    pub drag_coefficient: f32,
}

/// Which solver steps the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SolverKind {
    /// The contact MLCP solved by projected Gauss-Seidel (sequential impulses).
    #[default]
    Pgs,
    /// Extended position-based dynamics with substeps.
    Xpbd,
}

impl SolverKind {
    /// The name used in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Pgs => "pgs",
            SolverKind::Xpbd => "xpbd",
        }
    }
}

/// The solver's settings, complete. See [`SolverOverrides`] for the partial form a scene gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverSettings {
    pub kind: SolverKind,
    /// Step (s).
    pub dt: f32,
    /// Sub-steps per step.
    pub substeps: u32,
    /// PGS sweeps per (sub)step, or XPBD iterations per substep.
    pub iterations: u32,
    /// PGS stops early when every |delta lambda| of a sweep is below this (N s); 0 = never.
    pub tolerance: f32,
    /// Contact caching: last step's lambdas start this step's solve.
    pub warm_start: bool,
    /// Baumgarte factor beta in [0, 1].
    pub baumgarte: f32,
    /// Allowed penetration (m): S = min(sigma + slop, 0).
    pub slop: f32,
    /// Solve the position error apart from the velocities (no energy added).
    pub split_impulse: bool,
    /// Impacts slower than this (m/s) do not bounce.
    pub restitution_threshold: f32,
    /// The soft step instead of classic PGS: one collide per step, `substeps` substeps
    /// that reuse its manifolds, each with `iterations` soft (biased) sweeps and one rigid
    /// relax sweep. See `solver::soft`.
    pub soft_step: bool,
    /// Soft step: the contact spring's frequency (Hz), capped at a quarter of the substep
    /// rate; contacts against static or kinematic bodies use twice it.
    pub contact_hertz: f32,
    /// Soft step: the contact spring's damping ratio.
    pub contact_damping_ratio: f32,
    /// Soft step: the fastest a contact pushes overlapping bodies apart (m/s).
    pub max_push_speed: f32,
}

impl SolverSettings {
    /// PGS defaults: dt 1/60, 1 substep, 10 iterations, tolerance 1e-4, warm start,
    /// beta 0.2, slop 0.005 m, split impulse, restitution threshold 1 m/s; soft step off
    /// (when on: contacts of 30 Hz, damping ratio 10, push-out at most 3 m/s).
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
            restitution_threshold: 1.0,
            soft_step: false,
            contact_hertz: 30.0,
            contact_damping_ratio: 10.0,
            max_push_speed: 3.0,
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
            SolverKind::Pgs => Self::pgs(),
            SolverKind::Xpbd => Self::xpbd(),
        }
    }
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self::pgs()
    }
}

/// Solver settings where each may be absent: a scene's `[solver]` table, or command-line flags.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SolverOverrides {
    pub kind: Option<SolverKind>,
    pub dt: Option<f32>,
    pub substeps: Option<u32>,
    pub iterations: Option<u32>,
    pub tolerance: Option<f32>,
    pub warm_start: Option<bool>,
    pub baumgarte: Option<f32>,
    pub slop: Option<f32>,
    pub split_impulse: Option<bool>,
    pub restitution_threshold: Option<f32>,
    pub soft_step: Option<bool>,
    pub contact_hertz: Option<f32>,
    pub contact_damping_ratio: Option<f32>,
    pub max_push_speed: Option<f32>,
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
            restitution_threshold: other.restitution_threshold.or(self.restitution_threshold),
            soft_step: other.soft_step.or(self.soft_step),
            contact_hertz: other.contact_hertz.or(self.contact_hertz),
            contact_damping_ratio: other.contact_damping_ratio.or(self.contact_damping_ratio),
            max_push_speed: other.max_push_speed.or(self.max_push_speed),
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
            restitution_threshold: self
                .restitution_threshold
                .unwrap_or(d.restitution_threshold),
            soft_step: self.soft_step.unwrap_or(d.soft_step),
            contact_hertz: self.contact_hertz.unwrap_or(d.contact_hertz),
            contact_damping_ratio: self
                .contact_damping_ratio
                .unwrap_or(d.contact_damping_ratio),
            max_push_speed: self.max_push_speed.unwrap_or(d.max_push_speed),
        }
    }
}

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
    pub forces: Vec<ForceDef>,
    pub joints: Vec<JointDef>,
}
