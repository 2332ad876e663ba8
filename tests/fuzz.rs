//! Fuzzing the inputs: the built-in scenes, mutated, and random command-line
//! flags. Every outcome must be a clean one: a scene that loads builds, has finite
//! figures and runs (or stops on a non-finite state with one line naming the scene);
//! a scene that is refused is refused with one line `FILE:LINE:COL: ...` and exit 2.
//! Bounded: a few hundred library cases and a few dozen runs of the binary.

use std::path::PathBuf;
use std::process::Command;

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use sandbox2d::World;
use sandbox2d::scene::{builtin_names, load_str};

/// A runner: the same cases every run (so `cargo test` is repeatable), or, with
/// `FUZZ_SCALE` set, `FUZZ_SCALE` times as many random ones for a longer hunt.
fn runner(cases: u32) -> TestRunner {
    let config = Config {
        cases: cases * scale(),
        failure_persistence: None,
        ..Config::default()
    };
    if std::env::var_os("FUZZ_SCALE").is_some() {
        TestRunner::new(config)
    } else {
        TestRunner::new_with_rng(
            config,
            proptest::test_runner::TestRng::deterministic_rng(
                proptest::test_runner::RngAlgorithm::ChaCha,
            ),
        )
    }
}

/// Cases are multiplied by `FUZZ_SCALE` (default 1) for a longer hunt.
fn scale() -> u32 {
    std::env::var("FUZZ_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
}

/// The built-in scenes' text, from the assets folder.
fn builtin_texts() -> Vec<(String, String)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
    builtin_names()
        .iter()
        .map(|n| {
            let text = std::fs::read_to_string(dir.join(format!("{n}.toml"))).unwrap();
            (n.to_string(), text)
        })
        .collect()
}

/// Values that break things: zero, signs, overflow and underflow of f32, counts past
/// the limits, non-numbers, and strings with control characters.
const VALUES: &[&str] = &[
    "0",
    "-1",
    "1",
    "16",
    "0.5",
    "1e-30",
    "1e-45",
    "1e20",
    "1e38",
    "-1e38",
    "3e38",
    "1e39",
    "nan",
    "inf",
    "-inf",
    "1000001",
    "4294967295",
    "4294967296",
    "\"x\"",
    "\"a\\nb\"",
    "\"\\u001b[31mred\"",
    "[]",
    "[1e38, 1e38]",
    "[3e38, -3e38]",
    "[1e-30, 1e-30]",
    "true",
];

/// Lines that may be added to a table.
const LINES: &[&str] = &[
    "angular_velocity = 1e38",
    "velocity = [1e19, 1e19]",
    "shape = { box = [3e38, 3e38] }",
    "shape = { polygon = [[0,0],[1,0],[1,1],[0,1],[0.5,1.2],[-0.2,0.5],[0.1,-0.1],[0.9,-0.1],[1.1,0.5]] }",
    "name = \"line\\nbreak\"",
    "name = \"ret\\rurn\"",
    "iterations = 1000001",
    "substeps = 1001",
    "[[grid]]\nrows = 2\ncolumns = 2\nspacing = [3e38, 3e38]\nshape = { circle = 0.1 }",
    "[[chain]]\nlinks = 3\nlink = [1e38, 0.1]\nanchor = [0, 0]",
    "[[stack]]\ncount = 1000000",
    "[[body]]\nshape = { box = [1e-30, 1e-30] }",
    "[[body]]\nshape = { circle = 1 }\nmass = 1e38\nvelocity = [1e10, 0]",
    "[[body]]\nname = \"esc\\u001b[2J\"\nshape = { circle = 1 }\nmass = 0",
];

#[derive(Clone, Debug)]
enum Mutation {
    /// Replace the n-th number (mod the count) with a value.
    Number(usize, &'static str),
    /// Delete the n-th line.
    Delete(usize),
    /// Duplicate the n-th line.
    Duplicate(usize),
    /// Insert a line after the n-th line.
    Insert(usize, &'static str),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<usize>(), prop::sample::select(VALUES)).prop_map(|(n, v)| Mutation::Number(n, v)),
        1 => any::<usize>().prop_map(Mutation::Delete),
        1 => any::<usize>().prop_map(Mutation::Duplicate),
        2 => (any::<usize>(), prop::sample::select(LINES)).prop_map(|(n, l)| Mutation::Insert(n, l)),
    ]
}

/// Byte ranges of the numbers in `text` (outside comments and strings, roughly).
fn numbers(text: &str) -> Vec<std::ops::Range<usize>> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    let mut in_comment = false;
    let mut in_string = false;
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            in_comment = false;
        }
        if in_comment {
            i += 1;
            continue;
        }
        if c == b'#' && !in_string {
            in_comment = true;
        } else if c == b'"' {
            in_string = !in_string;
        } else if !in_string
            && (c.is_ascii_digit() || c == b'-')
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_'))
        {
            let start = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric() || b[i] == b'.' || b[i] == b'-' || b[i] == b'+')
            {
                i += 1;
            }
            if b[start..i].iter().any(|c| c.is_ascii_digit()) {
                out.push(start..i);
            }
            continue;
        }
        i += 1;
    }
    out
}

fn apply(text: &str, muts: &[Mutation]) -> String {
    let mut text = text.to_owned();
    for m in muts {
        match m {
            Mutation::Number(n, v) => {
                let nums = numbers(&text);
                if !nums.is_empty() {
                    let r = nums[n % nums.len()].clone();
                    text.replace_range(r, v);
                }
            }
            Mutation::Delete(n) | Mutation::Duplicate(n) | Mutation::Insert(n, _) => {
                let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
                if lines.is_empty() {
                    continue;
                }
                let k = n % lines.len();
                match m {
                    Mutation::Delete(_) => {
                        lines.remove(k);
                    }
                    Mutation::Duplicate(_) => {
                        let l = lines[k].clone();
                        lines.insert(k, l);
                    }
                    Mutation::Insert(_, l) => lines.insert(k + 1, (*l).to_owned()),
                    Mutation::Number(..) => unreachable!(),
                }
                text = lines.join("\n");
                text.push('\n');
            }
        }
    }
    text
}

/// A refusal is one line `FILE:LINE:COL: what` with no control characters.
fn check_refusal(shown: &str, file: &str) -> Result<(), TestCaseError> {
    prop_assert!(
        !shown.chars().any(|c| c.is_control()),
        "a control character in {shown:?}"
    );
    let rest = shown
        .strip_prefix(&format!("{file}:"))
        .ok_or_else(|| TestCaseError::fail(format!("no file in {shown:?}")))?;
    let mut parts = rest.splitn(3, ':');
    let line = parts.next().unwrap_or("");
    let col = parts.next().unwrap_or("");
    prop_assert!(
        line.parse::<usize>().is_ok() && col.parse::<usize>().is_ok(),
        "no line:col in {shown:?}"
    );
    prop_assert!(parts.next().is_some_and(|m| m.starts_with(' ')));
    Ok(())
}

#[test]
fn mutated_builtin_scenes_load_build_and_run_or_are_refused_with_a_place() {
    let texts = builtin_texts();
    let mut runner = runner(300);
    let strategy = (
        0..texts.len(),
        prop::collection::vec(mutation(), 1..4),
        0..3usize,
    );
    let (loaded, refused, stepped) = (
        std::cell::Cell::new(0),
        std::cell::Cell::new(0),
        std::cell::Cell::new(0),
    );
    runner
        .run(&strategy, |(k, muts, solver)| {
            let (name, text) = &texts[k];
            let mutated = apply(text, &muts);
            let file = format!("{name}.toml");
            match load_str(&mutated, &file) {
                Err(e) => {
                    refused.set(refused.get() + 1);
                    prop_assert!(e.line().is_some(), "{e}");
                    check_refusal(&e.to_string(), &file)?;
                }
                Ok(sc) => {
                    loaded.set(loaded.get() + 1);
                    let flags = sandbox2d::SolverOverrides {
                        kind: Some(sandbox2d::SolverKind::ALL[solver % 3]),
                        ..Default::default()
                    };
                    let settings = sc.world.solver.merged(flags).resolve();
                    // A scene that loads builds: every build-time refusal has a place.
                    let mut world = World::from_def(&sc.world, settings).map_err(|e| {
                        TestCaseError::fail(format!("loaded but did not build: {e}\n{mutated}"))
                    })?;
                    prop_assert!(world.energy().is_finite(), "energy at load\n{mutated}");
                    // a few steps where they are cheap
                    let work = settings.iterations as u64 * settings.substeps as u64;
                    if world.bodies.len() <= 400 && work <= 400 {
                        stepped.set(stepped.get() + 1);
                        for _ in 0..3 {
                            if let Err(e) = world.step() {
                                let m = e.to_string();
                                prop_assert!(m.contains("step") && !m.contains('\n'), "{m}");
                                break;
                            }
                        }
                    }
                }
            }
            Ok(())
        })
        .unwrap();
    // the mutations reach both outcomes, and the runs
    eprintln!(
        "loaded {}, refused {}, stepped {}",
        loaded.get(),
        refused.get(),
        stepped.get()
    );
    assert!(loaded.get() >= 30 && refused.get() >= 30 && stepped.get() >= 10);
}

fn sandbox2d() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sandbox2d"))
}

/// The binary's outcome for `args` is clean: exit 0 with finite figures, exit 2 with
/// one `error:` line (for a scene file: `error: FILE:LINE:COL: ...`), exit 1 with one
/// line naming the scene (a run that blew up), or a usage error from the flag parser
/// (exit 2, `error:` first).
fn check_run(args: &[String], scene_file: Option<&str>) -> Result<(), TestCaseError> {
    let out = sandbox2d()
        .args(args)
        .output()
        .map_err(|e| TestCaseError::fail(e.to_string()))?;
    let err = String::from_utf8_lossy(&out.stderr);
    let code = out.status.code();
    match code {
        Some(0) => {
            let v: serde_json::Value = serde_json::from_slice(&out.stdout)
                .map_err(|e| TestCaseError::fail(format!("{args:?}: {e}")))?;
            for key in ["start", "end"] {
                prop_assert!(
                    v["energy"][key].as_f64().is_some_and(f64::is_finite),
                    "{args:?}: energy {key} {}",
                    v["energy"][key]
                );
            }
            for (a, b) in [
                ("residual", "max"),
                ("penetration", "max"),
                ("ms_per_step", "median"),
            ] {
                prop_assert!(
                    v[a][b].as_f64().is_some_and(f64::is_finite),
                    "{args:?}: {a}"
                );
            }
        }
        Some(1) => {
            prop_assert_eq!(err.lines().count(), 1, "{:?}: {}", args, err);
            let file = scene_file.unwrap_or("builtin:");
            prop_assert!(
                err.starts_with(&format!("error: {file}")),
                "{args:?}: {err}"
            );
        }
        Some(2) => {
            prop_assert!(err.starts_with("error:"), "{args:?}: {err}");
            // ours are one line; clap's usage errors end with a hint to --help
            if !err.contains("--help") {
                prop_assert_eq!(err.lines().count(), 1, "{:?}: {}", args, err);
                if let Some(file) = scene_file
                    && err.starts_with(&format!("error: {file}:"))
                {
                    check_refusal(err.trim_end().trim_start_matches("error: "), file)?;
                }
            }
        }
        _ => prop_assert!(false, "{args:?}: exit {code:?}: {err}"),
    }
    Ok(())
}

#[test]
fn mutated_scenes_through_the_binary() {
    let texts: Vec<(String, String)> = builtin_texts()
        .into_iter()
        .filter(|(n, _)| n != "large_pyramid")
        .collect();
    let dir = std::env::temp_dir().join(format!("sandbox2d-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut runner = runner(24);
    let strategy = (
        0..texts.len(),
        prop::collection::vec(mutation(), 1..3),
        0..3usize,
    );
    let case = std::cell::Cell::new(0);
    runner
        .run(&strategy, |(k, muts, solver)| {
            let (name, text) = &texts[k];
            case.set(case.get() + 1);
            let path = dir.join(format!("{name}-{}.toml", case.get()));
            std::fs::write(&path, apply(text, &muts)).unwrap();
            let file = path.display().to_string();
            let args: Vec<String> = [
                "simulate",
                &file,
                "--steps",
                "3",
                "--json",
                "--iterations",
                "4",
                "--substeps",
                "2",
            ]
            .iter()
            .map(|s| s.to_string())
            .chain(
                [&["--solver", "pgs"][..], &["--solver", "xpbd"], &[]][solver]
                    .iter()
                    .map(|s| s.to_string()),
            )
            .collect();
            check_run(&args, Some(&file))
        })
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn random_flags_through_the_binary() {
    let flags: &[(&str, &[&str])] = &[
        (
            "--steps",
            &["0", "1", "3", "-1", "x", "18446744073709551616"],
        ),
        (
            "--iterations",
            &["0", "1", "10000", "10001", "4294967296", "-1"],
        ),
        ("--substeps", &["0", "1", "1000", "1001", "1e9"]),
        ("--dt", &["0", "-1", "nan", "inf", "1e-30", "1e30", "0.01"]),
        ("--tolerance", &["0", "-1", "nan", "1e30"]),
        ("--baumgarte", &["-0.1", "0.5", "2", "nan"]),
        ("--slop", &["-1", "0", "inf"]),
        ("--trace-every", &["0", "1"]),
        ("--solver", &["pgs", "xpbd", "soft"]),
        ("--joint-hertz", &["0", "60", "1e30", "nan", "-1"]),
        ("--contact-hertz", &["0", "30", "1e30", "inf", "-1"]),
        ("--max-push-speed", &["0", "3", "1e30"]),
    ];
    let mut runner = runner(32);
    let strategy = (
        prop::sample::select(vec!["stack", "bounce", "chain", "particles"]),
        prop::collection::vec((0..flags.len(), any::<usize>()), 0..4),
    );
    runner
        .run(&strategy, |(scene, picks)| {
            let mut args: Vec<String> = vec!["simulate".into(), scene.into(), "--json".into()];
            let mut has_steps = false;
            for (f, v) in picks {
                let (flag, values) = flags[f];
                if args.iter().any(|a| a == flag) {
                    continue;
                }
                has_steps |= flag == "--steps";
                args.push(flag.into());
                args.push(values[v % values.len()].into());
            }
            if !has_steps {
                args.extend(["--steps".into(), "3".into()]);
            }
            // a long run is not what this checks: keep the work per step small
            if !args.iter().any(|a| a == "--iterations") {
                args.extend(["--iterations".into(), "4".into()]);
            }
            // an accepted --substeps of 1000 with --iterations 10000 is 1e7 sweeps a step
            if args
                .windows(2)
                .any(|w| w[0] == "--substeps" && w[1] == "1000")
                && args
                    .windows(2)
                    .any(|w| w[0] == "--iterations" && w[1] == "10000")
            {
                return Ok(());
            }
            check_run(&args, None)
        })
        .unwrap();
}
