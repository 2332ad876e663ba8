//! The step allocates nothing in steady state (counted by a global allocator; this file
//! holds one test so no other test allocates on the same counter).

use sandbox2d::{SolverKind, SolverSettings, World, scene};

#[path = "common/counting.rs"]
mod counting;

#[global_allocator]
static COUNTING: counting::Counting = counting::Counting;

#[test]
fn steady_steps_allocate_nothing() {
    // every solver, on a pile, on joints (the pendulum's distance joint; the joints
    // scene's limits, servo, motor, prismatic and weld; the car's motors on contacts)
    // and with drag
    for (kind, name) in SolverKind::ALL.into_iter().flat_map(|k| {
        [
            (k, "pyramid"),
            (k, "pendulum"),
            (k, "joints"),
            (k, "car"),
            (k, "vacuum_vs_fluid"),
        ]
    }) {
        // the solvers' steady path: awake throughout (the sleeping path: below)
        let s = SolverSettings {
            sleep: false,
            ..SolverSettings::defaults(kind)
        };
        let built = counting::allocations();
        let sc = scene::load(name).unwrap();
        let mut w = World::from_def(&sc.world, s).unwrap();
        assert!(counting::allocations() > built, "the counter counts");
        for _ in 0..100 {
            w.step().unwrap();
        }
        let before = counting::allocations();
        for _ in 0..100 {
            w.step().unwrap();
        }
        let after = counting::allocations();
        assert_eq!(after - before, 0, "{kind:?} on {name}: allocations");
    }
}

#[test]
fn a_sleeping_pile_steps_without_allocating() {
    // the pyramid asleep: the steps that check for waking allocate nothing (soft step and
    // PGS; under XPBD the pyramid jitters at 0.1 m/s and never sleeps: docs/stability.md)
    for kind in [SolverKind::Soft, SolverKind::Pgs] {
        let sc = scene::load("pyramid").unwrap();
        let mut w = World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap();
        for _ in 0..600 {
            w.step().unwrap();
        }
        let asleep = w.bodies().map(|(_, b)| b).filter(|b| b.asleep).count();
        assert!(asleep > 200, "{kind:?}: {asleep} of 211 asleep");
        let before = counting::allocations();
        for _ in 0..100 {
            w.step().unwrap();
        }
        let after = counting::allocations();
        assert_eq!(after - before, 0, "{kind:?}: allocations while asleep");
    }
}
