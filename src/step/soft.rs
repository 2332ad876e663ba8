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
        self.soft.set_deepest(penetration);
        self.soft.set_odd_step(cx.index % 2 == 1);
        // the body passes skip the blocks where every body sleeps
        self.soft.set_awake(&state.collider.awake);
        // without drag (or bodies' own damping) the forces change every substep's
        // velocities by the same amount: integrate once, and the solver adds that
        // increment in the later substeps
        let uniform = state.forces().uniform();
        // the joints first: their pass also finds whether some joint has a drive
        let driven = self.soft.prepare_joints(
            state.joints,
            state.mouse.as_ref(),
            state.bodies,
            &s,
            h,
            pool,
        );
        // with only gravity and the bodies' own forces and damping, the first substep's
        // forces are integrated in prepare's pass over the bodies (and the damping
        // applied in every substep by the solver)
        let fused = state.plain_forces() && !driven;
        if fused {
            let g = state.gravity;
            // (this step's flags of the bodies the solver moves, where the collide found
            // them: the colouring need not wait for the solver's own pass over the bodies)
            let movers = state.collider.movers(state.bodies.len());
            self.soft.prepare_integrating(
                state.bodies,
                state.contacts,
                state.joints,
                movers,
                &s,
                h,
                g,
                state.damped,
                pool,
            );
        } else {
            self.soft
                .prepare_constraints(state.bodies, state.contacts, state.joints, &s, h, pool);
        }
        clock.lap(Stage::Solve);
        let residual;
        if uniform || fused {
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

    #[cfg(test)]
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}

#[cfg(test)]
mod tests {
    use crate::defs::{SolverKind, SolverSettings};
    use crate::math::Vec2;
    use crate::solver::soft::{SoftSolver, testing};
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
        w.wake_index(1);
        w.step().unwrap();
        assert_eq!(w.collider.movers(w.bodies.len()), all);
    }

    /// A ball (body 0) drifting at 2 m/s in zero gravity towards a wall of 24 x 40 boxes
    /// of 0.5 m, `spacing` apart, that start asleep: 961 bodies, sixteen awake blocks
    /// (`AWAKE_BLOCK`); the ball's holds 63 sleepers, the other fifteen only sleepers. The
    /// ball's edge reaches the wall's (x = -0.25) at t = 2.25 / 2 s, step 68.
    fn ball_and_sleeping_wall(settings: SolverSettings, spacing: f32) -> World {
        let sc = crate::scene::load_str(
            &format!("name = \"wall\"\n[world]\ngravity = [0.0, 0.0]\n\
             [solver]\nkind = \"soft\"\nsleep = true\n\
             [[body]]\nname = \"ball\"\nshape = {{ circle = 0.5 }}\nposition = [-3.0, 0.0]\nvelocity = [2.0, 0.0]\n\
             [[grid]]\nrows = 40\ncolumns = 24\nspacing = [{spacing}, {spacing}]\norigin = [0.0, -10.0]\n\
             shape = {{ box = [0.5, 0.5] }}\nawake = false\n"),
            "wall.toml",
        )
        .unwrap();
        World::from_def(&sc.world, settings).unwrap()
    }

    #[test]
    fn a_few_sleepers_among_many_movers_wake_as_through_a_grid_of_every_box() {
        // 240 boxes fall onto a ground where ten boxes sleep, 4 m apart: six under the
        // falling ones (which wake them), four far to the side (which stay asleep); a
        // kinematic box beyond them moves for ever, so every step's movers reach round
        // the sleepers. The waking pass looks through a grid of the sleepers' boxes; the
        // same world with every pass looking through a grid of every box must match it
        // to the bit, on one thread and on two
        let scene = "name = \"few sleepers\"\n[world]\ngravity = [0.0, -10.0]\n[solver]\nkind = \"soft\"\nsleep = true\n\
             [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [200.0, 1.0] }\nposition = [0.0, -0.5]\n\
             [[body]]\nname = \"drifter\"\ntype = \"kinematic\"\nshape = { box = [1.0, 1.0] }\nposition = [70.0, 0.5]\nvelocity = [0.0, 0.1]\n\
             [[grid]]\nrows = 1\ncolumns = 6\nspacing = [4.0, 1.0]\norigin = [-10.0, 0.5]\n\
             shape = { box = [1.0, 1.0] }\nawake = false\n\
             [[grid]]\nrows = 1\ncolumns = 4\nspacing = [4.0, 1.0]\norigin = [40.0, 0.5]\n\
             shape = { box = [1.0, 1.0] }\nawake = false\n\
             [[grid]]\nrows = 6\ncolumns = 40\nspacing = [0.5, 0.6]\norigin = [-10.0, 6.0]\n\
             shape = { box = [0.4, 0.4] }\n";
        let sc = crate::scene::load_str(scene, "few.toml").unwrap();
        let bits = World::motion_bits;
        use crate::step::sleep::testing::{EVERY_BOX, SLEEPERS_GRIDS};
        for threads in [1, 2] {
            let run = |every_box: bool| {
                EVERY_BOX.with(|c| c.set(every_box));
                SLEEPERS_GRIDS.with(|c| c.set(0));
                let mut w = World::from_def(&sc.world, SolverSettings::soft()).unwrap();
                w.set_threads(threads);
                // (bodies 2 to 11 the sleepers) the step each first woke at
                let mut woke = [None; 10];
                for k in 0..120 {
                    w.step().unwrap();
                    for (at, b) in woke.iter_mut().zip(&w.bodies[2..12]) {
                        if at.is_none() && !b.asleep {
                            *at = Some(k);
                        }
                    }
                }
                EVERY_BOX.with(|c| c.set(false));
                (w, woke, SLEEPERS_GRIDS.with(|c| c.get()))
            };
            let (a, woke_a, grids_a) = run(false);
            let (b, woke_b, grids_b) = run(true);
            assert_eq!(bits(&a), bits(&b), "{threads} threads");
            assert_eq!(woke_a, woke_b);
            assert!(grids_a > 40, "the sleepers' grid looked: {grids_a}");
            assert_eq!(grids_b, 0);
            // the six under the falling boxes woke as the boxes came down (about 5 m
            // of fall: 1 s), the four beside them sleep on
            assert!(
                woke_a[..6].iter().all(|k| k.is_some_and(|k| k > 40)),
                "{woke_a:?}"
            );
            assert!(woke_a[6..].iter().all(Option::is_none), "{woke_a:?}");
        }
    }

    #[test]
    fn rest_blocks_skip_the_sleeping_wall_and_change_no_bit() {
        // Boxes 0.5 m apart (each wakes alone). Under each solver, the same world stepped twice: once as it is, once with the
        // rest blocks forgotten before every step (every body visited). The skipped
        // blocks' entries are checked against fresh ones in debug builds; here every
        // body's state must match to the bit, through the ball's flight (the wall's
        // blocks rest), an impulse to a sleeper, a push (the window's force) on a
        // sleeper, a body removed, and the wall waking
        let bits = |w: &World| -> Vec<u32> {
            w.bodies
                .iter()
                .flat_map(|b| {
                    [
                        b.position.x,
                        b.position.y,
                        b.angle,
                        b.velocity.x,
                        b.velocity.y,
                    ]
                })
                .map(f32::to_bits)
                .collect()
        };
        for kind in SolverKind::ALL {
            let mut a = ball_and_sleeping_wall(SolverSettings::defaults(kind), 1.0);
            let mut b = ball_and_sleeping_wall(SolverSettings::defaults(kind), 1.0);
            assert!(a.settings.sleep);
            let rest = |w: &World| (0..16).map(|k| w.sleep.rest.is_rest(k)).collect::<Vec<_>>();
            // (961 bodies: sixteen awake blocks, the ball in the first)
            let resting = |off: &[usize]| {
                (0..16)
                    .map(|k| k > 0 && !off.contains(&k))
                    .collect::<Vec<_>>()
            };
            for k in 1..=100 {
                b.sleep.rest.forget();
                a.step().unwrap();
                b.step().unwrap();
                assert_eq!(bits(&a), bits(&b), "{kind:?} step {k}");
                match k {
                    // from the second step the wall's blocks rest (the first visits
                    // them)
                    2..=29 => assert_eq!(rest(&a), resting(&[]), "{kind:?} {k}"),
                    30 => {
                        // an impulse wakes a sleeper in block 9: that block is visited
                        // again
                        for w in [&mut a, &mut b] {
                            let key = w.body_key(600).unwrap();
                            w.apply_impulse(key, Vec2::new(0.0, 0.01), w.bodies[600].position)
                                .unwrap();
                        }
                        assert_eq!(rest(&a), resting(&[9]));
                    }
                    35 => {
                        // a force on a sleeper in block 12 (the window's push, which
                        // leaves the waking to the next wake pass): that block is
                        // visited again, and its pushed sleeper wakes there
                        for w in [&mut a, &mut b] {
                            let at = w.bodies[800].position;
                            w.apply_force_index(800, Vec2::new(0.0, 5.0), at);
                        }
                        assert!(!rest(&a)[12]);
                        b.sleep.rest.forget();
                        a.step().unwrap();
                        b.step().unwrap();
                        assert_eq!(bits(&a), bits(&b), "{kind:?} after the push");
                        assert!(!a.bodies[800].asleep, "{kind:?}: the pushed sleeper woke");
                    }
                    40 => {
                        // removing a body shifts the later ones, and a sleeper added
                        // far away keeps the count: nothing rests until the next
                        // step's end finds it again
                        for w in [&mut a, &mut b] {
                            let key = w.body_key(700).unwrap();
                            w.remove_body(key).unwrap();
                            let late = crate::defs::BodyDef {
                                name: "late".into(),
                                position: Vec2::new(50.0, 50.0),
                                awake: false,
                                ..Default::default()
                            };
                            w.create_body(&late).unwrap();
                        }
                        assert_eq!(a.bodies.len(), 961);
                    }
                    _ => {}
                }
            }
            assert!(
                a.bodies.iter().skip(1).any(|b| !b.asleep),
                "{kind:?}: the wall woke"
            );
        }
    }

    #[test]
    fn the_body_passes_skip_blocks_where_every_body_sleeps_and_read_no_sleeper() {
        let mut w = ball_and_sleeping_wall(SolverSettings::soft(), 0.5);
        let n = w.bodies.len();
        assert_eq!(n, 961);
        let dt = w.settings.dt;
        let start: Vec<_> = w.bodies.iter().map(|b| b.position).collect();
        let mut woke = None;
        for k in 1..=120 {
            // every sleeper's entry in the solver is NaN: a pass or a row that read one
            // the step did not load would put NaN into the world
            let bodies = w.bodies.clone();
            if let Some(st) = w.stepper_as_mut::<SoftStepper>() {
                st.soft.poison_sleepers(&bodies);
            }
            w.step().unwrap_or_else(|e| panic!("step {k}: {e}"));
            let st = w.stepper_as::<SoftStepper>().unwrap();
            if w.bodies.iter().filter(|b| b.asleep).count() == n - 1 {
                // only the ball's block is visited
                let want: Vec<bool> = (0..16).map(|k| k == 0).collect();
                assert_eq!(st.soft.awake_blocks(), &want[..], "step {k}");
                // the ball flies free: x = x0 + v t
                let x = -3.0 + 2.0 * dt * k as f32;
                assert!((w.bodies[0].position.x - x).abs() < 1e-4, "step {k}");
            } else {
                woke.get_or_insert(k);
            }
            assert!(
                w.bodies
                    .iter()
                    .all(|b| b.position.is_finite() && b.velocity.is_finite())
            );
        }
        // the ball reaches the wall at step 68, and wakes the boxes it reaches
        let woke = woke.expect("the ball woke the wall");
        assert!((66..=69).contains(&woke), "woke at step {woke}");
        assert!(w.bodies.iter().skip(1).any(|b| !b.asleep));
        assert!(w.bodies[0].position.x < 0.0, "the ball stopped at the wall");
        let moved = w
            .bodies
            .iter()
            .zip(&start)
            .filter(|(b, s)| b.position != **s)
            .count();
        assert!(moved > 1, "the wall was pushed");
    }

    /// The built-in pyramid (base 20, 210 boxes) under the soft step, after `n` steps.
    fn soft_pyramid(n: usize) -> World {
        let sc = crate::scene::load("pyramid").unwrap();
        let mut w = World::from_def(&sc.world, SolverSettings::defaults(SolverKind::Soft)).unwrap();
        for _ in 0..n {
            w.step().expect("steps");
        }
        w
    }

    /// One soft substep of the world's current contacts, from scratch: prepare, warm start,
    /// four biased sweeps, positions and a relax sweep; returns the solver (velocities,
    /// lambdas).
    fn soft_solve(w: &World) -> SoftSolver {
        let mut s = SoftSolver::default();
        let h = w.settings.dt / w.settings.substeps as f32;
        let settings = SolverSettings {
            iterations: 4,
            ..w.settings
        };
        s.prepare(&w.bodies, w.contacts(), &[], None, &settings, h, None);
        s.run(&[], 1, &settings, h, None);
        s
    }

    /// Every solved velocity and lambda, as bits.
    fn solve_bits(s: &SoftSolver) -> Vec<u32> {
        let mut lam = Vec::new();
        s.lambdas(&mut lam);
        s.solved_bodies()
            .iter()
            .flat_map(|b| [b.v.x, b.v.y, b.w])
            .chain(lam)
            .map(f32::to_bits)
            .collect()
    }

    #[test]
    fn soft_lanes_solve_what_one_by_one_solves() {
        // Constraints of one colour share no moving body, so four in lock step are four one
        // after another: the packed layout and one constraint per wide constraint (lane 0,
        // the others empty) give the same bits, for one solve and for whole steps.
        let w = soft_pyramid(30);
        assert!(w.contacts().len() > 300, "{} contacts", w.contacts().len());
        let packed = soft_solve(&w);
        testing::one_lane(true);
        let single = soft_solve(&w);
        testing::one_lane(false);
        assert!(packed.lanes_are_independent(w.contacts()));
        assert!(
            packed.wide_count() * 3 < single.wide_count(),
            "packed into {} wide constraints, one by one {}",
            packed.wide_count(),
            single.wide_count()
        );
        assert_eq!(single.wide_count(), w.contacts().len());
        assert!(
            solve_bits(&packed) == solve_bits(&single),
            "a solve differs"
        );

        let mut a = w.clone();
        let mut b = w.clone();
        testing::one_lane(true);
        for k in 0..60 {
            b.step().unwrap();
            testing::one_lane(false);
            a.step().unwrap();
            testing::one_lane(true);
            assert_eq!(a.state_hash(), b.state_hash(), "step {k}");
        }
        testing::one_lane(false);
    }

    #[test]
    fn soft_sse_and_avx2_builds_give_the_same_bits() {
        if !testing::avx2_detected() {
            eprintln!("SKIPPED: this CPU has no AVX2, only the SSE build runs");
            return;
        }
        // the AVX2 build solves two wide constraints of a colour at once in eight lanes;
        // with restitution the sweeps also keep each point's largest impulse
        let plain = soft_pyramid(30);
        let mut bouncy = plain.clone();
        for b in &mut bouncy.bodies {
            b.restitution = 0.5;
        }
        for _ in 0..5 {
            bouncy.step().expect("steps");
        }
        assert!(bouncy.contacts().iter().any(|c| c.restitution > 0.0));
        for w in [plain, bouncy] {
            testing::force_sse(true);
            let sse = soft_solve(&w);
            testing::force_sse(false);
            let avx2 = soft_solve(&w);
            assert!(solve_bits(&sse) == solve_bits(&avx2), "a solve differs");

            let mut a = w.clone();
            let mut b = w.clone();
            for k in 0..60 {
                testing::force_sse(true);
                a.step().unwrap();
                testing::force_sse(false);
                b.step().unwrap();
                assert_eq!(a.state_hash(), b.state_hash(), "step {k}");
            }
        }
    }
}
