//! The soft step (the default solver): one collide per step, then `substeps` substeps
//! that reuse its manifolds. Per substep: integrate velocities, warm start, `iterations`
//! biased sweeps (soft rows that pull errors out), integrate positions, one relax sweep
//! (rigid rows, no bias), each sweep colour by colour, a colour's joints then its
//! contacts. After the last substep: restitution, and the bodies take their new
//! velocities and positions. The substeps are one plan of phases that the solver runs on
//! one thread or, with threads, as one job of the pool (`SoftSolver::run`; the stage
//! clock counts the later substeps' force increments as solver time). With drag the
//! forces change from substep to substep: then each substep is a plan of its own, the
//! velocities integrated before it.

use super::{Stage, StageClock, StepContext, StepState, StepStats, Stepper};
use crate::collision::Contact;
use crate::collision::collide::Speculative;
use crate::defs::SolverKind;
use crate::solver::soft::SoftSolver;

/// The soft step and its scratch.
#[derive(Clone, Debug, Default)]
pub struct SoftStepper {
    pub(crate) soft: SoftSolver,
}

impl Stepper for SoftStepper {
    fn kind(&self) -> SolverKind {
        SolverKind::Soft
    }

    fn step(
        &mut self,
        state: &mut StepState,
        cx: &StepContext,
        clock: &mut StageClock,
    ) -> StepStats {
        let s = state.settings;
        let (n, h) = (cx.substeps, cx.h);
        let pool = state.pool;
        // points out to the distance each pair can close in the step (speculative
        // contacts): a fast body meets what it would pass through
        let penetration = state.collide(cx.dt, cx.margin, Speculative::MarginOrMotion, clock);
        // without drag (or bodies' own damping) the forces change every substep's
        // velocities by the same amount: integrate once, and the solver adds that
        // increment in the later substeps
        let uniform = state.forces().uniform();
        // with only gravity and the bodies' own forces, the first substep's forces are
        // integrated in prepare's pass over the bodies
        let fused = state.plain_forces();
        if fused {
            let g = state.gravity;
            let mouse = state.mouse;
            // (this step's flags of the bodies the solver moves, where the collide found
            // them: the colouring need not wait for the solver's own pass over the bodies)
            let movers = state.collider.movers(state.bodies.len());
            self.soft.prepare_integrating(
                state.bodies,
                state.contacts,
                state.joints,
                mouse.as_ref(),
                movers,
                &s,
                h,
                g,
                pool,
            );
        } else {
            self.soft.prepare(
                state.bodies,
                state.contacts,
                state.joints,
                state.mouse.as_ref(),
                &s,
                h,
                pool,
            );
        }
        clock.lap(Stage::Solve);
        let residual;
        if uniform {
            if !fused {
                state.integrate_velocities(h);
                self.soft.take_increments(state.bodies, pool);
            }
            clock.lap(Stage::Forces);
            residual = self.soft.run(state.joints, n as usize, &s, h, pool);
            clock.lap(Stage::Solve);
        } else {
            let mut last = 0.0;
            for _ in 0..n {
                state.integrate_velocities(h);
                self.soft.load_velocities(state.bodies);
                clock.lap(Stage::Forces);
                last = self.soft.run(state.joints, 1, &s, h, pool);
                self.soft.store_velocities(state.bodies);
                clock.lap(Stage::Solve);
            }
            residual = last;
        }
        let iterations = n * (s.iterations + 1);
        self.soft.apply_restitution(s.restitution_threshold);
        self.soft.store_impulses(state.contacts, pool);
        self.soft.store_joints(state.joints, pool);
        clock.lap(Stage::Solve);
        // velocities, then x = x0 + sum h v, theta = theta0 + sum h w
        state.ended = Some(self.soft.finish(state.bodies, pool));
        clock.lap(Stage::Integrate);
        StepStats {
            iterations,
            residual,
            position_iterations: 0,
            contacts: self.soft.points(),
            penetration,
            colors: self.soft.color_count(),
            ..Default::default()
        }
    }

    fn contact_lambdas(&self, _contacts: &[Contact], out: &mut Vec<f32>) {
        self.soft.lambdas(out);
    }

    fn box_clone(&self) -> Box<dyn Stepper> {
        Box::new(self.clone())
    }

    #[cfg(test)]
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverSettings;
    use crate::step::soft::SoftStepper;
    use crate::world::World;

    #[test]
    fn lanes_of_a_wide_constraint_share_no_moving_body() {
        let sc = crate::scene::load("pyramid").unwrap();
        let mut s = SolverSettings::soft();
        s.substeps = 2;
        let mut w = World::from_def(&sc.world, s).unwrap();
        for _ in 0..5 {
            w.step().unwrap();
        }
        assert!(!w.contacts().is_empty());
        let st = w.stepper_as::<SoftStepper>().expect("a soft stepper");
        assert!(st.soft.lanes_are_independent(w.contacts()));
        assert!(st.soft.color_count() >= 2);
    }

    #[test]
    fn the_solver_hears_which_bodies_are_dynamic_only_from_a_collide_with_none_asleep() {
        // (the collide's flags say "dynamic and awake": the same only with none asleep.)
        // A box at rest on the ground, and a ball far away that falls for ever: the box
        // sleeps while the ball keeps the world stepping
        let sc = crate::scene::load_str(
            "name = \"two\"\n[world]\ngravity = [0.0, -10.0]\n\
             [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [10.0, 1.0] }\nposition = [0.0, -0.5]\n\
             [[body]]\nname = \"box\"\nshape = { box = [1.0, 1.0] }\nposition = [0.0, 0.5]\n\
             [[body]]\nname = \"ball\"\nshape = { circle = 0.5 }\nposition = [100.0, 0.0]\n",
            "two.toml",
        )
        .unwrap();
        let mut w = World::from_def(&sc.world, SolverSettings::soft()).unwrap();
        assert!(w.settings.sleep);
        let all = Some(&[false, true, true][..]);
        w.step().unwrap();
        assert_eq!(w.collider.movers(w.bodies.len()), all);
        let mut asleep = false;
        for _ in 0..120 {
            // (asleep at the step's start, as its collide finds it)
            asleep = w.bodies[1].asleep;
            w.step().unwrap();
            assert_eq!(
                w.collider.movers(w.bodies.len()),
                if asleep { None } else { all }
            );
        }
        assert!(asleep, "the box falls asleep within 2 s");
        assert!(!w.bodies[2].asleep, "the ball falls");
        // woken, the next collide finds every flag again
        w.wake(1);
        w.step().unwrap();
        assert_eq!(w.collider.movers(w.bodies.len()), all);
    }
}
