//! Removing bodies and joints: a removed body leaves the world that never had it (bit
//! for bit), keys outlive removals and never name another body, and what a removed body
//! held falls as free fall says.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use glam::Vec2;
use sandbox2d::{
    BodyDef, BodyType, RemoveError, ShapeDef, SolverKind, SolverSettings, World, WorldDef,
};

fn settings(kind: SolverKind) -> SolverSettings {
    let mut s = match kind {
        SolverKind::Soft => SolverSettings::soft(),
        SolverKind::Pgs => SolverSettings::pgs(),
        SolverKind::Xpbd => SolverSettings::xpbd(),
    };
    s.sleep = false;
    s
}

fn hashes(w: &mut World, steps: usize) -> Vec<u64> {
    (0..steps)
        .map(|_| {
            w.step().unwrap();
            w.state_hash()
        })
        .collect()
}

#[test]
fn a_body_removed_before_the_first_step_leaves_the_world_that_never_had_it() {
    // the base-20 pyramid less one box of its middle row, against the pyramid built
    // whole with that box removed before step 0: the same hash at every step, under
    // every solver
    let def: WorldDef = sandbox2d::scene::load("pyramid").unwrap().world;
    let gone = def.bodies.len() / 2;
    let mut less = def.clone();
    less.bodies.remove(gone);
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        let mut a = World::from_def(&less, settings(kind)).unwrap();
        let mut b = World::from_def(&def, settings(kind)).unwrap();
        let key = b.nth_key(gone);
        let removed = b.remove_body(key).unwrap();
        assert_eq!(removed.name, def.bodies[gone].name);
        assert_eq!(hashes(&mut a, 60), hashes(&mut b, 60), "{kind:?}");
    }
}

#[test]
fn removing_a_chain_link_removes_its_joints_and_keeps_the_rest() {
    // the chain less its last link (and the joint that held it) against the chain built
    // whole and its last link removed: the same trajectories
    let def: WorldDef = sandbox2d::scene::load("chain").unwrap().world;
    let last = def.bodies.len() - 1;
    let mut less = def.clone();
    less.bodies.pop();
    less.joints.retain(|j| !j.bodies.contains(&last));
    assert_eq!(less.joints.len() + 1, def.joints.len());
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        let mut a = World::from_def(&less, settings(kind)).unwrap();
        let mut b = World::from_def(&def, settings(kind)).unwrap();
        b.remove_body(b.nth_key(last)).unwrap();
        assert_eq!(b.joint_count(), less.joints.len());
        assert_eq!(hashes(&mut a, 60), hashes(&mut b, 60), "{kind:?}");
    }
}

fn boxes_on_ground(kind: SolverKind) -> World {
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), settings(kind));
    let body = |name: &str, t, y| BodyDef {
        name: name.into(),
        body_type: t,
        shape: ShapeDef::Box {
            width: 1.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, y),
        ..BodyDef::default()
    };
    let mut ground = body("ground", BodyType::Static, -0.5);
    ground.shape = ShapeDef::Box {
        width: 20.0,
        height: 1.0,
    };
    w.create_body(&ground).unwrap();
    w.create_body(&body("low", BodyType::Dynamic, 0.5)).unwrap();
    w.create_body(&body("high", BodyType::Dynamic, 1.5))
        .unwrap();
    w
}

#[test]
fn keys_outlive_removals_and_never_name_another_body() {
    let mut w = boxes_on_ground(SolverKind::Soft);
    let (low, high) = (w.nth_key(1), w.nth_key(2));
    w.remove_body(low).unwrap();
    // the high box moved down an index, its key follows it
    assert_eq!(w.order_of_key(high), Some(1));
    assert_eq!(w.nth_body(1).name, "high");
    assert_eq!(w.order_of_key(low), None);
    assert_eq!(w.remove_body(low).unwrap_err(), RemoveError::NoSuchBody);
    // a new body takes the freed slot under a new generation: the old key stays dead
    let i = w
        .create_body(&BodyDef {
            name: "new".into(),
            position: Vec2::new(3.0, 0.5),
            ..BodyDef::default()
        })
        .unwrap();
    let new = i;
    assert_ne!(new, low);
    assert_eq!(w.order_of_key(low), None);
    assert_eq!(w.order_of_key(new), Some(w.body_count() - 1));
    // a key of another world's restore names nothing either
    let state = w.snapshot();
    w.restore(&state).unwrap();
    assert_eq!(w.order_of_key(high), None);
    assert_eq!(w.order_of_key(new), None);
    assert_eq!(w.order_of_key(w.nth_key(1)), Some(1));
}

#[test]
fn what_rested_on_a_removed_body_falls_freely_even_asleep() {
    // two boxes stacked on the ground, left to fall asleep; the lower one is removed:
    // the upper wakes and falls 1 m to the ground, y(t) = y0 - g t^2 / 2 until it lands
    // (within 1 cm while in the air), under every solver
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        let mut s = settings(kind);
        s.sleep = true;
        let mut w = boxes_on_ground(kind);
        w.settings = s;
        for _ in 0..120 {
            w.step().unwrap();
        }
        assert!(w.nth_body(2).asleep, "{kind:?}: the stack sleeps");
        let y0 = w.nth_body(2).position.y;
        w.remove_body(w.nth_key(1)).unwrap();
        // in the air for sqrt(2 * 1 m / g) = 0.447 s: check the first 0.4 s, against
        // semi-implicit Euler's free fall over N substeps of h: y0 - g h^2 N (N + 1) / 2
        let h = w.settings.dt / w.settings.substeps as f32;
        for n in 1..=24 {
            w.step().unwrap();
            let big_n = (n * w.settings.substeps) as f32;
            let t = n as f32 * w.settings.dt;
            let want = y0 - 10.0 * h * h * big_n * (big_n + 1.0) / 2.0;
            let y = w.nth_body(1).position.y;
            assert!((y - want).abs() < 0.01, "{kind:?}: t {t}: y {y} vs {want}");
        }
        for _ in 0..60 {
            w.step().unwrap();
        }
        let y = w.nth_body(1).position.y;
        assert!(
            (y - 0.5).abs() < 0.02,
            "{kind:?}: lands on the ground, y {y}"
        );
    }
}

#[test]
fn a_pendulum_whose_hinge_is_removed_falls_freely() {
    // the built-in pendulum: with its hinge removed the disc accelerates at g from the
    // velocity it had, under every solver
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        let def = sandbox2d::scene::load("pendulum").unwrap().world;
        let mut w = World::from_def(&def, settings(kind)).unwrap();
        for _ in 0..30 {
            w.step().unwrap();
        }
        let disc = w
            .bodies()
            .map(|(_, b)| b)
            .position(|b| b.is_dynamic())
            .unwrap();
        let (p0, v0) = (w.nth_body(disc).position, w.nth_body(disc).velocity);
        let key = w.joints().next().unwrap().0;
        w.remove_joint(key).unwrap();
        assert!((w.joint_count() == 0));
        assert_eq!(w.remove_joint(key).unwrap_err(), RemoveError::NoSuchJoint);
        let g = w.gravity.unwrap();
        let n = 30;
        for _ in 0..n {
            w.step().unwrap();
        }
        // semi-implicit Euler over N substeps of h: p = p0 + N h v0 + h^2 g N (N + 1) / 2
        let h = w.settings.dt / w.settings.substeps as f32;
        let big_n = (n * w.settings.substeps) as f32;
        let want = p0 + big_n * h * v0 + g * h * h * big_n * (big_n + 1.0) / 2.0;
        let got = w.nth_body(disc).position;
        assert!((got - want).length() < 1e-3, "{kind:?}: {got} vs {want}");
    }
}
