//! A body through its key: keys against a model over random adds and removes (a
//! removed body's key is refused and never names a later body), and the setters: they
//! check what they are given, leave the body as it was when they refuse, wake a
//! sleeping body, and move it as mechanics says (an impulse changes momentum by itself).

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
#[path = "common/ground.rs"]
mod ground;
use glam::Vec2;
use proptest::prelude::*;
use sandbox2d::{
    BodyDef, BodyKey, BodyType, EditError, JointDef, RemoveError, ShapeDef, SolverSettings, World,
};

fn crate_body(name: String, x: f32) -> BodyDef {
    BodyDef {
        name,
        shape: ShapeDef::Box {
            width: 1.0,
            height: 1.0,
        },
        position: Vec2::new(x, 0.5),
        ..BodyDef::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random adds and removes against a model (name of each live key): every live
    /// key names its own body, every removed key is refused everywhere, and no key is
    /// ever handed out twice.
    #[test]
    fn keys_follow_a_model_of_adds_and_removes(
        ops in proptest::collection::vec((any::<bool>(), any::<prop::sample::Index>()), 1..80),
    ) {
        let mut w = World::new(None, SolverSettings::default());
        let mut live: Vec<(BodyKey, String)> = Vec::new();
        let mut dead: Vec<BodyKey> = Vec::new();
        let mut every: Vec<BodyKey> = Vec::new();
        for (k, (add, pick)) in ops.iter().enumerate() {
            if *add || live.is_empty() {
                let name = format!("b{k}");
                let i = w.create_body(&crate_body(name.clone(), k as f32 * 2.0)).unwrap();
                let key = i;
                prop_assert!(!every.contains(&key), "key {key:?} handed out twice");
                every.push(key);
                live.push((key, name));
            } else {
                let (key, _) = live.remove(pick.index(live.len()));
                prop_assert!(w.remove_body(key).is_ok());
                dead.push(key);
            }
            // every few operations a step: keys live across steps as well
            if k % 7 == 0 {
                w.step().unwrap();
            }
            prop_assert_eq!(w.body_count(), live.len());
            for (key, name) in &live {
                prop_assert_eq!(&w.body(*key).unwrap().name, name);
            }
            for key in &dead {
                prop_assert!(w.body(*key).is_none());
                prop_assert_eq!(w.order_of_key(*key), None);
                prop_assert_eq!(w.remove_body(*key).unwrap_err(), RemoveError::NoSuchBody);
                prop_assert_eq!(
                    w.set_velocity(*key, Vec2::X, 0.0).unwrap_err(),
                    EditError::NoSuchBody
                );
            }
        }
    }
}

/// A box at rest on the ground, asleep.
fn sleeping_box() -> (World, BodyKey) {
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::default());
    ground::ground(&mut w);
    let i = w.create_body(&crate_body("box".into(), 0.0)).unwrap();
    let key = i;
    for _ in 0..240 {
        w.step().unwrap();
    }
    assert!(w.body(key).unwrap().asleep, "the box fell asleep");
    (w, key)
}

#[test]
fn every_setter_wakes_a_sleeping_body() {
    type Setter = fn(&mut World, BodyKey) -> Result<(), EditError>;
    let setters: [(&str, Setter); 6] = [
        ("set_transform", |w, k| {
            w.set_transform(k, Vec2::new(0.0, 3.0), 0.2)
        }),
        ("set_velocity", |w, k| {
            w.set_velocity(k, Vec2::new(1.0, 0.0), 0.0)
        }),
        ("apply_impulse", |w, k| {
            w.apply_impulse(k, Vec2::new(0.0, 5.0), Vec2::new(0.0, 0.5))
        }),
        ("apply_force_at", |w, k| {
            w.apply_force_at(k, Vec2::new(0.0, 500.0), Vec2::new(0.2, 0.5), 0.0)
        }),
        ("apply_force", |w, k| {
            w.apply_force(k, Vec2::new(0.0, 500.0), Vec2::new(0.2, 0.5))
        }),
        ("wake", |w, k| {
            // woken, the box still rests: nudge it with a second setter to see it move
            w.wake(k)?;
            assert!(!w.body(k).unwrap().asleep);
            w.set_velocity(k, Vec2::new(1.0, 0.0), 0.0)
        }),
    ];
    for (name, set) in setters {
        let (mut w, key) = sleeping_box();
        let before = w.body(key).unwrap().position;
        set(&mut w, key).unwrap();
        assert!(!w.body(key).unwrap().asleep, "{name} woke it");
        for _ in 0..5 {
            w.step().unwrap();
        }
        assert!(
            w.body(key).unwrap().position != before,
            "{name}: the woken box moved"
        );
    }
}

#[test]
fn an_impulse_changes_momentum_and_spin_by_itself() {
    let mut w = World::new(None, SolverSettings::default());
    let i = w.create_body(&crate_body("box".into(), 0.0)).unwrap();
    let key = i;
    let (m, inertia) = (w.body(i).unwrap().mass, w.body(i).unwrap().inertia);
    // 1 kg/m^2 box of 1 m: m = 1, I = m (w^2 + h^2) / 12 = 1/6
    assert!((m - 1.0).abs() < 1e-6 && (inertia - 1.0 / 6.0).abs() < 1e-6);
    // 2 N s upwards at the box's right edge (0.5 m from its centre)
    let centre = w.body(i).unwrap().position;
    w.apply_impulse(key, Vec2::new(0.0, 2.0), centre + Vec2::new(0.5, 0.0))
        .unwrap();
    let b = w.body(key).unwrap();
    assert!((b.velocity - Vec2::new(0.0, 2.0)).length() < 1e-6);
    // r x J = 0.5 * 2 = 1 N m s, over I = 1/6
    assert!(
        (b.angular_velocity - 6.0).abs() < 1e-5,
        "{}",
        b.angular_velocity
    );
}

#[test]
fn setters_refuse_what_does_not_apply_and_change_nothing() {
    let (mut w, key) = sleeping_box();
    let ground = w.nth_key(0);
    let before = w.state_hash();
    let refusals = [
        w.set_transform(key, Vec2::new(f32::NAN, 0.0), 0.0),
        w.set_velocity(key, Vec2::ZERO, f32::INFINITY),
        w.set_velocity(ground, Vec2::X, 0.0),
        w.apply_impulse(ground, Vec2::Y, Vec2::ZERO),
        w.apply_force_at(key, Vec2::Y, Vec2::new(f32::NAN, 0.0), 0.0),
    ];
    for r in &refusals {
        let e = r.as_ref().unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("\"box\"") || text.contains("\"ground\""),
            "{text}"
        );
    }
    assert!(matches!(
        refusals[0],
        Err(EditError::NotFinite {
            what: "position x",
            ..
        })
    ));
    assert!(matches!(refusals[2], Err(EditError::NotApplicable { .. })));
    assert_eq!(w.state_hash(), before, "a refused change changes nothing");
    assert!(w.body(key).unwrap().asleep, "and wakes nothing");
}

#[test]
fn set_transform_places_the_definitions_origin() {
    // a triangle whose centroid is not its origin: the origin goes where it is put
    let mut w = World::new(None, SolverSettings::default());
    let i = w
        .create_body(&BodyDef {
            name: "tri".into(),
            shape: ShapeDef::Polygon {
                points: vec![Vec2::ZERO, Vec2::new(3.0, 0.0), Vec2::new(0.0, 3.0)],
            },
            ..BodyDef::default()
        })
        .unwrap();
    let key = i;
    w.set_transform(key, Vec2::new(5.0, -2.0), std::f32::consts::FRAC_PI_2)
        .unwrap();
    let b = w.body(key).unwrap();
    assert!((b.origin() - Vec2::new(5.0, -2.0)).length() < 1e-5);
    // the centroid (1, 1) in the body frame, turned a quarter: (-1, 1) from the origin
    assert!(
        (b.position - Vec2::new(4.0, -1.0)).length() < 1e-5,
        "{}",
        b.position
    );
}

#[test]
fn joints_are_made_read_driven_and_removed_through_keys() {
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::default());
    let ground = w
        .create_body(&BodyDef {
            name: "ground".into(),
            body_type: BodyType::Static,
            ..BodyDef::default()
        })
        .unwrap();
    let a = w.create_body(&crate_body("a".into(), 0.0)).unwrap();
    let b = w.create_body(&crate_body("b".into(), 3.0)).unwrap();
    assert_eq!(w.find_body("b"), Some(b));
    let def = JointDef {
        anchor: Some(Vec2::new(1.5, 0.5)),
        ..Default::default()
    };
    let j = w.create_joint(a, b, &def).unwrap();
    assert_eq!(w.joint_bodies(j), Some([a, b]));
    assert_eq!(w.joint(j).unwrap().kind, sandbox2d::JointKind::Hinge);
    w.set_joint_drive(j, 3.0).unwrap();
    assert_eq!(w.joint(j).unwrap().drive, 3.0);
    // a removed body's key is refused by every call that names a body, and nothing
    // changes
    w.remove_body(a).unwrap();
    assert!(w.joint(j).is_none(), "the joint went with its body");
    let before = (w.state_hash(), w.joint_count(), w.body_count());
    assert_eq!(w.create_joint(a, ground, &def), Err(EditError::NoSuchBody));
    assert_eq!(w.create_joint(ground, a, &def), Err(EditError::NoSuchBody));
    assert_eq!(w.wake(a), Err(EditError::NoSuchBody));
    assert_eq!(
        w.apply_force(a, Vec2::Y, Vec2::ZERO),
        Err(EditError::NoSuchBody)
    );
    // a removed joint's key too
    assert_eq!(w.set_joint_drive(j, 1.0), Err(EditError::NoSuchJoint));
    assert_eq!(w.joint_bodies(j), None);
    assert_eq!(w.remove_joint(j).unwrap_err(), RemoveError::NoSuchJoint);
    // a definition the world cannot make a joint of is refused, nothing made
    assert!(matches!(
        w.create_joint(b, b, &def),
        Err(EditError::Build(_))
    ));
    let held = w.create_joint(ground, b, &def).unwrap();
    assert!(matches!(
        w.set_joint_drive(held, f32::NAN),
        Err(EditError::BadJointValue { .. })
    ));
    assert_eq!(w.joint_count(), before.1 + 1);
    assert_eq!((w.state_hash(), w.body_count()), (before.0, before.2));
    // a new joint between new bodies gets a key no old one had
    let c = w.create_body(&crate_body("c".into(), 6.0)).unwrap();
    let k = w.create_joint(b, c, &def).unwrap();
    assert_ne!(k, j);
    assert_eq!(w.joint_bodies(k), Some([b, c]));
}

#[test]
fn a_force_and_a_path_go_on_a_body_by_key_and_a_stale_key_is_refused() {
    // a constant 2 N on a 1 kg box, no gravity: after t s it has moved a t^2 / 2
    let mut w = World::new(None, SolverSettings::default());
    let b = w.create_body(&crate_body("box".into(), 0.0)).unwrap();
    let gone = w.create_body(&crate_body("gone".into(), 5.0)).unwrap();
    w.remove_body(gone).unwrap();
    let force = sandbox2d::ForceDef {
        body: 0,
        force: Vec2::new(2.0, 0.0),
        point: Vec2::ZERO,
    };
    let hash = w.state_hash();
    assert_eq!(w.create_force(gone, &force), Err(EditError::NoSuchBody));
    assert_eq!(w.force_count(), 0);
    assert_eq!(w.state_hash(), hash, "a refused force changes nothing");
    w.create_force(b, &force).unwrap();
    assert_eq!(w.force_count(), 1);
    let x0 = w.body(b).unwrap().position.x;
    let m = w.body(b).unwrap().mass;
    let steps = 60;
    for _ in 0..steps {
        w.step().unwrap();
    }
    let t = steps as f32 * w.settings.dt;
    let moved = w.body(b).unwrap().position.x - x0;
    let want = 0.5 * (2.0 / m) * t * t;
    assert!(
        (moved - want).abs() < 0.02 * want,
        "moved {moved} m, a t^2 / 2 = {want} m"
    );
    // a path: only a kinematic body takes one, and a stale key is refused
    let path = sandbox2d::MotionDef {
        body: 0,
        amplitude: Vec2::new(1.0, 0.0),
        angular_frequency: 2.0,
        phase: 0.0,
    };
    assert_eq!(w.create_motion(gone, &path), Err(EditError::NoSuchBody));
    assert!(matches!(
        w.create_motion(b, &path),
        Err(EditError::Build(_))
    ));
    let k = w
        .create_body(&BodyDef {
            body_type: BodyType::Kinematic,
            ..crate_body("slider".into(), -5.0)
        })
        .unwrap();
    w.create_motion(k, &path).unwrap();
    let x0 = w.body(k).unwrap().position.x;
    // the path is in the world's time: at time t it is at p0 + amplitude sin(2 t),
    // p0 where it was when it took the path
    for _ in 0..47 {
        w.step().unwrap();
    }
    let t = w.time() as f32;
    let x = w.body(k).unwrap().position.x - x0;
    assert!(
        (x - (2.0 * t).sin()).abs() < 1e-3,
        "on the path: {x} vs {}",
        (2.0 * t).sin()
    );
}
