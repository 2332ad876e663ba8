//! Shapes added to and removed from a body at run time: mass, centre of mass and
//! inertia against the parallel axis theorem (a box plus a disc, then the disc removed
//! gives the box back), the same rigid motion kept, stale keys refused with nothing
//! changed, and queries and contacts that see the new shape.

#[path = "common/ground.rs"]
mod ground;
use glam::Vec2;
use sandbox2d::{
    BodyDef, BodyKey, BodyType, EditError, Filter, JointDef, PartDef, ShapeDef, SolverKind,
    SolverSettings, World,
};
use std::f32::consts::PI;

/// A 1 m x 2 m box of density 1 (m = 2 kg) with its origin at `at`, turned by `angle`.
fn boxed(w: &mut World, at: Vec2, angle: f32) -> BodyKey {
    w.create_body(&BodyDef {
        name: "box".into(),
        shape: ShapeDef::Box {
            width: 1.0,
            height: 2.0,
        },
        position: at,
        angle,
        ..BodyDef::default()
    })
    .unwrap()
}

/// A disc of radius 0.5 and density 2 at `offset` from the body's origin.
fn disc(offset: Vec2) -> PartDef {
    PartDef {
        density: Some(2.0),
        friction: Some(0.1),
        ..PartDef::new(ShapeDef::Circle { radius: 0.5 }, offset)
    }
}

fn close(a: f32, b: f32, what: &str) {
    assert!(
        (a - b).abs() <= 1e-4 * b.abs().max(1.0),
        "{what}: {a} against {b}"
    );
}

#[test]
fn a_box_plus_a_disc_has_the_parallel_axis_mass_and_the_box_comes_back() {
    let mut w = World::new(None, SolverSettings::default());
    let (origin, angle) = (Vec2::new(1.0, -2.0), 0.3f32);
    let b = boxed(&mut w, origin, angle);
    let (m_box, i_box) = (2.0, 2.0 * (1.0 + 4.0) / 12.0);
    close(w.body(b).unwrap().mass, m_box, "box mass");
    close(w.body(b).unwrap().inertia, i_box, "box inertia");
    let s = w.add_shape(b, &disc(Vec2::new(2.0, 0.0))).unwrap();
    // the disc: m = rho pi r^2, I = m r^2 / 2 about its centre, 2 m from the box's
    let m_disc = 2.0 * PI * 0.25;
    let i_disc = m_disc * 0.25 / 2.0;
    let m = m_box + m_disc;
    let c = m_disc * 2.0 / m; // the centre of mass, along the body's x from the origin
    let i = i_box + m_box * c * c + i_disc + m_disc * (2.0 - c) * (2.0 - c);
    let body = w.body(b).unwrap();
    close(body.mass, m, "mass");
    close(body.inv_mass, 1.0 / m, "inverse mass");
    close(body.inertia, i, "inertia");
    let at = origin + Vec2::new(angle.cos(), angle.sin()) * c;
    assert!(
        (body.position - at).length() < 1e-5,
        "centre {}",
        body.position
    );
    assert_eq!(body.parts.len(), 2);
    assert_eq!(w.shape_keys(b).unwrap().len(), 2);
    // the disc removed: the box's own mass data, its centre back at the origin
    w.remove_shape(s).unwrap();
    let body = w.body(b).unwrap();
    close(body.mass, m_box, "mass after");
    close(body.inertia, i_box, "inertia after");
    assert!(
        (body.position - origin).length() < 1e-5,
        "{}",
        body.position
    );
    assert_eq!(w.shape_keys(b).unwrap().len(), 1);
}

#[test]
fn the_body_moves_on_as_the_same_rigid_motion() {
    let mut w = World::new(None, SolverSettings::default());
    let b = boxed(&mut w, Vec2::ZERO, 0.0);
    w.set_velocity(b, Vec2::new(1.0, 0.5), 2.0).unwrap();
    w.add_shape(b, &disc(Vec2::new(2.0, 0.0))).unwrap();
    let body = w.body(b).unwrap();
    // the new centre, c along x, moves at v + w x c
    let c = body.position;
    let want = Vec2::new(1.0, 0.5) + Vec2::new(-2.0 * c.y, 2.0 * c.x);
    assert!((body.velocity - want).length() < 1e-5, "{}", body.velocity);
    assert_eq!(body.angular_velocity, 2.0);
}

#[test]
fn stale_keys_and_bad_shapes_are_refused_and_change_nothing() {
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::default());
    let b = boxed(&mut w, Vec2::ZERO, 0.0);
    let other = w
        .create_body(&BodyDef {
            name: "other".into(),
            position: Vec2::new(5.0, 0.0),
            ..BodyDef::default()
        })
        .unwrap();
    let s = w.add_shape(b, &disc(Vec2::new(2.0, 0.0))).unwrap();
    w.remove_shape(s).unwrap();
    // a removed shape's key is not handed out again
    let again = w.add_shape(b, &disc(Vec2::new(2.0, 0.0))).unwrap();
    assert_ne!(again, s);
    w.remove_shape(again).unwrap();
    let os = w.add_shape(other, &disc(Vec2::new(1.0, 0.0))).unwrap();
    w.remove_body(other).unwrap();
    let before = w.state_hash();
    let mass = w.body(b).unwrap().mass;
    // removed shapes' keys name nothing
    assert_eq!(w.remove_shape(s), Err(EditError::NoSuchShape));
    assert_eq!(w.remove_shape(again), Err(EditError::NoSuchShape));
    // the last shape stays
    let last = w.shape_keys(b).unwrap()[0];
    assert!(matches!(
        w.remove_shape(last),
        Err(EditError::NotApplicable { .. })
    ));
    // a bad part
    let bad = PartDef::new(ShapeDef::Circle { radius: -1.0 }, Vec2::ZERO);
    assert!(matches!(
        w.add_shape(b, &bad),
        Err(EditError::BadShape { .. })
    ));
    let nan = disc(Vec2::new(f32::NAN, 0.0));
    assert!(w.add_shape(b, &nan).is_err());
    // a removed body's keys
    assert_eq!(w.remove_shape(os), Err(EditError::NoSuchShape));
    assert_eq!(
        w.add_shape(other, &disc(Vec2::ZERO)),
        Err(EditError::NoSuchBody)
    );
    assert_eq!(w.state_hash(), before, "refusals change nothing");
    assert_eq!(w.body(b).unwrap().mass, mass);
}

#[test]
fn queries_and_contacts_see_an_added_shape() {
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::default());
    ground::ground(&mut w);
    // a 1 m box resting on the ground, asleep after 4 s
    let b = w
        .create_body(&BodyDef {
            name: "box".into(),
            position: Vec2::new(0.0, 0.5),
            ..BodyDef::default()
        })
        .unwrap();
    for _ in 0..240 {
        w.step().unwrap();
    }
    assert!(w.body(b).unwrap().asleep);
    let all = Filter::default();
    // the query tree is made now, before the shape is there
    assert!(w.query_point(Vec2::new(3.0, 3.0), &all).is_empty());
    // a disc 2.5 m right of the box, 2.5 m up: the tree sees it at once
    let s = w.add_shape(b, &disc(Vec2::new(2.5, 2.5))).unwrap();
    assert!(!w.body(b).unwrap().asleep, "adding a shape wakes the body");
    assert_eq!(w.query_point(Vec2::new(2.6, 3.1), &all), vec![b]);
    let hit = w
        .ray_cast_closest(Vec2::new(2.5, 6.0), Vec2::new(0.0, -10.0), &all)
        .unwrap();
    assert_eq!(hit.body, b);
    assert!((hit.point.y - 3.5).abs() < 1e-3, "{:?}", hit.point);
    w.remove_shape(s).unwrap();
    assert!(w.query_point(Vec2::new(2.6, 3.1), &all).is_empty());
    // a disc of radius 0.5 put 1.5 m below the box's centre, the body lifted: it
    // stands on the disc, whose bottom touches the ground, the box's centre 2 m up
    w.set_transform(b, Vec2::new(0.0, 2.2), 0.0).unwrap();
    w.add_shape(b, &disc(Vec2::new(0.0, -1.5))).unwrap();
    w.set_velocity(b, Vec2::ZERO, 0.0).unwrap();
    for _ in 0..30 {
        w.step().unwrap();
    }
    let body = w.body(b).unwrap();
    let origin = body.position + body.rot.rotate(body.origin_offset);
    assert!(
        (origin.y - 2.0).abs() < 0.02,
        "the box stands on the disc: origin {origin}"
    );
    // the same with a disc whose filter does not touch the ground: it sinks through,
    // and the box rests on the ground on its own face, its centre 0.5 m up
    let keys = w.shape_keys(b).unwrap();
    w.remove_shape(keys[1]).unwrap();
    w.set_transform(b, Vec2::new(0.0, 2.2), 0.0).unwrap();
    let ghost = PartDef {
        filter: Some(Filter {
            category: 2,
            mask: !1,
            group: 0,
        }),
        ..disc(Vec2::new(0.0, -1.5))
    };
    w.add_shape(b, &ghost).unwrap();
    w.set_velocity(b, Vec2::ZERO, 0.0).unwrap();
    for _ in 0..60 {
        w.step().unwrap();
    }
    let body = w.body(b).unwrap();
    let origin = body.position + body.rot.rotate(body.origin_offset);
    assert!(
        (origin.y - 0.5).abs() < 0.02,
        "the box rests on the ground through its filtered disc: origin {origin}"
    );
}

#[test]
fn a_joint_on_the_body_keeps_its_anchor_on_the_material() {
    let mut w = World::new(None, SolverSettings::default());
    let ground = w
        .create_body(&BodyDef {
            name: "ground".into(),
            body_type: BodyType::Static,
            ..BodyDef::default()
        })
        .unwrap();
    let b = boxed(&mut w, Vec2::new(0.0, 3.0), 0.4);
    let j = w
        .create_joint(
            ground,
            b,
            &JointDef {
                anchor: Some(Vec2::new(0.2, 3.5)),
                ..Default::default()
            },
        )
        .unwrap();
    let before = w.joint_anchors(j).unwrap();
    w.add_shape(b, &disc(Vec2::new(2.0, 0.0))).unwrap();
    let after = w.joint_anchors(j).unwrap();
    assert!((before.1 - after.1).length() < 1e-5, "{before:?} {after:?}");
    assert!(w.joint_position_error(j).unwrap() < 1e-5);
}

#[test]
fn a_motor_joint_keeps_holding_its_body_where_it_was_when_either_body_takes_a_shape() {
    // no gravity: a free box a, and a box b held by a motor joint 3 m right of and 1 m
    // above it, a quarter turn further round. A disc added to b, then to a, moves each
    // one's centre of mass; the motor goes on holding b's origin at the same place in
    // a's frame (the joint's anchors move with the centres: the target does too)
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        let mut w = World::new(None, SolverSettings::defaults(kind));
        let a = boxed(&mut w, Vec2::ZERO, 0.0);
        let b = w
            .create_body(&BodyDef {
                name: "held".into(),
                shape: ShapeDef::Box {
                    width: 1.0,
                    height: 1.0,
                },
                position: Vec2::new(3.0, 1.0),
                angle: PI / 2.0,
                ..BodyDef::default()
            })
            .unwrap();
        w.create_joint(a, b, &JointDef::motor_joint(0, 0, 500.0, 500.0))
            .unwrap();
        // b's origin in a's frame from a's origin, and the angle between them
        let held = |w: &World| {
            let (ba, bb) = (w.body(a).unwrap(), w.body(b).unwrap());
            (
                ba.rot.inv_rotate(bb.origin() - ba.origin()),
                bb.angle - ba.angle,
            )
        };
        let start = held(&w);
        let run = |w: &mut World| {
            for _ in 0..240 {
                w.step().unwrap();
            }
        };
        for (body, offset) in [(b, Vec2::new(0.0, 1.5)), (a, Vec2::new(-2.0, 0.5))] {
            let moved = {
                let old = w.body(body).unwrap().position;
                w.add_shape(body, &disc(offset)).unwrap();
                (w.body(body).unwrap().position - old).length()
            };
            assert!(moved > 0.2, "{kind:?}: the centre moved {moved} m");
            run(&mut w);
            let (p, angle) = held(&w);
            assert!(
                (p - start.0).length() < 1e-3,
                "{kind:?}: b's origin held at {p} in a's frame, was {}",
                start.0
            );
            assert!((angle - start.1).abs() < 1e-3, "{kind:?}: {angle}");
        }
    }
}

#[test]
fn shapes_restored_from_a_state_without_density_or_numbers_are_numbered_and_kept() {
    // a state saved before shapes kept their density and number reads 0 for both: the
    // restore numbers the shapes again (each key names one shape), and adding or removing
    // a shape, which needs every shape's density, is refused with nothing changed
    let mut w = World::new(None, SolverSettings::default());
    let b = boxed(&mut w, Vec2::ZERO, 0.0);
    w.add_shape(b, &disc(Vec2::new(2.0, 0.0))).unwrap();
    w.add_shape(b, &disc(Vec2::new(-2.0, 0.0))).unwrap();
    let mut state: serde_json::Value =
        serde_json::from_slice(&w.snapshot().to_json().unwrap()).unwrap();
    for part in state["bodies"][0]["parts"].as_array_mut().unwrap() {
        let part = part.as_object_mut().unwrap();
        assert!(part.remove("density").is_some() && part.remove("id").is_some());
    }
    state["bodies"][0]
        .as_object_mut()
        .unwrap()
        .remove("next_part_id");
    let old = sandbox2d::WorldState::from_json(state.to_string().as_bytes()).unwrap();
    let mut r = World::from_state(&old).unwrap();
    let key = r.find_body("box").unwrap();
    let keys = r.shape_keys(key).unwrap();
    assert_eq!(keys.len(), 3);
    for (k, a) in keys.iter().enumerate() {
        assert!(keys[..k].iter().all(|b| b != a), "two shapes share a key");
    }
    let before = r.state_hash();
    let refused = |e: EditError| {
        let text = e.to_string();
        assert!(text.contains("no density"), "{text}");
    };
    refused(r.add_shape(key, &disc(Vec2::new(0.0, 2.0))).unwrap_err());
    refused(r.remove_shape(keys[1]).unwrap_err());
    assert_eq!(r.state_hash(), before);
}
