//! Queries on a 20,000-body world: the tree the world keeps against a scan over every
//! body (what the queries did before they had a tree), for a box query, a ray cast and
//! a point query.
//!
//! `cargo bench --bench queries`. The figures and their ratio are in docs/library.md.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec2;
use sandbox2d::math::Aabb;
use sandbox2d::{BodyDef, BodyType, Filter, ShapeDef, SolverSettings, World};
use std::hint::black_box;

/// 20,000 bodies on a 200 x 100 grid, 1.5 m apart: boxes, circles and capsules, turned.
fn field() -> World {
    let mut w = World::new(None, SolverSettings::default());
    for i in 0..20_000usize {
        let (x, y) = ((i % 200) as f32 * 1.5, (i / 200) as f32 * 1.5);
        let shape = match i % 3 {
            0 => ShapeDef::Box {
                width: 1.0,
                height: 0.6,
            },
            1 => ShapeDef::Circle { radius: 0.5 },
            _ => ShapeDef::Capsule {
                length: 1.0,
                radius: 0.25,
            },
        };
        w.create_body(&BodyDef {
            name: format!("b{i}"),
            body_type: BodyType::Static,
            shape,
            position: Vec2::new(x, y),
            angle: i as f32 * 0.37,
            ..BodyDef::default()
        })
        .unwrap();
    }
    w
}

fn queries(c: &mut Criterion) {
    let w = field();
    let all = Filter::default();
    let area = Aabb {
        min: Vec2::new(100.0, 50.0),
        max: Vec2::new(104.0, 54.0),
    };
    let (origin, ray) = (Vec2::new(100.2, 50.7), Vec2::new(40.0, 3.0));
    let point = Vec2::new(150.0, 75.0);
    // the tree is made at the first query: made before timing
    assert!(!w.query_aabb(&area, &all).is_empty());
    // the scans' bodies, gathered before timing (a scan walks a plain list)
    let bodies: Vec<_> = w.bodies().map(|(_, b)| b).collect();
    let mut g = c.benchmark_group("queries_20k");
    g.bench_function("aabb_tree", |b| {
        b.iter(|| {
            let mut n = 0;
            w.for_each_in_aabb(black_box(&area), &all, |_| {
                n += 1;
                true
            });
            n
        })
    });
    g.bench_function("aabb_scan", |b| {
        b.iter(|| {
            let area = black_box(&area);
            bodies.iter().filter(|b| b.aabb().overlaps(area)).count()
        })
    });
    g.bench_function("ray_tree", |b| {
        b.iter(|| w.ray_cast_closest(black_box(origin), ray, &all))
    });
    g.bench_function("ray_scan", |b| {
        b.iter(|| {
            let o = black_box(origin);
            bodies
                .iter()
                .filter_map(|b| {
                    let xf = b.transform();
                    b.ray_cast_local(xf.inv_apply(o), xf.q.inv_rotate(ray))
                        .map(|(t, _)| t)
                })
                .min_by(f32::total_cmp)
        })
    });
    g.bench_function("point_tree", |b| {
        b.iter(|| {
            let mut n = 0;
            w.for_each_at_point(black_box(point), &all, |_| {
                n += 1;
                true
            });
            n
        })
    });
    g.bench_function("point_scan", |b| {
        b.iter(|| {
            let p = black_box(point);
            bodies
                .iter()
                .filter(|b| b.contains_local(b.transform().inv_apply(p)))
                .count()
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(std::time::Duration::from_secs(2));
    targets = queries
}
criterion_main!(benches);
