//! What the mouse does to the world: drag a body with a spring, push bodies away from a
//! point (the seed demo's force emitter), pick and spawn bodies. Plain physics-side
//! functions on a [`World`], so they are tested without a window.

use glam::Vec2;

use crate::body::BodyId;
use crate::defs::{BodyDef, BodyType, ShapeDef};
use crate::joint::MouseJoint;
use crate::world::{BuildError, World};

/// The drag spring's natural frequency (Hz).
pub const DRAG_FREQUENCY_HZ: f32 = 4.0;
/// The drag spring's damping ratio: 1 is critically damped (no overshoot).
pub const DRAG_DAMPING_RATIO: f32 = 1.0;
/// Damping of the dragged body's spin, as a fraction of the spring's angular frequency.
pub const DRAG_ANGULAR_DAMPING: f32 = 0.25;
/// The drag force is capped at this acceleration (m/s^2) times the body's mass.
pub const DRAG_MAX_ACCELERATION: f32 = 400.0;

/// Pulls the material point `local_point` (body frame, relative to the centre of mass)
/// of `body` towards the world point `target` with the world's mouse joint (a soft point
/// constraint: DRAG_FREQUENCY_HZ, damping ratio DRAG_DAMPING_RATIO, force capped at
/// DRAG_MAX_ACCELERATION times the body's mass), solved by whichever solver the world
/// runs, for the next step (call it before every step while dragging; [`release`] lets
/// go). The body's spin is damped a little, so a held body comes to rest. Static and
/// kinematic bodies, and unknown ids, are left alone.
pub fn drag_body(world: &mut World, body: BodyId, local_point: Vec2, target: Vec2) {
    let Some(b) = world.bodies.get(body) else {
        return;
    };
    if b.body_type != BodyType::Dynamic || !target.is_finite() || !local_point.is_finite() {
        return;
    }
    let (mass, inertia, w, com) = (b.mass, b.inertia, b.angular_velocity, b.position);
    world.set_mouse(Some(MouseJoint {
        body,
        local: local_point,
        target,
        hertz: DRAG_FREQUENCY_HZ,
        damping_ratio: DRAG_DAMPING_RATIO,
        max_force: DRAG_MAX_ACCELERATION * mass,
    }));
    // The point is held but the body may still spin about it: damp the spin with a pure
    // torque tau = -c I w (c = DRAG_ANGULAR_DAMPING omega), applied as a couple of
    // forces +-tau/2 one metre either side of the centre of mass.
    let omega = std::f32::consts::TAU * DRAG_FREQUENCY_HZ;
    if inertia > 0.0 {
        let tau = -DRAG_ANGULAR_DAMPING * omega * inertia * w;
        let f = Vec2::new(0.0, 0.5 * tau);
        if f.is_finite() {
            world.apply_force_index(body, f, com + Vec2::X);
            world.apply_force_index(body, -f, com - Vec2::X);
        }
    }
}

/// Lets go of whatever the mouse joint holds.
pub fn release(world: &mut World) {
    world.set_mouse(None);
}

/// The seed demo's force emitter: pushes every dynamic body whose centre lies within
/// `radius` of `center` straight away from it, with an acceleration falling linearly
/// from `accel` (m/s^2) at the centre to 0 at the radius: F = m accel (1 - d / radius).
/// Returns how many bodies it pushed. For the next step only.
pub fn push_radial(world: &mut World, center: Vec2, radius: f32, accel: f32) -> usize {
    if !(radius > 0.0) || !center.is_finite() || !accel.is_finite() {
        return 0;
    }
    let mut pushes = Vec::new();
    for (i, b) in world.bodies.iter().enumerate() {
        if b.body_type != BodyType::Dynamic {
            continue;
        }
        let d = b.position - center;
        let dist = d.length();
        if dist < radius && dist > 1e-6 {
            let f = b.mass * accel * (1.0 - dist / radius);
            pushes.push((i, d / dist * f, b.position));
        }
    }
    for &(i, f, at) in &pushes {
        world.apply_force_index(i, f, at);
    }
    pushes.len()
}

/// The body under the world point `p` (the last created one when several overlap),
/// dynamic bodies before static ones.
pub fn body_at(world: &World, p: Vec2) -> Option<BodyId> {
    let hit = |dynamic: bool| {
        world
            .bodies
            .iter()
            .enumerate()
            .rev()
            .filter(|(_, b)| (b.body_type == BodyType::Dynamic) == dynamic)
            .find(|(_, b)| contains(b, p))
            .map(|(i, _)| i)
    };
    hit(true).or_else(|| hit(false))
}

/// Whether the world point `p` lies inside the body's shape, or inside any part of a
/// compound body.
pub fn contains(body: &crate::body::Body, p: Vec2) -> bool {
    let local = body.transform().inv_apply(p);
    if body.parts.is_empty() {
        return body.shape.contains_local(local);
    }
    body.parts.iter().any(|part| {
        part.shape
            .contains_local(part.rot.inv_rotate(local - part.offset))
    })
}

/// What a click spawns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpawnKind {
    /// A rigid circle.
    Circle,
    /// A rigid box.
    Box,
}

/// Adds a dynamic circle (diameter `size`) or box (`size` square) at `at`, named
/// `spawn_N` with the first N not taken. Density 1, friction 0.6.
pub fn spawn(
    world: &mut World,
    kind: SpawnKind,
    at: Vec2,
    size: f32,
) -> Result<BodyId, BuildError> {
    let shape = match kind {
        SpawnKind::Circle => ShapeDef::Circle { radius: 0.5 * size },
        SpawnKind::Box => ShapeDef::Box {
            width: size,
            height: size,
        },
    };
    let mut n = world.bodies.len();
    while world.body_index(&format!("spawn_{n}")).is_some() {
        n += 1;
    }
    world.add_body(&BodyDef {
        name: format!("spawn_{n}"),
        shape,
        position: at,
        friction: 0.6,
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::defs::SolverSettings;

    fn floating_box() -> World {
        // No gravity: only the spring moves it.
        let mut w = World::new(None, SolverSettings::pgs());
        w.add_body(&BodyDef {
            name: "box".into(),
            shape: ShapeDef::Box {
                width: 1.0,
                height: 0.5,
            },
            density: 3.0,
            ..Default::default()
        })
        .unwrap();
        w
    }

    #[test]
    fn drag_brings_the_grabbed_point_to_the_target_without_overshoot() {
        let mut w = floating_box();
        let local = Vec2::new(0.4, 0.2);
        let target = Vec2::new(3.0, 1.0);
        let mut closest = f32::MAX;
        let mut overshoot = 0.0f32;
        for _ in 0..240 {
            drag_body(&mut w, 0, local, target);
            w.step().unwrap();
            let b = &w.bodies[0];
            let p = b.position + b.rot.rotate(local);
            closest = closest.min((p - target).length());
            // Past the target along the approach direction?
            overshoot = overshoot.max((p.x - target.x).max(0.0));
        }
        let b = &w.bodies[0];
        let p = b.position + b.rot.rotate(local);
        assert!(
            (p - target).length() < 0.02,
            "point at {p}, target {target}"
        );
        assert!(b.velocity.length() < 0.05, "still moving: {}", b.velocity);
        assert!(overshoot < 0.05, "overshoot {overshoot}");
    }

    #[test]
    fn drag_holds_against_gravity_and_ignores_static_bodies() {
        let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::pgs());
        w.add_body(&BodyDef {
            name: "ball".into(),
            shape: ShapeDef::Circle { radius: 0.3 },
            ..Default::default()
        })
        .unwrap();
        w.add_body(&BodyDef {
            name: "wall".into(),
            body_type: BodyType::Static,
            shape: ShapeDef::Circle { radius: 0.3 },
            position: Vec2::new(5.0, 0.0),
            ..Default::default()
        })
        .unwrap();
        for _ in 0..300 {
            drag_body(&mut w, 0, Vec2::ZERO, Vec2::new(0.0, 2.0));
            drag_body(&mut w, 1, Vec2::ZERO, Vec2::new(0.0, 2.0));
            drag_body(&mut w, 99, Vec2::ZERO, Vec2::new(0.0, 2.0));
            w.step().unwrap();
        }
        // Sags by g / omega^2 (about 1.6 cm at 4 Hz).
        let sag = 10.0 / (std::f32::consts::TAU * DRAG_FREQUENCY_HZ).powi(2);
        assert!((w.bodies[0].position.y - (2.0 - sag)).abs() < 0.005);
        assert_eq!(w.bodies[1].position, Vec2::new(5.0, 0.0));
    }

    #[test]
    fn radial_push_moves_near_bodies_away_only() {
        let mut w = World::new(None, SolverSettings::pgs());
        for (i, x) in [1.0f32, -2.0, 10.0].into_iter().enumerate() {
            w.add_body(&BodyDef {
                name: format!("b{i}"),
                shape: ShapeDef::Circle { radius: 0.2 },
                position: Vec2::new(x, 0.0),
                ..Default::default()
            })
            .unwrap();
        }
        assert_eq!(push_radial(&mut w, Vec2::ZERO, 3.0, 30.0), 2);
        w.step().unwrap();
        assert!(w.bodies[0].velocity.x > 0.0);
        assert!(w.bodies[1].velocity.x < 0.0);
        // Nearer pushes harder: 1 - 1/3 against 1 - 2/3.
        assert!((w.bodies[0].velocity.x / -w.bodies[1].velocity.x - 2.0).abs() < 1e-3);
        assert_eq!(w.bodies[2].velocity, Vec2::ZERO);
        assert_eq!(push_radial(&mut w, Vec2::ZERO, f32::NAN, 30.0), 0);
    }

    #[test]
    fn picking_and_spawning() {
        let mut w = floating_box();
        w.bodies[0].angle = 0.5;
        w.bodies[0].rot = crate::math::Rot::from_angle(0.5);
        assert_eq!(body_at(&w, Vec2::new(0.1, 0.1)), Some(0));
        assert_eq!(
            body_at(&w, Vec2::new(0.6, 0.0)),
            None,
            "outside the rotated box"
        );
        let c = spawn(&mut w, SpawnKind::Circle, Vec2::new(5.0, 5.0), 0.5).unwrap();
        let b = spawn(&mut w, SpawnKind::Box, Vec2::new(5.0, 5.0), 0.5).unwrap();
        assert_ne!(w.bodies[c].name, w.bodies[b].name);
        assert_eq!(
            body_at(&w, Vec2::new(5.0, 5.0)),
            Some(b),
            "the newest on top"
        );
        assert!(contains(&w.bodies[c], Vec2::new(5.24, 5.0)));
        assert!(!contains(&w.bodies[c], Vec2::new(5.26, 5.0)));
        assert!(spawn(&mut w, SpawnKind::Box, Vec2::new(f32::NAN, 0.0), 0.5).is_err());
    }
}
