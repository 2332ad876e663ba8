//! What a world does between steps on its own: groups spawned every N steps (the oldest
//! removed past a count), and kinematic bodies on a path. Deterministic (the same state
//! hash twice, at one and two threads, through a save and restore), the copies where
//! the offsets put them, the removal of many bodies at once the same as one by one, and
//! the path against its closed form.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use sandbox2d::math::Vec2;
use sandbox2d::{SolverKind, SolverSettings, World};

/// A floor of 300 static boxes (past the world's threshold for worker threads), and
/// every 6 steps from step 2 a group of a human and a box, 3 m to the right of the one
/// before, the offsets starting over every 4 copies, at most 3 alive.
const SPAWNS: &str = "name = \"spawns\"\n[world]\ngravity = [0.0, -10.0]\n\
    [[grid]]\nrows = 1\ncolumns = 300\nspacing = [0.5, 1.0]\norigin = [-75.0, -0.25]\ntype = \"static\"\nshape = { box = [0.5, 0.5] }\n\
    [[spawn]]\nevery = 6\nfirst = 2\nkeep = 3\ncycle = 4\noffset = [3.0, 0.0]\n\
    [[spawn.humans]]\norigin = [0.0, 1.0]\n\
    [[spawn.body]]\nname = \"crate\"\nshape = { box = [0.5, 0.5] }\nposition = [1.0, 3.0]\n";

fn world(text: &str, kind: SolverKind, threads: usize) -> World {
    let sc = sandbox2d::scene::load_str(text, "spawns.toml").unwrap_or_else(|e| panic!("{e}"));
    let mut w = World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap();
    w.set_threads(threads);
    w
}

fn run(w: &mut World, n: usize) -> Vec<u64> {
    (0..n)
        .map(|_| {
            w.step().unwrap();
            w.state_hash()
        })
        .collect()
}

#[test]
fn spawns_are_deterministic_twice_and_at_one_and_two_threads() {
    for kind in SolverKind::ALL {
        let a = run(&mut world(SPAWNS, kind, 1), 80);
        let b = run(&mut world(SPAWNS, kind, 1), 80);
        assert_eq!(a, b, "{kind:?}: the same run twice");
        let mut two = world(SPAWNS, kind, 2);
        let c = run(&mut two, 80);
        assert_eq!(a, c, "{kind:?}: two threads");
        assert!(two.parallel_jobs() > 0, "{kind:?}: the second thread ran");
    }
}

#[test]
fn a_copy_is_made_when_due_and_the_oldest_goes_past_the_count() {
    let mut w = world(SPAWNS, SolverKind::Soft, 1);
    let floor = w.body_count();
    assert_eq!(floor, 300, "nothing spawned before the first step");
    let group = 12;
    for step in 0..60u64 {
        w.step().unwrap();
        // copies made before steps 2, 8, 14, ...: after step s, those due at <= s
        let made = if step >= 2 { (step - 2) / 6 + 1 } else { 0 };
        assert_eq!(w.spawned(), vec![made], "after step {step}");
        let alive = made.min(3);
        assert_eq!(
            w.body_count(),
            floor + group * alive as usize,
            "after step {step}"
        );
        assert_eq!(w.joint_count(), 10 * alive as usize);
        // the live copies are the newest, in order, after the floor
        let first = made - alive;
        for (i, k) in (first..made).enumerate() {
            let hip = &w.nth_body(floor + group * i);
            assert_eq!(hip.name, format!("spawn0/humans0_0_hip#{k}"));
        }
    }
}

#[test]
fn copies_lie_at_their_offsets() {
    // no gravity: a copy stays where it was made
    let text = SPAWNS.replace("gravity = [0.0, -10.0]", "gravity = [0.0, 0.0]");
    let mut w = world(&text, SolverKind::Soft, 1);
    let floor = w.body_count();
    let mut seen = 0;
    for _ in 0..60 {
        w.step().unwrap();
        let made = w.spawned()[0];
        let alive = made.min(3);
        for (i, k) in (made - alive..made).enumerate() {
            let crate_ = &w.nth_body(floor + 12 * i + 11);
            assert_eq!(crate_.name, format!("spawn0/crate#{k}"));
            // copy k at (1, 3) + (k mod 4) (3, 0)
            let want = Vec2::new(1.0 + 3.0 * (k % 4) as f32, 3.0);
            assert!(
                crate_.position.distance(want) < 1e-5,
                "copy {k} at {:?}",
                crate_.position
            );
            seen += 1;
        }
    }
    assert!(seen > 100);
}

#[test]
fn a_run_with_spawns_saves_and_restores_bit_for_bit() {
    for kind in SolverKind::ALL {
        let mut straight = world(SPAWNS, kind, 1);
        run(&mut straight, 30);
        let saved =
            sandbox2d::WorldState::from_json(&straight.snapshot().to_json().unwrap()).unwrap();
        let mut restored = world(SPAWNS, kind, 1);
        restored.restore(&saved).unwrap();
        assert_eq!(restored.spawned(), straight.spawned());
        // past several spawns and removals
        assert_eq!(run(&mut restored, 40), run(&mut straight, 40), "{kind:?}");
    }
}

#[test]
fn removing_many_bodies_at_once_is_removing_them_one_by_one() {
    for kind in SolverKind::ALL {
        let mut one = world(SPAWNS, kind, 1);
        run(&mut one, 40);
        let mut many = one.clone();
        // the first live copy's bodies and a floor box, as keys
        let picks: Vec<usize> = (300..312).chain([7]).collect();
        let keys: Vec<_> = picks.iter().map(|&i| one.nth_key(i)).collect();
        for &k in &keys {
            one.remove_body(k).unwrap();
        }
        assert_eq!(many.remove_bodies(&keys).unwrap(), keys.len());
        assert_eq!(many.body_count(), one.body_count());
        assert_eq!(many.joint_count(), one.joint_count());
        for ((_, a), (_, b)) in many.bodies().zip(one.bodies()) {
            assert_eq!((&a.name, a.asleep), (&b.name, b.asleep));
        }
        assert_eq!(run(&mut many, 30), run(&mut one, 30), "{kind:?}");
    }
}

#[test]
fn a_kinematic_body_follows_its_path() {
    // x(t) = 60 sin(0.2 t), the junkyard's pusher; y stays
    let text = "name = \"path\"\n[[body]]\nname = \"pusher\"\ntype = \"kinematic\"\n\
        shape = { box = [4.0, 8.0] }\nposition = [0.0, 4.0]\n\
        oscillate = { amplitude = [60.0, 0.0], angular_frequency = 0.2 }\n";
    for kind in SolverKind::ALL {
        let mut w = world(text, kind, 1);
        let dt = w.settings.dt as f64;
        let mut worst = 0.0f64;
        for n in 1..=1200u64 {
            w.step().unwrap();
            let t = n as f64 * dt;
            let want = 60.0 * (0.2 * t).sin();
            let p = w.nth_body(0).position;
            worst = worst.max((p.x as f64 - want).abs());
            assert_eq!(p.y, 4.0, "{kind:?}");
        }
        // f32 positions up to 60 m: a few ulps a step, never gathering
        assert!(worst < 1e-4, "{kind:?}: off the path by {worst} m");
    }
}
