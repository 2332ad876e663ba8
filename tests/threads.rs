//! Both cores: a step split between threads gives the same bits as one thread, under
//! every solver, with contacts, joints, restitution and sleeping.

#[path = "common/loops.rs"]
mod loops;
use loops::one_sided_loop;
use sandbox2d::scene::load_str;
use sandbox2d::{SolverKind, SolverSettings, Threads, World};

/// A pyramid of 435 boxes, a row of bouncing balls over it, and a 12 x 12 hinged grid
/// hanging from two static cells: contacts (many colours), restitution and joints, with
/// enough bodies for the worker threads to start.
const SCENE: &str = r#"
name = "threads"
[world]
gravity = [0.0, -10.0]

[[body]]
name = "ground"
type = "static"
shape = { box = [200.0, 2.0] }
position = [0.0, -1.0]

[[pyramid]]
base = 29
box = [1.0, 1.0]

[[grid]]
rows = 1
columns = 20
spacing = [1.5, 1.0]
origin = [-14.0, 34.0]
shape = { circle = 0.4 }
restitution = 0.8

[[grid]]
rows = 12
columns = 12
spacing = [1.0, 1.0]
origin = [40.0, 5.0]
shape = { box = [0.6, 0.6] }
joints = "hinge"
static_cells = [[11, 0], [11, 11]]
"#;

fn world(kind: SolverKind, threads: usize) -> World {
    let sc = load_str(SCENE, "threads.toml").expect("scene parses");
    let mut w = World::from_def(&sc.world, SolverSettings::defaults(kind)).expect("builds");
    w.set_threads(threads);
    w
}

#[test]
fn the_step_is_bit_identical_whatever_the_thread_count() {
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        let steps = if kind == SolverKind::Xpbd { 12 } else { 40 };
        let mut one = world(kind, 1);
        let mut hashes = Vec::new();
        for _ in 0..steps {
            one.step().unwrap();
            hashes.push(one.state_hash());
        }
        assert_eq!(one.parallel_jobs(), 0, "{kind:?}: one thread runs no job");
        assert!(
            one.contacts().len() > 800,
            "{} contacts",
            one.contacts().len()
        );
        for threads in [2, 3] {
            let mut many = world(kind, threads);
            for (i, h) in hashes.iter().enumerate() {
                many.step().unwrap();
                assert_eq!(
                    many.state_hash(),
                    *h,
                    "{kind:?}, {threads} threads: step {} differs",
                    i + 1
                );
            }
            assert!(
                many.parallel_jobs() >= steps as u64,
                "{kind:?}, {threads} threads: {} parallel jobs",
                many.parallel_jobs()
            );
            // the contacts come back in the one-thread order, impulses and all
            let (a, b) = (one.contacts(), many.contacts());
            assert_eq!(a.len(), b.len());
            for (x, y) in a.iter().zip(b) {
                // both built alike: the same keys name the same places
                assert_eq!(one.contact_bodies(x), many.contact_bodies(y));
                for (p, q) in x.manifold.points().iter().zip(y.manifold.points()) {
                    assert_eq!(p.normal_impulse.to_bits(), q.normal_impulse.to_bits());
                }
            }
        }
    }
}

#[test]
fn a_pile_falls_asleep_the_same_way_on_two_threads() {
    // a pyramid of 325 boxes under 8 substeps of 120 Hz contacts comes to rest and sleeps
    let text = "name = \"pile\"\n[world]\ngravity = [0.0, -10.0]\n\
                [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [200.0, 2.0] }\nposition = [0.0, -1.0]\n\
                [[pyramid]]\nbase = 25\n";
    let settle = |threads| {
        let sc = load_str(text, "pile.toml").unwrap();
        let mut s = SolverSettings::soft();
        (s.substeps, s.iterations, s.contact_hertz) = (8, 1, 120.0);
        let mut w = World::from_def(&sc.world, s).unwrap();
        w.set_threads(threads);
        let mut asleep_at = None;
        for i in 0..900 {
            w.step().unwrap();
            if asleep_at.is_none() && w.bodies().map(|(_, b)| b).filter(|b| b.asleep).count() > 300
            {
                asleep_at = Some(i);
            }
        }
        (asleep_at, w.state_hash(), w.parallel_jobs())
    };
    let (at1, h1, _) = settle(1);
    let (at2, h2, jobs) = settle(2);
    assert!(at1.is_some(), "the pile sleeps within 15 s");
    assert!(jobs > 0);
    assert_eq!((at1, h1), (at2, h2));
}

#[test]
fn a_step_of_contacts_alone_is_bit_identical_whatever_the_thread_count() {
    // no joints: the soft step runs its substeps in one job of the pool. 903 boxes: over
    // 2,048 contacts, so one thread colours them while the others load the bodies, and
    // the threads lay the constraints out side by side
    let text = "name = \"pile\"\n[world]\ngravity = [0.0, -10.0]\n\
                [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [200.0, 2.0] }\nposition = [0.0, -1.0]\n\
                [[pyramid]]\nbase = 42\n\
                [[grid]]\nrows = 1\ncolumns = 20\nspacing = [1.5, 1.0]\norigin = [-14.0, 34.0]\nshape = { circle = 0.4 }\n";
    let run = |threads| {
        let sc = load_str(text, "pile.toml").unwrap();
        let mut w = World::from_def(&sc.world, SolverSettings::soft()).unwrap();
        w.set_threads(threads);
        let hashes: Vec<u64> = (0..60)
            .map(|_| {
                w.step().unwrap();
                w.state_hash()
            })
            .collect();
        assert!(w.contacts().len() > 2048, "{} contacts", w.contacts().len());
        (hashes, w.parallel_jobs())
    };
    same_bits_at_two_and_three_threads(60, run);
}

/// `run(threads)` gives the state hash after each of `steps` steps and the pool's jobs:
/// at two and three threads, the hashes of one thread, with the pool at work (a job a
/// step at least).
fn same_bits_at_two_and_three_threads(steps: u64, run: impl Fn(usize) -> (Vec<u64>, u64)) {
    let (one, _) = run(1);
    for threads in [2, 3] {
        let (many, jobs) = run(threads);
        assert!(jobs >= steps, "{threads} threads: {jobs} jobs");
        assert_eq!(one, many, "{threads} threads");
    }
}

#[test]
fn threads_are_clamped_and_default_to_one() {
    let mut w = world(SolverKind::Soft, 1);
    assert_eq!(World::new(None, SolverSettings::soft()).threads(), 1);
    w.set_threads(0);
    assert_eq!(w.threads(), 1);
    w.set_threads(10_000);
    assert_eq!(w.threads(), sandbox2d::threads::MAX_THREADS);
}

#[test]
fn every_built_in_scene_ends_in_the_same_state_whatever_the_threads() {
    // 1, 2 and 3 threads on every step, and up to 3 measured (the world picks one thread
    // or three step by step): the same state hash after every step
    for name in sandbox2d::scene::builtin_names() {
        let sc = sandbox2d::scene::load(name).unwrap();
        let steps = if sc.world.bodies.len() > 1000 { 8 } else { 40 };
        let run = |policy: Threads| {
            let mut w = World::from_def(&sc.world, sc.world.solver.resolve()).unwrap();
            w.set_thread_policy(policy);
            let hashes: Vec<u64> = (0..steps)
                .map(|_| {
                    w.step().unwrap();
                    w.state_hash()
                })
                .collect();
            (hashes, w.thread_use())
        };
        let (one, _) = run(Threads::Fixed(1));
        for policy in [Threads::Fixed(2), Threads::Fixed(3), Threads::UpTo(3)] {
            let (many, used) = run(policy);
            assert_eq!(one, many, "{name} under {policy:?}");
            if policy == Threads::UpTo(3) && sc.world.bodies.len() >= 256 {
                assert_eq!(
                    used.steps_on_one + used.steps_on_many,
                    steps as u64,
                    "{name}"
                );
            }
        }
    }
}

#[test]
fn a_swirl_in_a_one_sided_loop_is_bit_identical_whatever_the_thread_count() {
    // 400 discs spun at up to 60 m/s inside a one-sided loop of 72 sides and pressed
    // outward at 10,000 g: a step carries the outer ones' centres behind the wall, and
    // the pass that puts them back runs over the bodies on every thread
    let radius = 10.0f32;
    let mut text = one_sided_loop("swirl", -10.0, radius, 72);
    let spin = 60.0 / (radius - 0.5);
    for i in 0..20 {
        for j in 0..20 {
            let (x, y) = (-6.65 + 0.7 * i as f32, -6.65 + 0.7 * j as f32);
            text += &format!(
                "[[body]]\nname = \"d{i}_{j}\"\nshape = {{ circle = 0.3 }}\nposition = [{x}, {y}]\n\
                 velocity = [{}, {}]\n",
                -spin * y,
                spin * x
            );
        }
    }
    let sc = load_str(&text, "swirl.toml").unwrap();
    let run = |threads| {
        let mut w = World::from_def(&sc.world, SolverSettings::soft()).unwrap();
        w.set_threads(threads);
        let hashes: Vec<u64> = (0..60)
            .map(|_| {
                let pushes: Vec<_> = w
                    .bodies()
                    .filter(|(_, b)| b.is_dynamic())
                    .map(|(key, b)| {
                        (
                            key,
                            b.position.normalize_or_zero() * (b.mass * 1.0e5),
                            b.position,
                        )
                    })
                    .collect();
                for (key, push, at) in pushes {
                    w.apply_force(key, push, at).unwrap();
                }
                w.step().unwrap();
                w.state_hash()
            })
            .collect();
        let outside = w
            .bodies()
            .filter(|(_, b)| b.is_dynamic() && b.position.length() > radius)
            .count();
        assert_eq!(outside, 0, "{threads} threads: discs left the loop");
        (hashes, w.parallel_jobs())
    };
    same_bits_at_two_and_three_threads(60, run);
}

/// A 50 x 50 hinged grid hanging from its top corners: 4,900 joints, enough for
/// `World::joint_error` to split them between the threads.
const BIG_GRID: &str = r#"
name = "big grid"
[world]
gravity = [0.0, -10.0]

[[grid]]
rows = 50
columns = 50
spacing = [1.0, 1.0]
origin = [0.0, 0.0]
shape = { circle = 0.4 }
joints = "hinge"
static_cells = [[49, 0], [49, 49]]
"#;

#[test]
fn the_largest_joint_error_is_the_same_measured_on_one_thread_or_several() {
    let sc = load_str(BIG_GRID, "big_grid.toml").expect("scene parses");
    for policy in [Threads::Fixed(1), Threads::Fixed(2), Threads::Fixed(3)] {
        let mut w = World::from_def(&sc.world, SolverSettings::soft()).expect("builds");
        w.set_thread_policy(policy);
        assert!(w.joint_count() >= 4096, "{} joints", w.joint_count());
        for _ in 0..30 {
            w.step().expect("steps");
            // the largest of each joint's own error, found one joint at a time
            let one_by_one = w
                .joints()
                .map(|(k, _)| w.joint_position_error(k).expect("a live key"))
                .fold(0.0, f32::max);
            assert_eq!(
                w.joint_error().to_bits(),
                one_by_one.to_bits(),
                "{policy:?}"
            );
        }
        // the grid sags under its own weight: the joints hold, yet not to the bit
        let e = w.joint_error();
        assert!(e > 0.0 && e < 0.5, "{policy:?}: largest joint error {e} m");
    }
}
