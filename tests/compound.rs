//! Compound bodies (`ShapeDef::Compound`, `shapes = [...]` in scenes): mass properties
//! against closed forms (the parallel axis theorem), a physical pendulum's period from
//! that inertia, resting contact part by part under every solver, per-part filters,
//! queries that see each part, sensor parts (heard, never touched, massless at density
//! 0), and snapshot/restore.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use glam::Vec2;
use sandbox2d::{
    BodyDef, BodyKey, BodyType, EventKind, Filter, JointDef, PartDef, ShapeDef, SolverKind,
    SolverSettings, World,
};

const G: f32 = 9.81;
const KINDS: [SolverKind; 3] = [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd];

fn settings(kind: SolverKind) -> SolverSettings {
    let mut s = SolverSettings::defaults(kind);
    s.sleep = false;
    s
}

fn boxdef(w: f32, h: f32) -> ShapeDef {
    ShapeDef::Box {
        width: w,
        height: h,
    }
}

fn body(name: &str, shape: ShapeDef, at: Vec2) -> BodyDef {
    BodyDef {
        name: name.into(),
        shape,
        position: at,
        ..BodyDef::default()
    }
}

fn ground(w: &mut World) -> BodyKey {
    let mut g = body("ground", boxdef(40.0, 1.0), Vec2::new(0.0, -0.5));
    g.body_type = BodyType::Static;
    w.create_body(&g).unwrap()
}

/// An L: a 2 x 0.4 bar at the origin and a 0.4 x 1.2 post at (-0.8, 0.8).
fn ell() -> ShapeDef {
    ShapeDef::Compound {
        parts: vec![
            PartDef::new(boxdef(2.0, 0.4), Vec2::ZERO),
            PartDef::new(boxdef(0.4, 1.2), Vec2::new(-0.8, 0.8)),
        ],
    }
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-9)
}

#[test]
fn an_l_has_the_mass_centre_and_inertia_of_its_two_boxes() {
    // closed form: m_i = rho w_i h_i, c = sum m_i c_i / m,
    // I = sum m_i (w_i^2 + h_i^2) / 12 + m_i |c_i - c|^2
    let rho = 2.0;
    let parts = [
        (2.0f32, 0.4f32, Vec2::ZERO),
        (0.4, 1.2, Vec2::new(-0.8, 0.8)),
    ];
    let m: f32 = parts.iter().map(|(w, h, _)| rho * w * h).sum();
    let c = parts
        .iter()
        .fold(Vec2::ZERO, |s, (w, h, p)| s + *p * (rho * w * h))
        / m;
    let inertia: f32 = parts
        .iter()
        .map(|(w, h, p)| {
            let mi = rho * w * h;
            mi * (w * w + h * h) / 12.0 + mi * (*p - c).length_squared()
        })
        .sum();
    let mut w = World::new(None, settings(SolverKind::Soft));
    let at = Vec2::new(3.0, 4.0);
    let angle = 0.7f32;
    let mut def = body("ell", ell(), at);
    def.density = rho;
    def.angle = angle;
    let i = w.create_body(&def).unwrap();
    let b = &w.body(i).unwrap();
    assert!(close(b.mass, m, 1e-5), "mass {} vs {m}", b.mass);
    assert!(
        close(b.inertia, inertia, 1e-4),
        "inertia {} vs {inertia}",
        b.inertia
    );
    // the body's position is its centre of mass: the description's c, turned and placed
    let want = at + Vec2::from_angle(angle).rotate(c);
    assert!(
        (b.position - want).length() < 1e-5,
        "{} vs {want}",
        b.position
    );
    assert_eq!(b.parts.len(), 2);
}

#[test]
fn part_densities_and_a_given_mass_follow_the_parallel_axis_theorem() {
    // a light 1 x 1 box (density 1) and a disk of radius 0.5 (density 3) 2 m to its right
    let (r, d) = (0.5f32, 2.0f32);
    let mut disk = PartDef::new(ShapeDef::Circle { radius: r }, Vec2::new(d, 0.0));
    disk.density = Some(3.0);
    let shape = ShapeDef::Compound {
        parts: vec![PartDef::new(boxdef(1.0, 1.0), Vec2::ZERO), disk],
    };
    let (m1, m2) = (1.0f32, 3.0 * std::f32::consts::PI * r * r);
    let m = m1 + m2;
    let cx = m2 * d / m;
    let inertia = m1 / 6.0 + m1 * cx * cx + 0.5 * m2 * r * r + m2 * (d - cx) * (d - cx);
    let mut w = World::new(None, settings(SolverKind::Soft));
    let i = w
        .create_body(&body("free", shape.clone(), Vec2::ZERO))
        .unwrap();
    let b = &w.body(i).unwrap();
    assert!(close(b.mass, m, 1e-5), "{} vs {m}", b.mass);
    assert!(close(b.position.x, cx, 1e-5), "{} vs {cx}", b.position.x);
    assert!(
        close(b.inertia, inertia, 1e-4),
        "{} vs {inertia}",
        b.inertia
    );
    // a given mass scales every part alike: same centre, inertia in proportion
    let mut def = body("given", shape, Vec2::ZERO);
    def.mass = Some(10.0);
    let j = w.create_body(&def).unwrap();
    let b = &w.body(j).unwrap();
    assert!(close(b.mass, 10.0, 1e-6));
    assert!(close(b.position.x, cx, 1e-5));
    assert!(close(b.inertia, inertia * 10.0 / m, 1e-4), "{}", b.inertia);
}

#[test]
fn a_compound_physical_pendulum_swings_with_the_period_of_its_inertia() {
    // a hammer (a 2 x 0.1 handle and a 0.4 x 0.4 head at its far end, four times as
    // dense) hinged at the handle's free end: T = 2 pi sqrt(I_pivot / (m g l)) for small
    // swings, with I_pivot = I + m l^2 (l: pivot to centre of mass)
    let mut head = PartDef::new(boxdef(0.4, 0.4), Vec2::new(1.0, 0.0));
    head.density = Some(4.0);
    let hammer = ShapeDef::Compound {
        parts: vec![PartDef::new(boxdef(2.0, 0.1), Vec2::ZERO), head],
    };
    for kind in KINDS {
        let mut w = World::new(Some(Vec2::new(0.0, -G)), settings(kind));
        let mut pin = body(
            "pin",
            ShapeDef::Circle { radius: 0.05 },
            Vec2::new(-1.0, 0.0),
        );
        pin.body_type = BodyType::Static;
        let p = w.create_body(&pin).unwrap();
        // hanging down from the pivot at (-1, 0), turned 0.1 rad off the vertical
        let theta0 = 0.1f32;
        let angle = -std::f32::consts::FRAC_PI_2 + theta0;
        let dir = Vec2::from_angle(angle);
        let mut def = body("hammer", hammer.clone(), Vec2::new(-1.0, 0.0) + dir * 1.0);
        def.angle = angle;
        let h = w.create_body(&def).unwrap();
        let pivot = Vec2::new(-1.0, 0.0);
        // a joint definition names its bodies by creation order
        let (pi, hi) = (w.order_of_key(p).unwrap(), w.order_of_key(h).unwrap());
        let mut j = JointDef::hinge(pi, hi, pivot);
        j.collide_connected = false;
        w.add_joint(&j).unwrap();
        // closed form, in the description frame (pivot at x = -1): the handle
        // (0.2 kg at x = 0) and the head (0.64 kg at x = 1), each a box
        let (m1, m2) = (2.0 * 0.1, 0.4 * 0.4 * 4.0);
        let m = m1 + m2;
        let l = (m1 * 1.0 + m2 * 2.0) / m;
        let i_pivot = m1 * (4.0 + 0.01) / 12.0 + m1 * 1.0 + m2 * (0.16 + 0.16) / 12.0 + m2 * 4.0;
        let period = 2.0 * std::f32::consts::PI * (i_pivot / (m * G * l)).sqrt();
        // the swing's zero crossings of the angle from the vertical
        let dt = w.settings.dt;
        let mut crossings = Vec::new();
        let side = |w: &World| (w.body(h).unwrap().position - pivot).x;
        let mut last = side(&w);
        for n in 1..=(4.0 * period / dt) as usize {
            w.step().unwrap();
            let now = side(&w);
            if (now > 0.0) != (last > 0.0) {
                // interpolate the crossing within the step
                crossings.push((n as f32 - 1.0 + last / (last - now)) * dt);
            }
            last = now;
        }
        assert!(crossings.len() >= 6, "{kind:?}: {crossings:?}");
        let measured =
            2.0 * (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f32;
        assert!(
            close(measured, period, 0.02),
            "{kind:?}: period {measured} s vs 2 pi sqrt(I_p / m g l) = {period} s"
        );
    }
}

#[test]
fn a_table_rests_on_its_legs_under_every_solver() {
    // a 3 x 0.2 top on two 0.2 x 1 legs: the top's upper face rests 1.2 m up, level,
    // and the ground touches it through two manifolds (one per leg)
    let table = ShapeDef::Compound {
        parts: vec![
            PartDef::new(boxdef(3.0, 0.2), Vec2::new(0.0, 1.0)),
            PartDef::new(boxdef(0.2, 1.0), Vec2::new(-1.3, 0.4)),
            PartDef::new(boxdef(0.2, 1.0), Vec2::new(1.3, 0.4)),
        ],
    };
    for kind in KINDS {
        let mut w = World::new(Some(Vec2::new(0.0, -G)), settings(kind));
        let g = ground(&mut w);
        // legs' feet 0.1 m above the ground
        let t = w
            .create_body(&body("table", table.clone(), Vec2::new(0.0, 0.2)))
            .unwrap();
        let origin = |w: &World| {
            let b = &w.body(t).unwrap();
            b.position + b.rot.rotate(b.origin_offset)
        };
        for _ in 0..180 {
            w.step().unwrap();
        }
        let b = &w.body(t).unwrap();
        let top = origin(&w).y + 1.1;
        assert!((top - 1.2).abs() < 0.01, "{kind:?}: top at {top}");
        assert!(b.angle.abs() < 0.005, "{kind:?}: tilted {}", b.angle);
        assert!(b.velocity.length() < 0.01, "{kind:?}: {}", b.velocity);
        // the ground was made first: it is the pair's a
        let with_ground: Vec<_> = w
            .contacts()
            .iter()
            .filter(|c| w.contact_bodies(c) == Some([g, t]))
            .collect();
        assert_eq!(with_ground.len(), 2, "{kind:?}: one manifold per leg");
        for c in with_ground {
            assert_eq!(c.manifold.count, 2, "{kind:?}: a leg stands on two points");
        }
    }
}

#[test]
fn a_part_filtered_from_the_ground_passes_through_it_while_the_rest_holds() {
    // a nail: a 1 x 0.2 head on a 0.2 x 1 shank below it. The shank's mask leaves out the
    // ground's category: it sinks into the ground until the head lies on it.
    let ground_cat = 1 << 1;
    let mut shank = PartDef::new(boxdef(0.2, 1.0), Vec2::new(0.0, -0.6));
    shank.filter = Some(Filter {
        category: 1,
        mask: !ground_cat,
        group: 0,
    });
    let nail = ShapeDef::Compound {
        parts: vec![PartDef::new(boxdef(1.0, 0.2), Vec2::ZERO), shank],
    };
    for kind in KINDS {
        let mut w = World::new(Some(Vec2::new(0.0, -G)), settings(kind));
        let mut g = body("ground", boxdef(40.0, 2.0), Vec2::new(0.0, -1.0));
        g.body_type = BodyType::Static;
        g.filter.category = ground_cat;
        w.create_body(&g).unwrap();
        let n = w
            .create_body(&body("nail", nail.clone(), Vec2::new(0.0, 1.5)))
            .unwrap();
        for _ in 0..150 {
            w.step().unwrap();
        }
        let b = &w.body(n).unwrap();
        let head = b.position + b.rot.rotate(b.origin_offset);
        // the head's lower face on the ground's top (y = 0)
        assert!((head.y - 0.1).abs() < 0.01, "{kind:?}: head at {}", head.y);
        for c in w.contacts() {
            for p in c.manifold.points() {
                // part 1 (the shank) of the nail (body B) would set bits 22..28
                assert_eq!(p.id >> 22 & 0x3f, 0, "{kind:?}: the shank touched");
            }
        }
    }
}

#[test]
fn queries_and_rays_see_each_part() {
    let mut w = World::new(None, settings(SolverKind::Soft));
    let t = w
        .create_body(&body(
            "table",
            ShapeDef::Compound {
                parts: vec![
                    PartDef::new(boxdef(3.0, 0.2), Vec2::new(0.0, 1.0)),
                    PartDef::new(boxdef(0.2, 1.0), Vec2::new(-1.3, 0.4)),
                    PartDef::new(boxdef(0.2, 1.0), Vec2::new(1.3, 0.4)),
                ],
            },
            Vec2::ZERO,
        ))
        .unwrap();
    let any = Filter::default();
    // in a leg, in the top, and under the top between the legs
    assert_eq!(w.query_point(Vec2::new(-1.3, 0.2), &any), vec![t]);
    assert_eq!(w.query_point(Vec2::new(0.5, 1.05), &any), vec![t]);
    assert!(w.query_point(Vec2::new(0.0, 0.4), &any).is_empty());
    // down onto the top: enters at y = 1.1, normal up
    let hit = w
        .ray_cast_closest(Vec2::new(0.5, 3.0), Vec2::new(0.0, -3.0), &any)
        .unwrap();
    assert!((hit.point - Vec2::new(0.5, 1.1)).length() < 1e-4, "{hit:?}");
    assert!((hit.normal - Vec2::Y).length() < 1e-4);
    // sideways under the top: the left leg's outer face at x = -1.4, normal -x
    let hit = w
        .ray_cast_closest(Vec2::new(-3.0, 0.3), Vec2::new(6.0, 0.0), &any)
        .unwrap();
    assert!(
        (hit.point - Vec2::new(-1.4, 0.3)).length() < 1e-4,
        "{hit:?}"
    );
    assert!((hit.normal + Vec2::X).length() < 1e-4);
    // the box around all three parts
    let bb = w.body(t).unwrap().aabb();
    assert!((bb.min - Vec2::new(-1.5, -0.1)).length() < 1e-4, "{bb:?}");
    assert!((bb.max - Vec2::new(1.5, 1.1)).length() < 1e-4, "{bb:?}");
}

#[test]
fn a_restored_snapshot_of_compounds_continues_bit_identically() {
    let mut w = World::new(Some(Vec2::new(0.0, -G)), settings(SolverKind::Soft));
    ground(&mut w);
    for k in 0..3 {
        let mut def = body(
            &format!("ell{k}"),
            ell(),
            Vec2::new(0.3 * k as f32, 1.0 + 1.5 * k as f32),
        );
        def.angle = 0.4 * k as f32;
        w.create_body(&def).unwrap();
    }
    for _ in 0..40 {
        w.step().unwrap();
    }
    let snap = w.snapshot();
    let mut copy = w.clone();
    for _ in 0..60 {
        w.step().unwrap();
    }
    // run the copy elsewhere, then bring it back to the snapshot
    for _ in 0..25 {
        copy.step().unwrap();
    }
    copy.restore(&snap).unwrap();
    for _ in 0..60 {
        copy.step().unwrap();
    }
    assert_eq!(w.state_hash(), copy.state_hash());
    assert!(
        w.contacts().len() >= 3,
        "the Ls touch the ground and each other"
    );
}

/// A static floor (a 10 x 1 box, top at y = 0) with a sensor part: a 2 x 1 zone whose
/// bottom is at y = 1.5 and top at y = 2.5; or the floor alone.
fn floor_with_zone(zone: bool) -> BodyDef {
    let mut parts = vec![PartDef::new(boxdef(10.0, 1.0), Vec2::new(0.0, -0.5))];
    if zone {
        let mut z = PartDef::new(boxdef(2.0, 1.0), Vec2::new(0.0, 2.0));
        z.sensor = true;
        parts.push(z);
    }
    let mut b = body("floor", ShapeDef::Compound { parts }, Vec2::ZERO);
    b.body_type = BodyType::Static;
    b
}

#[test]
fn a_sensor_part_hears_a_ball_pass_once_and_the_solid_part_holds_it() {
    let r = 0.25;
    for kind in KINDS {
        let mut with = World::new(Some(Vec2::new(0.0, -G)), settings(kind));
        let mut without = World::new(Some(Vec2::new(0.0, -G)), settings(kind));
        for w in [&mut with, &mut without] {
            w.create_body(&body(
                "ball",
                ShapeDef::Circle { radius: r },
                Vec2::new(0.0, 4.0),
            ))
            .unwrap();
        }
        with.create_body(&floor_with_zone(true)).unwrap();
        without.create_body(&floor_with_zone(false)).unwrap();
        assert!(with.record_events, "a sensor part turns the events on");
        let (mut begins, mut ends) = (0, 0);
        let mut prev_y = with.nth_body(0).position.y;
        for k in 1..=180 {
            with.step().unwrap();
            without.step().unwrap();
            let y = with.nth_body(0).position.y;
            // the zone never touches the ball: it moves as with the floor alone
            assert!(
                (y - without.nth_body(0).position.y).abs() < 1e-5,
                "{kind:?} step {k}: {y} against {}",
                without.nth_body(0).position.y
            );
            for e in with.events() {
                match e.kind {
                    EventKind::SensorBegin => {
                        assert!(y - r <= 2.5 && prev_y - r > 2.5, "{kind:?}: begin at {y}");
                        begins += 1;
                    }
                    EventKind::SensorEnd => {
                        assert!(y + r < 1.5 && prev_y + r >= 1.5, "{kind:?}: end at {y}");
                        ends += 1;
                    }
                    // the floor part's contact
                    EventKind::Begin | EventKind::End => {}
                }
            }
            prev_y = y;
        }
        assert_eq!((begins, ends), (1, 1), "{kind:?}");
        // the solid part holds the ball: it rests on y = 0 (within the solvers' slop)
        let y = with.nth_body(0).position.y;
        assert!((y - r).abs() < 0.02, "{kind:?}: ball at {y}");
        // no contact of the ball with the zone part (part 1, feature bits 16..22 or 22..28)
        for c in with.contacts() {
            for p in c.manifold.points() {
                assert_eq!((p.id >> 16) & 0xfff, 0, "{kind:?}: a contact with the zone");
            }
        }
    }
}

#[test]
fn a_massless_sensor_part_adds_no_mass_and_a_dense_one_does() {
    let rho = 3.0;
    let make = |zone_density: Option<f32>| {
        let mut z = PartDef::new(boxdef(2.0, 2.0), Vec2::new(2.0, 0.0));
        z.sensor = true;
        z.density = zone_density;
        let mut b = body(
            "probe",
            ShapeDef::Compound {
                parts: vec![PartDef::new(boxdef(1.0, 0.5), Vec2::ZERO), z],
            },
            Vec2::ZERO,
        );
        b.density = rho;
        let mut w = World::new(None, settings(SolverKind::Soft));
        w.create_body(&b).unwrap();
        let b = &w.nth_body(0);
        (b.mass, b.inertia, b.position)
    };
    // density 0: the box alone, m = rho w h, I = m (w^2 + h^2) / 12, centre at the box
    let (m, i, c) = make(Some(0.0));
    let m0 = rho * 0.5;
    assert!(close(m, m0, 1e-5), "{m}");
    assert!(close(i, m0 * (1.0 + 0.25) / 12.0, 1e-4), "{i}");
    assert!(c.length() < 1e-6, "{c}");
    // the body's density: Box2D's rule, a sensor part weighs as any part
    let (m, i, c) = make(None);
    let mz = rho * 4.0;
    let cx = mz * 2.0 / (m0 + mz);
    let want = m0 * 1.25 / 12.0 + m0 * cx * cx + mz * 8.0 / 12.0 + mz * (2.0 - cx).powi(2);
    assert!(close(m, m0 + mz, 1e-5), "{m}");
    assert!(close(c.x, cx, 1e-5), "{c}");
    assert!(close(i, want, 1e-4), "{i} against {want}");
    // a solid part of density 0 is refused
    let mut w = World::new(None, settings(SolverKind::Soft));
    let mut p = PartDef::new(boxdef(1.0, 1.0), Vec2::ZERO);
    p.density = Some(0.0);
    let bad = body("bad", ShapeDef::Compound { parts: vec![p] }, Vec2::ZERO);
    assert!(w.create_body(&bad).is_err());
}

#[test]
fn a_moving_probe_hears_a_box_ahead_without_pushing_it_and_never_hears_statics() {
    // zero gravity: a 1 x 1 body moving at 2 m/s along x carries a massless 2 x 2 zone
    // ahead of it (x from 0.5 to 2.5 of its centre); a box at rest at x = 5 (its left
    // face at 4.5); a static post above the body's path (y from 0.6 to 1.1) that the
    // zone sweeps over
    for kind in KINDS {
        let mut w = World::new(None, settings(kind));
        let mut zone = PartDef::new(boxdef(2.0, 2.0), Vec2::new(1.5, 0.0));
        zone.sensor = true;
        zone.density = Some(0.0);
        let mut probe = body(
            "probe",
            ShapeDef::Compound {
                parts: vec![PartDef::new(boxdef(1.0, 1.0), Vec2::ZERO), zone],
            },
            Vec2::ZERO,
        );
        probe.velocity = Vec2::new(2.0, 0.0);
        w.create_body(&probe).unwrap();
        w.create_body(&body("box", boxdef(1.0, 1.0), Vec2::new(5.0, 0.0)))
            .unwrap();
        let mut post = body("post", boxdef(0.5, 0.5), Vec2::new(3.0, 0.85));
        post.body_type = BodyType::Static;
        w.create_body(&post).unwrap();
        let mut heard = None;
        for k in 1..=90 {
            w.step().unwrap();
            let post = w.key_at(2);
            for e in w.events() {
                assert!(
                    Some(e.a) != post && Some(e.b) != post,
                    "{kind:?}: the static post was heard"
                );
                if e.kind == EventKind::SensorBegin {
                    assert_eq!((Some(e.a), Some(e.b)), (w.key_at(0), w.key_at(1)));
                    assert!(heard.is_none(), "{kind:?}: heard twice");
                    heard = Some(k);
                }
            }
            if heard.is_none() {
                // nothing touched the box while the zone went over it
                assert_eq!(w.nth_body(1).velocity, Vec2::ZERO, "{kind:?} step {k}");
            }
        }
        // the zone's front (x = 2.5 + 2 t) reaches the box's face (4.5) at t = 1 s
        let t = heard.expect("the probe heard the box") as f32 / 60.0;
        assert!((t - 1.0).abs() <= 1.5 / 60.0, "{kind:?}: heard at {t} s");
        // the probe kept its speed: nothing (the post above all) touched it
        assert!(
            (w.nth_body(0).velocity - Vec2::new(2.0, 0.0)).length() < 1e-5,
            "{kind:?}: {}",
            w.nth_body(0).velocity
        );
    }
}
