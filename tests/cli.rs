//! The command line as a user runs it: exit codes, messages, --json and --trace.

use std::process::Command;

fn sandbox2d() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sandbox2d"))
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("sandbox2d-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

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
    assert_eq!(v["solver"]["kind"], "pgs");
    assert_eq!(v["solver"]["iterations"], 7);
    assert_eq!(v["solver"]["warm_start"], false);
    for key in ["median", "mean", "p95"] {
        assert!(v["ms_per_step"][key].as_f64().unwrap() > 0.0);
    }
    assert!(v["contacts"]["max"].as_u64().unwrap() >= 2);
    assert!(v["iterations"]["mean"].as_f64().unwrap() <= 7.0);
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

#[test]
fn bench_writes_csv_markdown_and_plots_quietly() {
    let dir = tmp("bench-out");
    let _ = std::fs::remove_dir_all(&dir);
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
    // 24 PGS settings and 6 XPBD settings of the one scene "stack"
    assert_eq!(rows.len(), 30);
    let stable = header.iter().position(|c| *c == "stable").unwrap();
    let ms = header.iter().position(|c| *c == "ms_per_step").unwrap();
    for r in &rows {
        assert_eq!(r[0], "stack");
        assert!(
            ["yes", "no", "n/a (unsupported)"].contains(&r[stable]),
            "{r:?}"
        );
        if r[1] == "pgs" {
            assert!(r[ms].parse::<f64>().unwrap() > 0.0, "{r:?}");
        }
    }
    let md = std::fs::read_to_string(dir.join("results.md")).unwrap();
    assert!(md.contains("## stack") && md.contains("Not dominated"));
    let svg = std::fs::read_to_string(dir.join("stack.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("PGS warm+split"));
}

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
