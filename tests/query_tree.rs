//! The world's queries walk a tree over the bodies' boxes; here each one is checked
//! against a scan over every body in random worlds (rotated polygons, capsules, rounded
//! boxes, compounds, bodies far from the rest), before and after steps that move the
//! bodies (the tree's moved list and its rebuilds), and after bodies are removed and
//! added. A shape cast's time of impact is checked against closed forms.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use glam::Vec2;
use proptest::prelude::*;
use sandbox2d::collision::sat::collide;
use sandbox2d::compound::for_each_collider;
use sandbox2d::math::{Aabb, Rot, Transform};
use sandbox2d::shape::Shape;
use sandbox2d::{
    BodyDef, BodyKey, BodyType, Filter, PartDef, QueryShape, SHAPE_CAST_TOLERANCE, ShapeDef,
    SolverSettings, World,
};

/// One of the shapes a body can have, by a number.
fn shape_of(kind: u8, size: f32) -> ShapeDef {
    match kind % 6 {
        0 => ShapeDef::Circle { radius: size },
        1 => ShapeDef::Box {
            width: 2.0 * size,
            height: size,
        },
        2 => ShapeDef::Polygon {
            points: vec![
                Vec2::new(-size, -0.5 * size),
                Vec2::new(size, -0.7 * size),
                Vec2::new(0.3 * size, size),
            ],
        },
        3 => ShapeDef::Capsule {
            length: 3.0 * size,
            radius: 0.4 * size,
        },
        4 => ShapeDef::RoundedBox {
            width: 2.0 * size,
            height: 1.5 * size,
            radius: 0.2 * size,
        },
        _ => ShapeDef::Compound {
            parts: vec![
                PartDef::new(
                    ShapeDef::Box {
                        width: 2.0 * size,
                        height: 0.4 * size,
                    },
                    Vec2::ZERO,
                ),
                PartDef::new(
                    ShapeDef::Circle { radius: 0.5 * size },
                    Vec2::new(1.2 * size, 0.8 * size),
                ),
            ],
        },
    }
}

/// A body to add: (shape kind, size, x, y, angle, dynamic, category bit, far away).
type Spec = (u8, f32, f32, f32, f32, bool, u8, bool);

fn spec() -> impl Strategy<Value = Spec> {
    (
        0u8..6,
        0.2f32..1.5,
        -20.0f32..20.0,
        -20.0f32..20.0,
        -3.2f32..3.2,
        any::<bool>(),
        0u8..3,
        proptest::bool::weighted(0.1),
    )
}

fn add(w: &mut World, i: usize, s: &Spec) -> BodyKey {
    let &(kind, size, x, y, angle, dynamic, category, far) = s;
    // a few bodies far from the rest: the tree spans a huge box
    let offset = if far {
        Vec2::new(5.0e4, -3.0e4)
    } else {
        Vec2::ZERO
    };
    w.create_body(&BodyDef {
        name: format!("b{i}"),
        body_type: if dynamic {
            BodyType::Dynamic
        } else {
            BodyType::Static
        },
        shape: shape_of(kind, size),
        position: Vec2::new(x, y) + offset,
        angle,
        velocity: Vec2::new(y, -x) * 0.5,
        angular_velocity: x * 0.1,
        filter: Filter {
            category: 1 << category,
            ..Filter::default()
        },
        ..BodyDef::default()
    })
    .unwrap()
}

/// The bodies a scan finds whose shape holds `p`.
fn scan_point(w: &World, p: Vec2, filter: &Filter) -> Vec<usize> {
    (0..w.body_count())
        .filter(|&i| {
            let b = &w.nth_body(i);
            filter.mask & b.filter.category != 0 && b.contains_local(b.transform().inv_apply(p))
        })
        .collect()
}

fn scan_aabb(w: &World, q: &Aabb, filter: &Filter) -> Vec<usize> {
    (0..w.body_count())
        .filter(|&i| {
            let b = &w.nth_body(i);
            filter.mask & b.filter.category != 0 && b.aabb().overlaps(q)
        })
        .collect()
}

/// Every body a segment enters, as (fraction, body), nearest first.
fn scan_ray(w: &World, o: Vec2, t: Vec2, filter: &Filter) -> Vec<(f32, usize)> {
    let mut hits: Vec<(f32, usize)> = (0..w.body_count())
        .filter_map(|i| {
            let b = &w.nth_body(i);
            if filter.mask & b.filter.category == 0 {
                return None;
            }
            let xf = b.transform();
            let (f, _) = b.ray_cast_local(xf.inv_apply(o), xf.q.inv_rotate(t))?;
            Some((f, i))
        })
        .collect();
    hits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    hits
}

/// The bodies a shape placed by `xf` overlaps, by the narrow phase's own test.
fn scan_shape(w: &World, shape: &Shape, xf: &Transform, filter: &Filter) -> Vec<usize> {
    (0..w.body_count())
        .filter(|&i| {
            let b = &w.nth_body(i);
            if filter.mask & b.filter.category == 0 {
                return false;
            }
            let mut touches = false;
            for_each_collider(b, |_, c| {
                let m = collide(shape, xf, &c.shape, &c.xf, 0.0);
                touches |= m.points().iter().any(|p| p.separation <= 0.0);
            });
            touches
        })
        .collect()
}

/// Where the bodies of `keys` are now (every key must name one).
fn at(w: &World, keys: Vec<BodyKey>) -> Vec<usize> {
    keys.iter()
        .map(|&k| w.order_of_key(k).expect("a query names live bodies"))
        .collect()
}

/// Checks every query at a few places against the scans.
fn check_all(w: &World, probes: &[(f32, f32, f32, f32)], mask: u32) -> Result<(), TestCaseError> {
    let filter = Filter {
        mask,
        ..Filter::default()
    };
    let disc = QueryShape::new(&ShapeDef::Circle { radius: 1.3 }).unwrap();
    let (disc_shape, _) = Shape::from_def(&ShapeDef::Circle { radius: 1.3 }).unwrap();
    for &(x, y, dx, dy) in probes {
        let p = Vec2::new(x, y);
        prop_assert_eq!(at(w, w.query_point(p, &filter)), scan_point(w, p, &filter));
        let q = Aabb {
            min: p,
            max: p + Vec2::new(dx.abs(), dy.abs()),
        };
        prop_assert_eq!(at(w, w.query_aabb(&q, &filter)), scan_aabb(w, &q, &filter));
        let t = Vec2::new(dx, dy) * 3.0;
        let hits: Vec<(f32, usize)> = w
            .ray_cast_all(p, t, &filter)
            .iter()
            .map(|h| (h.fraction, at(w, vec![h.body])[0]))
            .collect();
        prop_assert_eq!(&hits, &scan_ray(w, p, t, &filter));
        prop_assert_eq!(
            w.ray_cast_closest(p, t, &filter)
                .map(|h| (h.fraction, at(w, vec![h.body])[0])),
            hits.first().copied()
        );
        let xf = Transform {
            p,
            q: Rot::from_angle(0.0),
        };
        prop_assert_eq!(
            at(w, w.query_shape(&disc, p, 0.0, &filter)),
            scan_shape(w, &disc_shape, &xf, &filter)
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Point, box, ray and shape queries find what a scan over every body finds, in a
    /// world as built, after steps that move its bodies, and after removals and adds.
    #[test]
    fn every_query_finds_what_a_scan_finds(
        specs in proptest::collection::vec(spec(), 1..60),
        probes in proptest::collection::vec(
            (-25.0f32..25.0, -25.0f32..25.0, -8.0f32..8.0, -8.0f32..8.0), 6),
        mask in prop_oneof![Just(u32::MAX), 1u32..8],
        remove in proptest::collection::vec(any::<prop::sample::Index>(), 0..5),
    ) {
        let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::default());
        for (i, s) in specs.iter().enumerate() {
            add(&mut w, i, s);
        }
        check_all(&w, &probes, mask)?;
        // bodies move (falling, thrown): some leave their place in the tree
        for _ in 0..20 {
            w.step().unwrap();
        }
        check_all(&w, &probes, mask)?;
        for r in &remove {
            if w.body_count() == 0 {
                break;
            }
            let key = w.nth_key(r.index(w.body_count()));
            w.remove_body(key).unwrap();
        }
        for (i, s) in specs.iter().take(3).enumerate() {
            add(&mut w, 1000 + i, s);
        }
        check_all(&w, &probes, mask)?;
        for _ in 0..40 {
            w.step().unwrap();
        }
        check_all(&w, &probes, mask)?;
    }
}

fn ground_world() -> World {
    let mut w = World::new(None, SolverSettings::default());
    w.create_body(&BodyDef {
        name: "wall".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 2.0,
            height: 10.0,
        },
        position: Vec2::new(10.0, 0.0),
        ..BodyDef::default()
    })
    .unwrap();
    w.create_body(&BodyDef {
        name: "ball".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Circle { radius: 1.0 },
        position: Vec2::new(0.0, 10.0),
        ..BodyDef::default()
    })
    .unwrap();
    w
}

#[test]
fn a_disc_cast_at_a_wall_stops_where_their_gap_closes() {
    let w = ground_world();
    let disc = QueryShape::new(&ShapeDef::Circle { radius: 0.5 }).unwrap();
    let all = Filter::default();
    // from x = 0 towards the wall's face at x = 9: the disc's edge closes 8.5 m of 20
    let hit = w
        .cast_shape(&disc, Vec2::ZERO, 0.0, Vec2::new(20.0, 0.0), &all)
        .unwrap();
    assert_eq!(w.order_of_key(hit.body), Some(0));
    let exact = 8.5 / 20.0;
    assert!(
        hit.fraction <= exact && (exact - hit.fraction) * 20.0 <= SHAPE_CAST_TOLERANCE,
        "{} against {exact}",
        hit.fraction
    );
    assert!((hit.normal - Vec2::X).length() < 1e-4, "{:?}", hit.normal);
    assert!((hit.point.x - 9.0).abs() < 1e-3, "{:?}", hit.point);
    // too short to reach it, or going away: nothing
    assert!(
        w.cast_shape(&disc, Vec2::ZERO, 0.0, Vec2::new(8.0, 0.0), &all)
            .is_none()
    );
    assert!(
        w.cast_shape(&disc, Vec2::ZERO, 0.0, Vec2::new(-20.0, 0.0), &all)
            .is_none()
    );
}

#[test]
fn a_box_cast_at_an_angle_meets_a_disc_where_geometry_says() {
    let w = ground_world();
    let all = Filter::default();
    // a 1 x 1 box moving straight up under the disc centred at (0, 10), radius 1: its
    // top face (y + 0.5) meets the disc's bottom (y = 9): 8.5 m of 17
    let block = QueryShape::new(&ShapeDef::Box {
        width: 1.0,
        height: 1.0,
    })
    .unwrap();
    let hit = w
        .cast_shape(&block, Vec2::ZERO, 0.0, Vec2::new(0.0, 17.0), &all)
        .unwrap();
    assert_eq!(w.order_of_key(hit.body), Some(1));
    let exact = 8.5 / 17.0;
    assert!(
        hit.fraction <= exact + 1e-6 && (exact - hit.fraction) * 17.0 <= SHAPE_CAST_TOLERANCE,
        "{} against {exact}",
        hit.fraction
    );
    // a disc of radius 0.5 moving along a diagonal towards the disc: the centres'
    // distance closes to 1.5, |o + t d - c| = 1.5, solved for t
    let disc = QueryShape::new(&ShapeDef::Circle { radius: 0.5 }).unwrap();
    let (o, d, c) = (
        Vec2::new(-3.0, 6.0),
        Vec2::new(6.0, 8.0),
        Vec2::new(0.0, 10.0),
    );
    let oc = o - c;
    let (a, b, cc) = (d.dot(d), 2.0 * oc.dot(d), oc.dot(oc) - 1.5 * 1.5);
    let exact = (-b - (b * b - 4.0 * a * cc).sqrt()) / (2.0 * a);
    let hit = w.cast_shape(&disc, o, 0.0, d, &all).unwrap();
    assert_eq!(w.order_of_key(hit.body), Some(1));
    assert!(
        hit.fraction <= exact + 1e-6 && (exact - hit.fraction) * d.length() <= SHAPE_CAST_TOLERANCE,
        "{} against {exact}",
        hit.fraction
    );
    // the normal points from the moving disc's centre at impact to the disc's
    let n = (c - (o + d * exact)).normalize();
    assert!(
        (hit.normal - n).length() < 1e-3,
        "{:?} against {n:?}",
        hit.normal
    );
}

#[test]
fn a_shape_overlapping_at_its_start_is_hit_at_once() {
    let w = ground_world();
    let disc = QueryShape::new(&ShapeDef::Circle { radius: 0.5 }).unwrap();
    let hit = w
        .cast_shape(
            &disc,
            Vec2::new(0.0, 9.0),
            0.0,
            Vec2::new(5.0, 0.0),
            &Filter::default(),
        )
        .unwrap();
    assert_eq!((w.order_of_key(hit.body), hit.fraction), (Some(1), 0.0));
    assert!(
        QueryShape::new(&ShapeDef::Segment {
            a: Vec2::ZERO,
            b: Vec2::X
        })
        .is_err()
    );
}
