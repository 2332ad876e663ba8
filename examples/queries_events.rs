//! A small game loop driven by queries and events: a cannon fires balls at a wall of
//! crates; each frame the game reads the hit events (where a game would play a sound),
//! sweeps a laser across the wall with a ray cast, and at 2 s sets off a bomb that
//! finds the crates near it with a shape query and throws them with impulses, through
//! the bodies' keys. It prints what happened and fails if any of it did not.
//!
//! cargo run --example queries_events --no-default-features

use glam::Vec2;
use sandbox2d::{BodyDef, BodyKey, BodyType, Filter, QueryShape, ShapeDef, SolverSettings, World};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut world = World::new(Some(Vec2::new(0.0, -9.81)), SolverSettings::default());
    world.record_events = true;
    world.hit_speed = 2.0; // louder than a crate settling
    world.create_body(&BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 60.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        ..Default::default()
    })?;
    // a wall of 5 x 8 crates at x = 10..14
    let mut crates: Vec<BodyKey> = Vec::new();
    for row in 0..8 {
        for col in 0..5 {
            let key = world.create_body(&BodyDef {
                name: format!("crate {row} {col}"),
                shape: ShapeDef::Box {
                    width: 0.9,
                    height: 0.9,
                },
                position: Vec2::new(10.0 + col as f32, 0.45 + row as f32 * 0.9),
                ..Default::default()
            })?;
            crates.push(key);
        }
    }
    let everything = Filter::default();
    let blast = QueryShape::new(&ShapeDef::Circle { radius: 2.0 })?;
    let (mut hits, mut loudest, mut lasered, mut thrown) = (0usize, 0.0f32, 0usize, 0usize);
    for frame in 0..300 {
        // fire a ball every half second from the cannon at x = -5
        if frame % 30 == 0 && frame < 150 {
            let key = world.create_body(&BodyDef {
                name: format!("ball {frame}"),
                shape: ShapeDef::Circle { radius: 0.3 },
                density: 5.0,
                position: Vec2::new(-5.0, 2.0 + (frame / 30) as f32),
                ..Default::default()
            })?;
            world.set_velocity(key, Vec2::new(18.0, 2.0), 0.0)?;
        }
        // the bomb: every crate it reaches is thrown away from it
        if frame == 120 {
            let centre = Vec2::new(12.0, 2.0);
            let mut near = Vec::new();
            world.for_each_overlapping(&blast, centre, 0.0, &everything, |body| {
                near.push(body);
                true
            });
            for key in near {
                if !crates.contains(&key) {
                    continue;
                }
                let b = world.body(key).unwrap();
                let away = (b.position - centre).normalize_or(Vec2::Y);
                let at = b.position;
                world.apply_impulse(key, away * 6.0, at)?;
                thrown += 1;
            }
        }
        world.step()?;
        for hit in world.hits() {
            hits += 1;
            loudest = loudest.max(hit.approach_speed);
        }
        // the laser sweeps up the wall: the first thing it meets
        let height = 0.2 + (frame % 60) as f32 * 0.12;
        let laser =
            world.ray_cast_closest(Vec2::new(-10.0, height), Vec2::new(40.0, 0.0), &everything);
        if laser.is_some_and(|h| crates.contains(&h.body)) {
            lasered += 1;
        }
    }
    let fallen = crates
        .iter()
        .filter(|&&k| world.body(k).is_some_and(|b| b.position.y < 0.5))
        .count();
    println!(
        "hits: {hits} (loudest {loudest:.1} m/s), laser frames on a crate: {lasered}, thrown by the bomb: {thrown}, crates on the ground row now: {fallen}"
    );
    if hits == 0 || loudest < 10.0 || lasered == 0 || thrown < 5 || fallen <= 5 {
        return Err("the game saw too little: every count above should be well above 0".into());
    }
    Ok(())
}
