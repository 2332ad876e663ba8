//! Read-only views of the solver's state for measuring a step (the bench's residual).

use super::World;

impl World {
    /// The contact lambdas of the last (sub)step's solve, normal and friction of every
    /// point, contact by contact in pair order (N s), as the solver that ran holds them.
    /// Two worlds stepped from the same state find the same contacts, so their lambdas
    /// line up row by row.
    pub fn contact_lambdas(&self, out: &mut Vec<f32>) {
        match &self.stepper {
            Some(s) => s.contact_lambdas(&self.contacts, out),
            None => crate::step::stored_lambdas(&self.contacts, out),
        }
    }
}

/// Beyond this distance from the world's origin (m) a position in f32 steps by about
/// 1 mm (2^-10 m from 8192 m on), and stacks start to slide. A scene placed far from
/// 0 is simulated relative to its own centre ([`crate::defs::WorldDef::origin`]), so
/// this is about a scene's size: a body this far from the scene's centre.
pub const FAR_FROM_ORIGIN: f32 = 1e4;

/// The farthest a body of `def` starts from the world's origin (m) and the step of an f32
/// position there (m), when that is beyond [`FAR_FROM_ORIGIN`].
pub fn far_from_origin(def: &crate::defs::WorldDef) -> Option<(f32, f32)> {
    let far = def
        .bodies
        .iter()
        .map(|b| b.position.x.abs().max(b.position.y.abs()))
        .fold(0.0f32, f32::max);
    if far > FAR_FROM_ORIGIN && far.is_finite() {
        // the gap between far and the next f32 up
        let ulp = f32::from_bits(far.to_bits() + 1) - far;
        Some((far, ulp))
    } else {
        None
    }
}
