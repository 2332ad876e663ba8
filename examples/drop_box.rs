//! Drops a box on the ground and prints its height as it falls and settles.
//!
//! cargo run --example drop_box --no-default-features

use glam::Vec2;
use sandbox2d::{BodyDef, BodyType, ShapeDef, SolverSettings, World};

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
    let b = world.create_body(&BodyDef {
        name: "box".into(),
        shape: ShapeDef::Box {
            width: 1.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, 5.0),
        angle: 0.3,
        ..Default::default()
    })?;
    for step in 0..=180 {
        if step % 15 == 0 {
            let body = world.body(b).expect("the box is there");
            println!(
                "t = {:5.2} s  height = {:6.3} m  angle = {:6.3} rad",
                world.time(),
                body.position.y,
                body.angle
            );
        }
        world.step()?;
    }
    Ok(())
}
