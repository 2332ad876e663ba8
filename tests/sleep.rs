//! Sleeping: islands at rest stop costing, and wake when anything reaches them.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use sandbox2d::{SolverKind, SolverSettings, World};

/// A stack of `count` 1 m boxes on a static ground, gravity 10, under `kind`'s defaults
/// (sleep on, as they default).
fn stack(count: u32, kind: SolverKind) -> World {
    let text = format!(
        "name = \"s\"\n[world]\ngravity = [0.0, -10.0]\n\
         [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = {{ box = [40.0, 1.0] }}\nposition = [0.0, -0.5]\n\
         [[stack]]\ncount = {count}\nbox = [1.0, 1.0]\norigin = [0.0, 0.0]\n"
    );
    let sc = sandbox2d::scene::load_str(&text, "stack.toml").unwrap();
    World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap()
}

fn steps(w: &mut World, n: usize) {
    for _ in 0..n {
        w.step().unwrap();
    }
}

fn asleep(w: &World) -> usize {
    w.bodies().map(|(_, b)| b).filter(|b| b.asleep).count()
}

fn box_def(name: &str, y: f32) -> sandbox2d::BodyDef {
    sandbox2d::BodyDef {
        name: name.into(),
        shape: sandbox2d::ShapeDef::Box {
            width: 1.0,
            height: 1.0,
        },
        position: sandbox2d::math::Vec2::new(0.0, y),
        ..Default::default()
    }
}

#[test]
fn a_stack_at_rest_falls_asleep_and_stops_costing() {
    // every solver: a stack of 5 at rest sleeps within 3 s (0.5 s below 0.05 m/s and
    // 2 deg/s), then its bodies do not move by a bit and no contact reaches the solver
    for kind in SolverKind::ALL {
        let mut w = stack(5, kind);
        steps(&mut w, 180);
        assert_eq!(asleep(&w), 5, "{kind:?}: all five asleep after 3 s");
        let before: Vec<_> = w
            .bodies()
            .map(|(_, b)| b)
            .map(|b| (b.position, b.angle))
            .collect();
        steps(&mut w, 60);
        let after: Vec<_> = w
            .bodies()
            .map(|(_, b)| b)
            .map(|b| (b.position, b.angle))
            .collect();
        assert_eq!(before, after, "{kind:?}: a sleeping stack moved");
        assert_eq!(
            w.stats().contacts,
            0,
            "{kind:?}: contacts solved while asleep"
        );
        // a world at rest runs no solver at all
        assert_eq!(
            w.stats().iterations,
            0,
            "{kind:?}: a solver swept a world at rest"
        );
        assert!(
            w.bodies()
                .all(|(_, b)| b.velocity == sandbox2d::math::Vec2::ZERO)
        );
    }
}

#[test]
fn sleep_off_keeps_every_body_awake() {
    for kind in SolverKind::ALL {
        let mut w = stack(5, kind);
        w.settings.sleep = false;
        steps(&mut w, 240);
        assert_eq!(asleep(&w), 0, "{kind:?}");
        assert!(
            w.stats().contacts >= 5,
            "{kind:?}: the stack's contacts are solved"
        );
    }
}

#[test]
fn a_box_dropped_on_a_sleeping_stack_wakes_it_and_is_carried() {
    // the falling box reaches the island: it wakes whole, with its contacts' impulses
    // kept (warm), and the stack carries the new box (its top at 6 m, within the slops)
    for kind in SolverKind::ALL {
        let mut w = stack(5, kind);
        steps(&mut w, 180);
        assert_eq!(asleep(&w), 5, "{kind:?}");
        let top = w.create_body(&box_def("dropped", 8.0)).unwrap();
        let mut woke_at = None;
        for k in 0..240 {
            w.step().unwrap();
            if woke_at.is_none() && asleep(&w) == 0 {
                woke_at = Some(k);
            }
        }
        let k = woke_at.unwrap_or_else(|| panic!("{kind:?}: the stack never woke"));
        // free fall from 8 m to the top at 5 m takes sqrt(2 * 2.5 / 10) = 0.71 s: it must
        // wake before the box lands (42 steps), not after
        assert!(k < 45, "{kind:?}: woke at step {k}");
        let y = w.body(top).unwrap().position.y;
        assert!(
            (y - 5.5).abs() < 0.05,
            "{kind:?}: the dropped box rests at {y}, not on the stack"
        );
        for (i, (_, b)) in w.bodies().skip(1).take(5).enumerate() {
            let want = 0.5 + i as f32;
            assert!(
                (b.position.y - want).abs() < 0.05,
                "{kind:?}: box {i} at {}",
                b.position.y
            );
        }
    }
}

#[test]
fn a_force_a_grab_or_a_new_velocity_wakes_the_island() {
    for kind in SolverKind::ALL {
        let mut w = stack(3, kind);
        steps(&mut w, 180);
        assert_eq!(asleep(&w), 3, "{kind:?}");
        // a force on the bottom box wakes all three (one island)
        let p = w.nth_body(1).position;
        w.apply_force(w.nth_key(1), sandbox2d::math::Vec2::new(50.0, 0.0), p)
            .unwrap();
        w.step().unwrap();
        assert_eq!(asleep(&w), 0, "{kind:?}: a force woke nothing");
        steps(&mut w, 240);
        assert_eq!(asleep(&w), 3, "{kind:?}: asleep again");
        // the mouse
        let grab = w.grab(w.nth_key(3), w.nth_body(3).position).unwrap();
        w.set_mouse(Some(grab));
        assert_eq!(asleep(&w), 0, "{kind:?}: a grab woke nothing");
        w.set_mouse(None);
        steps(&mut w, 240);
        assert_eq!(asleep(&w), 3, "{kind:?}: asleep again");
        // a velocity set from outside
        let b = w.nth_body(2);
        let v = sandbox2d::math::Vec2::new(1.0, b.velocity.y);
        w.set_velocity(w.nth_key(2), v, b.angular_velocity).unwrap();
        w.step().unwrap();
        assert_eq!(asleep(&w), 0, "{kind:?}: a new velocity woke nothing");
        assert!(w.nth_body(2).position.x > 0.0, "{kind:?}: and it moved");
    }
}

#[test]
fn a_sleeping_world_saves_and_restores_bit_for_bit() {
    // the sleeping island's kept contacts are part of the state: a world restored while
    // asleep, woken by the same falling box, steps to the same bits
    let mut w = stack(5, SolverKind::Soft);
    steps(&mut w, 180);
    assert_eq!(asleep(&w), 5);
    let saved = w.snapshot();
    let mut r = stack(5, SolverKind::Soft);
    r.restore(&saved).unwrap();
    for world in [&mut w, &mut r] {
        world.create_body(&box_def("dropped", 7.0)).unwrap();
        steps(world, 120);
    }
    assert_eq!(w.state_hash(), r.state_hash());
    let json = saved.to_json().unwrap();
    let back = sandbox2d::WorldState::from_json(&json).unwrap();
    let mut r2 = stack(5, SolverKind::Soft);
    r2.restore(&back).unwrap();
    r2.create_body(&box_def("dropped", 7.0)).unwrap();
    steps(&mut r2, 120);
    assert_eq!(w.state_hash(), r2.state_hash(), "through JSON");
}

#[test]
fn falling_asleep_ends_no_touch() {
    // a sleeping island's contacts still touch: no end events when it falls asleep, and
    // none begin again when it wakes
    let mut w = stack(3, SolverKind::Soft);
    w.record_events = true;
    let mut begins = 0;
    let mut ends = 0;
    for _ in 0..300 {
        w.step().unwrap();
        for e in w.events() {
            match e.kind {
                sandbox2d::EventKind::Begin => begins += 1,
                sandbox2d::EventKind::End => ends += 1,
                _ => {}
            }
        }
    }
    assert_eq!(asleep(&w), 3);
    assert_eq!(begins, 3, "three touching pairs begin once");
    assert_eq!(ends, 0, "no pair ended");
}

#[test]
fn a_jointed_island_sleeps_costs_nothing_and_wakes_when_hit() {
    // a disc at rest on a hinge to a static pivot, and a chain of three links hanging
    // from another: each falls asleep like a resting box (its joints sit out the solve,
    // so their warm-started impulses, which balanced a gravity the sleeping bodies no
    // longer get, do not push it awake), and does not move while asleep. A ball dropped
    // on the disc wakes it, and the chain (a separate island) sleeps on.
    let text = "name = \"h\"\n[world]\ngravity = [0.0, -10.0]\n\
                [[body]]\nname = \"pivot\"\ntype = \"static\"\nshape = { circle = 0.05 }\nposition = [0.0, 5.0]\n\
                [[body]]\nname = \"disc\"\nshape = { circle = 0.1 }\nposition = [0.0, 4.0]\n\
                [[joint]]\ntype = \"hinge\"\nbodies = [\"pivot\", \"disc\"]\nanchor = [0.0, 5.0]\n\
                [[chain]]\nlinks = 3\nlink = [0.5, 0.1]\nanchor = [10.0, 5.0]\ndirection = [0.0, -1.0]\n";
    let sc = sandbox2d::scene::load_str(text, "hang.toml").unwrap();
    for kind in SolverKind::ALL {
        let mut w = World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap();
        let disc = w.order_of("disc").unwrap();
        let links: Vec<usize> = (0..w.body_count())
            .filter(|&i| w.nth_body(i).is_dynamic() && i != disc)
            .collect();
        assert_eq!(links.len(), 3);
        let mut slept = None;
        for k in 0..300 {
            w.step().unwrap();
            if slept.is_none()
                && w.nth_body(disc).asleep
                && links.iter().all(|&i| w.nth_body(i).asleep)
            {
                slept = Some(k);
            }
        }
        let slept = slept.unwrap_or_else(|| panic!("{kind:?}: the jointed bodies never slept"));
        eprintln!("{kind:?}: asleep from step {slept}");
        // asleep, nothing moves: the state is the same to the bit, step after step
        let h = w.state_hash();
        for _ in 0..60 {
            w.step().unwrap();
        }
        assert_eq!(
            w.state_hash(),
            h,
            "{kind:?}: a sleeping jointed island moved"
        );
        let y = w.nth_body(disc).position.y;
        // within 2 cm: PGS's hinge stretches 1.4 cm under the load (docs/tradeoffs.md)
        assert!((y - 4.0).abs() < 0.02, "{kind:?}: the disc hangs at {y}");
        // a ball dropped onto the disc wakes it; the chain sleeps on
        w.create_body(&sandbox2d::BodyDef {
            name: "ball".into(),
            shape: sandbox2d::ShapeDef::Circle { radius: 0.1 },
            position: glam::Vec2::new(0.05, 4.5),
            ..Default::default()
        })
        .unwrap();
        let mut woke = false;
        for _ in 0..30 {
            w.step().unwrap();
            woke |= !w.nth_body(disc).asleep;
        }
        assert!(woke, "{kind:?}: the ball woke the disc");
        assert!(
            links.iter().all(|&i| w.nth_body(i).asleep),
            "{kind:?}: the chain slept on"
        );
    }
}

/// A box made asleep (`awake = false`) 5 m up, and a ball that falls onto it after a
/// while: gravity 10, sleep on.
fn sleeper_and_ball(kind: SolverKind) -> World {
    let text = "name = \"s\"\n[world]\ngravity = [0.0, -10.0]\n\
        [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [40.0, 1.0] }\nposition = [0.0, -0.5]\n\
        [[body]]\nname = \"sleeper\"\nshape = { box = [1.0, 1.0] }\nposition = [0.0, 5.0]\nawake = false\n\
        [[body]]\nname = \"ball\"\nshape = { circle = 0.25 }\nposition = [0.0, 10.0]\n";
    let sc = sandbox2d::scene::load_str(text, "sleeper.toml").unwrap();
    World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap()
}

#[test]
fn a_body_made_asleep_is_not_integrated_until_something_touches_it() {
    for kind in SolverKind::ALL {
        let mut w = sleeper_and_ball(kind);
        let s = w.order_of("sleeper").unwrap();
        let b = w.order_of("ball").unwrap();
        assert!(w.nth_body(s).asleep, "{kind:?}: made asleep");
        let start = (w.nth_body(s).position, w.nth_body(s).angle);
        // the ball falls 4.25 m to the box's top: sqrt(2 * 4.25 / 10) = 0.92 s, 55 steps
        let mut woke_at = None;
        for i in 0..120 {
            w.step().unwrap();
            if w.nth_body(s).asleep {
                // asleep in gravity, 5 m up: not one bit moved, no velocity
                assert_eq!(
                    (w.nth_body(s).position, w.nth_body(s).angle),
                    start,
                    "{kind:?} step {i}"
                );
                assert_eq!(w.nth_body(s).velocity, sandbox2d::math::Vec2::ZERO);
            } else if woke_at.is_none() {
                woke_at = Some(i);
            }
        }
        let woke_at = woke_at.unwrap_or_else(|| panic!("{kind:?}: the ball never woke the box"));
        // it woke when the ball reached it (free fall: 0.92 s = step 55), not before
        assert!(
            (45..65).contains(&woke_at),
            "{kind:?}: woke at step {woke_at}"
        );
        // and then fell like any body: 2 s after waking it lies on the ground
        steps(&mut w, 120);
        let y = w.nth_body(s).position.y;
        assert!(
            (0.4..0.6).contains(&y),
            "{kind:?}: the box rests on the ground, y = {y}"
        );
        assert!(
            w.nth_body(b).position.y < 3.0,
            "{kind:?}: the ball came down too"
        );
    }
}

#[test]
fn bodies_made_asleep_and_jointed_sleep_as_one_island_and_wake_together() {
    let text = "name = \"s\"\n[world]\ngravity = [0.0, -10.0]\n\
        [[body]]\nname = \"a\"\nshape = { box = [1.0, 0.2] }\nposition = [0.0, 5.0]\nawake = false\n\
        [[body]]\nname = \"b\"\nshape = { box = [1.0, 0.2] }\nposition = [1.0, 5.0]\nawake = false\n\
        [[joint]]\ntype = \"hinge\"\nbodies = [\"a\", \"b\"]\nanchor = [0.5, 5.0]\n\
        [[body]]\nname = \"ball\"\nshape = { circle = 0.1 }\nposition = [1.0, 6.0]\n";
    let sc = sandbox2d::scene::load_str(text, "pair.toml").unwrap();
    let mut w = World::from_def(&sc.world, SolverSettings::defaults(SolverKind::Soft)).unwrap();
    assert!(
        w.nth_body(0).asleep && w.nth_body(1).asleep,
        "the joint did not wake them"
    );
    // the ball lands on b only (0.9 m in 0.42 s); a wakes with it
    for _ in 0..60 {
        w.step().unwrap();
        assert_eq!(w.nth_body(0).asleep, w.nth_body(1).asleep, "one island");
    }
    assert!(!w.nth_body(0).asleep, "hit, the pair woke");
    assert!(w.nth_body(0).position.y < 5.0, "and falls");
}

/// Ragdolls (Box2D's humans: hinges with limits, joint friction and springs) dropped on
/// a ground come to rest and sleep, under every solver: a body rests when none of its
/// points moves faster than its threshold, so a limb turning slowly about its joint
/// still counts its spin at its reach.
#[test]
fn dropped_ragdolls_come_to_rest_and_fall_asleep() {
    let text = "name = \"h\"\n[world]\ngravity = [0.0, -10.0]\n\
        [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [40.0, 2.0] }\nposition = [0.0, -1.0]\n\
        [[humans]]\norigin = [-3.0, 1.0]\ncount = 3\nspacing = [3.0, 0.0]\n\
        [[humans]]\norigin = [-3.0, 3.5]\ncount = 3\nspacing = [3.0, 0.0]\ngroup = 4\n";
    let sc = sandbox2d::scene::load_str(text, "humans.toml").unwrap();
    for kind in [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd] {
        let mut w = World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap();
        let dynamic = w
            .bodies()
            .map(|(_, b)| b)
            .filter(|b| b.is_dynamic())
            .count();
        assert_eq!(dynamic, 66);
        // at most 10 s
        let mut n = 0;
        while asleep(&w) < dynamic && n < 600 {
            w.step().unwrap();
            n += 1;
        }
        assert_eq!(
            asleep(&w),
            dynamic,
            "{kind:?}: every bone asleep after 10 s"
        );
    }
    // the rule itself: a body spinning at 0.2 rad/s with a reach of 0.5 m moves its rim
    // at 0.1 m/s, over the 0.05 m/s threshold: it stays awake however slow its centre
    let mut w = stack(1, SolverKind::Soft);
    w.settings.sleep = true;
    let (b, body) = w.bodies().find(|(_, b)| b.is_dynamic()).unwrap();
    let at = sandbox2d::math::Vec2::new(body.position.x, 5.0);
    let angle = body.angle;
    w.gravity = None;
    // lifted clear of the ground and set spinning once: nothing touches it after
    w.set_transform(b, at, angle).unwrap();
    w.set_velocity(b, sandbox2d::math::Vec2::ZERO, 0.2).unwrap();
    for _ in 0..120 {
        w.step().unwrap();
    }
    let body = w.body(b).unwrap();
    assert!(
        (body.position.y - 5.0).abs() < 1e-3,
        "it stayed where it was put"
    );
    assert!(!body.asleep, "a spinning body stays awake");
}

/// Islands: two stacks on one ground are two islands (a static body joins none). With
/// the top box of one held by the mouse (a held body never rests), that stack stays
/// awake, every box of it, while the other sleeps; let go, it falls asleep too, all its
/// boxes in the same step. Under every solver.
#[test]
fn a_held_box_keeps_its_stack_awake_and_the_other_stack_sleeps() {
    let text = "name = \"s\"\n[world]\ngravity = [0.0, -10.0]\n\
        [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [40.0, 1.0] }\nposition = [0.0, -0.5]\n\
        [[stack]]\ncount = 3\nbox = [1.0, 1.0]\norigin = [-3.0, 0.0]\n\
        [[stack]]\ncount = 3\nbox = [1.0, 1.0]\norigin = [3.0, 0.0]\n";
    let sc = sandbox2d::scene::load_str(text, "stacks.toml").unwrap();
    for kind in SolverKind::ALL {
        let mut w = World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap();
        let side = |w: &World, right: bool| -> Vec<bool> {
            w.bodies()
                .map(|(_, b)| b)
                .filter(|b| b.is_dynamic() && (b.position.x > 0.0) == right)
                .map(|b| b.asleep)
                .collect()
        };
        let (top, top_body) = w
            .bodies()
            .filter(|(_, b)| b.is_dynamic() && b.position.x > 0.0)
            .max_by(|x, y| x.1.position.y.total_cmp(&y.1.position.y))
            .unwrap();
        let at = top_body.position;
        w.set_mouse(Some(w.grab(top, at).unwrap()));
        steps(&mut w, 240);
        assert_eq!(
            side(&w, false),
            [true; 3],
            "{kind:?}: the free stack sleeps"
        );
        assert_eq!(
            side(&w, true),
            [false; 3],
            "{kind:?}: the held stack is awake, every box of it"
        );
        w.set_mouse(None);
        let mut n = 0;
        while side(&w, true) == [false; 3] && n < 240 {
            w.step().unwrap();
            n += 1;
        }
        assert_eq!(
            side(&w, true),
            [true; 3],
            "{kind:?}: let go, the stack sleeps as one island ({n} steps)"
        );
    }
}

#[test]
fn a_swarm_far_from_a_sleeping_wall_leaves_it_asleep_until_it_arrives() {
    // 40 discs (more than the wake pass tests one by one) fly at 20 m/s towards a wall of
    // 200 boxes made asleep 60 m away, with no gravity: no step may wake the wall before
    // the swarm gets there, and the swarm's arrival must wake it and push it
    let mut text = String::from(
        "name = \"swarm\"\n[world]\ngravity = [0.0, 0.0]\n\
         [[grid]]\nrows = 10\ncolumns = 20\nspacing = [1.0, 1.0]\norigin = [60.5, 0.5]\n\
         shape = { box = [1.0, 1.0] }\nawake = false\n",
    );
    for k in 0..40 {
        let (x, y) = ((k % 8) as f32 * 1.0, (k / 8) as f32 * 1.0 + 2.5);
        text += &format!(
            "[[body]]\nname = \"disc{k}\"\nshape = {{ circle = 0.4 }}\n\
             position = [{x}, {y}]\nvelocity = [20.0, 0.0]\n"
        );
    }
    let sc = sandbox2d::scene::load_str(&text, "swarm.toml").unwrap();
    for kind in [SolverKind::Soft, SolverKind::Pgs] {
        let mut w = World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap();
        let wall_x = |w: &World| -> Vec<f32> {
            let wall = w
                .bodies()
                .map(|(_, b)| b)
                .filter(|b| !b.name.starts_with("disc"));
            wall.map(|b| b.position.x).collect()
        };
        let before = wall_x(&w);
        assert_eq!(before.len(), 200);
        // the front discs reach x = 60 - 0.4 after (59.6 - 7) / 20 s: 157 steps
        for step in 0..140 {
            w.step().unwrap();
            assert_eq!(
                asleep(&w),
                200,
                "{kind:?} step {step}: nothing reached the wall"
            );
        }
        assert_eq!(
            wall_x(&w),
            before,
            "{kind:?}: the sleeping wall did not move"
        );
        steps(&mut w, 100);
        let after = wall_x(&w);
        assert!(asleep(&w) < 200, "{kind:?}: the swarm woke the wall");
        let pushed = after.iter().zip(&before).filter(|(a, b)| a > b).count();
        assert!(
            pushed > 5,
            "{kind:?}: the swarm pushed the wall ({pushed} boxes)"
        );
    }
}

/// Joints of sleeping islands sit out the solve while the joints of an awake island
/// among them are solved: two hanging chains fall asleep on either side of a wheel a
/// turning motor keeps awake, their joints before and after the wheel's in the world's
/// order. Every step, each joint is still where it was in that order, with the same
/// bodies; a sleeping chain's joints are the same to the bit (their warm-start impulses
/// untouched); and the motor keeps its wheel turning at its speed. Under every solver,
/// and PGS with substeps.
#[test]
fn sleeping_joints_around_an_awake_one_keep_their_places_and_impulses() {
    let text = "name = \"j\"\n[world]\ngravity = [0.0, -10.0]\n\
        [[chain]]\nlinks = 3\nlink = [0.5, 0.1]\nanchor = [0.0, 5.0]\ndirection = [0.0, -1.0]\n\
        [[body]]\nname = \"axle\"\ntype = \"static\"\nshape = { circle = 0.05 }\nposition = [10.0, 5.0]\n\
        [[body]]\nname = \"wheel\"\nshape = { circle = 0.5 }\nposition = [10.0, 5.0]\n\
        [[joint]]\ntype = \"hinge\"\nbodies = [\"axle\", \"wheel\"]\nanchor = [10.0, 5.0]\n\
        motor = { speed = 2.0, max_torque = 100.0 }\n\
        [[chain]]\nlinks = 3\nlink = [0.5, 0.1]\nanchor = [20.0, 5.0]\ndirection = [0.0, -1.0]\n";
    let sc = sandbox2d::scene::load_str(text, "chains.toml").unwrap();
    // (PGS with substeps collides, and parks, every substep)
    let runs = SolverKind::ALL.map(|k| (k, None)).into_iter();
    for (kind, substeps) in runs.chain([(SolverKind::Pgs, Some(4))]) {
        let mut settings = SolverSettings::defaults(kind);
        if let Some(n) = substeps {
            settings.substeps = n;
        }
        let mut w = World::from_def(&sc.world, settings).unwrap();
        let wheel = w.order_of("wheel").unwrap();
        let wheel_key = w.nth_key(wheel);
        let order = |w: &World| -> Vec<_> {
            w.joints()
                .map(|(k, j)| (k, w.joint_bodies(k).unwrap(), format!("{j:?}")))
                .collect()
        };
        let start = order(&w);
        let n = start.len();
        let at = start
            .iter()
            .position(|(_, b, _)| b.contains(&wheel_key))
            .expect("the wheel's joint");
        assert!(
            0 < at && at + 1 < n,
            "the wheel's joint sits among the chains'"
        );
        // the chains fall asleep (at most 10 s)
        let chains = |w: &World| {
            (0..w.body_count())
                .filter(|&i| i != wheel && w.nth_body(i).is_dynamic())
                .all(|i| w.nth_body(i).asleep)
        };
        let mut k = 0;
        while !chains(&w) && k < 600 {
            w.step().unwrap();
            k += 1;
        }
        assert!(chains(&w), "{kind:?}: the chains fell asleep");
        assert!(
            !w.nth_body(wheel).asleep,
            "{kind:?}: the motor keeps its wheel awake"
        );
        let asleep = order(&w);
        for _ in 0..60 {
            w.step().unwrap();
            let now = order(&w);
            assert_eq!(now.len(), n);
            for (i, ((k0, b0, j0), (k1, b1, j1))) in asleep.iter().zip(&now).enumerate() {
                assert_eq!((k0, b0), (k1, b1), "{kind:?}: joint {i} is where it was");
                if i != at {
                    assert_eq!(j0, j1, "{kind:?}: sleeping joint {i} changed");
                }
            }
            let spin = w.nth_body(wheel).angular_velocity;
            assert!(
                (spin - 2.0).abs() < 0.05,
                "{kind:?}: the wheel turns at {spin} rad/s, not the motor's 2"
            );
        }
    }
}

/// The spin's part of the sleep test measures a body as it is now: a slow spin that
/// lets a small box rest and sleep keeps the same box awake once shapes far from its
/// centre are added to it (their points move faster than the threshold).
#[test]
fn a_slow_spin_rests_a_small_box_and_not_one_given_far_shapes() {
    use sandbox2d::math::Vec2;
    use sandbox2d::{PartDef, ShapeDef};
    let make = || {
        let text = "name = \"spin\"\n[world]\ngravity = [0.0, 0.0]\n\
                    [[body]]\nname = \"top\"\nshape = { box = [0.2, 0.2] }\nangular_velocity = 0.2\n";
        let sc = sandbox2d::scene::load_str(text, "spin.toml").unwrap();
        World::from_def(&sc.world, SolverSettings::defaults(SolverKind::Soft)).unwrap()
    };
    // the box's corners move at 0.2 rad/s x 0.141 m = 0.028 m/s, below 0.05 m/s
    let (mut small, mut wide) = (make(), make());
    steps(&mut small, 10);
    steps(&mut wide, 10);
    // two discs 2 m either side keep the centre of mass where it was: their points
    // move at 0.2 rad/s x 2.1 m = 0.42 m/s
    let key = wide.bodies().next().unwrap().0;
    for x in [-2.0, 2.0] {
        let disc = PartDef {
            density: Some(1.0),
            ..PartDef::new(ShapeDef::Circle { radius: 0.1 }, Vec2::new(x, 0.0))
        };
        wide.add_shape(key, &disc).unwrap();
    }
    steps(&mut small, 50);
    steps(&mut wide, 50);
    assert_eq!(
        asleep(&small),
        1,
        "the small box rested 0.5 s and fell asleep"
    );
    assert_eq!(asleep(&wide), 0, "the discs' points move too fast to rest");
    let w = wide.bodies().next().unwrap().1.angular_velocity;
    assert!(
        (w - 0.2).abs() < 1e-4,
        "the wide body spins on at {w} rad/s"
    );
}

/// Box2D's large pyramid (5050 boxes) at its 4 substeps of one sweep comes to rest and
/// falls asleep whole, at the scene's own contact springs and at Box2D's. Each of its
/// points keeps its cached lambdas from step to step while the boxes' tilts make the
/// reference face pass between the two boxes of a contact; when a few of the
/// load-bearing points started cold each step, the bottom rows kept rocking at 0.2 m/s
/// and the pyramid never slept. `-- --nocapture` prints the step each falls asleep at.
#[test]
fn the_large_pyramid_comes_to_rest_and_falls_asleep() {
    let sc = sandbox2d::scene::load("large_pyramid").expect("built-in scene");
    let own = sc.world.solver.resolve();
    assert_eq!((own.substeps, own.iterations), (4, 1));
    // Box2D's: 30 Hz at damping ratio 10, and no slop in the springs
    let box2d = SolverSettings {
        contact_hertz: 30.0,
        contact_damping_ratio: 10.0,
        slop: 0.0,
        ..own
    };
    // within 25 s at the scene's stiffer springs (60 Hz: they ring longer), 15 s at
    // Box2D's 30 Hz (Box2D's own pyramid is asleep after 6 s)
    for (what, mut s, most) in [("own springs", own, 1500), ("Box2D's springs", box2d, 900)] {
        s.sleep = true;
        let mut w = World::from_def(&sc.world, s).unwrap();
        let boxes = w.body_count() - 1;
        let at = (1..=most).find(|_| {
            w.step().unwrap();
            asleep(&w) == boxes
        });
        eprintln!("large pyramid, {what}: every box asleep at step {at:?}");
        assert!(
            at.is_some(),
            "{what}: {} of {boxes} boxes asleep after {most} steps",
            asleep(&w)
        );
    }
}
