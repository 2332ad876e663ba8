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
