//! The collide stage: contacts between bodies, found by the broad phase and SAT and
//! warm-started from last step's by the contact cache.

use super::Manifold;

/// A touching pair of bodies and its manifold. `a < b`; the normal points from a to b.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    pub a: u32,
    pub b: u32,
    pub manifold: Manifold,
    /// Mixed friction coefficient: sqrt(mu_a mu_b).
    pub friction: f32,
    /// Mixed restitution: max(e_a, e_b).
    pub restitution: f32,
}
