//! Joints that break: a weight hanging from a joint whose break force is a little
//! above its weight m g holds; a little below, the joint breaks in the first step and
//! reports a force within 1% of m g; a broken joint's key names nothing. Under every
//! solver, for a hinge, a weld and a distance joint; a weld's break torque against the
//! moment m g d of a weight held off to one side; the same breaks at any thread count.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use glam::Vec2;
use sandbox2d::{
    BodyDef, BodyType, JointDef, JointKind, ShapeDef, SolverKind, SolverSettings, World,
};

const G: f32 = 10.0;
/// The weight: a 0.5 m x 0.5 m box of density 8, so m = 2 kg.
const M: f32 = 2.0;

fn ground() -> BodyDef {
    BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 0.2,
            height: 0.2,
        },
        position: Vec2::new(0.0, 5.0),
        ..BodyDef::default()
    }
}

fn weight(at: Vec2) -> BodyDef {
    BodyDef {
        name: "weight".into(),
        shape: ShapeDef::Box {
            width: 0.5,
            height: 0.5,
        },
        density: 8.0,
        position: at,
        ..BodyDef::default()
    }
}

/// A world with the weight hung from the ground by a joint of `kind` with the given
/// thresholds: a hinge or weld at the weight's centre, a distance joint 1 m above it.
fn hung(
    kind: SolverKind,
    joint: JointKind,
    break_force: Option<f32>,
    break_torque: Option<f32>,
) -> World {
    let mut w = World::new(Some(Vec2::new(0.0, -G)), SolverSettings::defaults(kind));
    let g = w.create_body(&ground()).unwrap();
    let at = Vec2::new(0.0, 3.0);
    let b = w.create_body(&weight(at)).unwrap();
    assert!((w.body(b).unwrap().mass - M).abs() < 1e-5);
    // a joint definition names its bodies by creation order
    let (g, b) = (w.order_of_key(g).unwrap(), w.order_of_key(b).unwrap());
    let mut def = match joint {
        JointKind::Hinge => JointDef::hinge(g, b, at),
        JointKind::Weld => JointDef {
            kind: JointKind::Weld,
            ..JointDef::hinge(g, b, at)
        },
        JointKind::Distance => JointDef::distance(g, b, at + Vec2::Y, at),
        other => panic!("no hanging test for {other:?}"),
    };
    def.break_force = break_force;
    def.break_torque = break_torque;
    w.add_joint(&def).unwrap();
    w
}

#[test]
fn a_weight_holds_above_its_break_force_and_breaks_below_it() {
    let mg = M * G;
    for kind in SolverKind::ALL {
        for joint in [JointKind::Hinge, JointKind::Weld, JointKind::Distance] {
            let who = format!("{kind:?} {joint:?}");
            // a little above m g: it holds, step after step
            let mut w = hung(kind, joint, Some(1.02 * mg), None);
            for k in 1..=60 {
                w.step().unwrap();
                assert!(w.joint_breaks().is_empty(), "{who}: broke at step {k}");
            }
            assert_eq!(w.joint_count(), 1, "{who}");
            assert!(
                (w.nth_body(1).position.y - 3.0).abs() < 0.01,
                "{who}: the weight hangs where it was, y {}",
                w.nth_body(1).position.y
            );
            // a little below: it breaks in the first step, reporting m g
            let mut w = hung(kind, joint, Some(0.98 * mg), None);
            let key = w.joints().next().unwrap().0;
            let weight = w.nth_key(1);
            w.step().unwrap();
            let breaks = w.joint_breaks().to_vec();
            assert_eq!(breaks.len(), 1, "{who}: {breaks:?}");
            let e = breaks[0];
            assert_eq!(e.joint, key, "{who}");
            assert_eq!(e.bodies, [w.nth_key(0), weight], "{who}");
            assert!(
                (e.force - mg).abs() <= 0.01 * mg,
                "{who}: force {} against m g = {mg}",
                e.force
            );
            assert!((w.joint_count() == 0), "{who}: the joint is removed");
            // its key names nothing now
            assert!(w.joint(key).is_none(), "{who}");
            assert!(w.remove_joint(key).is_err(), "{who}");
            // reported once: the next step has no break, and the weight falls freely
            let v0 = w.nth_body(1).velocity.y;
            w.step().unwrap();
            assert!(w.joint_breaks().is_empty(), "{who}");
            let dv = w.nth_body(1).velocity.y - v0;
            let dt = w.settings.dt;
            assert!(
                (dv + G * dt).abs() < 1e-3 * G * dt + 1e-5,
                "{who}: the weight falls at g, dv {dv} against {}",
                -G * dt
            );
        }
    }
}

#[test]
fn a_weld_breaks_on_the_moment_of_a_weight_held_to_one_side() {
    // the weld holds the weight d = 1 m to the right of its anchor: its torque is m g d
    // once the weight hangs still (the first steps carry the soft solve's transient)
    let (mg, d) = (M * G, 1.0);
    for kind in SolverKind::ALL {
        let settled = || {
            let mut w = World::new(Some(Vec2::new(0.0, -G)), SolverSettings::defaults(kind));
            let g = w.create_body(&ground()).unwrap();
            let b = w.create_body(&weight(Vec2::new(d, 3.0))).unwrap();
            let (g, b) = (w.order_of_key(g).unwrap(), w.order_of_key(b).unwrap());
            w.add_joint(&JointDef {
                kind: JointKind::Weld,
                ..JointDef::hinge(g, b, Vec2::new(0.0, 3.0))
            })
            .unwrap();
            for _ in 0..60 {
                w.step().unwrap();
            }
            let key = w.joints().next().unwrap().0;
            (w, key)
        };
        let (mut holds, key) = settled();
        holds
            .set_joint_break(key, None, Some(1.02 * mg * d))
            .unwrap();
        for k in 1..=60 {
            holds.step().unwrap();
            assert!(
                holds.joint_breaks().is_empty(),
                "{kind:?}: broke at step {k}"
            );
        }
        let (mut breaks, key) = settled();
        breaks
            .set_joint_break(key, None, Some(0.98 * mg * d))
            .unwrap();
        breaks.step().unwrap();
        let e = *breaks
            .joint_breaks()
            .first()
            .unwrap_or_else(|| panic!("{kind:?}: the weld did not break"));
        assert_eq!(e.joint, key);
        assert!(
            (e.torque - mg * d).abs() <= 0.01 * mg * d,
            "{kind:?}: torque {} against m g d = {}",
            e.torque,
            mg * d
        );
        assert!(
            (e.force - mg).abs() <= 0.01 * mg,
            "{kind:?}: force {} against m g = {mg}",
            e.force
        );
        // the key is stale now: the setter refuses it
        assert_eq!(
            breaks.set_joint_break(key, Some(1.0), None),
            Err(sandbox2d::EditError::NoSuchJoint)
        );
    }
}

#[test]
fn a_break_threshold_must_be_positive_and_finite() {
    let mut w = hung(SolverKind::Soft, JointKind::Hinge, None, None);
    let key = w.joints().next().unwrap().0;
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert!(w.set_joint_break(key, Some(bad), None).is_err(), "{bad}");
        assert!(w.set_joint_break(key, None, Some(bad)).is_err(), "{bad}");
        let mut def = JointDef::hinge(0, 1, Vec2::new(0.0, 3.0));
        def.break_force = Some(bad);
        assert!(w.add_joint(&def).is_err(), "{bad}");
    }
    assert_eq!(w.joints().next().unwrap().1.break_force, None);
}

#[test]
fn joints_break_the_same_at_any_thread_count() {
    // 300 pendulums (enough for the worker threads), each hinge's break force spread
    // around its weight, so some hold and some break as they swing
    let run = |kind: SolverKind, threads: usize| {
        let mut w = World::new(Some(Vec2::new(0.0, -G)), SolverSettings::defaults(kind));
        w.set_threads(threads);
        let g = w
            .create_body(&BodyDef {
                body_type: BodyType::Static,
                ..ground()
            })
            .unwrap();
        for i in 0..300 {
            let x = (i % 30) as f32 * 1.5;
            let y = 3.0 - (i / 30) as f32 * 2.0;
            let b = w
                .create_body(&BodyDef {
                    filter: sandbox2d::Filter {
                        group: -1,
                        ..Default::default()
                    },
                    name: format!("bob {i}"),
                    ..weight(Vec2::new(x + 0.7, y))
                })
                .unwrap();
            let (gi, bi) = (w.order_of_key(g).unwrap(), w.order_of_key(b).unwrap());
            let mut def = JointDef::hinge(gi, bi, Vec2::new(x, y));
            def.break_force = Some(M * G * (1.0 + 0.075 * (i % 40) as f32));
            w.add_joint(&def).unwrap();
        }
        let mut broken = Vec::new();
        for _ in 0..40 {
            w.step().unwrap();
            broken.extend(
                w.joint_breaks()
                    .iter()
                    .map(|e| (e.joint, e.force.to_bits())),
            );
        }
        (w.state_hash(), broken)
    };
    for kind in SolverKind::ALL {
        let one = run(kind, 1);
        assert!(
            !one.1.is_empty() && one.1.len() < 300,
            "{kind:?}: {}",
            one.1.len()
        );
        assert_eq!(one, run(kind, 3), "{kind:?}");
    }
}

#[test]
fn a_restored_world_breaks_its_joints_as_the_saved_one_would() {
    let mg = M * G;
    for kind in SolverKind::ALL {
        let saved = hung(kind, JointKind::Hinge, Some(0.98 * mg), None).snapshot();
        // a world with no joint that may break takes the saved one's
        let mut w = hung(kind, JointKind::Hinge, None, None);
        w.restore(&saved).unwrap();
        w.step().unwrap();
        assert_eq!(w.joint_breaks().len(), 1, "{kind:?}");
        assert!((w.joint_count() == 0), "{kind:?}");
    }
}
