//! Capsules, rounded boxes and segments in motion, against closed forms: a capsule on
//! its flat side slides down a ramp (a = g (sin - mu cos)) where a disk rolls
//! (a = 2/3 g sin, from I = m r^2 / 2); rounded shapes come to rest on the ground at
//! their half height under every solver; a box rests on a static segment.

use glam::Vec2;
use sandbox2d::{BodyDef, BodyType, ShapeDef, SolverKind, SolverSettings, World};

const G: f32 = 9.81;

fn settings(kind: SolverKind) -> SolverSettings {
    let mut s = match kind {
        SolverKind::Soft => SolverSettings::soft(),
        SolverKind::Pgs => SolverSettings::pgs(),
        SolverKind::Xpbd => SolverSettings::xpbd(),
    };
    s.sleep = false;
    s
}

fn body(name: &str, shape: ShapeDef, at: Vec2, angle: f32, static_: bool) -> BodyDef {
    BodyDef {
        name: name.into(),
        body_type: if static_ {
            BodyType::Static
        } else {
            BodyType::Dynamic
        },
        shape,
        position: at,
        angle,
        friction: 0.3,
        ..BodyDef::default()
    }
}

/// A ramp tilted by `theta` (a static 30 m x 1 m box through the origin) and `shape`
/// resting on it; returns the speed along the slope after `t` seconds.
fn speed_down_ramp(shape: ShapeDef, rest_height: f32, theta: f32, mu: f32, t: f32) -> f32 {
    let mut w = World::new(Some(Vec2::new(0.0, -G)), settings(SolverKind::Soft));
    let mut ramp = body(
        "ramp",
        ShapeDef::Box {
            width: 30.0,
            height: 1.0,
        },
        Vec2::ZERO,
        theta,
        true,
    );
    ramp.friction = mu;
    w.add_body(&ramp).unwrap();
    let up = Vec2::new(-theta.sin(), theta.cos());
    let along = Vec2::new(theta.cos(), theta.sin());
    let mut b = body(
        "b",
        shape,
        along * 8.0 + up * (0.5 + rest_height),
        theta,
        false,
    );
    b.friction = mu;
    let i = w.add_body(&b).unwrap();
    let steps = (t / w.settings.dt).round() as usize;
    for _ in 0..steps {
        w.step().unwrap();
    }
    -w.bodies[i].velocity.dot(along)
}

#[test]
fn a_capsule_slides_down_a_ramp_where_a_disk_rolls() {
    let (theta, mu, t) = (30f32.to_radians(), 0.3f32, 1.0f32);
    // a capsule on its flat side cannot roll: it slides, friction mu cos theta against it
    let slide = G * (theta.sin() - mu * theta.cos()) * t;
    let v = speed_down_ramp(
        ShapeDef::Capsule {
            length: 1.5,
            radius: 0.25,
        },
        0.25,
        theta,
        mu,
        t,
    );
    assert!(
        (v - slide).abs() < 0.02 * slide,
        "capsule: {v} m/s after {t} s, sliding gives {slide}"
    );
    // a disk rolls without slipping (mu = 0.3 > tan(theta) / 3): a = g sin / (1 + 1/2)
    let roll = 2.0 / 3.0 * G * theta.sin() * t;
    let v = speed_down_ramp(ShapeDef::Circle { radius: 0.25 }, 0.25, theta, mu, t);
    assert!(
        (v - roll).abs() < 0.02 * roll,
        "disk: {v} m/s after {t} s, rolling gives {roll}"
    );
    assert!(
        roll > 1.2 * slide,
        "the two must differ for the test to mean anything"
    );
}

#[test]
fn rounded_shapes_come_to_rest_at_their_half_height_under_every_solver() {
    let shapes = [
        (
            ShapeDef::Capsule {
                length: 1.2,
                radius: 0.3,
            },
            0.3f32,
        ),
        (
            ShapeDef::RoundedBox {
                width: 1.0,
                height: 0.6,
                radius: 0.15,
            },
            0.3,
        ),
        (
            ShapeDef::RoundedPolygon {
                points: vec![
                    Vec2::new(-0.4, -0.2),
                    Vec2::new(0.4, -0.2),
                    Vec2::new(0.4, 0.2),
                    Vec2::new(-0.4, 0.2),
                ],
                radius: 0.1,
            },
            0.3,
        ),
    ];
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        for (shape, half) in &shapes {
            let mut w = World::new(Some(Vec2::new(0.0, -G)), settings(kind));
            w.add_body(&body(
                "ground",
                ShapeDef::Segment {
                    a: Vec2::new(-10.0, 0.0),
                    b: Vec2::new(10.0, 0.0),
                },
                Vec2::ZERO,
                0.0,
                true,
            ))
            .unwrap();
            // dropped 0.5 m, tilted a little: it must settle flat
            let i = w
                .add_body(&body(
                    "b",
                    shape.clone(),
                    Vec2::new(0.0, half + 0.5),
                    0.15,
                    false,
                ))
                .unwrap();
            for _ in 0..300 {
                w.step().unwrap();
            }
            let b = &w.bodies[i];
            assert!(
                (b.position.y - half).abs() < 0.01,
                "{kind:?} {shape:?}: rests at y = {}, expected {half}",
                b.position.y
            );
            let tilt = (b.angle.sin()).abs();
            assert!(tilt < 0.01, "{kind:?} {shape:?}: angle {}", b.angle);
            assert!(
                b.velocity.length() < 0.01,
                "{kind:?} {shape:?}: still moving"
            );
        }
    }
}

#[test]
fn four_capsules_stacked_on_their_sides_stand_on_a_segment() {
    let mut w = World::new(Some(Vec2::new(0.0, -G)), settings(SolverKind::Soft));
    w.add_body(&body(
        "ground",
        ShapeDef::Segment {
            a: Vec2::new(-5.0, 0.0),
            b: Vec2::new(5.0, 0.0),
        },
        Vec2::ZERO,
        0.0,
        true,
    ))
    .unwrap();
    let ids: Vec<usize> = (0..4)
        .map(|k| {
            let d = body(
                &format!("c{k}"),
                ShapeDef::Capsule {
                    length: 1.6,
                    radius: 0.25,
                },
                Vec2::new(0.0, 0.25 + 0.5 * k as f32),
                0.0,
                false,
            );
            w.add_body(&d).unwrap()
        })
        .collect();
    for _ in 0..600 {
        w.step().unwrap();
    }
    for (k, &i) in ids.iter().enumerate() {
        let b = &w.bodies[i];
        let want = Vec2::new(0.0, 0.25 + 0.5 * k as f32);
        assert!(
            (b.position - want).length() < 0.02,
            "capsule {k} at {}, expected {want}",
            b.position
        );
    }
}
