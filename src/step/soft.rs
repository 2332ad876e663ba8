//! The soft step (the default solver): one collide per step, then `substeps` substeps
//! that reuse its manifolds. Per substep: integrate velocities, warm start, `iterations`
//! biased sweeps (joints, then contacts: soft rows that pull errors out), integrate
//! positions, one relax sweep (rigid rows, no bias). After the last substep:
//! restitution, and the bodies take their new velocities and positions. See
//! `solver::soft` (contacts) and `solver::soft_joints` (joints). With threads, no joints
//! and the same force increment each substep, the substeps run as one job of the pool
//! (`SoftSolver::substeps_in_one_job`; the stage clock then counts the later substeps'
//! increments as solver time).

use super::{Stage, StageClock, StepContext, Stepper};
use crate::defs::SolverKind;
use crate::solver::soft::SoftSolver;
use crate::solver::soft_joints::SoftJoints;
use crate::world::{Speculative, StepStats, World};

/// The soft step and its scratch.
#[derive(Clone, Debug, Default)]
pub struct SoftStepper {
    pub(crate) soft: SoftSolver,
    joints: SoftJoints,
}

impl Stepper for SoftStepper {
    fn kind(&self) -> SolverKind {
        SolverKind::Soft
    }

    fn step(&mut self, world: &mut World, cx: &StepContext, clock: &mut StageClock) -> StepStats {
        let s = world.settings;
        let (n, h) = (cx.substeps, cx.h);
        let pool = world.pool();
        let pool = pool.as_deref();
        // points out to the distance each pair can close in the step (speculative
        // contacts): a fast body meets what it would pass through
        let penetration = world.collide(cx.dt, cx.margin, Speculative::MarginOrMotion, clock);
        // without drag (or bodies' own damping) the forces change every substep's
        // velocities by the same amount: integrate once, and the solver adds that
        // increment in the later substeps
        let uniform = world.uniform_forces();
        // with only gravity and the bodies' own forces, the first substep's forces are
        // integrated in prepare's pass over the bodies
        let fused = world.plain_forces();
        if fused {
            let g = world.gravity;
            // (this step's flags of the bodies the solver moves, where the collide found
            // them: the colouring need not wait for the solver's own pass over the bodies)
            let (bodies, contacts, movers) = world.bodies_with_movers();
            self.soft
                .prepare_integrating(bodies, contacts, movers, &s, h, g, pool);
        } else {
            self.soft
                .prepare(&world.bodies, &world.contacts, &s, h, pool);
        }
        let joints = !world.joints.is_empty() || world.mouse.is_some();
        if joints {
            self.joints
                .prepare(&world.joints, world.mouse.as_ref(), &world.bodies, &s, h);
        }
        clock.lap(Stage::Solve);
        let (mut iterations, mut residual) = (0u32, 0.0f32);
        // with threads, and only contacts, every substep in one job of the pool
        let in_one_job = uniform && !joints && self.soft.can_run_substeps_in_one_job(pool);
        if let (true, Some(pool)) = (in_one_job, pool) {
            if !fused {
                world.integrate_velocities(h);
                self.soft.take_increments(&world.bodies, Some(pool));
            }
            clock.lap(Stage::Forces);
            residual = self
                .soft
                .substeps_in_one_job(n as usize, &s, h, pool)
                .max(0.0);
            iterations = n * (s.iterations + 1);
            clock.lap(Stage::Solve);
        }
        for i in 0..if in_one_job { 0 } else { n } {
            if !uniform || (i == 0 && !fused) {
                world.integrate_velocities(h);
            }
            if !uniform {
                self.soft.load_velocities(&world.bodies);
            } else if i == 0 {
                if !fused {
                    self.soft.take_increments(&world.bodies, pool);
                }
            } else {
                self.soft.apply_increments(pool);
            }
            clock.lap(Stage::Forces);
            let soft = &mut self.soft;
            if s.warm_start {
                if joints {
                    self.joints
                        .warm_start(&world.joints, &mut soft.bodies, &soft.inv_mass);
                }
                soft.warm_start(pool);
            }
            for _ in 0..s.iterations {
                let rj = if joints {
                    self.joints
                        .sweep(&world.joints, &mut soft.bodies, &soft.inv_mass, true)
                } else {
                    0.0
                };
                let _ = soft.sweep::<true>(pool).max(rj);
                iterations += 1;
            }
            if joints {
                self.joints
                    .damp(&world.joints, &mut soft.bodies, &soft.inv_mass);
            }
            soft.integrate_positions(h, pool);
            let rj = if joints {
                self.joints
                    .sweep(&world.joints, &mut soft.bodies, &soft.inv_mass, false)
            } else {
                0.0
            };
            residual = soft.sweep::<false>(pool).max(rj);
            iterations += 1;

            if !uniform {
                soft.store_velocities(&mut world.bodies);
            }
            clock.lap(Stage::Solve);
        }
        self.soft.apply_restitution(s.restitution_threshold);
        self.soft.store_impulses(&mut world.contacts, pool);
        if joints {
            self.joints.store(&mut world.joints);
        }
        clock.lap(Stage::Solve);
        // velocities, then x = x0 + sum h v, theta = theta0 + sum h w
        world.ended = Some(self.soft.finish(&mut world.bodies, pool));
        clock.lap(Stage::Integrate);
        StepStats {
            iterations,
            residual,
            position_iterations: 0,
            contacts: self.soft.points(),
            penetration,
            ..Default::default()
        }
    }

    fn contact_lambdas(&self, _world: &World, out: &mut Vec<f32>) {
        self.soft.lambdas(out);
    }

    fn box_clone(&self) -> Box<dyn Stepper> {
        Box::new(self.clone())
    }

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
        assert_eq!(w.bodies_with_movers().2, all);
        let mut asleep = false;
        for _ in 0..120 {
            // (asleep at the step's start, as its collide finds it)
            asleep = w.bodies[1].asleep;
            w.step().unwrap();
            assert_eq!(w.bodies_with_movers().2, if asleep { None } else { all });
        }
        assert!(asleep, "the box falls asleep within 2 s");
        assert!(!w.bodies[2].asleep, "the ball falls");
        // woken, the next collide finds every flag again
        w.wake(1);
        w.step().unwrap();
        assert_eq!(w.bodies_with_movers().2, all);
    }
}
