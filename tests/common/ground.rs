//! The ground the world-building tests stand their bodies on.

#![allow(dead_code)]

use glam::Vec2;
use sandbox2d::{BodyDef, BodyKey, BodyType, ShapeDef, World};

/// Adds a static box 20 m wide and 1 m deep whose top is at y = 0.
pub fn ground(w: &mut World) -> BodyKey {
    w.create_body(&BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 20.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        ..BodyDef::default()
    })
    .expect("a static box builds")
}
