//! Bodies: the state the integrator advances, and the mass properties found from the shape.

use crate::defs::{BodyModel, BodyType, Color};
use crate::math::{Aabb, Rot, Transform, Vec2};
use crate::shape::Shape;

/// A body's place in its world's creation order: what definitions ([`crate::defs::JointDef`],
/// forces, paths) and scene files name bodies by. The world's API names them by
/// [`crate::BodyKey`].
pub type BodyId = usize;

/// The bytes at the start of a [`Body`] that every step's passes over the bodies read
/// (its state, masses, forces, type and sleep flag).
pub(crate) const HOT_BYTES: usize = 56;

/// The bytes at the start of a [`Body`] up to the end of a box's vertices and normals:
/// what finding its bounding box reads.
pub(crate) const SHAPE_BYTES: usize = 256;

const _: () = {
    // the hot fields lie in the first HOT_BYTES
    assert!(std::mem::offset_of!(Body, asleep) < HOT_BYTES);
    assert!(std::mem::offset_of!(Body, torque) + 4 <= HOT_BYTES);
    assert!(std::mem::offset_of!(Body, shape) < SHAPE_BYTES);
    assert!(std::mem::offset_of!(Body, parts) + 24 <= SHAPE_BYTES);
};

/// A body of the world. Its frame's origin is the centre of mass.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
// In this order in memory: the fields every step reads first, the shape (large: up
// to 16 vertices inline), then what only set-up, drawing and output read.
#[repr(C)]
pub struct Body {
    /// World position of the centre of mass (m).
    pub position: Vec2,
    /// The rotation of `angle`, kept in step with it.
    pub rot: Rot,
    /// m/s.
    pub velocity: Vec2,
    /// Radians, counter-clockwise; always 0 for a particle.
    pub angle: f32,
    /// rad/s; always 0 for a particle.
    pub angular_velocity: f32,
    /// 1 / `mass` (1/kg); 0 for static and kinematic bodies.
    pub inv_mass: f32,
    /// 1 / `inertia` (1/(kg m^2)); 0 for particles, static and kinematic bodies.
    pub inv_inertia: f32,
    /// Force (N) accumulated for the next step by [`crate::World::apply_force`]; cleared by the step.
    pub force: Vec2,
    /// Torque (N m) accumulated for the next step.
    pub torque: f32,
    /// Static, dynamic or kinematic.
    pub body_type: BodyType,
    /// Rigid or particle (translation only).
    pub model: BodyModel,
    /// Overlaps are reported, never resolved.
    pub sensor: bool,
    /// Asleep (read by every step's loops over the bodies, so in the first cache line
    /// with the state, where it fills a byte of padding): at rest with its whole island; not moved, integrated or solved until
    /// something touches, pulls or pushes the island ([`crate::World`]'s sleep).
    #[serde(default)]
    pub asleep: bool,
    /// Coulomb friction coefficient; a contact uses sqrt(mu_a mu_b) of its two bodies.
    pub friction: f32,
    /// Coefficient of restitution; a contact uses the larger of its two bodies'.
    pub restitution: f32,
    /// kg (0 for static and kinematic bodies).
    pub mass: f32,
    /// kg m^2 about the centre of mass (0 for particles, static and kinematic bodies).
    pub inertia: f32,
    /// XPBD: the position and angle corrections of the current substep. Velocities are
    /// derived from them, v = v_predicted + dx / h, which is (x - x_prev) / h without the
    /// f32 cancellation of subtracting two nearby positions far from the origin.
    pub(crate) correction: Vec2,
    pub(crate) correction_angle: f32,
    /// Which other bodies it may touch.
    pub filter: crate::defs::Filter,
    /// A compound body's parts (then `shape` is [`Shape::Compound`]); empty for a body
    /// of one shape. Before the shape: the narrow phase and the box loop ask every
    /// body whether it has parts, and here they read it from the lines they read anyway.
    #[serde(default)]
    pub parts: Vec<crate::compound::Part>,
    /// The number the next part added to the body gets ([`crate::compound::Part::id`]).
    #[serde(default)]
    pub(crate) next_part_id: u32,
    /// The shape, centred on the centre of mass.
    pub shape: Shape,
    /// Where the scene's shape origin lies in the body frame (minus the centroid of the
    /// shape as described); zero for circles, boxes and centred polygons.
    pub origin_offset: Vec2,
    /// Drawing colour; `None` lets the renderer choose.
    pub color: Option<Color>,
    /// Unique name.
    pub name: String,
    /// How long (s) it has moved slower than the sleep thresholds.
    #[serde(default)]
    pub(crate) sleep_time: f32,
    /// The island it fell asleep with (woken together).
    #[serde(default)]
    pub(crate) island: u32,
    /// Box2D's linear and angular damping (1/s): each (sub)step of h divides the
    /// velocity by 1 + h c ([`crate::defs::BodyDef::linear_damping`]).
    #[serde(default)]
    pub linear_damping: f32,
    /// Angular damping (1/s), as `linear_damping` for the spin.
    #[serde(default)]
    pub angular_damping: f32,
    /// The speed (m/s) below which it counts as at rest for sleeping.
    #[serde(default = "default_sleep_threshold")]
    pub sleep_threshold: f32,
    /// While asleep: its bounding box, found the first time the wake pass needs it (a
    /// sleeper does not move, and whatever moves or reshapes it wakes it first);
    /// cleared when it wakes.
    #[serde(skip)]
    pub(crate) rest_box: Option<Aabb>,
}

fn default_sleep_threshold() -> f32 {
    crate::defs::SLEEP_THRESHOLD
}

impl Body {
    /// The body's frame: centre of mass and rotation.
    #[inline]
    pub fn transform(&self) -> Transform {
        Transform {
            p: self.position,
            q: self.rot,
        }
    }

    /// Whether forces and contacts move it.
    #[inline]
    pub fn is_dynamic(&self) -> bool {
        self.body_type == BodyType::Dynamic
    }

    /// Its own damping over a step of h, as factors of its velocities (Box2D's):
    /// (1 / (1 + h c_linear), 1 / (1 + h c_angular)).
    #[inline]
    pub(crate) fn damping_factors(&self, h: f32) -> (f32, f32) {
        (
            1.0 / (1.0 + h * self.linear_damping),
            1.0 / (1.0 + h * self.angular_damping),
        )
    }

    /// Its velocities after `h` of gravity `g` and its own force and torque, before
    /// drag: v + h (F / m + g), w + h tau / I (semi-implicit Euler's velocity half; see
    /// `step::integrate`).
    #[inline]
    pub(crate) fn free_velocity(&self, h: f32, g: Option<Vec2>) -> (Vec2, f32) {
        let mut v = self.velocity + h * self.inv_mass * self.force;
        if let Some(g) = g {
            v += h * g;
        }
        (
            v,
            self.angular_velocity + h * self.inv_inertia * self.torque,
        )
    }

    /// Whether its position, velocity, angle and spin are all finite.
    #[inline]
    pub(crate) fn is_finite(&self) -> bool {
        self.position.is_finite()
            && self.velocity.is_finite()
            && self.angle.is_finite()
            && self.angular_velocity.is_finite()
    }

    /// No velocity, spin, force or torque: a sleeper that is not still was pushed, set
    /// moving or given a force since it fell asleep, and wakes.
    #[inline]
    pub(crate) fn is_still(&self) -> bool {
        self.velocity == Vec2::ZERO
            && self.angular_velocity == 0.0
            && self.force == Vec2::ZERO
            && self.torque == 0.0
    }

    /// Adds `force` (N) at `world_point`, and a `torque` (N m) of its own, to this
    /// step's force and torque (no torque of its own: -0.0, which adding changes no
    /// bit of).
    #[inline]
    pub(crate) fn add_force_at(&mut self, force: Vec2, world_point: Vec2, torque: f32) {
        self.force += force;
        self.torque += crate::math::cross(world_point - self.position, force) + torque;
    }

    /// An awake dynamic body, or a kinematic one that moves: what wakes a sleeping
    /// island it reaches.
    #[inline]
    pub(crate) fn is_mover(&self) -> bool {
        (self.is_dynamic() && !self.asleep)
            || (self.body_type == BodyType::Kinematic
                && (self.velocity != Vec2::ZERO || self.angular_velocity != 0.0))
    }

    /// World position of the shape origin the scene gave (equal to the centre of mass
    /// unless the polygon was not centred).
    pub fn origin(&self) -> Vec2 {
        self.position + self.rot.rotate(self.origin_offset)
    }

    /// Velocity of the material point at world position `p`: v + w x r.
    #[inline]
    pub fn velocity_at(&self, p: Vec2) -> Vec2 {
        self.velocity + crate::math::cross_sv(self.angular_velocity, p - self.position)
    }

    /// Kinetic energy, 1/2 m v^2 + 1/2 I w^2 (J).
    pub fn kinetic_energy(&self) -> f32 {
        0.5 * self.mass * self.velocity.length_squared()
            + 0.5 * self.inertia * self.angular_velocity * self.angular_velocity
    }
}
