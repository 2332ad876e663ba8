//! Fuzzing the inputs: the built-in scenes, mutated, and random command-line
//! flags. Every outcome must be a clean one: a scene that loads builds, has finite
//! figures and runs (or stops on a non-finite state with one line naming the scene);
//! a scene that is refused is refused with one line `FILE:LINE:COL: ...` and exit 2;
//! what is saved loads back. Then the faults: file-size limits, a full disk, interrupts
//! at random moments, outputs aimed at inputs, damaged states, and every run of the
//! binary under an address-space limit. Bounded: a few hundred library cases and about
//! two hundred runs of the binary; `FUZZ_SCALE=N` runs N times as many random ones.

use std::path::PathBuf;
use std::process::Command;

mod common;
use common::cli::{limited, sandbox2d, start_writing, temporaries};
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
    let (loaded, refused, stepped, saved) = (
        std::cell::Cell::new(0),
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
                    let mut finite = true;
                    if world.body_count() <= 400 && work <= 400 {
                        stepped.set(stepped.get() + 1);
                        for _ in 0..3 {
                            if let Err(e) = world.step() {
                                let m = e.to_string();
                                prop_assert!(m.contains("step") && !m.contains('\n'), "{m}");
                                finite = false;
                                break;
                            }
                        }
                    }
                    // what is saved loads back, the same to the bit; what would not
                    // load back is refused when saved, with one line
                    if finite {
                        let json = match world.snapshot().to_json() {
                            Ok(json) => json,
                            Err(e) => {
                                let m = e.to_string();
                                prop_assert!(
                                    m.starts_with("the world cannot be saved: ")
                                        && !m.contains('\n'),
                                    "{m}"
                                );
                                return Ok(());
                            }
                        };
                        let back = sandbox2d::WorldState::from_json(&json)
                            .and_then(|s| World::from_state(&s))
                            .map_err(|e| {
                                TestCaseError::fail(format!("saved but not loaded: {e}\n{mutated}"))
                            })?;
                        prop_assert_eq!(back.state_hash(), world.state_hash(), "{}", mutated);
                        saved.set(saved.get() + 1);
                    }
                }
            }
            Ok(())
        })
        .unwrap();
    // the mutations reach both outcomes, and the runs
    eprintln!(
        "loaded {}, refused {}, stepped {}, saved and loaded back {}",
        loaded.get(),
        refused.get(),
        stepped.get(),
        saved.get()
    );
    assert!(loaded.get() >= 30 && refused.get() >= 30 && stepped.get() >= 10);
    assert!(saved.get() >= 10);
}

/// The binary's outcome for `args` is clean: exit 0 with finite figures, exit 2 with
/// one `error:` line (for a scene file: `error: FILE:LINE:COL: ...`), exit 1 with one
/// line naming the scene (a run that blew up; the loader's notes may stand before it), or a usage error from the flag parser
/// (exit 2, `error:` first).
///
/// Runs under a 2 GiB address-space limit (bash's `ulimit -v`): a scene that would need
/// more must be refused before it allocates, not die by a failed allocation's abort.
fn check_run(args: &[String], scene_file: Option<&str>) -> Result<(), TestCaseError> {
    let out = Command::new("bash")
        .arg("-c")
        .arg("ulimit -v 2097152; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_sandbox2d"))
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
            // one error line; before it only the loader's documented notes (a scene far
            // from its origin) may stand
            let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with("note: ")).collect();
            prop_assert_eq!(lines.len(), 1, "{:?}: {}", args, err);
            let file = scene_file.unwrap_or("builtin:");
            prop_assert!(
                lines[0].starts_with(&format!("error: {file}")),
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

// ---------------------------------------------------------------------------------------
// Faults: every way a write can fail, at random points of random commands. Whatever
// happens, a command ends with exit 0 and its files whole, or with one line naming what
// failed; never a signal's death, never a temporary file left behind.

/// A fresh empty folder for one case of a test.
fn case_dir(test: &str, case: u32) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "sandbox2d-fuzz-{test}-{}-{case}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Commands that write files, each with the files it writes when it ends well.
fn writers() -> Vec<(Vec<&'static str>, Vec<&'static str>)> {
    let mut w: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["simulate", "pyramid", "--steps", "20", "--trace", "t.csv"],
            vec!["t.csv"],
        ),
        (
            vec![
                "simulate",
                "newtons_cradle",
                "--steps",
                "40",
                "--events",
                "e.csv",
            ],
            vec!["e.csv"],
        ),
        (
            vec![
                "simulate",
                "stack",
                "--steps",
                "10",
                "--save-state",
                "s.json",
            ],
            vec!["s.json"],
        ),
    ];
    if cfg!(feature = "render") {
        w.push((
            vec![
                "render", "pendulum", "--frames", "2", "--size", "160x100", "--out", "f",
            ],
            vec!["f/frame_0000.png", "f/frame_0001.png"],
        ));
        w.push((
            vec![
                "render", "pendulum", "--frames", "3", "--size", "160x100", "--out", "f", "--gif",
                "g.gif",
            ],
            vec!["g.gif"],
        ));
    }
    if cfg!(feature = "lab") {
        w.push((
            vec![
                "tune",
                "pendulum",
                "--budget-ms",
                "1",
                "--steps",
                "10",
                "--rounds",
                "1",
                "--out",
                "t",
            ],
            vec!["t/tune.md", "t/tune.json", "t/solver.toml", "t/pareto.svg"],
        ));
    }
    w
}

/// The outcome of a writer run in `dir`: exit 0 with every file it writes there, or
/// exit 1 with one line naming the file that failed; no temporary file either way.
fn check_write(
    out: &std::process::Output,
    args: &[&str],
    files: &[&str],
    dir: &std::path::Path,
) -> Result<bool, TestCaseError> {
    let err = String::from_utf8_lossy(&out.stderr);
    prop_assert_eq!(
        temporaries(dir),
        Vec::<String>::new(),
        "{:?}: {}",
        args,
        err
    );
    match out.status.code() {
        Some(0) => {
            for f in files {
                prop_assert!(dir.join(f).is_file(), "{args:?}: exit 0 without {f}");
            }
            Ok(true)
        }
        Some(1) => {
            prop_assert_eq!(err.lines().count(), 1, "{:?}: {}", args, err);
            let named = err
                .strip_prefix("error: ")
                .and_then(|rest| rest.split(": ").next())
                .unwrap_or("");
            prop_assert!(
                !named.is_empty() && (files.contains(&named) || named.ends_with(".png")),
                "{args:?}: the line names no output: {err}"
            );
            prop_assert!(!dir.join(named).exists(), "{args:?}: {named} left: {err}");
            Ok(false)
        }
        code => {
            prop_assert!(false, "{args:?}: exit {code:?}: {err}");
            unreachable!()
        }
    }
}

/// Under a random file-size limit (bash's `ulimit -f`: past it a write fails with
/// EFBIG, the signal it would raise being ignored) every writer ends whole or with one
/// line naming the file.
#[cfg(unix)]
#[test]
fn writers_under_random_file_size_limits_end_whole_or_with_one_line() {
    let writers = writers();
    let mut runner = runner(12);
    let (whole, failed, case) = (
        std::cell::Cell::new(0),
        std::cell::Cell::new(0),
        std::cell::Cell::new(0),
    );
    runner
        .run(&(0..writers.len(), 1u32..48), |(k, kib)| {
            let (args, files) = &writers[k];
            case.set(case.get() + 1);
            let dir = case_dir("fsize", case.get());
            let out = limited(&format!("ulimit -f {kib}"), args, &dir);
            let ok = check_write(&out, args, files, &dir)?;
            if ok { &whole } else { &failed }.set(if ok { whole.get() } else { failed.get() } + 1);
            let _ = std::fs::remove_dir_all(&dir);
            Ok(())
        })
        .unwrap();
    eprintln!(
        "file-size limits: {} ended whole, {} failed with one line",
        whole.get(),
        failed.get()
    );
    assert!(failed.get() >= 3, "the limits reach the writes");
}

/// On a full disk (a small tmpfs, filled to a random room) every writer ends whole or
/// with one line naming the file. Mounting needs root (and a machine that allows it);
/// elsewhere the test says on stderr that it did not run.
#[cfg(target_os = "linux")]
#[test]
fn writers_on_a_full_disk_end_whole_or_with_one_line() {
    let mount = case_dir("disk", 0);
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=256k", "tmpfs"])
        .arg(&mount)
        .output();
    match &mounted {
        Ok(o) if o.status.success() => {}
        // a machine that lets no one mount (not root, or a container without the
        // right) cannot fill a disk of its own: said, not hidden
        other => {
            eprintln!("full disk: not run here (a tmpfs could not be mounted: {other:?})");
            let _ = std::fs::remove_dir_all(&mount);
            return;
        }
    }
    let writers = writers();
    let mut runner = runner(12);
    let (whole, failed) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
    let result = runner.run(&(0..writers.len(), 0u32..240), |(k, room_kib)| {
        let (args, files) = &writers[k];
        // leave `room_kib` free: a filler takes the rest
        for e in std::fs::read_dir(&mount).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                std::fs::remove_dir_all(&p).unwrap();
            } else {
                std::fs::remove_file(&p).unwrap();
            }
        }
        let fill = (256 - room_kib.min(256)) as usize * 1024;
        // a write past the end of the disk is cut short; that is the filler's size
        let _ = std::fs::write(mount.join("filler"), vec![0u8; fill]);
        let work = mount.join("w");
        std::fs::create_dir_all(&work).ok();
        if !work.is_dir() {
            return Ok(());
        }
        let out = limited("true", args, &work);
        let ok = check_write(&out, args, files, &work)?;
        if ok { &whole } else { &failed }.set(if ok { whole.get() } else { failed.get() } + 1);
        Ok(())
    });
    let _ = Command::new("umount").arg(&mount).status();
    let _ = std::fs::remove_dir_all(&mount);
    result.unwrap();
    eprintln!(
        "full disk: {} ended whole, {} failed with one line",
        whole.get(),
        failed.get()
    );
    assert!(failed.get() >= 3, "the disk fills during the writes");
}

/// One or two interrupts at a random moment of a run that writes a trace (once it has
/// begun): exit 130 with one line, no temporary file, and a trace that is kept is whole
/// (ends with its line break).
#[cfg(unix)]
#[test]
fn interrupts_at_random_moments_end_with_one_line_and_nothing_half_written() {
    let mut runner = runner(8);
    let case = std::cell::Cell::new(0);
    let kept = std::cell::Cell::new(0);
    runner
        .run(
            &(0u64..700, 1usize..=2, 0u64..250),
            |(wait_ms, signals, gap_ms)| {
                case.set(case.get() + 1);
                let dir = case_dir("interrupt", case.get());
                // from the moment the run has begun (its trace's temporary file is
                // there): a signal before the program set its handler ends it as any
                // program
                let (mut child, began) = start_writing(
                    &[
                        "simulate", "pyramid", "--steps", "1000000", "--trace", "t.csv",
                    ],
                    &dir,
                    "t.csv",
                );
                if !began {
                    let _ = child.kill();
                    let _ = child.wait();
                    prop_assert!(false, "the run did not begin in a minute");
                }
                std::thread::sleep(std::time::Duration::from_millis(wait_ms));
                let pid = child.id();
                let mut script = format!("kill -INT {pid}");
                if signals == 2 {
                    script += &format!("; sleep {}; kill -INT {pid}", gap_ms as f64 / 1000.0);
                }
                Command::new("sh").arg("-c").arg(&script).status().unwrap();
                let status = child.wait().unwrap();
                let mut err = String::new();
                std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
                prop_assert_eq!(status.code(), Some(130), "{}", err);
                prop_assert_eq!(err.lines().count(), 1, "{}", err);
                prop_assert!(err.starts_with("error: "), "{}", err);
                prop_assert!(err.contains("interrupted"), "{}", err);
                prop_assert_eq!(temporaries(&dir), Vec::<String>::new(), "{}", err);
                let trace = dir.join("t.csv");
                if trace.exists() {
                    let text = std::fs::read_to_string(&trace).unwrap();
                    prop_assert!(text.ends_with('\n'), "a trace cut mid-line: {err}");
                    kept.set(kept.get() + 1);
                }
                let _ = std::fs::remove_dir_all(&dir);
                Ok(())
            },
        )
        .unwrap();
    eprintln!(
        "interrupts: {} runs, {} kept a whole trace",
        case.get(),
        kept.get()
    );
}

/// Every output flag aimed at an input, through any spelling of its path (the name,
/// `./name`, `d/../name`, the absolute path, a symbolic link, a hard link): exit 2, one
/// line, the input unchanged.
#[cfg(unix)]
#[test]
fn outputs_aimed_at_an_input_by_any_path_are_refused() {
    let text = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/pendulum.toml"),
    )
    .unwrap();
    let mut flags: Vec<(&str, &str)> = vec![
        ("simulate", "--trace"),
        ("simulate", "--events"),
        ("simulate", "--save-state"),
        ("simulate", "--save-run"),
    ];
    if cfg!(feature = "render") {
        flags.push(("render", "--gif"));
    }
    let mut runner = runner(16);
    let case = std::cell::Cell::new(0);
    runner
        .run(&(0..flags.len(), 0..6usize), |(f, spelling)| {
            case.set(case.get() + 1);
            let dir = case_dir("aim", case.get());
            std::fs::create_dir_all(dir.join("d")).unwrap();
            let scene = dir.join("s.toml");
            std::fs::write(&scene, &text).unwrap();
            let target = match spelling {
                0 => "s.toml".to_string(),
                1 => "./s.toml".to_string(),
                2 => "d/../s.toml".to_string(),
                3 => scene.display().to_string(),
                4 => {
                    std::os::unix::fs::symlink(&scene, dir.join("link.csv")).unwrap();
                    "link.csv".to_string()
                }
                _ => {
                    std::fs::hard_link(&scene, dir.join("hard.csv")).unwrap();
                    "hard.csv".to_string()
                }
            };
            let (command, flag) = flags[f];
            let mut args = vec![command, "s.toml", flag, &target];
            if command == "render" {
                args.extend(["--frames", "2", "--out", "o"]);
            } else {
                args.extend(["--steps", "2"]);
            }
            let out = limited("true", &args, &dir);
            let err = String::from_utf8_lossy(&out.stderr);
            prop_assert_eq!(out.status.code(), Some(2), "{:?}: {}", args, err);
            prop_assert_eq!(err.lines().count(), 1, "{:?}: {}", args, err);
            prop_assert!(err.contains("would overwrite"), "{args:?}: {err}");
            prop_assert_eq!(&std::fs::read_to_string(&scene).unwrap(), &text);
            prop_assert_eq!(temporaries(&dir), Vec::<String>::new());
            let _ = std::fs::remove_dir_all(&dir);
            Ok(())
        })
        .unwrap();
}

/// A saved state damaged at a random number (set to zero, a huge value, NaN, a string,
/// ...) is loaded and runs with finite figures, or is refused with exit 2 and one line,
/// or stops with one line; never a panic.
#[test]
fn damaged_states_load_or_are_refused_with_one_line() {
    let dir = case_dir("states", 0);
    let mut states = Vec::new();
    for name in ["stack", "chain", "bounce", "car"] {
        let sc = sandbox2d::scene::builtin(name).unwrap().unwrap();
        let mut w = World::from_def(&sc.world, sc.world.solver.resolve()).unwrap();
        for _ in 0..5 {
            w.step().unwrap();
        }
        let json = String::from_utf8(w.snapshot().to_json().unwrap()).unwrap();
        states.push((name, json));
    }
    let mut runner = runner(24);
    let case = std::cell::Cell::new(0);
    let (ran, refused) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
    runner
        .run(
            &(
                0..states.len(),
                prop::collection::vec((any::<usize>(), prop::sample::select(VALUES)), 1..3),
            ),
            |(k, damage)| {
                let (name, json) = &states[k];
                let mut text = json.clone();
                for (n, v) in damage {
                    let nums = numbers(&text);
                    if !nums.is_empty() {
                        let r = nums[n % nums.len()].clone();
                        text.replace_range(r, v);
                    }
                }
                case.set(case.get() + 1);
                let file = dir.join(format!("{name}-{}.json", case.get()));
                std::fs::write(&file, &text).unwrap();
                let args: Vec<String> = [
                    "simulate",
                    name,
                    "--load-state",
                    &file.display().to_string(),
                    "--steps",
                    "2",
                    "--json",
                ]
                .iter()
                .map(|s| s.to_string())
                .collect();
                let out = sandbox2d().args(&args).output().unwrap();
                match out.status.code() {
                    Some(2) => {
                        let err = String::from_utf8_lossy(&out.stderr);
                        prop_assert_eq!(err.lines().count(), 1, "{}", err);
                        prop_assert!(
                            err.starts_with(&format!("error: {}", file.display())),
                            "the line names the state: {err}"
                        );
                        refused.set(refused.get() + 1);
                    }
                    _ => {
                        check_run(&args, None)?;
                        ran.set(ran.get() + 1);
                    }
                }
                Ok(())
            },
        )
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!(
        "damaged states: {} refused, {} ran",
        refused.get(),
        ran.get()
    );
    assert!(refused.get() >= 5, "the damage reaches the checks");
}
