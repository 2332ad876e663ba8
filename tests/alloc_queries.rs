//! A game's loop of queries between steps allocates nothing once the world is warm: the
//! closure forms of every query, and the step that keeps their tree (counted by a
//! global allocator, per thread; this file holds one test).

use glam::Vec2;
use sandbox2d::math::Aabb;
use sandbox2d::{Filter, QueryShape, ShapeDef, SolverSettings, World, scene};

#[path = "common/counting.rs"]
mod counting;

#[global_allocator]
static COUNTING: counting::Counting = counting::Counting;

/// One frame of a game's questions; returns how many answers, so none is optimised out.
fn ask(w: &World, probe: &QueryShape, x: f32) -> usize {
    let all = Filter::default();
    let mut n = 0;
    let area = Aabb {
        min: Vec2::new(x - 2.0, 0.0),
        max: Vec2::new(x + 2.0, 4.0),
    };
    w.for_each_in_aabb(&area, &all, |_| {
        n += 1;
        true
    });
    w.for_each_at_point(Vec2::new(x, 1.0), &all, |_| {
        n += 1;
        true
    });
    w.for_each_overlapping(probe, Vec2::new(x, 2.0), 0.3, &all, |_| {
        n += 1;
        true
    });
    n += w
        .ray_cast_closest(Vec2::new(x, 30.0), Vec2::new(0.0, -40.0), &all)
        .is_some() as usize;
    w.ray_cast(Vec2::new(-30.0, 1.0), Vec2::new(60.0, 0.0), &all, |_| {
        n += 1;
        1.0
    });
    n += w
        .cast_shape(probe, Vec2::new(x, 30.0), 0.0, Vec2::new(0.0, -40.0), &all)
        .is_some() as usize;
    n
}

#[test]
fn steady_queries_and_steps_allocate_nothing() {
    let probe = QueryShape::new(&ShapeDef::Box {
        width: 1.0,
        height: 0.5,
    })
    .unwrap();
    // the pyramid awake throughout (the step's steady path, as tests/alloc.rs), with the
    // queries' tree kept by each step: nothing allocates, steps or queries
    let sc = scene::load("pyramid").unwrap();
    let settings = SolverSettings {
        sleep: false,
        ..SolverSettings::default()
    };
    let mut w = World::from_def(&sc.world, settings).unwrap();
    let mut answers = 0;
    for k in 0..100 {
        w.step().unwrap();
        answers += ask(&w, &probe, (k % 20) as f32 - 10.0);
    }
    let before = counting::allocations();
    for k in 0..100 {
        w.step().unwrap();
        answers += ask(&w, &probe, (k % 20) as f32 - 10.0);
    }
    let after = counting::allocations();
    assert!(answers > 1000, "the queries find the pyramid: {answers}");
    assert_eq!(
        after - before,
        0,
        "allocations in 100 frames of steps and queries"
    );

    // a ball smashing the pyramid, bodies falling asleep: the steps grow their buffers
    // as contacts come and go, the queries never allocate
    let sc = scene::load("pyramid_throw").unwrap();
    let mut w = World::from_def(&sc.world, SolverSettings::default()).unwrap();
    let (mut in_queries, mut answers) = (0, 0);
    for k in 0..240 {
        w.step().unwrap();
        let before = counting::allocations();
        answers += ask(&w, &probe, (k % 20) as f32 - 10.0);
        let made = counting::allocations() - before;
        if k == 0 {
            assert!(
                made > 0,
                "the first frame makes the tree (and the counter counts)"
            );
        } else {
            in_queries += made;
        }
    }
    assert!(answers > 1000, "the queries find the pyramid: {answers}");
    assert_eq!(in_queries, 0, "allocations in 239 frames of queries");
}
