//! Contact and sensor events: a sensor hears each overlap begin and end exactly once and
//! never touches what passes through it; a bouncing ball's contacts begin and end with
//! each bounce, the begin carrying the impact's impulse; nothing is recorded unless asked.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use glam::Vec2;
use sandbox2d::{
    BodyDef, BodyKey, BodyType, EventKind, Filter, ShapeDef, SolverKind, SolverSettings, World,
};

const G: f32 = 10.0;

/// The keys of bodies `a` and `b` (indices now).
fn keys(w: &World, a: usize, b: usize) -> (BodyKey, BodyKey) {
    (w.nth_key(a), w.nth_key(b))
}

fn ball(y: f32) -> BodyDef {
    BodyDef {
        name: "ball".into(),
        shape: ShapeDef::Circle { radius: 0.25 },
        position: Vec2::new(0.0, y),
        ..BodyDef::default()
    }
}

fn gate() -> BodyDef {
    // a 2 m x 1 m static sensor whose top is at y = 0.5 and bottom at y = -0.5
    BodyDef {
        name: "gate".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 2.0,
            height: 1.0,
        },
        sensor: true,
        ..BodyDef::default()
    }
}

#[test]
fn a_sensor_hears_each_overlap_once_and_never_touches_the_body() {
    for kind in SolverKind::ALL {
        let settings = SolverSettings::defaults(kind);
        let mut with = World::new(Some(Vec2::new(0.0, -G)), settings);
        with.create_body(&ball(3.0)).unwrap();
        with.create_body(&gate()).unwrap();
        assert!(with.record_events, "a sensor turns the events on");
        let mut without = World::new(Some(Vec2::new(0.0, -G)), settings);
        without.create_body(&ball(3.0)).unwrap();
        let (mut begins, mut ends) = (Vec::new(), Vec::new());
        let mut prev_y = with.nth_body(0).position.y;
        for k in 1..=120 {
            with.step().unwrap();
            without.step().unwrap();
            // the ball falls as if the gate were not there, bit for bit
            assert_eq!(
                with.nth_body(0).position,
                without.nth_body(0).position,
                "{kind:?} step {k}"
            );
            let y = with.nth_body(0).position.y;
            for e in with.events() {
                assert_eq!((e.a, e.b), keys(&with, 0, 1));
                match e.kind {
                    EventKind::SensorBegin => {
                        // the ball's bottom crossed the gate's top in this step
                        assert!(
                            y - 0.25 <= 0.5 && prev_y - 0.25 > 0.5,
                            "{kind:?}: begin at y {y}"
                        );
                        begins.push(k);
                    }
                    EventKind::SensorEnd => {
                        // its top left the gate's bottom in this step
                        assert!(
                            y + 0.25 < -0.5 && prev_y + 0.25 >= -0.5,
                            "{kind:?}: end at y {y}"
                        );
                        ends.push(k);
                    }
                    other => panic!("{kind:?}: a sensor pair made a {other:?} event"),
                }
            }
            prev_y = y;
        }
        assert_eq!((begins.len(), ends.len()), (1, 1), "{kind:?}");
        assert!(
            with.contacts().is_empty(),
            "a sensor pair is never a contact"
        );
    }
}

#[test]
fn a_bouncing_ball_begins_and_ends_a_contact_with_each_bounce() {
    let settings = SolverSettings::default();
    let mut w = World::new(Some(Vec2::new(0.0, -G)), settings);
    let h = 2.0f32;
    w.create_body(&BodyDef {
        restitution: 0.5,
        ..ball(h + 0.25)
    })
    .unwrap();
    w.create_body(&BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 10.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        restitution: 0.5,
        ..BodyDef::default()
    })
    .unwrap();
    assert!(w.events().is_empty());
    w.record_events = true;
    let m = w.nth_body(0).mass;
    let mut log = Vec::new();
    for k in 1..=240 {
        w.step().unwrap();
        for e in w.events() {
            assert_eq!((e.a, e.b), keys(&w, 0, 1));
            log.push((k, e.kind, e.impulse));
        }
    }
    let kinds: Vec<EventKind> = log.iter().map(|e| e.1).collect();
    // begin, end, begin, end, ... : never two of a kind in a row
    assert!(kinds.len() >= 3, "{log:?}");
    assert_eq!(kinds[0], EventKind::Begin);
    assert!(kinds.windows(2).all(|p| p[0] != p[1]), "{log:?}");
    // the first impact: the ball arrives at sqrt(2 g h) and leaves at about e times that,
    // so the whole bounce's impulse is m v (1 + e); the begin carries the share of the
    // step the touch began in: positive, and at most the whole
    let v = (2.0 * G * h).sqrt();
    let begins: Vec<f32> = log
        .iter()
        .filter(|e| e.1 == EventKind::Begin)
        .map(|e| e.2)
        .collect();
    assert!(
        begins[0] > 0.0 && begins[0] <= 1.1 * m * v * 1.5,
        "impulse {}, m v (1 + e) = {}",
        begins[0],
        m * v * 1.5
    );
    // each bounce arrives slower (by e), and so does its impulse
    assert!(begins.windows(2).all(|p| p[1] < p[0]), "{begins:?}");
}

#[test]
fn a_filtered_pair_never_touches_and_never_makes_an_event() {
    let mut w = World::new(Some(Vec2::new(0.0, -G)), SolverSettings::default());
    w.record_events = true;
    let ghost = sandbox2d::Filter {
        group: -1,
        ..Default::default()
    };
    w.create_body(&BodyDef {
        filter: ghost,
        ..ball(1.0)
    })
    .unwrap();
    w.create_body(&BodyDef {
        name: "floor".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 10.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        filter: ghost,
        ..BodyDef::default()
    })
    .unwrap();
    for _ in 0..60 {
        w.step().unwrap();
        assert!(w.events().is_empty());
        assert!(w.contacts().is_empty());
    }
    // it fell through the floor as in free fall: y = 1 - g t^2 / 2 (semi-implicit Euler
    // is ahead by g t dt / 2)
    let t = 1.0f32;
    let y = w.nth_body(0).position.y;
    let exact = 1.0 - 0.5 * G * t * t;
    assert!(
        (y - exact).abs() <= 0.5 * G * t / 60.0 + 1e-3,
        "y {y}, free fall {exact}"
    );
}

#[test]
fn a_body_asleep_in_a_sensor_stays_heard_until_it_wakes_and_leaves() {
    // A ball dropped onto a floor inside a static sensor (the floor's top at y = 0, the
    // sensor from y = -0.5 to 0.5): it comes to rest in the sensor and falls asleep,
    // which must not end the overlap; woken and thrown upwards it leaves, once.
    for kind in SolverKind::ALL {
        let mut settings = SolverSettings::defaults(kind);
        settings.sleep = true;
        let mut w = World::new(Some(Vec2::new(0.0, -G)), settings);
        w.create_body(&ball(1.0)).unwrap();
        w.create_body(&gate()).unwrap();
        w.create_body(&BodyDef {
            name: "floor".into(),
            body_type: BodyType::Static,
            shape: ShapeDef::Box {
                width: 4.0,
                height: 1.0,
            },
            position: Vec2::new(0.0, -0.5),
            ..BodyDef::default()
        })
        .unwrap();
        // a ball far away that falls for ever keeps the world awake (else a world asleep
        // skips its broad phase altogether)
        w.create_body(&BodyDef {
            name: "faller".into(),
            position: Vec2::new(100.0, 0.0),
            ..ball(0.0)
        })
        .unwrap();
        let mut log = Vec::new();
        let mut slept = false;
        for k in 0..600 {
            w.step().unwrap();
            slept |= w.nth_body(0).asleep;
            log.extend(
                w.events()
                    .iter()
                    .filter(|e| (e.a, e.b) == keys(&w, 0, 1))
                    .map(|e| (k, e.kind)),
            );
        }
        assert!(
            slept && w.nth_body(0).asleep,
            "{kind:?}: the ball never slept"
        );
        assert_eq!(
            log.iter().map(|e| e.1).collect::<Vec<_>>(),
            [EventKind::SensorBegin],
            "{kind:?}: {log:?}"
        );
        // woken and thrown up at 6 m/s: it rises 1.8 m, out of the sensor, and ends once
        w.wake(w.nth_key(0)).unwrap();
        w.set_velocity(
            w.nth_key(0),
            Vec2::new(0.0, 6.0),
            w.nth_body(0).angular_velocity,
        )
        .unwrap();
        let mut ends = 0;
        for _ in 0..30 {
            w.step().unwrap();
            ends += w
                .events()
                .iter()
                .filter(|e| e.kind == EventKind::SensorEnd)
                .count();
        }
        assert_eq!(ends, 1, "{kind:?}");
    }
}

fn ground() -> BodyDef {
    BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 40.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        ..BodyDef::default()
    }
}

#[test]
fn a_dropped_box_hits_the_ground_at_the_speed_of_its_fall() {
    // a 1 m box let go with its bottom h above the ground: it meets it at sqrt(2 g h).
    // The event gives the approach speed when the step of the impact began, which is
    // below that by at most g dt (0.8% at 20 m)
    for kind in SolverKind::ALL {
        for h in [20.0f32, 30.0] {
            let mut w = World::new(Some(Vec2::new(0.0, -G)), SolverSettings::defaults(kind));
            w.record_events = true;
            w.create_body(&ground()).unwrap();
            w.create_body(&BodyDef {
                name: "box".into(),
                shape: ShapeDef::Box {
                    width: 1.0,
                    height: 1.0,
                },
                position: Vec2::new(0.0, h + 0.5),
                ..BodyDef::default()
            })
            .unwrap();
            let mut hits = Vec::new();
            for _ in 0..240 {
                w.step().unwrap();
                hits.extend(w.hits().iter().copied());
            }
            let exact = (2.0 * G * h).sqrt();
            assert_eq!(
                hits.len(),
                1,
                "{kind:?} h {h}: one impact, then rest: {hits:?}"
            );
            let hit = hits[0];
            assert_eq!((hit.a, hit.b), keys(&w, 0, 1));
            let err = (hit.approach_speed - exact).abs() / exact;
            assert!(
                err < 0.01,
                "{kind:?} h {h}: {} against {exact} m/s",
                hit.approach_speed
            );
            // a point of the box's bottom where the step found the contact: at most one
            // step's fall above the ground; the normal from the ground up to the box
            let dt = w.settings.dt;
            assert!(
                hit.point.x.abs() <= 0.501 && (-0.05..exact * dt + 0.05).contains(&hit.point.y),
                "{:?}",
                hit.point
            );
            assert!((hit.normal - Vec2::Y).length() < 1e-3, "{:?}", hit.normal);
        }
    }
}

#[test]
fn a_ball_thrown_at_a_wall_hits_it_at_its_speed_and_slow_touches_make_no_hit() {
    for kind in SolverKind::ALL {
        let mut w = World::new(None, SolverSettings::defaults(kind));
        w.record_events = true;
        w.create_body(&BodyDef {
            name: "wall".into(),
            body_type: BodyType::Static,
            shape: ShapeDef::Box {
                width: 1.0,
                height: 10.0,
            },
            position: Vec2::new(5.0, 0.0),
            ..BodyDef::default()
        })
        .unwrap();
        // 12.5 m/s into the wall, and 0.5 m/s (below the 1 m/s threshold)
        for (v, y) in [(12.5f32, 2.0f32), (0.5, -2.0)] {
            w.create_body(&BodyDef {
                name: format!("ball{v}"),
                shape: ShapeDef::Circle { radius: 0.25 },
                position: Vec2::new(3.0, y),
                velocity: Vec2::new(v, 0.0),
                ..BodyDef::default()
            })
            .unwrap();
        }
        let mut hits = Vec::new();
        for _ in 0..600 {
            w.step().unwrap();
            hits.extend(w.hits().iter().copied());
        }
        assert_eq!(hits.len(), 1, "{kind:?}: {hits:?}");
        assert_eq!((hits[0].a, hits[0].b), keys(&w, 0, 1));
        assert!(
            (hits[0].approach_speed - 12.5).abs() < 12.5 * 1e-3,
            "{kind:?}: {}",
            hits[0].approach_speed
        );
        // the slow ball did reach the wall: it touched without a hit
        assert!(
            w.nth_body(2).position.x > 4.0,
            "{kind:?}: {}",
            w.nth_body(2).position
        );
    }
}

#[test]
fn a_box_that_falls_asleep_and_is_woken_says_so_once_each() {
    let mut w = World::new(Some(Vec2::new(0.0, -G)), SolverSettings::default());
    w.record_events = true;
    w.create_body(&ground()).unwrap();
    let i = w
        .create_body(&BodyDef {
            name: "box".into(),
            shape: ShapeDef::Box {
                width: 1.0,
                height: 1.0,
            },
            position: Vec2::new(0.0, 1.0),
            ..BodyDef::default()
        })
        .unwrap();
    let key = i;
    let mut seen = Vec::new();
    for k in 0..300 {
        if k == 200 {
            // a push between steps wakes it: reported with the next step
            assert!(w.body(i).unwrap().asleep, "asleep by 200 steps");
            w.set_velocity(key, Vec2::new(3.0, 0.0), 0.0).unwrap();
        }
        w.step().unwrap();
        for e in w.sleep_events() {
            seen.push((k, *e));
        }
    }
    // asleep once, woken once (at step 200), asleep again; the ground never changes
    let flags: Vec<bool> = seen.iter().map(|(_, e)| e.asleep).collect();
    assert_eq!(flags, [true, false, true], "{seen:?}");
    assert!(seen.iter().all(|(_, e)| e.body == key));
    assert!(
        seen[0].0 < 200 && seen[1].0 == 200 && seen[2].0 > 200,
        "{seen:?}"
    );
}

#[test]
fn events_and_query_hits_name_bodies_that_keys_still_find_after_a_removal() {
    // a static shelf far off, made first, then the ground and a box dropped 5 m onto it:
    // the box is body 2 when it lands. The shelf is removed after the landing step,
    // so the box is body 1 from then on; the events of that step, read after the
    // removal, still lead to the box and the ground
    for kind in SolverKind::ALL {
        let mut w = World::new(Some(Vec2::new(0.0, -G)), SolverSettings::defaults(kind));
        w.record_events = true;
        let shelf = w
            .create_body(&BodyDef {
                name: "shelf".into(),
                position: Vec2::new(100.0, 0.0),
                ..ground()
            })
            .unwrap();
        let floor = w.create_body(&ground()).unwrap();
        let block = w
            .create_body(&BodyDef {
                name: "box".into(),
                shape: ShapeDef::Box {
                    width: 1.0,
                    height: 1.0,
                },
                position: Vec2::new(0.0, 5.5),
                ..BodyDef::default()
            })
            .unwrap();
        let mut landed = false;
        for _ in 0..120 {
            w.step().unwrap();
            if !w.hits().is_empty() {
                landed = true;
                break;
            }
        }
        assert!(landed, "{kind:?}: the box never hit the ground");
        assert_eq!(w.order_of_key(block), Some(2));
        w.remove_body(shelf).unwrap();
        assert_eq!(
            w.order_of_key(block),
            Some(1),
            "the box moved down one index"
        );
        let hit = w.hits()[0];
        assert_eq!((hit.a, hit.b), (floor, block), "{kind:?}");
        assert_eq!(w.body(hit.b).unwrap().name, "box");
        assert_eq!(w.body(hit.a).unwrap().name, "ground");
        // the approach speed of a 5 m fall, less at most g dt
        let exact = (2.0 * G * 5.0).sqrt();
        assert!(
            (hit.approach_speed - exact).abs() < 0.03 * exact,
            "{kind:?}: {}",
            hit.approach_speed
        );
        let begin = w
            .events()
            .iter()
            .find(|e| e.kind == EventKind::Begin)
            .expect("the landing began a contact");
        assert_eq!((begin.a, begin.b), (floor, block));
        assert!(w.body(shelf).is_none() && w.world_position(shelf).is_none());
        // queries name it by the same key: a ray down onto it, a point inside it
        let at = w.world_position(block).unwrap().as_vec2();
        let ray = w
            .ray_cast_closest(
                at + Vec2::new(0.0, 3.0),
                Vec2::new(0.0, -6.0),
                &Filter::default(),
            )
            .unwrap();
        assert_eq!(ray.body, block);
        assert!(
            (ray.point.y - (at.y + 0.5)).abs() < 1e-3,
            "{kind:?}: {ray:?}"
        );
        assert_eq!(w.query_point(at, &Filter::default()), [block]);
        // once it sleeps, the sleep event names it by key too
        let mut slept = None;
        for _ in 0..600 {
            w.step().unwrap();
            if let Some(e) = w.sleep_events().iter().find(|e| e.asleep) {
                slept = Some(e.body);
                break;
            }
        }
        assert_eq!(slept, Some(block), "{kind:?}");
    }
}
