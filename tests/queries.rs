//! World queries against closed forms: ray casts into circles, boxes and polygons
//! (entry point, normal, fraction), point and box queries, filters, and a property test
//! that every reported hit lies on the surface with no earlier entry.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use glam::Vec2;
use proptest::prelude::*;
use sandbox2d::{BodyDef, BodyKey, BodyType, Filter, ShapeDef, SolverSettings, World};

fn world() -> World {
    World::new(None, SolverSettings::default())
}

fn add(w: &mut World, name: &str, shape: ShapeDef, at: Vec2, angle: f32) -> BodyKey {
    w.create_body(&BodyDef {
        name: name.into(),
        body_type: BodyType::Static,
        shape,
        position: at,
        angle,
        ..BodyDef::default()
    })
    .unwrap()
}

fn close(a: Vec2, b: Vec2) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn a_ray_enters_a_circle_where_the_line_meets_it() {
    let mut w = world();
    let c = add(
        &mut w,
        "c",
        ShapeDef::Circle { radius: 1.0 },
        Vec2::new(5.0, 0.0),
        0.0,
    );
    let all = Filter::default();
    // straight at the centre: enters at x = 4, 40% along
    let h = w
        .ray_cast_closest(Vec2::ZERO, Vec2::new(10.0, 0.0), &all)
        .unwrap();
    assert_eq!(h.body, c);
    assert!((h.fraction - 0.4).abs() < 1e-6);
    assert!(close(h.point, Vec2::new(4.0, 0.0)) && close(h.normal, Vec2::new(-1.0, 0.0)));
    // off-centre at height 0.6: x = 5 - sqrt(1 - 0.36) = 4.2, normal (-0.8, 0.6)
    let h = w
        .ray_cast_closest(Vec2::new(0.0, 0.6), Vec2::new(10.0, 0.0), &all)
        .unwrap();
    assert!(close(h.point, Vec2::new(4.2, 0.6)), "{:?}", h.point);
    assert!(close(h.normal, Vec2::new(-0.8, 0.6)), "{:?}", h.normal);
    // too short, passing above, pointing away, or starting inside: no hit
    for (o, t) in [
        (Vec2::ZERO, Vec2::new(3.9, 0.0)),
        (Vec2::new(0.0, 1.01), Vec2::new(10.0, 0.0)),
        (Vec2::ZERO, Vec2::new(-10.0, 0.0)),
        (Vec2::new(5.0, 0.5), Vec2::new(10.0, 0.0)),
    ] {
        assert_eq!(w.ray_cast_closest(o, t, &all), None, "{o} + {t}");
    }
}

#[test]
fn a_ray_enters_a_turned_box_through_the_edge_it_faces() {
    // a 2 m square turned 45 degrees at (5, 0): its edges are |x'| + |y'| = sqrt 2
    let mut w = world();
    add(
        &mut w,
        "b",
        ShapeDef::Box {
            width: 2.0,
            height: 2.0,
        },
        Vec2::new(5.0, 0.0),
        std::f32::consts::FRAC_PI_4,
    );
    let h = w
        .ray_cast_closest(
            Vec2::new(0.0, 0.5),
            Vec2::new(10.0, 0.0),
            &Filter::default(),
        )
        .unwrap();
    // upper-left edge: -x' + y' = sqrt 2 at y' = 0.5
    let x = 5.0 + 0.5 - std::f32::consts::SQRT_2;
    assert!(close(h.point, Vec2::new(x, 0.5)), "{:?}", h.point);
    let n = Vec2::new(-1.0, 1.0).normalize();
    assert!(close(h.normal, n), "{:?}", h.normal);
    assert!((h.fraction - x / 10.0).abs() < 1e-6);
    // along an edge's line, outside: parallel and outside is no hit
    let edge_dir = Vec2::new(1.0, 1.0).normalize();
    let outside = Vec2::new(5.0, 0.0) + n * 1.5 - edge_dir * 5.0;
    assert_eq!(
        w.ray_cast_closest(outside, edge_dir * 10.0, &Filter::default()),
        None
    );
}

#[test]
fn a_ray_enters_a_triangle_through_its_slanted_side() {
    // the triangle (0,0), (2,0), (0,2) placed at the origin: its hypotenuse is x + y = 2
    // (the points are where the scene puts them, whatever the centre of mass)
    let mut w = world();
    let points = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(2.0, 0.0),
        Vec2::new(0.0, 2.0),
    ];
    add(&mut w, "t", ShapeDef::Polygon { points }, Vec2::ZERO, 0.0);
    let h = w
        .ray_cast_closest(
            Vec2::new(3.0, 3.0),
            Vec2::new(-3.0, -3.0),
            &Filter::default(),
        )
        .unwrap();
    assert!(close(h.point, Vec2::ONE), "{:?}", h.point);
    assert!((h.fraction - 2.0 / 3.0).abs() < 1e-6);
    assert!(close(h.normal, Vec2::new(1.0, 1.0).normalize()));
}

#[test]
fn ray_cast_all_lists_every_body_nearest_first_and_filters_by_category() {
    let mut w = world();
    for k in 0..4 {
        // body 1 is in category bit 1 only
        let filter = if k == 1 {
            Filter {
                category: 1 << 1,
                ..Filter::default()
            }
        } else {
            Filter::default()
        };
        w.create_body(&BodyDef {
            name: format!("c{k}"),
            body_type: BodyType::Static,
            shape: ShapeDef::Circle { radius: 0.5 },
            position: Vec2::new(8.0 - 2.0 * k as f32, 0.0),
            filter,
            ..BodyDef::default()
        })
        .unwrap();
    }
    let hits = w.ray_cast_all(Vec2::ZERO, Vec2::new(10.0, 0.0), &Filter::default());
    let index = |k: BodyKey| w.order_of_key(k).unwrap();
    let bodies: Vec<usize> = hits.iter().map(|h| index(h.body)).collect();
    assert_eq!(bodies, [3, 2, 1, 0]);
    assert!(hits.windows(2).all(|p| p[0].fraction <= p[1].fraction));
    let only_default = Filter {
        mask: 1,
        ..Filter::default()
    };
    let bodies: Vec<usize> = w
        .ray_cast_all(Vec2::ZERO, Vec2::new(10.0, 0.0), &only_default)
        .iter()
        .map(|h| index(h.body))
        .collect();
    assert_eq!(bodies, [3, 2, 0]);
    assert_eq!(
        w.ray_cast_closest(Vec2::ZERO, Vec2::new(10.0, 0.0), &only_default)
            .map(|h| index(h.body)),
        Some(3)
    );
}

#[test]
fn point_and_box_queries_find_what_holds_and_what_overlaps() {
    let mut w = world();
    let c = add(
        &mut w,
        "c",
        ShapeDef::Circle { radius: 1.0 },
        Vec2::ZERO,
        0.0,
    );
    let b = add(
        &mut w,
        "b",
        ShapeDef::Box {
            width: 2.0,
            height: 1.0,
        },
        Vec2::new(3.0, 0.0),
        std::f32::consts::FRAC_PI_2,
    );
    let all = Filter::default();
    assert_eq!(w.query_point(Vec2::new(0.7, 0.7), &all), [c]);
    assert!(w.query_point(Vec2::new(0.75, 0.75), &all).is_empty()); // |p| = 1.06
    // the box stands up (turned 90 degrees): 1 m wide, 2 m tall
    assert_eq!(w.query_point(Vec2::new(3.0, 0.9), &all), [b]);
    assert!(w.query_point(Vec2::new(3.9, 0.0), &all).is_empty());
    let aabb = |x0: f32, y0: f32, x1: f32, y1: f32| sandbox2d::math::Aabb {
        min: Vec2::new(x0, y0),
        max: Vec2::new(x1, y1),
    };
    assert_eq!(w.query_aabb(&aabb(-5.0, -5.0, 5.0, 5.0), &all), [c, b]);
    assert_eq!(w.query_aabb(&aabb(2.6, 0.9, 2.7, 1.1), &all), [b]);
    assert!(w.query_aabb(&aabb(1.1, 1.1, 2.4, 2.0), &all).is_empty());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Any reported hit lies on the shape's surface, the normal points out of the shape
    /// against the ray, and a point a little before the hit is outside the shape.
    #[test]
    fn every_hit_is_on_the_surface_with_nothing_before_it(
        ox in -6.0f32..6.0, oy in -6.0f32..6.0,
        tx in -12.0f32..12.0, ty in -12.0f32..12.0,
        angle in -3.2f32..3.2,
        circle in proptest::bool::ANY,
    ) {
        let mut w = world();
        let shape = if circle {
            ShapeDef::Circle { radius: 1.5 }
        } else {
            ShapeDef::Box { width: 3.0, height: 1.0 }
        };
        add(&mut w, "s", shape, Vec2::new(0.5, -0.25), angle);
        let (o, t) = (Vec2::new(ox, oy), Vec2::new(tx, ty));
        let inside = |p: Vec2| !w.query_point(p, &Filter::default()).is_empty();
        if let Some(h) = w.ray_cast_closest(o, t, &Filter::default()) {
            prop_assert!((0.0..=1.0).contains(&h.fraction));
            prop_assert!(close(h.point, o + t * h.fraction));
            prop_assert!((h.normal.length() - 1.0).abs() < 1e-4);
            prop_assert!(h.normal.dot(t) <= 1e-6, "the ray enters against the normal");
            // on the surface: just inside along -normal, just outside along +normal
            prop_assert!(inside(h.point - h.normal * 1e-3));
            prop_assert!(!inside(h.point + h.normal * 1e-3));
            // nothing earlier: the ray's points before the hit are outside
            for k in 1..20 {
                let f = h.fraction * k as f32 / 20.0;
                prop_assert!(!inside(o + t * (f - 1e-3).max(0.0)) || f < 1e-3);
            }
        } else if !inside(o) {
            // a miss from outside: no point of the segment is inside
            for k in 0..=40 {
                let p = o + t * (k as f32 / 40.0);
                prop_assert!(!inside(p), "missed, but {p} is inside");
            }
        }
    }
}
