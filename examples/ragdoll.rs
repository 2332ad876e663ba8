//! A ragdoll built in code: capsule limbs on hinges with limits, dropped on the ground
//! under the default solver (the soft step). Prints where it lies and how far its joints
//! stretch, and fails unless it comes to rest on the ground with its joints held.
//!
//! cargo run --example ragdoll --no-default-features

use glam::Vec2;
use sandbox2d::{BodyDef, BodyKey, BodyType, JointDef, ShapeDef, SolverSettings, World};

/// A limb: a capsule from `a` to `b` (world points, m) of `radius`.
fn limb(name: &str, a: Vec2, b: Vec2, radius: f32) -> BodyDef {
    let d = b - a;
    BodyDef {
        name: name.into(),
        shape: ShapeDef::Capsule {
            length: d.length() + 2.0 * radius,
            radius,
        },
        position: (a + b) * 0.5,
        angle: d.y.atan2(d.x),
        ..Default::default()
    }
}

/// A hinge at `anchor` between bodies `a` and `b`, turning within `limits` (rad).
fn hinge(
    world: &mut World,
    (a, b): (BodyKey, BodyKey),
    anchor: Vec2,
    limits: [f32; 2],
) -> Result<(), sandbox2d::EditError> {
    let def = JointDef {
        anchor: Some(anchor),
        limits: Some(limits),
        ..Default::default()
    };
    world.create_joint(a, b, &def)?;
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut world = World::new(Some(Vec2::new(0.0, -9.81)), SolverSettings::default());
    world.create_body(&BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 20.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        ..Default::default()
    })?;
    // standing 2 m up: hips at y = 3, shoulders at 3.6, the head above
    let (hip, neck) = (Vec2::new(0.0, 3.0), Vec2::new(0.0, 3.6));
    let torso = world.create_body(&limb("torso", hip, neck, 0.15))?;
    let head = world.create_body(&BodyDef {
        name: "head".into(),
        shape: ShapeDef::Circle { radius: 0.13 },
        position: neck + Vec2::new(0.0, 0.22),
        ..Default::default()
    })?;
    hinge(
        &mut world,
        (torso, head),
        neck + Vec2::new(0.0, 0.08),
        [-0.5, 0.5],
    )?;
    let quarter = std::f32::consts::FRAC_PI_2;
    for side in [-1.0f32, 1.0] {
        let s = if side < 0.0 { "left" } else { "right" };
        // arms hang from the shoulders, legs from the hips
        let shoulder = neck + Vec2::new(0.2 * side, -0.05);
        let elbow = shoulder + Vec2::new(0.05 * side, -0.3);
        let wrist = elbow + Vec2::new(0.0, -0.28);
        let upper = world.create_body(&limb(&format!("{s} upper arm"), shoulder, elbow, 0.06))?;
        let lower = world.create_body(&limb(&format!("{s} forearm"), elbow, wrist, 0.05))?;
        hinge(&mut world, (torso, upper), shoulder, [-2.5, 2.5])?;
        hinge(&mut world, (upper, lower), elbow, [-2.2, 0.0])?;
        let hip_joint = hip + Vec2::new(0.1 * side, -0.05);
        let knee = hip_joint + Vec2::new(0.0, -0.42);
        let ankle = knee + Vec2::new(0.0, -0.4);
        let thigh = world.create_body(&limb(&format!("{s} thigh"), hip_joint, knee, 0.08))?;
        let shin = world.create_body(&limb(&format!("{s} shin"), knee, ankle, 0.07))?;
        hinge(&mut world, (torso, thigh), hip_joint, [-quarter, 1.2])?;
        hinge(&mut world, (thigh, shin), knee, [0.0, 2.4])?;
    }
    // four seconds: it falls 2 m, crumples and settles
    let mut worst_gap = 0.0f32;
    for step in 0..240 {
        world.step()?;
        worst_gap = worst_gap.max(world.joint_error());
        if step % 60 == 59 {
            let t = world.body(torso).expect("the torso is there");
            println!(
                "t = {:4.2} s  torso at ({:6.3}, {:6.3}) m  speed {:6.3} m/s  joint gap {:.4} m",
                world.time(),
                t.position.x,
                t.position.y,
                t.velocity.length(),
                world.joint_error()
            );
        }
    }
    // on the ground: no part below it, nothing moving, every joint together
    let lowest = world
        .bodies()
        .skip(1)
        .map(|(_, b)| b.aabb().min.y)
        .fold(f32::MAX, f32::min);
    let fastest = world
        .bodies()
        .skip(1)
        .map(|(_, b)| b.velocity.length())
        .fold(0.0, f32::max);
    println!(
        "ragdoll at rest: lowest point {lowest:.4} m, fastest part {fastest:.4} m/s, largest joint gap while falling {worst_gap:.4} m"
    );
    if lowest < -0.02 || fastest > 0.05 || worst_gap > 0.02 {
        return Err(format!(
            "the ragdoll should rest on the ground with its joints held: lowest {lowest}, fastest {fastest}, gap {worst_gap}"
        )
        .into());
    }
    Ok(())
}
