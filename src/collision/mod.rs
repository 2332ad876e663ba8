//! Collision detection: the broad phase finds pairs whose boxes overlap, the narrow phase
//! (SAT) turns each pair into a contact manifold.

pub(crate) mod broad_phase;
pub(crate) mod bvh;
pub(crate) mod collide;
pub(crate) mod contact_cache;
pub mod sat;

pub use collide::Contact;

use crate::math::Vec2;

/// Names the pair of features (edges, vertices) that make a contact point, so the same
/// point can be found again next step while the same features touch.
pub type FeatureId = u32;

/// One point of contact between two bodies.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactPoint {
    /// World position of the point (midway between the two surfaces).
    pub point: Vec2,
    /// From body A's centre of mass to the point, world frame (m).
    pub anchor_a: Vec2,
    /// From body B's centre of mass to the point, world frame (m).
    pub anchor_b: Vec2,
    /// sigma: the signed gap along the normal; negative = overlap (m).
    pub separation: f32,
    /// Which features touch.
    pub id: FeatureId,
    /// lambda of the normal row: the impulse (N s) applied last step, for warm starting.
    pub normal_impulse: f32,
    /// lambda of the friction row (N s).
    pub tangent_impulse: f32,
}

/// Up to two contact points sharing one normal.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Manifold {
    /// Unit normal pointing from body A to body B, world frame.
    pub normal: Vec2,
    /// The points; only the first `count` are in use (see [`Manifold::points`]).
    pub points: [ContactPoint; 2],
    /// How many points are in use: 0, 1 or 2.
    pub count: usize,
}

impl Manifold {
    /// The points in use.
    pub fn points(&self) -> &[ContactPoint] {
        &self.points[..self.count]
    }
}
