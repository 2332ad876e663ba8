//! Read-only views of the solver's state for measuring a step (the bench's residual).

use super::World;

impl World {
    /// The contact lambdas of the last (sub)step's solve, normal and friction of every
    /// point, contact by contact in pair order (N s), as the solver that ran holds them.
    /// Two worlds stepped from the same state find the same contacts, so their lambdas
    /// line up row by row.
    pub fn contact_lambdas(&self, out: &mut Vec<f32>) {
        match &self.stepper {
            Some(s) => s.contact_lambdas(self, out),
            None => crate::step::stored_lambdas(self, out),
        }
    }
}
