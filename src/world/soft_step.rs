//! The world's step with the soft-step solver (`SolverSettings::soft_step`): one collide,
//! then `substeps` solver substeps that reuse its manifolds (see `solver::soft`).

use std::time::Instant;

use super::World;
use crate::defs::{BodyModel, BodyType};
use crate::math::Rot;
use crate::solver::pgs::SolveStats;

impl World {
    /// One step of dt: collide at the step's start, then per substep of h = dt / n:
    /// integrate velocities, warm start, soft sweeps, integrate positions, relax sweep;
    /// then restitution, and the bodies take their new velocities and positions.
    pub(super) fn step_soft(&mut self) {
        let settings = self.settings;
        let dt = settings.dt;
        let n = settings.substeps.max(1);
        let h = dt / n as f32;
        let (ms_broad, ms_narrow) = self.collide(dt, false);
        let t1 = Instant::now();
        self.soft
            .prepare(&self.bodies, &self.contacts, &settings, h);
        let mut ms_forces = 0.0;
        let mut stats = SolveStats::default();
        // without drag the forces change every substep's velocities by the same amount:
        // integrate once, and the solver adds that increment in the later substeps
        let uniform = self.drag.is_none();
        for i in 0..n {
            let t = Instant::now();
            if !uniform || i == 0 {
                self.integrate_velocities(h);
            }
            ms_forces += t.elapsed().as_secs_f32() * 1e3;
            if !uniform {
                self.soft.load_velocities(&self.bodies);
            } else if i == 0 {
                self.soft.take_increments(&self.bodies);
            } else {
                self.soft.apply_increments();
            }
            self.soft.substep(&settings, h, &mut stats);
            if !uniform {
                self.soft.store_velocities(&mut self.bodies);
            }
        }
        self.soft.apply_restitution(settings.restitution_threshold);
        self.soft.store_velocities(&mut self.bodies);
        self.soft.store_impulses(&mut self.contacts);
        let t3 = Instant::now();
        // x = x0 + sum h v, theta = theta0 + sum h w
        for (b, s) in self.bodies.iter_mut().zip(&self.soft.bodies) {
            if b.body_type == BodyType::Static {
                continue;
            }
            b.position += s.dp;
            if b.model == BodyModel::Rigid {
                b.angle += s.dtheta;
                b.rot = Rot::from_angle(b.angle);
            }
        }
        let t4 = Instant::now();
        self.stats.iterations = stats.iterations;
        self.stats.residual = stats.residual;
        self.stats.position_iterations = 0;
        self.stats.contacts = self.contacts.iter().map(|c| c.manifold.count).sum();
        self.stats.ms_broad = ms_broad;
        self.stats.ms_narrow = ms_narrow;
        self.stats.ms_forces = ms_forces;
        self.stats.ms_solve = (t3 - t1).as_secs_f32() * 1e3 - ms_forces;
        self.stats.ms_integrate = (t4 - t3).as_secs_f32() * 1e3;
    }
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverSettings;
    use crate::world::World;

    #[test]
    fn lanes_of_a_wide_constraint_share_no_moving_body() {
        let sc = crate::scene::load("pyramid").unwrap();
        let mut s = SolverSettings::pgs();
        s.soft_step = true;
        s.substeps = 2;
        let mut w = World::from_def(&sc.world, s).unwrap();
        for _ in 0..5 {
            w.step().unwrap();
        }
        assert!(!w.contacts.is_empty());
        assert!(w.soft.lanes_are_independent(&w.contacts));
        assert!(w.soft.color_count() >= 2);
    }
}
