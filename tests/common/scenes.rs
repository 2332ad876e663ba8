//! Hand-built draw lists shared by the snapshot tests and the render benchmark: what
//! the engine will produce for a pyramid of boxes on a ground, a few balls and joints.

#![allow(dead_code)]

use glam::Vec2;
use sandbox2d::draw::DrawList;

/// Ground colour.
pub const GROUND: [u8; 4] = [70, 74, 84, 255];
/// Outline colour of bodies.
pub const OUTLINE: [u8; 4] = [12, 12, 16, 255];
/// Joint colour.
pub const JOINT: [u8; 4] = [235, 200, 60, 255];

/// A colour per pyramid row, cycling through a small palette.
pub fn row_color(row: usize) -> [u8; 4] {
    const PALETTE: [[u8; 4]; 5] = [
        [220, 90, 70, 255],
        [230, 160, 60, 255],
        [90, 170, 100, 255],
        [70, 140, 210, 255],
        [150, 100, 200, 255],
    ];
    PALETTE[row % PALETTE.len()]
}

/// A pyramid of `rows` rows of 1 m boxes (rows * (rows + 1) / 2 boxes; 20 rows = 210)
/// standing on a ground box whose top is at y = 0. Boxes leave 2 cm gaps and lean a
/// little, as a settling stack does.
pub fn pyramid(list: &mut DrawList, rows: usize) {
    let half_width = rows as f32 * 0.55 + 2.0;
    list.push_box(
        Vec2::new(0.0, -0.5),
        2.0 * half_width,
        1.0,
        0.0,
        GROUND,
        OUTLINE,
    );
    for row in 0..rows {
        let count = rows - row;
        let y = 0.5 + row as f32 * 1.0;
        for i in 0..count {
            let x = (i as f32 - (count as f32 - 1.0) * 0.5) * 1.02;
            // A tiny deterministic lean so outlines show rotation.
            let angle = ((row * 7 + i * 3) % 5) as f32 * 0.004 - 0.008;
            list.push_box(Vec2::new(x, y), 0.98, 0.98, angle, row_color(row), OUTLINE);
        }
    }
}

/// The small snapshot scene: a 5-row pyramid, three balls with rotation lines, a
/// particle, a pendulum and a two-link chain drawn as joint lines, and a translucent
/// ball over the stack.
pub fn small_scene() -> DrawList {
    let mut list = DrawList::new();
    pyramid(&mut list, 5);
    let ball = [240, 240, 235, 255];
    list.push_circle(Vec2::new(-5.0, 0.6), 0.6, Some(0.0), ball, OUTLINE);
    list.push_circle(
        Vec2::new(-3.6, 0.4),
        0.4,
        Some(std::f32::consts::FRAC_PI_2),
        ball,
        OUTLINE,
    );
    list.push_circle(
        Vec2::new(4.5, 0.8),
        0.8,
        Some(2.4),
        [200, 80, 160, 255],
        OUTLINE,
    );
    // A particle: no rotation line.
    list.push_circle(
        Vec2::new(3.2, 0.15),
        0.15,
        None,
        [120, 220, 230, 255],
        OUTLINE,
    );
    // Pendulum: anchor, thread, bob.
    let anchor = Vec2::new(-4.0, 6.0);
    let bob = Vec2::new(-2.6, 3.9);
    list.push_line(anchor, bob, 2.0, JOINT);
    list.push_circle(anchor, 0.08, None, JOINT, OUTLINE);
    list.push_circle(bob, 0.35, Some(-0.9), [90, 200, 120, 255], OUTLINE);
    // A chain of two links with hinge points.
    let links = [
        Vec2::new(2.0, 6.5),
        Vec2::new(3.0, 5.8),
        Vec2::new(3.6, 4.9),
    ];
    for w in links.windows(2) {
        list.push_line(w[0], w[1], 3.0, JOINT);
    }
    // A translucent ball over the stack (blending in linear light).
    list.push_circle(
        Vec2::new(1.0, 3.6),
        0.9,
        None,
        [80, 160, 255, 110],
        [255, 255, 255, 180],
    );
    // A thin debug vector.
    list.push_line(
        Vec2::new(4.5, 0.8),
        Vec2::new(5.8, 2.0),
        0.75,
        [255, 255, 255, 255],
    );
    list
}

/// The benchmark scene: a 20-row (210-box) pyramid, a few balls and joints.
pub fn bench_scene() -> DrawList {
    bench_scene_rows(20)
}

/// The benchmark scene with a pyramid of `rows` rows (100 rows: 5050 boxes, the large
/// pyramid's count), the same balls and joints above a 20-row pyramid's top.
pub fn bench_scene_rows(rows: usize) -> DrawList {
    let mut list = DrawList::new();
    pyramid(&mut list, rows);
    for i in 0..12 {
        let x = -14.0 + i as f32 * 2.5;
        list.push_circle(
            Vec2::new(x, 23.0),
            0.5,
            Some(i as f32 * 0.5),
            [240, 240, 235, 255],
            OUTLINE,
        );
        list.push_line(Vec2::new(x, 26.0), Vec2::new(x, 23.0), 2.0, JOINT);
    }
    list
}
