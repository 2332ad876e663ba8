//! Save and restore: a world snapshot taken after N steps, written to bytes, read back
//! and restored into a freshly built world, continues bit for bit like the world that
//! never stopped; damaged or foreign state files are refused, through the library and
//! through `simulate --save-state / --load-state`.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use sandbox2d::math::Vec2;
use sandbox2d::{SolverKind, SolverSettings, StateError, World, WorldState};

const KINDS: [SolverKind; 3] = [SolverKind::Soft, SolverKind::Pgs, SolverKind::Xpbd];

fn build(scene: &str, kind: SolverKind) -> World {
    let sc = sandbox2d::scene::load(scene).unwrap();
    World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap()
}

fn steps(w: &mut World, n: usize) {
    for _ in 0..n {
        w.step().unwrap();
    }
}

/// The state through its file form: JSON bytes and back.
fn through_bytes(s: &WorldState) -> WorldState {
    WorldState::from_json(&s.to_json().unwrap()).unwrap()
}

/// Runs `n + m` steps straight and `n`, save, load into a fresh world, `m`; asserts the
/// two agree bit for bit after every one of the `m` steps (state hash, contact count,
/// and at the end the whole saved state, impulses included).
fn check_continues(scene: &str, kind: SolverKind, n: usize, m: usize) {
    let mut straight = build(scene, kind);
    steps(&mut straight, n);
    let saved = through_bytes(&straight.snapshot());
    // restored into a world built from the scene, which has stepped on its own a little
    // (its stepper and scratch hold other numbers) and must not matter
    let mut restored = build(scene, kind);
    steps(&mut restored, 3);
    saved.check_scene(&restored, false).unwrap();
    restored.restore(&saved).unwrap();
    assert_eq!(restored.step_count(), n as u64);
    assert_eq!(restored.state_hash(), straight.state_hash());
    for k in 1..=m {
        straight.step().unwrap();
        restored.step().unwrap();
        assert_eq!(
            restored.state_hash(),
            straight.state_hash(),
            "{scene} {kind:?}: step {k} after the restore differs"
        );
        assert_eq!(restored.contacts().len(), straight.contacts().len());
    }
    assert_eq!(restored.step_count(), straight.step_count());
    assert_eq!(restored.time().to_bits(), straight.time().to_bits());
    assert_eq!(
        restored.snapshot().to_json().unwrap(),
        straight.snapshot().to_json().unwrap(),
        "{scene} {kind:?}: the saved states differ"
    );
}

#[test]
fn snapshot_restore_identical_for_every_solver() {
    // contacts and stacking (pyramid, particles), joints with motors, limits and
    // contacts (car, ragdoll, bridge, ball_and_chain), restitution on threads
    // (newtons_cradle), drag (vacuum_vs_fluid), sensors and events (sensor_gate)
    for scene in [
        "pyramid",
        "ball_and_chain",
        "ragdoll",
        "car",
        "newtons_cradle",
        "bridge",
        "particles",
        "vacuum_vs_fluid",
        "sensor_gate",
    ] {
        for kind in KINDS {
            check_continues(scene, kind, 40, 40);
        }
    }
}

#[test]
fn from_state_builds_a_world_that_continues_the_same() {
    for kind in KINDS {
        let mut a = build("joints", kind);
        steps(&mut a, 30);
        let mut b = World::from_state(&through_bytes(&a.snapshot())).unwrap();
        steps(&mut a, 30);
        steps(&mut b, 30);
        assert_eq!(a.state_hash(), b.state_hash(), "{kind:?}");
    }
}

#[test]
fn the_mouse_joint_and_queued_forces_are_kept() {
    for kind in KINDS {
        let mut a = build("pyramid", kind);
        steps(&mut a, 20);
        let top = a.body_count() - 1;
        let p = a.nth_body(top).position + Vec2::new(0.2, 0.1);
        let grab = a.grab(a.nth_key(top), p).unwrap();
        a.set_mouse(Some(grab));
        let mut moved = grab;
        moved.target = p + Vec2::new(1.0, 2.0);
        a.set_mouse(Some(moved));
        // a force queued for the next step only
        let below = a.nth_key(top - 1);
        a.apply_force(below, Vec2::new(300.0, 50.0), a.nth_body(top - 1).position)
            .unwrap();
        let s = through_bytes(&a.snapshot());
        let mut b = build("pyramid", kind);
        b.restore(&s).unwrap();
        assert!(b.mouse().is_some());
        for k in 0..30 {
            a.step().unwrap();
            b.step().unwrap();
            assert_eq!(a.state_hash(), b.state_hash(), "{kind:?}: step {k}");
        }
    }
}

#[test]
fn events_continue_the_same() {
    for kind in KINDS {
        let mut a = build("pyramid", kind);
        a.record_events = true;
        steps(&mut a, 25);
        let mut b = build("pyramid", kind);
        b.restore(&through_bytes(&a.snapshot())).unwrap();
        assert!(b.record_events);
        for k in 0..25 {
            a.step().unwrap();
            b.step().unwrap();
            // the restored world's keys are new ones: the events name the same bodies
            let named = |w: &World| {
                let at = |k| w.order_of_key(k).unwrap();
                w.events()
                    .iter()
                    .map(|e| (e.kind, at(e.a), at(e.b), e.impulse))
                    .collect::<Vec<_>>()
            };
            assert_eq!(named(&a), named(&b), "{kind:?}: step {k}");
        }
    }
}

/// The test above is sensitive: without the contact cache (warm-start impulses) or the
/// joints' impulses, the restored world goes another way.
#[test]
fn restoring_without_the_warm_start_state_differs() {
    for kind in [SolverKind::Soft, SolverKind::Pgs] {
        let mut a = build("pyramid", kind);
        steps(&mut a, 40);
        let mut s = through_bytes(&a.snapshot());
        assert!(!s.contacts.is_empty());
        s.contacts.clear();
        let mut b = build("pyramid", kind);
        b.restore(&s).unwrap();
        steps(&mut a, 10);
        steps(&mut b, 10);
        assert_ne!(a.state_hash(), b.state_hash(), "{kind:?}: contacts");

        let mut a = build("ball_and_chain", kind);
        steps(&mut a, 40);
        let mut s = a.snapshot();
        let fresh = build("ball_and_chain", kind);
        s.joints = fresh.joints().map(|(_, j)| j.clone()).collect();
        let mut b = build("ball_and_chain", kind);
        b.restore(&s).unwrap();
        steps(&mut a, 10);
        steps(&mut b, 10);
        assert_ne!(a.state_hash(), b.state_hash(), "{kind:?}: joint impulses");
    }
}

#[test]
fn every_finite_f32_reads_back_to_its_bits() {
    // a xorshift over the bit patterns, plus the edges: subnormals, the largest
    let mut x: u32 = 0x9e37_79b9;
    let mut values: Vec<f32> = vec![
        f32::MIN_POSITIVE,
        f32::MAX,
        -f32::MAX,
        f32::from_bits(1),
        f32::EPSILON,
        -0.0,
    ];
    for _ in 0..200_000 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        let f = f32::from_bits(x);
        if f.is_finite() {
            values.push(f);
        }
    }
    let text = serde_json::to_string(&values).unwrap();
    let back: Vec<f32> = serde_json::from_str(&text).unwrap();
    for (a, b) in values.iter().zip(&back) {
        assert_eq!(a.to_bits(), b.to_bits(), "{a:e} read back as {b:e}");
    }
    for t in [0.1f64, 1.0 / 60.0 * 37.0, 1e-300, 123456.789] {
        let back: f64 = serde_json::from_str(&serde_json::to_string(&t).unwrap()).unwrap();
        assert_eq!(t.to_bits(), back.to_bits());
    }
}

#[test]
fn bad_states_are_refused() {
    let mut w = build("ragdoll", SolverKind::Soft);
    steps(&mut w, 10);
    let good = w.snapshot().to_json().unwrap();
    let err = |bytes: &[u8]| WorldState::from_json(bytes).unwrap_err();
    assert!(matches!(err(b"garbage"), StateError::Parse(_)));
    assert!(matches!(err(&good[..good.len() / 2]), StateError::Parse(_)));
    assert!(matches!(err(b"{\"a\": 1}"), StateError::Parse(_)));
    let text = String::from_utf8(good.clone()).unwrap();
    let edit = |from: &str, to: &str| {
        assert!(text.contains(from), "{from}");
        text.replacen(from, to, 1).into_bytes()
    };
    assert_eq!(
        err(&edit("\"version\":1", "\"version\":99")),
        StateError::Version(99)
    );
    // a joint naming a body that is not there
    let e = err(&edit(
        "\"kind\":\"Hinge\",\"a\":",
        "\"kind\":\"Hinge\",\"a\":999,\"x\":",
    ));
    assert!(matches!(e, StateError::Invalid(_)), "{e}");
    // from another scene
    let s = WorldState::from_json(&good).unwrap();
    let other = build("car", SolverKind::Soft);
    let e = s.check_scene(&other, false).unwrap_err();
    assert!(matches!(e, StateError::Mismatch(_)), "{e}");
    // a refused restore leaves the world as it was
    // a joint's second body past the end (the joint's indices are the state's own:
    // edited through its serialized form)
    let mut json: serde_json::Value = serde_json::from_slice(&good).unwrap();
    json["joints"][0]["b"] = 999.into();
    assert!(matches!(
        err(&serde_json::to_vec(&json).unwrap()),
        StateError::Invalid(_)
    ));
    let mut bad = s.clone();
    bad.joints[0] = serde_json::from_value(json["joints"][0].clone()).unwrap();
    let mut x = build("ragdoll", SolverKind::Soft);
    let h = x.state_hash();
    assert!(matches!(x.restore(&bad), Err(StateError::Invalid(_))));
    assert_eq!(x.state_hash(), h);
    assert_eq!(x.step_count(), 0);
    for e in [
        err(b"garbage"),
        err(&good[..100]),
        StateError::Version(7),
        e,
    ] {
        assert!(!e.to_string().contains('\n'), "{e}");
    }
}

/// Runs `scene` under `kind` for `n` steps keeping a timeline (keyframes every few
/// steps within a small bound), goes back to several steps and checks each one's state
/// hash, then from the earliest of them steps on to `n` again: the run ends with the
/// hash of the unbroken one.
fn check_rewind(scene: &str, kind: SolverKind, n: u64, threads: usize) {
    use sandbox2d::timeline::Timeline;
    let mut w = build(scene, kind);
    w.set_threads(threads);
    let one = w.state_bytes();
    // a bound of about 12 states: the stride grows as the run goes on
    let mut t: Timeline<()> = Timeline::new(10_000, 12 * one.max(1));
    let mut hashes = vec![w.state_hash()];
    for _ in 0..n {
        t.before_step(&w);
        w.step().unwrap();
        t.after_step(&w, ());
        hashes.push(w.state_hash());
    }
    let unbroken = w.state_hash();
    let step = |w: &mut World, _: &()| w.step();
    let oldest = t.oldest().unwrap();
    for k in [n - 1, oldest, n / 2, n / 3 + 1, n] {
        t.seek(&mut w, k, step).unwrap();
        assert_eq!(w.step_count(), k);
        assert_eq!(
            w.state_hash(),
            hashes[k as usize],
            "{scene} {kind:?} on {threads} thread(s): step {k} gone back to"
        );
    }
    t.seek(&mut w, n / 3 + 1, step).unwrap();
    while w.step_count() < n {
        t.before_step(&w);
        w.step().unwrap();
        t.after_step(&w, ());
    }
    assert_eq!(
        w.state_hash(),
        unbroken,
        "{scene} {kind:?} on {threads} thread(s): rewound and stepped on to {n}"
    );
}

#[test]
fn a_rewound_and_restepped_run_ends_as_the_unbroken_one_under_every_solver() {
    // stacking and sleep (pyramid), joints with motors and limits (car, ragdoll),
    // restitution (newtons_cradle), drag (vacuum_vs_fluid)
    for scene in [
        "pyramid",
        "car",
        "ragdoll",
        "newtons_cradle",
        "vacuum_vs_fluid",
    ] {
        for kind in KINDS {
            check_rewind(scene, kind, 120, 1);
        }
    }
    // and with the steps split between threads
    for kind in KINDS {
        check_rewind("pyramid", kind, 90, 2);
    }
}

/// A state that parses but holds what the scene loader refuses is refused too, with
/// the body and the field named: the numbers a run would blow up on, ranges, the shape,
/// and mass properties that do not fit together.
#[test]
fn damaged_numbers_are_refused_as_a_scene_refuses_them() {
    let mut w = build("pendulum", SolverKind::Soft);
    steps(&mut w, 5);
    let good = w.snapshot();
    let bob = good
        .bodies
        .iter()
        .position(|b| b.is_dynamic())
        .expect("a dynamic body");
    let name = good.bodies[bob].name.clone();
    let refused = |damage: &dyn Fn(&mut sandbox2d::Body), field: &str| {
        let mut s = good.clone();
        damage(&mut s.bodies[bob]);
        // through the file: a value past f32 reads back as infinite
        let bytes = serde_json::to_vec(&s).unwrap();
        let e = WorldState::from_json(&bytes).unwrap_err();
        let m = e.to_string();
        assert!(matches!(e, StateError::Invalid(_)), "{field}: {m}");
        assert!(
            m.contains(&format!("body {name:?} (#{bob}): {field}")),
            "{field}: {m}"
        );
        assert!(!m.contains('\n'));
        // and the library's restore refuses the same
        let mut x = build("pendulum", SolverKind::Soft);
        assert!(x.restore(&s).is_err(), "{field}");
    };
    refused(&|b| b.angular_velocity = 1e30, "angular_velocity");
    refused(&|b| b.inv_inertia = 3e38, "inv_inertia");
    refused(&|b| b.velocity.x = 1e30, "velocity");
    refused(&|b| b.mass = -1.0, "mass");
    refused(&|b| b.inv_mass = 0.0, "mass");
    refused(&|b| b.friction = -0.5, "friction");
    refused(&|b| b.restitution = 2.0, "restitution");
    refused(&|b| b.rot.c = 5.0, "rot");
    refused(&|b| b.position.y = 3e38, "position");
    refused(
        &|b| {
            if let sandbox2d::shape::Shape::Circle { radius } = &mut b.shape {
                *radius = -1.0;
            } else if let sandbox2d::shape::Shape::Polygon(p) = &mut b.shape {
                p.normals[0] = Vec2::ZERO;
            }
        },
        "shape",
    );
    // a value past f32 written into the file is refused where it is written
    let text = String::from_utf8(good.to_json().unwrap()).unwrap();
    for key in ["angular_velocity", "torque"] {
        let quoted = format!("\"{key}\":");
        let at = text
            .match_indices(&quoted)
            .nth(bob)
            .expect("the bob's field")
            .0
            + quoted.len();
        let end = at + text[at..].find([',', '}']).unwrap();
        let damaged = format!("{}1e39{}", &text[..at], &text[end..]);
        let e = WorldState::from_json(damaged.as_bytes()).unwrap_err();
        assert!(
            matches!(e, StateError::Parse(_)) && e.to_string().contains("out of range at line 1"),
            "{key}: {e}"
        );
    }
    // the good one still loads
    WorldState::from_json(&good.to_json().unwrap()).unwrap();
}

/// A state whose bodies were piled onto each other by the hundred thousand is refused
/// before the first step could take gigabytes for their contacts.
#[test]
fn a_state_of_bodies_piled_together_is_refused() {
    let text = "name = \"grid\"\n[[grid]]\nrows = 40\ncolumns = 40\nspacing = [3.0, 3.0]\nshape = { circle = 1.0 }\n";
    let sc = sandbox2d::scene::load_str(text, "grid.toml").unwrap();
    let w = World::from_def(&sc.world, SolverSettings::defaults(SolverKind::Soft)).unwrap();
    let mut s = w.snapshot();
    WorldState::from_json(&s.to_json().unwrap()).unwrap();
    // 1600 circles of radius 1 moved onto one point: 1.28 million pairs
    for b in &mut s.bodies {
        b.position = Vec2::new(0.5, 0.5);
    }
    let e = WorldState::from_json(&s.to_json().unwrap()).unwrap_err();
    assert!(
        e.to_string().contains("overlap in more than 1048576 pairs"),
        "{e}"
    );
}

// ---- the command line ----

mod common;
use common::cli::{sandbox2d, tmp};

fn simulate(args: &[&str]) -> std::process::Output {
    sandbox2d().arg("simulate").args(args).output().unwrap()
}

fn hash_of(out: &std::process::Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["state_hash"].as_str().unwrap().to_string()
}

#[test]
fn cli_save_then_load_continues_the_run() {
    for solver in ["soft", "pgs", "xpbd"] {
        let f = tmp(&format!("pyramid-{solver}.json"));
        let f = f.to_str().unwrap();
        let first = simulate(&[
            "pyramid",
            "--solver",
            solver,
            "--steps",
            "100",
            "--save-state",
            f,
        ]);
        assert!(
            first.status.success(),
            "{}",
            String::from_utf8_lossy(&first.stderr)
        );
        // this run's own temporary file (`.name.pid.tmp`): the other tests of this file
        // write theirs in the same folder at the same time
        let path = std::path::Path::new(f);
        let (dir, name) = (path.parent().unwrap(), path.file_name().unwrap());
        let own = format!(".{}.", name.to_string_lossy());
        let leftovers: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| {
                let n = e.file_name().to_string_lossy().into_owned();
                n.starts_with(&own) && n.ends_with(".tmp")
            })
            .collect();
        assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
        let resumed = simulate(&[
            "pyramid",
            "--solver",
            solver,
            "--steps",
            "50",
            "--load-state",
            f,
            "--json",
        ]);
        let straight = simulate(&["pyramid", "--solver", solver, "--steps", "150", "--json"]);
        assert_eq!(hash_of(&resumed), hash_of(&straight), "{solver}");
        assert!(
            resumed.stderr.is_empty(),
            "{}",
            String::from_utf8_lossy(&resumed.stderr)
        );
        // and on from the same file, overwriting it: 100 + 25 + 25
        let again = simulate(&[
            "pyramid",
            "--solver",
            solver,
            "--steps",
            "25",
            "--load-state",
            f,
            "--save-state",
            f,
        ]);
        assert!(
            again.status.success(),
            "{}",
            String::from_utf8_lossy(&again.stderr)
        );
        let last = simulate(&[
            "pyramid",
            "--solver",
            solver,
            "--steps",
            "25",
            "--load-state",
            f,
            "--json",
        ]);
        assert_eq!(
            hash_of(&last),
            hash_of(&straight),
            "{solver}: in three parts"
        );
    }
}

/// Exit 2 and one line on stderr that names the file.
fn assert_refused(out: &std::process::Output, file: &str, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{what}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{what}: {err}");
    assert!(err.contains(file), "{what}: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
}

#[test]
fn cli_refuses_bad_state_files() {
    let good = tmp("ragdoll.json");
    let good_s = good.to_str().unwrap();
    let out = simulate(&["ragdoll", "--steps", "20", "--save-state", good_s]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(&good).unwrap();

    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("garbage", b"\x00\x01 not json at all".to_vec()),
        ("empty", Vec::new()),
        ("truncated", bytes[..bytes.len() * 2 / 3].to_vec()),
        (
            "version",
            String::from_utf8(bytes.clone())
                .unwrap()
                .replacen("\"version\":1", "\"version\":42", 1)
                .into_bytes(),
        ),
    ];
    for (what, content) in cases {
        let f = tmp(&format!("bad-{what}.json"));
        std::fs::write(&f, content).unwrap();
        let out = simulate(&[
            "ragdoll",
            "--steps",
            "5",
            "--load-state",
            f.to_str().unwrap(),
        ]);
        assert_refused(&out, f.to_str().unwrap(), what);
    }
    // parseable but damaged: a spin the scene loader would refuse, through the CLI
    let mut v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    let body = v["bodies"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|b| b["body_type"] == "Dynamic")
        .expect("a dynamic body");
    body["angular_velocity"] = serde_json::json!(1e30);
    let damaged = serde_json::to_vec(&v).unwrap();
    let f = tmp("bad-spin.json");
    std::fs::write(&f, damaged).unwrap();
    let out = simulate(&[
        "ragdoll",
        "--steps",
        "5",
        "--load-state",
        f.to_str().unwrap(),
    ]);
    assert_refused(&out, f.to_str().unwrap(), "spin");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("angular_velocity"), "{err}");
    // a state of the ragdoll loaded into the car
    let out = simulate(&["car", "--steps", "5", "--load-state", good_s]);
    assert_refused(&out, good_s, "another scene");
    assert!(String::from_utf8_lossy(&out.stderr).contains("different scene"));
    // a file that is not there
    let missing = tmp("missing.json");
    let out = simulate(&["ragdoll", "--load-state", missing.to_str().unwrap()]);
    assert_refused(&out, missing.to_str().unwrap(), "missing");
    // a state that cannot be written: refused before the run
    let nowhere = tmp("no/such/folder/s.json");
    let out = simulate(&[
        "ragdoll",
        "--steps",
        "5",
        "--save-state",
        nowhere.to_str().unwrap(),
    ]);
    assert_refused(&out, nowhere.to_str().unwrap(), "no folder");
}

#[test]
fn cli_from_step_of_a_saved_run_goes_on_as_the_run_did() {
    for solver in ["soft", "pgs", "xpbd"] {
        let f = tmp(&format!("run-car-{solver}.json"));
        let f = f.to_str().unwrap();
        let saved = simulate(&[
            "car",
            "--solver",
            solver,
            "--steps",
            "150",
            "--save-run",
            f,
            "--keyframes-every",
            "40",
            "--json",
        ]);
        let whole = hash_of(&saved);
        let run: serde_json::Value = serde_json::from_slice(&std::fs::read(f).unwrap()).unwrap();
        assert_eq!(run["last_hash"].as_str(), Some(whole.as_str()));
        assert_eq!(
            run["keyframes"].as_array().unwrap().len(),
            4,
            "0, 40, 80, 120"
        );
        // from step 95 (re-stepped from the keyframe at 80) on for the other 55 steps
        let on = simulate(&[
            "car",
            "--solver",
            solver,
            "--steps",
            "55",
            "--run",
            f,
            "--from-step",
            "95",
            "--json",
        ]);
        assert_eq!(hash_of(&on), whole, "{solver}");
        assert!(
            on.stderr.is_empty(),
            "{}",
            String::from_utf8_lossy(&on.stderr)
        );
        // from its first and from its last step
        let all = simulate(&[
            "car",
            "--solver",
            solver,
            "--steps",
            "150",
            "--run",
            f,
            "--from-step",
            "0",
            "--json",
        ]);
        assert_eq!(hash_of(&all), whole);
        // under other settings: a branch, said on stderr
        let other = if solver == "pgs" { "xpbd" } else { "pgs" };
        let branch = simulate(&[
            "car",
            "--solver",
            other,
            "--steps",
            "55",
            "--run",
            f,
            "--from-step",
            "95",
            "--json",
        ]);
        assert_ne!(hash_of(&branch), whole);
        assert!(String::from_utf8_lossy(&branch.stderr).contains("other solver settings"));
    }
}

#[test]
fn cli_refuses_a_step_outside_the_run_and_a_bad_run_file() {
    let good = tmp("run-ragdoll.json");
    let good_s = good.to_str().unwrap();
    let out = simulate(&["ragdoll", "--steps", "30", "--save-run", good_s]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = simulate(&["ragdoll", "--run", good_s, "--from-step", "31"]);
    assert_refused(&out, good_s, "past the end");
    assert!(String::from_utf8_lossy(&out.stderr).contains("steps 0 to 30"));
    let out = simulate(&["car", "--run", good_s, "--from-step", "3"]);
    assert_refused(&out, good_s, "another scene");
    let text = std::fs::read_to_string(&good).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let hash = v["keyframes"][0]["hash"].as_str().unwrap().to_string();
    for (what, content) in [
        ("truncated", text[..text.len() / 2].to_string()),
        (
            "a state",
            std::fs::read_to_string(&good)
                .unwrap()
                .replacen("sandbox2d-run", "sandbox2d-state", 1),
        ),
        // a keyframe whose state no longer gives its recorded hash
        ("hash", text.replacen(&hash, "0123456789abcdef", 1)),
    ] {
        let f = tmp(&format!("bad-run-{}.json", what.replace(' ', "-")));
        std::fs::write(&f, content).unwrap();
        let out = simulate(&["ragdoll", "--run", f.to_str().unwrap(), "--from-step", "3"]);
        assert_refused(&out, f.to_str().unwrap(), what);
    }
    // --from-step needs --run, and --run --from-step
    let out = simulate(&["ragdoll", "--from-step", "3"]);
    assert_eq!(out.status.code(), Some(2));
}
