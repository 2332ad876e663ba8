//! The command line as a user runs it: exit codes, messages, --json and --trace.

use std::process::Command;

mod common;
use common::cli::{limited, sandbox2d, start_writing, temporaries, tmp};

#[test]
fn scenes_lists_every_builtin() {
    let out = sandbox2d().arg("scenes").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for name in [
        "particles",
        "ball_stack",
        "pyramid",
        "large_pyramid",
        "stack",
        "vacuum_vs_fluid",
        "friction_ramp",
        "bounce",
    ] {
        assert!(
            text.lines().any(|l| l.starts_with(name)),
            "{name} missing from:\n{text}"
        );
    }
}

#[test]
fn simulate_json_has_the_figures() {
    let started = std::time::Instant::now();
    let out = sandbox2d()
        .args([
            "simulate",
            "stack",
            "--steps",
            "30",
            "--json",
            "--iterations",
            "7",
            "--warm-start",
            "off",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["steps"], 30);
    assert_eq!(v["bodies"], 16);
    assert_eq!(v["solver"]["kind"], "soft");
    assert_eq!(v["solver"]["iterations"], 7);
    assert_eq!(v["solver"]["warm_start"], false);
    // The step times are milliseconds of this run: ordered (median <= p95), and the 30
    // steps' total no longer than the whole process took (a time in the wrong unit, or
    // one not measured, fails one or the other).
    let wall_ms = started.elapsed().as_secs_f64() * 1e3;
    let ms = |key: &str| v["ms_per_step"][key].as_f64().unwrap();
    assert!(
        ms("median") > 0.0 && ms("median") <= ms("p95"),
        "{}",
        v["ms_per_step"]
    );
    assert!(
        ms("mean") * 30.0 <= wall_ms,
        "30 steps of {} ms in a process of {wall_ms} ms",
        ms("mean")
    );
    assert!(v["contacts"]["max"].as_u64().unwrap() >= 2);
    // the soft step: 8 substeps of 7 soft sweeps and 1 relax sweep, every step
    assert_eq!(v["solver"]["substeps"], 8);
    assert_eq!(v["iterations"]["mean"].as_f64().unwrap(), 64.0);
    assert!(v["penetration"]["max"].as_f64().unwrap() >= 0.0);
    assert!(v["energy"]["start"].as_f64().is_some() && v["residual"]["max"].as_f64().is_some());
    assert_eq!(v["state_hash"].as_str().unwrap().len(), 16);
}

#[test]
fn simulate_is_deterministic_run_to_run() {
    let hash = || {
        let out = sandbox2d()
            .args(["simulate", "pyramid", "--steps", "120", "--json"])
            .output()
            .unwrap();
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["state_hash"].as_str().unwrap().to_string()
    };
    assert_eq!(hash(), hash());
}

#[test]
fn trace_writes_one_row_per_body_per_traced_step() {
    let path = tmp("trace.csv");
    let out = sandbox2d()
        .args(["simulate", "stack", "--steps", "10", "--trace"])
        .arg(&path)
        .args(["--trace-every", "5"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "step,t,id,name,x,y,angle,vx,vy,omega"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // steps 0, 5 and 10, 16 bodies each
    assert_eq!(rows.len(), 3 * 16);
    assert_eq!(rows[0][0], "0");
    assert_eq!(rows[16][0], "5");
    assert_eq!(rows[47][0], "10");
    assert_eq!(rows[0][3], "ground");
    assert_eq!(rows[1][2], "1");
    let t: f64 = rows[47][1].parse().unwrap();
    assert!((t - 10.0 / 60.0).abs() < 1e-6);
}

#[test]
fn a_bad_scene_is_one_clear_error_and_exit_2() {
    let path = tmp("bad.toml");
    std::fs::write(
        &path,
        "name = \"bad\"\n\n[[body]]\nname = \"ball\"\nshape = { circle = -0.5 }\n",
    )
    .unwrap();
    let out = sandbox2d().args(["simulate"]).arg(&path).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.contains("bad.toml:5:"), "{err}");
    assert!(err.contains("radius") && err.contains("-0.5"), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn bad_flags_are_refused_with_exit_2() {
    for args in [
        vec!["simulate", "stack", "--dt", "0"],
        vec!["simulate", "stack", "--iterations", "0"],
        vec!["simulate", "stack", "--baumgarte", "1.5"],
        vec!["simulate", "stack", "--slop", "-1"],
        vec!["simulate", "no_such_scene_or_file"],
        vec!["simulate", "stack", "--warm-start", "maybe"],
    ] {
        let out = sandbox2d().args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!out.stderr.is_empty());
    }
}

#[cfg(feature = "lab")]
#[test]
fn bench_writes_csv_markdown_and_plots_quietly() {
    let dir = tmp("bench-out");
    let _ = std::fs::remove_dir_all(&dir);
    let started = std::time::Instant::now();
    let out = sandbox2d()
        .args(["bench", "--suite", "quick", "--filter", "stack"])
        .args(["--steps", "6", "--repeats", "1", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // not a terminal: no progress bar, one line of output
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 1);
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in [
        "scene",
        "solver",
        "iterations",
        "substeps",
        "warm_start",
        "split_impulse",
        "ms_per_step",
        "penetration_max",
        "penetration_mean",
        "drift",
        "joint_error",
        "energy_drift",
        "residual",
        "stable",
    ] {
        assert!(header.contains(&col), "{col} missing from {header:?}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // 24 PGS settings, 6 XPBD and 6 soft-step settings of the one scene "stack"
    assert_eq!(rows.len(), 36);
    let solver = header.iter().position(|c| *c == "solver").unwrap();
    for (name, count) in [("pgs", 24), ("xpbd", 6), ("soft", 6)] {
        assert_eq!(rows.iter().filter(|r| r[solver] == name).count(), count);
    }
    let stable = header.iter().position(|c| *c == "stable").unwrap();
    let ms = header.iter().position(|c| *c == "ms_per_step").unwrap();
    // Every row that ran was timed: 6 steps (5 timed) at its ms per step, all 36 rows
    // together within the run's wall time (a time in the wrong unit fails that).
    let wall_ms = started.elapsed().as_secs_f64() * 1e3;
    let mut timed_ms = 0.0;
    for r in &rows {
        assert_eq!(r[0], "stack");
        assert!(["yes", "no"].contains(&r[stable]), "{r:?}");
        let t: f64 = r[ms].parse().unwrap_or_else(|_| panic!("{r:?}"));
        assert!(t > 0.0 && t.is_finite(), "{r:?}");
        timed_ms += 5.0 * t;
    }
    assert!(
        timed_ms <= wall_ms,
        "rows timed {timed_ms} ms in a run of {wall_ms} ms"
    );
    let md = std::fs::read_to_string(dir.join("results.md")).unwrap();
    assert!(md.contains("## stack") && md.contains("**What to pick**"));
    assert!(md.contains("- the scene's own setting: soft 8 substeps x 1"));
    assert!(md.contains("- within 2x its time ("));
    assert!(md.contains("The front (candidates"));
    let svg = std::fs::read_to_string(dir.join("stack.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("PGS warm+split"));
    // the legend says what the marks mean
    assert!(svg.contains("unstable or fell (X)") && svg.contains("own setting"));
}

#[cfg(feature = "lab")]
#[test]
fn bench_refuses_bad_input_with_one_line_and_exit_2() {
    let dir = tmp("bench-bad");
    for args in [
        vec!["bench", "--suite", "quick", "--steps", "0"],
        vec!["bench", "--suite", "quick", "--repeats", "0"],
        vec!["bench", "--suite", "quick", "--filter", "no_such_scene"],
        vec!["bench", "--suite", "extremes", "--filter", "no_such_sweep"],
    ] {
        let out = sandbox2d()
            .args(&args)
            .arg("--out")
            .arg(&dir)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{err}");
    }
    let out = sandbox2d()
        .args(["bench", "--suite", "fast", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[cfg(feature = "lab")]
#[test]
fn bench_extremes_writes_the_stability_table() {
    let dir = tmp("bench-ext");
    let out = sandbox2d()
        .args([
            "bench",
            "--suite",
            "extremes",
            "--filter",
            "tunneling",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    let md = std::fs::read_to_string(dir.join("stability.md")).unwrap();
    let claims = sandbox2d::bench::extremes::parse_claims(&md).unwrap();
    assert!(claims.iter().all(|c| c.sweep.name() == "tunneling"));
    assert!(!claims.is_empty());
}

#[test]
fn simulate_json_reports_the_joint_error_under_xpbd() {
    let out = sandbox2d()
        .args([
            "simulate", "chain", "--steps", "60", "--json", "--solver", "xpbd",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["solver"]["kind"], "xpbd");
    assert_eq!(v["solver"]["substeps"], 20);
    let max = v["joint_error"]["max"].as_f64().unwrap();
    let last = v["joint_error"]["final"].as_f64().unwrap();
    // a 40-link chain falling from horizontal under 20 substeps: within a few cm
    assert!(max >= last && max > 0.0 && max < 0.05, "{max} {last}");
}

/// A fresh empty folder for one test.
#[cfg(feature = "render")]
fn fresh_dir(name: &str) -> std::path::PathBuf {
    let dir = tmp(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// True (and says why) when a render failed only for want of a graphics adapter and
/// the run does not require one.
#[cfg(feature = "render")]
fn skipped_for_no_adapter(out: &std::process::Output) -> bool {
    let err = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(1) && err.contains("no graphics adapter") {
        assert!(
            std::env::var_os("SANDBOX2D_REQUIRE_ADAPTER").is_none(),
            "no adapter and SANDBOX2D_REQUIRE_ADAPTER is set: {err}"
        );
        eprintln!("SKIPPED: no graphics adapter: {err}");
        return true;
    }
    false
}

#[cfg(feature = "render")]
fn distinct_colours(img: &image::RgbaImage) -> usize {
    let mut seen: Vec<[u8; 4]> = img.pixels().map(|p| p.0).collect();
    seen.sort_unstable();
    seen.dedup();
    seen.len()
}

#[cfg(feature = "render")]
#[test]
fn render_writes_numbered_pngs_and_a_gif() {
    let dir = fresh_dir("render-frames");
    let gif = dir.join("anim.gif");
    let out = sandbox2d()
        .args(["render", "bounce", "--frames", "3", "--every", "20"])
        .args(["--size", "320x180", "--overlays", "contacts,velocities"])
        .arg("--out")
        .arg(dir.join("frames"))
        .arg("--gif")
        .arg(&gif)
        .output()
        .unwrap();
    if skipped_for_no_adapter(&out) {
        return;
    }
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("wrote 3 frames"), "{stdout}");
    let frames: Vec<image::RgbaImage> = (0..3)
        .map(|k| {
            let p = dir.join("frames").join(format!("frame_{k:04}.png"));
            image::open(&p)
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
                .to_rgba8()
        })
        .collect();
    assert!(!dir.join("frames").join("frame_0003.png").exists());
    for f in &frames {
        assert_eq!(f.dimensions(), (320, 180));
        assert!(
            distinct_colours(f) >= 5,
            "a frame of the scene, not a blank"
        );
    }
    assert_ne!(frames[0], frames[2], "the balls move between frames");
    // The GIF has the same frames.
    use image::AnimationDecoder;
    let decoder = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(
        std::fs::File::open(&gif).unwrap(),
    ))
    .unwrap();
    let gif_frames = decoder.into_frames().collect_frames().unwrap();
    assert_eq!(gif_frames.len(), 3);
    assert_eq!(gif_frames[0].buffer().dimensions(), (320, 180));
}

/// GIF counts delays in centiseconds: at every `--every` each frame's delay is the
/// scene's `dt * every` to within 1 cs, and the animation's length is `frames * dt *
/// every` to within 1 cs (so it plays at the simulated speed, not 1.7 x too fast).
#[cfg(feature = "render")]
#[test]
fn gif_delays_are_the_simulated_interval_in_centiseconds() {
    use image::AnimationDecoder;
    let scene = sandbox2d::scene::load("bounce").unwrap();
    let dt = scene.world.solver.resolve().dt as f64;
    let dir = fresh_dir("render-gif-delays");
    let frames = 7;
    for every in [1u32, 2, 3] {
        let gif = dir.join(format!("every{every}.gif"));
        let out = sandbox2d()
            .args(["render", "bounce", "--frames", &frames.to_string()])
            .args(["--every", &every.to_string(), "--size", "64x36"])
            .arg("--out")
            .arg(dir.join(format!("f{every}")))
            .arg("--gif")
            .arg(&gif)
            .output()
            .unwrap();
        if skipped_for_no_adapter(&out) {
            return;
        }
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let decoded = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(
            std::fs::File::open(&gif).unwrap(),
        ))
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
        assert_eq!(decoded.len(), frames);
        let interval_cs = dt * f64::from(every) * 100.0;
        let mut total = 0.0;
        for (k, f) in decoded.iter().enumerate() {
            let (num, den) = f.delay().numer_denom_ms();
            let cs = f64::from(num) / f64::from(den) / 10.0;
            assert!(
                (cs - interval_cs).abs() <= 1.0,
                "--every {every}: frame {k} shown {cs} cs, the interval is {interval_cs:.2} cs"
            );
            total += cs;
        }
        let want = interval_cs * frames as f64;
        assert!(
            (total - want).abs() <= 1.0,
            "--every {every}: {frames} frames last {total} cs, simulated {want:.2} cs"
        );
    }
}

#[cfg(feature = "render")]
#[test]
fn render_refuses_bad_input_with_exit_2() {
    let dir = fresh_dir("render-bad");
    let file = dir.join("a_file");
    std::fs::write(&file, "x").unwrap();
    let d = dir.join("frames").display().to_string();
    let f = file.display().to_string();
    let cases: Vec<(Vec<&str>, bool)> = vec![
        // (arguments, whether the message is ours: exactly one line)
        (
            vec!["render", "no_such_scene", "--frames", "2", "--out", &d],
            true,
        ),
        (vec!["render", "stack", "--frames", "0", "--out", &d], true),
        (
            vec![
                "render", "stack", "--frames", "2", "--every", "0", "--out", &d,
            ],
            true,
        ),
        (
            vec![
                "render",
                "stack",
                "--frames",
                "2",
                "--iterations",
                "0",
                "--out",
                &d,
            ],
            true,
        ),
        (vec!["render", "stack", "--frames", "2", "--out", &f], true),
        (
            vec![
                "render", "stack", "--frames", "2", "--size", "0x10", "--out", &d,
            ],
            false,
        ),
        (
            vec![
                "render", "stack", "--frames", "2", "--size", "wide", "--out", &d,
            ],
            false,
        ),
        (vec!["render", "stack", "--frames", "2"], false),
        (vec!["run", "no_such_scene"], true),
        (vec!["run", "stack", "--screenshot", "x.png"], false),
    ];
    for (args, ours) in cases {
        let out = sandbox2d()
            .args(&args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error:"), "{args:?}: {err}");
        if ours {
            assert_eq!(err.lines().count(), 1, "{args:?}: one line: {err}");
        }
    }
    assert!(
        !dir.join("frames").exists(),
        "nothing written for bad input"
    );
}

/// Without a display, `run` says so in one line, renders the scene headless into ./out
/// and exits 0.
#[cfg(feature = "render")]
#[test]
fn run_without_a_display_renders_frames_into_out() {
    let dir = fresh_dir("run-headless");
    let out = sandbox2d()
        .args(["run", "stack", "--frames", "3", "--screenshot", "last.png"])
        .current_dir(&dir)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    if skipped_for_no_adapter(&out) {
        return;
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let first = stdout.lines().next().unwrap_or_default();
    assert!(first.contains("no display"), "{stdout}");
    assert!(first.contains("./out"), "{stdout}");
    assert_eq!(
        stdout.lines().filter(|l| l.contains("no display")).count(),
        1
    );
    for k in 0..3 {
        let p = dir.join("out").join(format!("frame_{k:04}.png"));
        let img = image::open(&p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .to_rgba8();
        assert_eq!(img.dimensions(), (1280, 720), "the scene's camera size");
        assert!(distinct_colours(&img) >= 5);
    }
    assert!(!dir.join("out").join("frame_0003.png").exists());
    assert_eq!(
        std::fs::read(dir.join("last.png")).unwrap(),
        std::fs::read(dir.join("out").join("frame_0002.png")).unwrap()
    );
}

/// The plain command (what `cargo run --release` runs) falls back the same way.
#[cfg(feature = "render")]
#[test]
fn plain_command_without_a_display_exits_0_with_frames() {
    let dir = fresh_dir("plain-headless");
    let out = sandbox2d()
        .current_dir(&dir)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    if skipped_for_no_adapter(&out) {
        return;
    }
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let pngs = std::fs::read_dir(dir.join("out")).unwrap().count();
    assert!(pngs >= 60, "{pngs} frames");
    assert!(dir.join("out").join("frame_0000.png").exists());
}

// ---------------------------------------------------------------------------
// No panics, no preallocation from a count, outputs written in full or not
// at all, interrupts that say what was kept, outputs that would overwrite an input.

/// Starts `args`, waits `secs`, and returns whether it is still running (then kills
/// it): a run of a huge count must neither panic nor abort on allocation.
fn still_running_after(args: &[&str], secs: f32) -> bool {
    let mut child = sandbox2d()
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_secs_f32(secs));
    let running = child.try_wait().unwrap().is_none();
    if running {
        child.kill().unwrap();
    }
    let out = child.wait_with_output().unwrap();
    if !running {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    }
    running
}

#[test]
fn huge_step_counts_are_not_preallocated() {
    for steps in [
        "2305843009213693952",
        "100000000000",
        "18446744073709551615",
    ] {
        assert!(
            still_running_after(&["simulate", "stack", "--steps", steps], 1.5),
            "--steps {steps} ended early (a panic or an abort)"
        );
    }
}

#[test]
fn zero_steps_are_refused_like_bench_does() {
    let out = sandbox2d()
        .args(["simulate", "stack", "--steps", "0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim(), "error: --steps must be at least 1");
    assert!(out.stdout.is_empty());
}

#[test]
fn iteration_and_substep_flags_have_upper_bounds() {
    for (flag, value, max) in [
        ("--iterations", "1000001", "10000"),
        ("--substeps", "1001", "1000"),
    ] {
        let out = sandbox2d()
            .args(["simulate", "stack", "--steps", "1", flag, value])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(flag) && err.contains(max), "{err}");
    }
}

/// A scene that is fine at load and blows up in its first step: a force of 3e38 N on
/// a small ball.
const BLOWS_UP: &str = "name = \"boom\"\n[[body]]\nname = \"ball\"\nshape = { circle = 0.05 }\n\
                        [[force]]\nbody = \"ball\"\nforce = [3e38, 0]\n";

#[test]
fn a_non_finite_state_names_the_scene_the_step_and_the_body() {
    let dir = fresh_tmp("blow-up");
    let scene = dir.join("boom.toml");
    std::fs::write(&scene, BLOWS_UP).unwrap();
    let trace = dir.join("trace.csv");
    let out = sandbox2d()
        .args(["simulate"])
        .arg(&scene)
        .args(["--steps", "10", "--trace"])
        .arg(&trace)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    let last = err.lines().last().unwrap();
    assert!(
        last.starts_with(&format!("error: {}: ", scene.display())),
        "{err}"
    );
    assert!(
        last.contains("\"ball\"") && last.contains("after step 1"),
        "{err}"
    );
    // the trace is incomplete: not left at its name, and no temporary file either
    assert!(!trace.exists(), "an incomplete trace was left");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        1,
        "only the scene"
    );
    assert!(
        err.contains("trace.csv: not written"),
        "says what was kept: {err}"
    );
}

/// An energy that overflows while every state stays finite is a failed run whose line
/// names the body whose term overflowed.
#[test]
fn an_energy_that_overflows_names_the_body() {
    let dir = fresh_tmp("energy-overflow");
    let scene = dir.join("heavy.toml");
    // 1/2 m v^2 starts at 3.38e38 J, just inside f32, and gravity along x adds to v
    std::fs::write(
        &scene,
        "name = \"heavy\"\n[world]\ngravity = [10, 0]\n[[body]]\nname = \"weight\"\nshape = { circle = 1 }\nmass = 1e30\nvelocity = [26000, 0]\n",
    )
    .unwrap();
    let out = sandbox2d()
        .arg("simulate")
        .arg(&scene)
        .args(["--steps", "600"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("the energy at the end is inf"), "{err}");
    assert!(
        err.contains("body \"weight\" (#0): its kinetic energy is not finite"),
        "{err}"
    );
}

/// A fresh empty folder (also without the render feature).
fn fresh_tmp(name: &str) -> std::path::PathBuf {
    let dir = tmp(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `args` under a file-size limit of `kib` KiB (bash's `ulimit -f`).
fn with_file_limit(kib: u32, args: &[&str], cwd: &std::path::Path) -> std::process::Output {
    limited(&format!("ulimit -f {kib}"), args, cwd)
}

#[cfg(unix)]
#[test]
fn a_trace_that_cannot_be_written_in_full_is_not_left_and_the_error_names_it() {
    let dir = fresh_tmp("full-trace");
    let out = with_file_limit(
        4,
        &["simulate", "pyramid", "--steps", "30", "--trace", "t.csv"],
        &dir,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: t.csv: cannot write:"), "{err}");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "neither the trace nor its temporary file is left"
    );
}

#[cfg(unix)]
#[cfg(feature = "lab")]
#[test]
fn bench_results_that_cannot_be_written_in_full_are_not_left() {
    let dir = fresh_tmp("full-bench");
    // room for the partial rows, not for the plots
    let out = with_file_limit(
        2,
        &[
            "bench",
            "--out",
            "r",
            "--filter",
            "stack",
            "--steps",
            "5",
            "--repeats",
            "1",
        ],
        &dir,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let line = err.lines().last().unwrap();
    assert!(
        line.starts_with("error: r/") && line.contains("cannot write"),
        "names the file: {err}"
    );
    for name in ["results.csv", "results.md", "stack.svg"] {
        assert!(!dir.join("r").join(name).exists(), "{name} left");
    }
    for e in std::fs::read_dir(dir.join("r")).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "temporary file {name} left");
    }
}

/// Under `ulimit -f` every command that writes a file stops with exit 1 and one line
/// naming the file that did not fit (the binary ignores SIGXFSZ, which would end it
/// with no word), and leaves no temporary file.
#[cfg(unix)]
#[test]
fn every_output_past_the_file_size_limit_is_one_line_naming_it() {
    let cases: &[(u32, &[&str], &str)] = &[
        (
            4,
            &[
                "simulate", "pyramid", "--steps", "30", "--events", "e.csv", "--trace", "t.csv",
            ],
            "t.csv",
        ),
        (
            4,
            &[
                "simulate",
                "pyramid",
                "--steps",
                "30",
                "--save-state",
                "s.json",
            ],
            "s.json",
        ),
        (
            4,
            &[
                "render", "pyramid", "--frames", "2", "--size", "640x400", "--out", "f",
            ],
            "f/frame_0000.png",
        ),
        // frames of about 4.5 KB fit, the GIF of about 6 KB does not
        (
            5,
            &[
                "render", "pyramid", "--frames", "3", "--size", "160x100", "--out", "f", "--gif",
                "g.gif",
            ],
            "g.gif",
        ),
        (
            4,
            &[
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
            "t/tune.md",
        ),
    ];
    for (kib, args, file) in cases {
        if !cfg!(feature = "render") && args[0] == "render" {
            continue;
        }
        if !cfg!(feature = "lab") && args[0] == "tune" {
            continue;
        }
        let dir = fresh_tmp("size-limit");
        let out = with_file_limit(*kib, args, &dir);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(
            err.starts_with(&format!("error: {file}: ")) && err.contains("too large"),
            "{args:?}: {err}"
        );
        assert_eq!(temporaries(&dir), Vec::<String>::new(), "{args:?}");
        assert!(!dir.join(file).exists(), "{args:?}: {file} left");
    }
}

/// Two interrupts back to back (what `timeout -s INT` and an impatient user send) end
/// the run at once: exit 130, one line, and no temporary file left behind.
#[cfg(unix)]
#[test]
fn two_interrupts_end_at_once_with_one_line_and_leave_nothing() {
    let dir = fresh_tmp("interrupt-twice");
    // steps of seconds each (10,000 PGS sweeps on 5050 boxes), so that the second
    // interrupt comes while the first waits for the step to end; apart by a moment, as
    // two signals sent at once may reach the process as one
    let (mut child, began) = start_writing(
        &[
            "simulate",
            "large_pyramid",
            "--steps",
            "1000",
            "--solver",
            "pgs",
            "--substeps",
            "1",
            "--iterations",
            "10000",
            "--tolerance",
            "0",
            "--trace",
            "t.csv",
        ],
        &dir,
        "t.csv",
    );
    assert!(began, "the run started");
    // a second into the first step (about 10 s long), so the first interrupt waits for it
    // to end and the second finds the run still stepping
    std::thread::sleep(std::time::Duration::from_secs(1));
    let pid = child.id().to_string();
    Command::new("sh")
        .arg("-c")
        .arg(format!("kill -INT {pid}; sleep 0.2; kill -INT {pid}"))
        .status()
        .unwrap();
    let status = child.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("error: interrupted again: stopped at once; removed 1 incomplete file"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing left");
}

/// stdout that cannot be written (a full disk, a closed pipe) is a failed run with one
/// line, not a panic.
#[cfg(target_os = "linux")]
#[test]
fn stdout_that_cannot_be_written_is_one_line_not_a_panic() {
    for args in [
        &["scenes"][..],
        &["simulate", "pendulum", "--steps", "5", "--json"],
    ] {
        let out = sandbox2d()
            .args(args)
            .stdout(std::fs::File::create("/dev/full").unwrap())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(
            err.trim_end(),
            "error: stdout: cannot write: No space left on device (os error 28)",
            "{args:?}"
        );
    }
}

#[cfg(target_os = "linux")]
#[cfg(feature = "lab")]
#[test]
fn bench_checks_its_folder_before_measuring() {
    let t = std::time::Instant::now();
    // /proc/self exists and takes no new files, even for root
    let out = sandbox2d()
        .args(["bench", "--suite", "standard", "--out", "/proc/self"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: /proc/self: cannot write"), "{err}");
    assert!(t.elapsed().as_secs() < 10, "refused before measuring");
}

/// Sends `signal` to a child once `ready` holds (or 20 s pass).
fn interrupt_when(
    child: &mut std::process::Child,
    signal: &str,
    ready: impl Fn() -> bool,
) -> std::process::ExitStatus {
    let t = std::time::Instant::now();
    while !ready() && t.elapsed().as_secs() < 20 {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    child.wait().unwrap()
}

#[cfg(unix)]
#[test]
fn an_interrupted_simulation_leaves_no_trace_and_says_so() {
    let dir = fresh_tmp("interrupt-sim");
    for signal in ["-INT", "-TERM"] {
        let mut child = sandbox2d()
            .args([
                "simulate",
                "pyramid",
                "--steps",
                "100000000",
                "--trace",
                "t.csv",
            ])
            .current_dir(&dir)
            .stderr(std::process::Stdio::piped())
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // the temporary trace appears once the run has started
        let d = dir.clone();
        let status = interrupt_when(&mut child, signal, move || {
            std::fs::read_dir(&d).unwrap().count() > 0
        });
        let mut err = String::new();
        std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
        assert_eq!(status.code(), Some(130), "{signal}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains("interrupted after step"), "{err}");
        assert!(err.contains("t.csv: not written"), "{err}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing left");
    }
}

#[cfg(unix)]
#[cfg(feature = "lab")]
#[test]
fn an_interrupted_bench_keeps_the_cases_it_finished_and_says_so() {
    let dir = fresh_tmp("interrupt-bench");
    let mut child = sandbox2d()
        .args(["bench", "--out", "r", "--steps", "20", "--repeats", "1"])
        .current_dir(&dir)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let partial = dir.join("r").join("results.partial.csv");
    // the rows go to a temporary file until the suite stops
    let temp = dir
        .join("r")
        .join(format!(".results.partial.csv.{}.tmp", child.id()));
    let status = interrupt_when(&mut child, "-INT", move || {
        std::fs::read_to_string(&temp).is_ok_and(|t| t.lines().count() >= 3)
    });
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted: kept the"), "{err}");
    assert!(err.contains("results.partial.csv"), "{err}");
    let rows = std::fs::read_to_string(&partial).unwrap();
    assert!(rows.lines().count() >= 3, "{rows}");
    assert!(rows.starts_with("scene,"), "{rows}");
    assert!(!dir.join("r").join("results.csv").exists());
    assert!(!dir.join("r").join("results.md").exists());
}

#[test]
fn an_output_that_is_an_input_is_refused() {
    let dir = fresh_tmp("collide-trace");
    let scene = dir.join("my.toml");
    let text = "name = \"mine\"\n[[body]]\nshape = { circle = 1 }\n";
    std::fs::write(&scene, text).unwrap();
    // the same file, spelt another way
    let other = dir.join(".").join("my.toml");
    let out = sandbox2d()
        .arg("simulate")
        .arg(&scene)
        .arg("--trace")
        .arg(&other)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("--trace would overwrite the scene file"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&scene).unwrap(),
        text,
        "scene unchanged"
    );
}

/// For every command and every file it may write, an input in that place (the scene
/// file, a state, a shard) is refused with exit 2 and one line before anything is
/// written, and is left as it was: the scene as a frame of `render` or of `run`'s
/// headless frames, as each of `tune`'s four files, as `simulate`'s trace, events and
/// state, a shard as a report of `bench --merge`.
#[test]
fn no_output_of_any_command_replaces_an_input() {
    let dir = fresh_tmp("outputs-over-inputs");
    let scene_text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/scenes/pendulum.toml"
    ))
    .unwrap();
    // (the input's path in the folder, the command line with IN for the input)
    let mut cases: Vec<(&str, Vec<&str>)> = vec![
        (
            "s.toml",
            vec!["simulate", "IN", "--steps", "2", "--trace", "./s.toml"],
        ),
        (
            "s.toml",
            vec!["simulate", "IN", "--steps", "2", "--events", "s.toml"],
        ),
        (
            "s.toml",
            vec!["simulate", "IN", "--steps", "2", "--save-state", "s.toml"],
        ),
        (
            "t/tune.md",
            vec!["tune", "IN", "--budget-ms", "1", "--out", "t"],
        ),
        (
            "t/tune.json",
            vec!["tune", "IN", "--budget-ms", "1", "--out", "t"],
        ),
        (
            "t/pareto.svg",
            vec!["tune", "IN", "--budget-ms", "1", "--out", "t"],
        ),
        (
            "t/solver.toml",
            vec!["tune", "IN", "--budget-ms", "1", "--out", "t/."],
        ),
    ];
    if cfg!(feature = "render") {
        cases.extend([
            (
                "o/frame_0000.png",
                vec!["render", "IN", "--frames", "1", "--out", "o"],
            ),
            (
                "o/frame_0007.png",
                vec!["render", "IN", "--frames", "8", "--out", "./o"],
            ),
            (
                "o/frame_0001.png",
                vec![
                    "render",
                    "IN",
                    "--frames",
                    "2",
                    "--out",
                    "o",
                    "--compare",
                    "--solver pgs",
                    "--compare",
                    "",
                ],
            ),
            (
                "s.toml",
                vec![
                    "render", "IN", "--frames", "2", "--out", "o", "--gif", "s.toml",
                ],
            ),
            ("out/frame_0002.png", vec!["run", "IN", "--frames", "3"]),
            (
                "s.toml",
                vec!["run", "IN", "--frames", "3", "--screenshot", "s.toml"],
            ),
        ]);
    }
    if !cfg!(feature = "lab") {
        cases.retain(|(_, args)| args[0] != "tune");
    }
    for (input, args) in &cases {
        let path = dir.join(input);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &scene_text).unwrap();
        let args: Vec<&str> = args
            .iter()
            .map(|a| if *a == "IN" { *input } else { *a })
            .collect();
        let out = sandbox2d()
            .args(&args)
            .current_dir(&dir)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .env_remove("WAYLAND_SOCKET")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().last().unwrap_or("");
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            last.starts_with("error: ") && last.contains("would overwrite the scene file"),
            "{args:?}: {err}"
        );
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            scene_text,
            "{args:?}: the input is unchanged"
        );
        assert_eq!(temporaries(&dir), Vec::<String>::new(), "{args:?}");
        std::fs::remove_file(&path).unwrap();
    }
    // a shard read by --merge is not replaced by the report of the same name
    #[cfg(feature = "lab")]
    {
        let shard = dir.join("m").join("results.md");
        std::fs::create_dir_all(shard.parent().unwrap()).unwrap();
        std::fs::write(&shard, "{}").unwrap();
        let out = sandbox2d()
            .args(["bench", "--merge", "m/results.md", "--out", "m"])
            .current_dir(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("--out would overwrite the shard file"),
            "{err}"
        );
        assert_eq!(std::fs::read_to_string(&shard).unwrap(), "{}");
    }
    // a hard link to the scene is the scene
    #[cfg(unix)]
    {
        let scene = dir.join("s.toml");
        std::fs::write(&scene, &scene_text).unwrap();
        std::fs::hard_link(&scene, dir.join("link.csv")).unwrap();
        let out = sandbox2d()
            .args(["simulate", "s.toml", "--steps", "2", "--trace", "link.csv"])
            .current_dir(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert_eq!(std::fs::read_to_string(&scene).unwrap(), scene_text);
    }
}

#[cfg(feature = "render")]
#[test]
fn render_and_run_refuse_outputs_that_collide() {
    let dir = fresh_tmp("collide-render");
    let d = dir.join("d");
    let out = sandbox2d()
        .args(["render", "stack", "--frames", "3", "--out"])
        .arg(&d)
        .arg("--gif")
        .arg(d.join("frame_0001.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--gif would overwrite the frame it writes"),
        "{err}"
    );
    assert!(!d.exists(), "nothing written");
    // the GIF may be a later frame's name when there are fewer frames
    let out = sandbox2d()
        .args(["render", "stack", "--frames", "3", "--out"])
        .arg(&d)
        .arg("--gif")
        .arg(&d)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--out folder"), "{err}");

    let out = sandbox2d()
        .args([
            "run",
            "stack",
            "--frames",
            "3",
            "--screenshot",
            "out/frame_0002.png",
        ])
        .current_dir(&dir)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--screenshot would overwrite the frame it writes"),
        "{err}"
    );
    assert!(!dir.join("out").join("frame_0002.png").exists());
}

#[cfg(feature = "render")]
#[test]
fn an_interrupted_render_keeps_complete_frames_and_no_gif() {
    let dir = fresh_tmp("interrupt-render");
    let mut child = sandbox2d()
        .args(["render", "stack", "--frames", "100000", "--size", "64x36"])
        .args(["--out", "f", "--gif", "a.gif"])
        .current_dir(&dir)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let f = dir.join("f");
    let status = interrupt_when(&mut child, "-INT", move || {
        f.join("frame_0002.png").exists()
    });
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    if status.code() == Some(1) && err.contains("no graphics adapter") {
        eprintln!("SKIPPED: no graphics adapter: {err}");
        return;
    }
    assert_eq!(status.code(), Some(130), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("interrupted after step"), "{err}");
    assert!(
        err.contains("complete frame(s)") && err.contains("no GIF"),
        "{err}"
    );
    assert!(!dir.join("a.gif").exists(), "no GIF without a trailer");
    for e in std::fs::read_dir(&dir)
        .unwrap()
        .chain(std::fs::read_dir(dir.join("f")).unwrap())
    {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "temporary file {name} left");
    }
    // every frame kept is a whole PNG
    for e in std::fs::read_dir(dir.join("f")).unwrap() {
        let p = e.unwrap().path();
        image::open(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
}

#[cfg(feature = "render")]
#[test]
fn a_frame_that_cannot_be_written_in_full_is_not_left() {
    let dir = fresh_tmp("full-render");
    let out = with_file_limit(
        4,
        &[
            "render", "stack", "--frames", "2", "--out", "f", "--gif", "a.gif",
        ],
        &dir,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(1) && err.contains("no graphics adapter") {
        eprintln!("SKIPPED: no graphics adapter: {err}");
        return;
    }
    assert_eq!(out.status.code(), Some(1), "{err}");
    let line = err.lines().last().unwrap();
    assert!(
        line.contains("cannot write") || line.contains("File too large"),
        "{err}"
    );
    assert!(
        line.contains("f/frame_0000.png") || line.contains("a.gif"),
        "names the file: {err}"
    );
    assert!(!dir.join("a.gif").exists());
    assert!(
        !dir.join("f").join("frame_0000.png").exists(),
        "no truncated PNG"
    );
}

/// On a terminal, a run longer than two seconds shows its progress (on stderr); `script`
/// gives the run a terminal. Skipped where `script` (util-linux) is missing.
#[cfg(target_os = "linux")]
#[test]
fn a_long_run_shows_progress_on_a_terminal() {
    let bin = env!("CARGO_BIN_EXE_sandbox2d");
    let Ok(mut child) = Command::new("script")
        .args(["-qfec"])
        .arg(format!("{bin} simulate stack --steps 1000000000"))
        .arg("/dev/null")
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
    else {
        eprintln!("SKIPPED: no `script` to give the run a terminal");
        return;
    };
    std::thread::sleep(std::time::Duration::from_millis(4500));
    let _ = child.kill();
    let out = child.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("/1000000000 steps"),
        "no progress after 4.5 s: {text:?}"
    );
}

#[cfg(feature = "render")]
#[test]
fn a_huge_frame_count_is_not_preallocated() {
    let dir = fresh_tmp("huge-frames");
    let mut child = sandbox2d()
        .args([
            "render",
            "stack",
            "--frames",
            "4294967295",
            "--size",
            "32x18",
            "--out",
        ])
        .arg(dir.join("f"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let f = dir.join("f");
    let t = std::time::Instant::now();
    while !f.join("frame_0001.png").exists() && t.elapsed().as_secs() < 20 {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let running = child.try_wait().unwrap().is_none();
    if running {
        child.kill().unwrap();
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    if err.contains("no graphics adapter") {
        eprintln!("SKIPPED: no graphics adapter: {err}");
        return;
    }
    assert!(running, "ended early (an abort on allocation?): {err}");
    assert!(f.join("frame_0001.png").exists());
}

#[cfg(feature = "render")]
#[test]
fn a_render_that_blows_up_names_the_scene_the_step_and_the_body() {
    let dir = fresh_tmp("blow-up-render");
    let scene = dir.join("boom.toml");
    std::fs::write(&scene, BLOWS_UP).unwrap();
    let out = sandbox2d()
        .arg("render")
        .arg(&scene)
        .args(["--frames", "3", "--size", "32x18", "--out"])
        .arg(dir.join("f"))
        .arg("--gif")
        .arg(dir.join("a.gif"))
        .output()
        .unwrap();
    if skipped_for_no_adapter(&out) {
        return;
    }
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with(&format!("error: {}: body \"ball\"", scene.display())),
        "{err}"
    );
    assert!(err.contains("after step 1"), "{err}");
    assert!(!dir.join("a.gif").exists(), "no unfinished GIF");
    assert!(
        dir.join("f").join("frame_0000.png").exists(),
        "frame 0 is complete"
    );
}

#[test]
fn a_bad_solver_flag_is_blamed_on_the_flags_not_the_scene() {
    let out = sandbox2d()
        .args(["simulate", "stack", "--steps", "1", "--dt", "0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(
        err.trim_end(),
        "error: command-line flags: solver: dt must be in (0, 1] s, got 0"
    );
}

#[test]
fn a_name_with_control_characters_cannot_reach_the_terminal_raw() {
    let dir = fresh_tmp("escapes");
    let scene = dir.join("esc.toml");
    // an escape sequence (clear screen) and a carriage return that would overwrite the line
    std::fs::write(
        &scene,
        "name = \"t\"\n[[body]]\nname = \"\\u001b[2J\\rerror: all fine\"\nshape = { circle = -1 }\n",
    )
    .unwrap();
    let out = sandbox2d().arg("simulate").arg(&scene).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err:?}");
    let line = err.strip_suffix('\n').unwrap();
    assert!(!line.chars().any(|c| c.is_control()), "{line:?}");
    assert!(
        line.contains("body \"\\u{1b}[2J\\rerror: all fine\""),
        "{line:?}"
    );
}

#[test]
fn a_trace_that_is_a_folder_is_refused_before_the_run() {
    let dir = fresh_tmp("trace-folder");
    let out = sandbox2d()
        .args(["simulate", "stack", "--steps", "5", "--trace"])
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--trace is a folder"), "{err}");
    assert!(out.stdout.is_empty(), "refused before the run");
}

#[test]
fn a_scene_far_from_the_origin_gets_one_note_and_still_runs() {
    let far = tmp("far.toml");
    std::fs::write(
        &far,
        "name = \"far\"\n[world]\ngravity = [0.0, -10.0]\n[[body]]\nname = \"ball\"\nshape = { circle = 0.5 }\nposition = [0.0, 1e6]\n[[body]]\nname = \"pad\"\ntype = \"static\"\nshape = { box = [1.0, 1.0] }\nposition = [0.0, 0.0]\n",
    )
    .unwrap();
    let out = sandbox2d()
        .arg("simulate")
        .arg(&far)
        .args(["--steps", "10"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    // the scene spans 1e6 m: its origin is the midpoint, 5e5 m from either body, where
    // an f32 position steps by 2^-5 m
    assert!(
        err.starts_with("note: ") && err.contains("5.000e5 m") && err.contains("3.1e-2 m"),
        "{err}"
    );
    // the ball alone, 1e6 m out, is simulated relative to its own place: no note
    std::fs::write(
        &far,
        "name = \"far\"\n[world]\ngravity = [0.0, -10.0]\n[[body]]\nname = \"ball\"\nshape = { circle = 0.5 }\nposition = [0.0, 1e6]\n",
    )
    .unwrap();
    let out = sandbox2d()
        .arg("simulate")
        .arg(&far)
        .args(["--steps", "10"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // a scene near the origin gets no note
    let out = sandbox2d()
        .args(["simulate", "pyramid", "--steps", "2"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn simulate_writes_events_and_counts_them() {
    let scene = tmp("gate.toml");
    std::fs::write(
        &scene,
        "name = \"gate\"\n[world]\ngravity = [0.0, -10.0]\n\
         [[body]]\nname = \"ball\"\nshape = { circle = 0.25 }\nposition = [0.0, 3.0]\nrestitution = 0.5\n\
         [[body]]\nname = \"gate, the\"\ntype = \"static\"\nshape = { box = [2.0, 0.5] }\nposition = [0.0, 1.5]\nsensor = true\n\
         [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [10.0, 1.0] }\nposition = [0.0, -0.5]\n",
    )
    .unwrap();
    let events = tmp("events.csv");
    let out = sandbox2d()
        .arg("simulate")
        .arg(&scene)
        .args(["--steps", "120", "--json", "--events"])
        .arg(&events)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let csv = std::fs::read_to_string(&events).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("step,kind,a,b,impulse"));
    let rows: Vec<&str> = lines.collect();
    let count = |kind: &str| {
        rows.iter()
            .filter(|r| r.split(',').nth(1) == Some(kind))
            .count()
    };
    // the ball passes through the gate once and lands on the ground
    assert_eq!(count("sensor_begin"), 1, "{csv}");
    assert_eq!(count("sensor_end"), 1, "{csv}");
    assert!(count("begin") >= 1, "{csv}");
    // a name with a comma is quoted
    assert!(csv.contains("ball,\"gate, the\""), "{csv}");
    for kind in ["begin", "end", "sensor_begin", "sensor_end"] {
        assert_eq!(
            v["events"][kind].as_u64(),
            Some(count(kind) as u64),
            "{kind}"
        );
    }
    // without --events and without a sensor, nothing is recorded
    let out = sandbox2d()
        .args(["simulate", "pyramid", "--steps", "2", "--json"])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["events"].is_null());
}

/// `run --compare` checks its values as `render --compare` does, before any window
/// opens: 1 or 5 panes, or a value that is not solver flags, exit 2 with one line.
#[cfg(feature = "render")]
#[test]
fn run_refuses_bad_compare_with_one_line_and_exit_2() {
    let five: Vec<&str> = ["--compare", ""].repeat(5);
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--compare", "--solver pgs"], "2 to 4"),
        (five, "2 to 4"),
        (
            vec!["--compare", "--solver nope", "--compare", "--solver soft"],
            "nope",
        ),
    ];
    for (compare, names) in cases {
        let mut args = vec!["run", "pyramid", "--frames", "2"];
        args.extend(compare);
        let out = sandbox2d()
            .args(&args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: --compare"), "{args:?}: {err}");
        assert!(err.contains(names), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: one line: {err}");
        assert!(out.stdout.is_empty(), "{args:?}: nothing shown or written");
    }
}

/// `--compare` values that are not solver flags, and too few or too many panes, are
/// refused before anything is written: exit 2, one line naming --compare and the value.
#[cfg(feature = "render")]
#[test]
fn render_refuses_bad_compare_with_one_line_and_exit_2() {
    let dir = fresh_dir("render-bad-compare");
    let d = dir.join("frames").display().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["--compare", "--solver nope", "--compare", "--solver soft"],
            "nope",
        ),
        (
            vec!["--compare", "--bogus 3", "--compare", "--solver soft"],
            "--bogus",
        ),
        (
            vec!["--compare", "--iterations 0", "--compare", ""],
            "--iterations",
        ),
        (vec!["--compare", "--dt", "--compare", ""], "--dt"),
        (vec!["--compare", "pgs", "--compare", ""], "pgs"),
        (vec!["--compare", "--solver pgs"], "2 to 4"),
        (
            vec![
                "--compare",
                "",
                "--compare",
                "",
                "--compare",
                "",
                "--compare",
                "",
                "--compare",
                "",
            ],
            "2 to 4",
        ),
    ];
    for (compare, names) in cases {
        let mut args = vec!["render", "pyramid", "--frames", "2", "--out", &d];
        args.extend(compare);
        let out = sandbox2d()
            .args(&args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: --compare"), "{args:?}: {err}");
        assert!(err.contains(names), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: one line: {err}");
    }
    assert!(
        !dir.join("frames").exists(),
        "nothing written for bad input"
    );
}

/// `render --compare` writes frames of the panes side by side, the width shared.
#[cfg(feature = "render")]
#[test]
fn render_compare_writes_side_by_side_frames() {
    let dir = fresh_dir("render-compare");
    let frames = dir.join("frames");
    let gif = dir.join("c.gif");
    let out = sandbox2d()
        .args(["render", "pyramid", "--frames", "3", "--every", "2"])
        .args(["--size", "641x200", "--out"])
        .arg(&frames)
        .arg("--gif")
        .arg(&gif)
        .args(["--compare", "--solver pgs --iterations 4"])
        .args(["--compare", "--solver soft", "--dt", "0.01"])
        .output()
        .unwrap();
    if skipped_for_no_adapter(&out) {
        return;
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for k in 0..3 {
        let p = frames.join(format!("frame_{k:04}.png"));
        let img = image::open(&p).unwrap().to_rgba8();
        assert_eq!(img.dimensions(), (640, 200), "2 panes of 320");
    }
    assert!(gif.exists());
    assert!(stdout.contains("--solver pgs --iterations 4"), "{stdout}");
}

#[test]
fn threads_give_the_same_bits_and_bad_counts_are_refused() {
    // a pile big enough for the worker threads (the pool starts from 256 bodies)
    let scene = tmp("threads_pile.toml");
    std::fs::write(
        &scene,
        "name = \"pile\"\n[world]\ngravity = [0.0, -10.0]\n\
         [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [100.0, 2.0] }\nposition = [0.0, -1.0]\n\
         [[pyramid]]\nbase = 25\n",
    )
    .unwrap();
    let run = |threads: &str| {
        let out = sandbox2d()
            .args([
                "simulate",
                scene.to_str().unwrap(),
                "--steps",
                "20",
                "--json",
            ])
            .args(threads.split(' '))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let (one, two) = (run("--threads 1"), run("--threads 2 --fixed-threads"));
    assert_eq!(one["threads"]["allowed"], 1);
    assert_eq!(one["threads"]["parallel_jobs"], 0);
    assert_eq!(two["threads"]["allowed"], 2);
    assert_eq!(two["threads"]["adaptive"], false);
    assert_eq!(
        two["threads"]["steps_on_many"], 0,
        "a fixed count is not measured"
    );
    // without --fixed-threads the steps measure whether two threads pay, and take one
    // or two step by step: every step counted, the same bits
    let up_to = run("--threads 2");
    assert_eq!(up_to["threads"]["adaptive"], true);
    let counted = up_to["threads"]["steps_on_one"].as_u64().unwrap()
        + up_to["threads"]["steps_on_many"].as_u64().unwrap();
    assert_eq!(counted, 20, "{up_to}");
    assert_eq!(up_to["state_hash"], one["state_hash"]);
    assert!(
        two["threads"]["parallel_jobs"].as_u64().unwrap() > 20,
        "{two}"
    );
    // the cores' round trip is measured only with threads: null on one, and on two a
    // time (or null where the other core never answered in time)
    assert!(one["threads"]["core_round_trip_ns"].is_null(), "{one}");
    let rt = &two["threads"]["core_round_trip_ns"];
    assert!(
        rt.is_null() || rt.as_f64().is_some_and(|ns| ns > 1.0),
        "{two}"
    );
    assert_eq!(one["state_hash"], two["state_hash"]);
    for bad in ["0", "65", "x"] {
        let out = sandbox2d()
            .args(["simulate", "stack", "--steps", "1", "--threads", bad])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "--threads {bad}");
        assert!(out.stdout.is_empty());
        assert!(String::from_utf8_lossy(&out.stderr).contains("--threads"));
    }
}

/// `render --from-step K`: frame 0 is step K, whether the world there comes from a run
/// saved by `simulate --save-run` or from running the scene K steps; with `--compare`
/// every pane starts from that world (a branch at K) and goes on its own way.
#[cfg(feature = "render")]
#[test]
fn render_from_a_step_starts_every_pane_at_that_step() {
    let dir = fresh_dir("render-from-step");
    let run = dir.join("run.json");
    let saved = sandbox2d()
        .args(["simulate", "ball_and_chain", "--steps", "90", "--save-run"])
        .arg(&run)
        .output()
        .unwrap();
    assert!(
        saved.status.success(),
        "{}",
        String::from_utf8_lossy(&saved.stderr)
    );
    let render = |name: &str, extra: &[&str]| {
        let out_dir = dir.join(name);
        let out = sandbox2d()
            .args(["render", "ball_and_chain", "--size", "200x120", "--out"])
            .arg(&out_dir)
            .args(extra)
            .output()
            .unwrap();
        (out, out_dir)
    };
    let (out, from_run) = render(
        "from-run",
        &[
            "--frames",
            "1",
            "--from-step",
            "75",
            "--run",
            run.to_str().unwrap(),
        ],
    );
    if skipped_for_no_adapter(&out) {
        return;
    }
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("from step 75"));
    let (out, trunk) = render("trunk", &["--frames", "1", "--from-step", "75"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (out, start) = render("start", &["--frames", "1"]);
    assert!(out.status.success());
    let png = |d: &std::path::Path, k: u32| {
        image::open(d.join(format!("frame_{k:04}.png")))
            .unwrap()
            .to_rgba8()
    };
    assert_eq!(
        png(&from_run, 0),
        png(&trunk, 0),
        "the saved run's step 75 is the scene's"
    );
    assert_ne!(
        png(&from_run, 0),
        png(&start, 0),
        "the chain swung in 75 steps"
    );
    // two panes from step 75: alike at frame 0, apart once they go their own ways
    let (out, panes) = render(
        "panes",
        &[
            "--frames",
            "3",
            "--every",
            "15",
            "--from-step",
            "75",
            "--compare",
            "",
            "--compare",
            "--solver xpbd --substeps 1",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // the pixels that differ between the two panes, below the labels (which name each
    // pane's settings) and away from the divider
    let apart = |img: &image::RgbaImage| {
        let (w, h) = (img.width() / 2, img.height());
        let mut n = 0;
        for y in h / 3..h {
            for x in 3..w - 3 {
                let (a, b) = (img.get_pixel(x, y).0, img.get_pixel(x + w, y).0);
                if a.iter().zip(b).any(|(p, q)| p.abs_diff(q) > 16) {
                    n += 1;
                }
            }
        }
        n
    };
    assert_eq!(
        apart(&png(&panes, 0)),
        0,
        "both panes start from the same world"
    );
    assert!(
        apart(&png(&panes, 2)) > 20,
        "30 steps later the panes differ"
    );
    // a step outside the saved run: exit 2, naming the file
    let (out, _) = render(
        "past",
        &[
            "--frames",
            "1",
            "--from-step",
            "91",
            "--run",
            run.to_str().unwrap(),
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("run.json"));
}
