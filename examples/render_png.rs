//! Renders a world to a PNG from code: a pyramid hit by a ball, drawn off-screen through
//! wgpu (a CPU adapter such as Mesa's llvmpipe works without a GPU) and written with
//! `image`. Fails if no adapter is found or the picture is blank.
//!
//! cargo run --example render_png -- [OUT.png]   (default: pyramid.png)

use glam::Vec2;
use sandbox2d::draw::Camera;
use sandbox2d::draw::world::{Overlays, world_draw_list};
use sandbox2d::render::{Renderer, save_png};
use sandbox2d::{BodyDef, BodyType, ShapeDef, SolverSettings, World};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "pyramid.png".into());
    let mut world = World::new(Some(Vec2::new(0.0, -9.81)), SolverSettings::default());
    world.create_body(&BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 40.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        ..Default::default()
    })?;
    // a pyramid of 10 rows of boxes
    for row in 0..10 {
        for k in 0..(10 - row) {
            world.create_body(&BodyDef {
                name: format!("box {row} {k}"),
                shape: ShapeDef::Box {
                    width: 1.0,
                    height: 1.0,
                },
                position: Vec2::new(k as f32 - (9 - row) as f32 * 0.5, 0.5 + row as f32),
                ..Default::default()
            })?;
        }
    }
    world.create_body(&BodyDef {
        name: "ball".into(),
        shape: ShapeDef::Circle { radius: 0.6 },
        density: 10.0,
        position: Vec2::new(-14.0, 3.0),
        velocity: Vec2::new(20.0, 4.0),
        ..Default::default()
    })?;
    for _ in 0..50 {
        world.step()?;
    }
    // the camera: 960 x 540 pixels around the scene, 20 px of margin
    let mut camera = Camera::new(Vec2::ZERO, 40.0, [960, 540]);
    camera.fit(Vec2::new(-16.0, -1.0), Vec2::new(16.0, 12.0), 20.0);
    let list = world_draw_list(&world, &Overlays::default());
    let mut renderer = Renderer::new_headless()?;
    let image = renderer.render_to_image(&list, &camera)?;
    // not blank: the background and the bodies' colours both show
    let first = image.get_pixel(0, 0);
    let differing = image.pixels().filter(|p| *p != first).count();
    save_png(&out, &image)?;
    println!(
        "wrote {out}: {} x {} pixels, {differing} of them not background",
        image.width(),
        image.height()
    );
    if differing < 10_000 {
        return Err(format!("{out} is nearly blank: {differing} pixels drawn").into());
    }
    Ok(())
}
