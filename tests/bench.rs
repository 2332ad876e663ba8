//! The bench's measures: monotone trade-offs, the residual, n/a rows, energy.

use glam::Vec2;
use sandbox2d::bench::{self, Budget, Outcome, Setting, Suite};
use sandbox2d::{BodyDef, BodyType, ShapeDef, SolverSettings, World};

fn scene(name: &str) -> bench::BenchScene {
    bench::scenes::suite(Suite::Standard)
        .into_iter()
        .find(|s| s.name == name)
        .expect("bench scene")
}

fn measured(o: Outcome) -> bench::Measured {
    match o {
        Outcome::Ran(m) => m,
        other => panic!("did not run: {other:?}"),
    }
}

const NO_RESIDUAL: Budget = Budget {
    steps: 300,
    repeats: 1,
    residual_samples: 0,
    reference_iterations: 0,
};

#[test]
fn more_pgs_iterations_never_deepen_the_base_20_pyramids_penetration() {
    let sc = scene("pyramid");
    for (warm, split) in [(true, true), (false, false)] {
        let mut last: Option<(u32, f64)> = None;
        for n in bench::GRID_COUNTS {
            let m = measured(bench::run_case(
                &sc,
                &Setting::pgs(n, warm, split),
                &NO_RESIDUAL,
            ));
            if let Some((k, p)) = last {
                assert!(
                    m.penetration_max <= p,
                    "warm {warm} split {split}: {n} sweeps overlap {} m, deeper than {k} sweeps' {p} m",
                    m.penetration_max
                );
            }
            last = Some((n, m.penetration_max));
        }
        // and the deepest overlap at 32 sweeps is a few slops at most
        assert!(last.unwrap().1 < 4.0 * 0.005, "{last:?}");
    }
}

#[test]
fn more_xpbd_substeps_never_worsen_the_pendulums_energy_drift() {
    let sc = scene("pendulum");
    let budget = Budget {
        steps: 600,
        ..NO_RESIDUAL
    };
    let mut last: Option<(u32, f64)> = None;
    for n in bench::GRID_COUNTS {
        let m = measured(bench::run_case(&sc, &Setting::xpbd(n), &budget));
        let drift = m.energy_drift.abs();
        assert!(drift.is_finite());
        if let Some((k, d)) = last {
            assert!(
                drift <= d,
                "{n} substeps drift {drift}, worse than {k} substeps' {d}"
            );
        }
        last = Some((n, drift));
    }
    // 32 substeps of 1/1920 s: the pendulum keeps its energy within 1%
    assert!(last.unwrap().1 < 0.01, "{last:?}");
}

#[test]
fn the_residual_falls_with_sweeps_and_vanishes_for_the_reference_itself() {
    let sc = scene("pyramid");
    let budget = Budget {
        steps: 60,
        repeats: 1,
        residual_samples: 3,
        reference_iterations: 200,
    };
    let one = measured(bench::run_case(&sc, &Setting::pgs(1, true, true), &budget));
    let many = measured(bench::run_case(&sc, &Setting::pgs(32, true, true), &budget));
    assert!(one.residual > 0.1, "{}", one.residual);
    assert!(
        many.residual < one.residual / 10.0,
        "{} vs {}",
        many.residual,
        one.residual
    );
    // the reference setting against itself: the same sweeps from the same state
    let same = measured(bench::run_case(
        &sc,
        &Setting::pgs(200, true, true),
        &budget,
    ));
    assert!(same.residual < 1e-6, "{}", same.residual);
}

#[test]
fn a_resting_box_s_converged_lambdas_carry_its_weight() {
    // sum of normal lambdas (impulses) per step = m g dt for a box at rest
    let mut s = SolverSettings::pgs();
    s.iterations = 200;
    s.tolerance = 0.0;
    s.sleep = false;
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), s);
    w.create_body(&BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 10.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        ..Default::default()
    })
    .unwrap();
    w.create_body(&BodyDef {
        name: "box".into(),
        shape: ShapeDef::Box {
            width: 1.0,
            height: 1.0,
        },
        density: 2.0,
        position: Vec2::new(0.0, 0.5),
        ..Default::default()
    })
    .unwrap();
    for _ in 0..60 {
        w.step().unwrap();
    }
    let mut lam = Vec::new();
    w.contact_lambdas(&mut lam);
    assert_eq!(lam.len(), 4, "two points, normal and friction each");
    let normal: f32 = lam.iter().step_by(2).sum();
    let weight_impulse = 2.0 * 10.0 / 60.0;
    assert!(
        (normal - weight_impulse).abs() < 1e-3 * weight_impulse,
        "{normal} vs {weight_impulse}"
    );
    // and a clone steps to the same state, bit for bit
    let mut c = w.clone();
    w.step().unwrap();
    c.step().unwrap();
    assert_eq!(w.state_hash(), c.state_hash());
}

#[test]
fn both_solvers_run_stacks_and_joints_and_a_build_failure_is_na() {
    let sc = scene("pyramid");
    let budget = Budget {
        steps: 5,
        ..NO_RESIDUAL
    };
    // XPBD on the pyramid: 5 steps from rest, stable, no box deeper than the suite's
    // overlap bound, and the tracked top box moved no further than a free fall of 5
    // steps (1/2 g t^2 = 0.035 m).
    let xpbd = measured(bench::run_case(&sc, &Setting::xpbd(4), &budget));
    assert_eq!(xpbd.steps, 5);
    assert!(xpbd.verdict.is_stable(), "{xpbd:?}");
    assert!(
        (0.0..0.05).contains(&xpbd.penetration_max),
        "{}",
        xpbd.penetration_max
    );
    let t = 5.0 / 60.0;
    assert!(xpbd.drift <= 0.5 * 10.0 * t * t, "{}", xpbd.drift);
    // PGS on the distance-joint pendulum: the joint holds and the energy is kept
    let pendulum = scene("pendulum");
    let row = measured(bench::run_case(
        &pendulum,
        &Setting::pgs(4, true, true),
        &budget,
    ));
    assert_eq!(row.steps, 5);
    assert!(row.verdict.is_stable(), "{row:?}");
    assert!(row.joint_error < 0.01, "{}", row.joint_error);
    assert!(row.energy_drift.abs() < 0.01, "{}", row.energy_drift);
    let csv = bench::report::csv(&[bench::Row {
        scene: "pendulum".into(),
        setting: Setting::xpbd(4),
        outcome: Outcome::Failed("no such body".into()),
    }]);
    assert!(csv.lines().nth(1).unwrap().contains(",n/a (build failed),"));
}

#[test]
fn energy_is_kinetic_plus_potential_above_the_floor() {
    // E = m g h + 1/2 m v^2 for a ball of mass m at height h moving at v
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::pgs());
    let b = w
        .create_body(&BodyDef {
            name: "ball".into(),
            shape: ShapeDef::Circle { radius: 0.5 },
            mass: Some(3.0),
            position: Vec2::new(7.0, 2.5),
            velocity: Vec2::new(3.0, -4.0),
            ..Default::default()
        })
        .unwrap();
    let e = bench::energy_about(&w, 0.5);
    assert!(
        (e - (3.0 * 10.0 * 2.0 + 0.5 * 3.0 * 25.0)).abs() < 1e-9,
        "{e}"
    );
    // semi-implicit Euler in free fall: v' = v + g h, x' = x + h v' changes the energy
    // by exactly -1/2 m |g|^2 h^2 a step
    let e0 = bench::energy_about(&w, 0.0);
    for _ in 0..30 {
        w.step().unwrap();
    }
    let e1 = bench::energy_about(&w, 0.0);
    let expect = -30.0 * 0.5 * 3.0 * 100.0 / (60.0 * 60.0);
    assert!((e1 - e0 - expect).abs() < 1e-3, "{} vs {expect}", e1 - e0);
    assert!(w.body(b).unwrap().position.y < 2.5);
}

mod common;
use common::cli::{sandbox2d, tmp};

/// Runs `sandbox2d bench` on the pendulum (36 settings, 1 repeat, 6 steps unless `extra`
/// says) with `extra` flags into a fresh folder `name`; returns the folder and the one
/// line printed.
fn bench_pendulum(name: &str, extra: &[&str]) -> (std::path::PathBuf, String) {
    let dir = tmp(name);
    let _ = std::fs::remove_dir_all(&dir);
    let out = sandbox2d()
        .args(["bench", "--suite", "quick", "--filter", "pendulum"])
        .args(["--repeats", "1"])
        .args(if extra.contains(&"--steps") {
            &[][..]
        } else {
            &["--steps", "6"][..]
        })
        .args(extra)
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{extra:?}: {err}");
    assert!(err.is_empty(), "{extra:?}: {err}");
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 1, "{text}");
    (dir, text)
}

/// results.csv without its timing columns (ms_*): every other column, row by row.
fn csv_without_timings(dir: &std::path::Path) -> Vec<String> {
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !header[i].starts_with("ms_"))
        .collect();
    assert!(keep.len() < header.len() && keep.len() > 10, "{header:?}");
    csv.lines()
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            keep.iter()
                .map(|&i| cells.get(i).copied().unwrap_or(""))
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}

/// results.md without its timing figures: the tables' ms/step and solve ms cells are
/// blanked, and the "not dominated" lists (which rank by cost) left out.
fn markdown_without_timings(dir: &std::path::Path) -> Vec<String> {
    let md = std::fs::read_to_string(dir.join("results.md")).unwrap();
    md.lines()
        .filter(|l| !l.starts_with("- "))
        .map(|l| {
            if l.starts_with("| ") {
                let mut cells: Vec<&str> = l.split('|').collect();
                for c in cells.iter_mut().skip(2).take(2) {
                    *c = "";
                }
                cells.join("|")
            } else {
                l.to_string()
            }
        })
        .collect()
}

#[test]
fn jobs_2_writes_the_same_rows_in_the_same_order_as_jobs_1() {
    let (one, _) = bench_pendulum("jobs-1", &["--jobs", "1"]);
    let (two, said) = bench_pendulum("jobs-2", &["--jobs", "2"]);
    assert!(said.contains("(36 rows)"), "{said}");
    let (a, b) = (csv_without_timings(&one), csv_without_timings(&two));
    // the header and the 36 rows, the grid's order: PGS warm+split 1 sweep first
    assert_eq!(a.len(), 37);
    assert!(a[1].starts_with("pendulum,pgs,1,1,true,true,"), "{}", a[1]);
    // the soft step at the scenes' own count: 1 sweep a substep
    assert!(a[36].starts_with("pendulum,soft,1,32,"), "{}", a[36]);
    assert_eq!(a, b);
    let md = markdown_without_timings(&one);
    assert!(md.iter().any(|l| l.starts_with("| xpbd 4 substeps |")));
    assert_eq!(md, markdown_without_timings(&two));
    assert!(two.join("pendulum.svg").exists());
    assert!(!two.join("results.partial.csv").exists());
}

#[test]
fn shards_merge_into_the_results_of_one_unsharded_run() {
    let (whole, _) = bench_pendulum("shard-whole", &[]);
    let (parts, said) = bench_pendulum("shard-parts", &["--shard", "1/2"]);
    assert!(said.contains("shard 1/2: 18 of 36 cases"), "{said}");
    let (again, _) = bench_pendulum("shard-parts-2", &["--shard", "2/2", "--jobs", "2"]);
    // a shard writes its file, not the reports
    let second = parts.join("results.shard-2-of-2.json");
    std::fs::copy(again.join("results.shard-2-of-2.json"), &second).unwrap();
    assert!(!parts.join("results.csv").exists());
    assert!(!parts.join("results.md").exists());
    let first = std::fs::read_to_string(parts.join("results.shard-1-of-2.json")).unwrap();
    assert!(first.contains("\"case\": 0,") && !first.contains("\"case\": 1,"));
    let merged = tmp("shard-merged");
    let _ = std::fs::remove_dir_all(&merged);
    // the shards in reverse order: the merged rows still come in the run's order
    let out = sandbox2d()
        .args(["bench", "--merge"])
        .arg(&second)
        .arg(parts.join("results.shard-1-of-2.json"))
        .arg("--out")
        .arg(&merged)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("(36 rows)"));
    assert_eq!(csv_without_timings(&whole), csv_without_timings(&merged));
    assert_eq!(
        markdown_without_timings(&whole),
        markdown_without_timings(&merged)
    );
    assert!(merged.join("pendulum.svg").exists());
    // a folder of shards merges the same
    let from_dir = tmp("shard-merged-dir");
    let _ = std::fs::remove_dir_all(&from_dir);
    let out = sandbox2d()
        .args(["bench", "--merge"])
        .arg(&parts)
        .arg("--out")
        .arg(&from_dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(
        std::fs::read_to_string(merged.join("results.csv")).unwrap(),
        std::fs::read_to_string(from_dir.join("results.csv")).unwrap(),
        "the same shards merge to the same bytes"
    );
}

/// Runs `sandbox2d bench` expecting a refusal: exit 2 and one line, returned.
fn refused(args: &[&str]) -> String {
    let out = sandbox2d().args(args).output().unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    assert!(err.starts_with("error: "), "{err}");
    err
}

#[test]
fn bad_shard_and_jobs_values_are_refused_with_one_line_and_exit_2() {
    let dir = tmp("shard-bad");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().unwrap();
    for bad in ["0/3", "4/3", "x/y", "1/0", "3", "-1/3", "1/2/3", ""] {
        let err = refused(&["bench", "--filter", "pendulum", "--shard", bad, "--out", d]);
        assert!(err.starts_with("error: --shard"), "{bad}: {err}");
    }
    let err = refused(&["bench", "--filter", "pendulum", "--jobs", "0", "--out", d]);
    assert!(err.contains("--jobs"), "{err}");
    assert!(!dir.exists(), "refused before writing anything");
}

#[test]
fn merge_refuses_a_missing_duplicated_or_foreign_shard() {
    let (dir, _) = bench_pendulum("merge-bad", &["--shard", "1/3"]);
    let (other, _) = bench_pendulum("merge-bad-steps", &["--shard", "2/3", "--steps", "7"]);
    let one = dir.join("results.shard-1-of-3.json");
    let out = tmp("merge-bad-out");
    let _ = std::fs::remove_dir_all(&out);
    let o = out.to_str().unwrap();
    let (p1, p2) = (
        one.to_str().unwrap(),
        other.join("results.shard-2-of-3.json"),
    );
    let err = refused(&["bench", "--merge", p1, "--out", o]);
    assert!(err.contains("shard 2/3, 3/3 missing"), "{err}");
    let err = refused(&["bench", "--merge", p1, p1, "--out", o]);
    assert!(err.contains("shard 1/3 is given twice"), "{err}");
    let err = refused(&["bench", "--merge", p1, p2.to_str().unwrap(), "--out", o]);
    assert!(err.contains("different runs: steps 7 vs 6"), "{err}");
    let err = refused(&["bench", "--merge", "no-such-shard.json", "--out", o]);
    assert!(err.contains("no-such-shard.json: cannot read"), "{err}");
    assert!(!out.join("results.csv").exists());
}

#[test]
fn extremes_shards_and_jobs_write_the_same_stability_table() {
    // stability.md has no timings: every way of running the sweep writes the same bytes
    let run = |name: &str, extra: &[&str]| {
        let dir = tmp(name);
        let out = sandbox2d()
            .args(["bench", "--suite", "extremes", "--filter", "tunneling"])
            .args(extra)
            .arg("--out")
            .arg(&dir)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        dir
    };
    let _ = std::fs::remove_dir_all(tmp("ext-parts"));
    let whole = run("ext-whole", &[]);
    let threads = run("ext-jobs", &["--jobs", "3"]);
    for i in 1..=3 {
        run("ext-parts", &["--shard", &format!("{i}/3")]);
    }
    assert!(!tmp("ext-parts").join("stability.md").exists());
    let merged = tmp("ext-merged");
    let _ = std::fs::remove_dir_all(&merged);
    let out = sandbox2d()
        .args(["bench", "--merge"])
        .arg(tmp("ext-parts"))
        .arg("--out")
        .arg(&merged)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = std::fs::read_to_string(whole.join("stability.md")).unwrap();
    assert!(table.contains("| tunneling | PGS 10 |"), "{table}");
    for dir in [threads, merged] {
        assert_eq!(
            std::fs::read_to_string(dir.join("stability.md")).unwrap(),
            table,
            "{}",
            dir.display()
        );
    }
}

#[test]
fn the_scaling_suite_times_1_and_2_threads_to_the_same_bits() {
    let dir = tmp("scaling-1k");
    let _ = std::fs::remove_dir_all(&dir);
    let out = sandbox2d()
        .args(["bench", "--suite", "scaling", "--filter", "1k"])
        .args(["--steps", "3", "--repeats", "2"])
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.is_empty(), "{err}");
    let said = String::from_utf8(out.stdout).unwrap();
    assert!(said.contains("scaling.csv"), "{said}");
    let csv = std::fs::read_to_string(dir.join("scaling.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let threads: Vec<&str> = rows.iter().map(|r| r[col("threads")]).collect();
    assert!(threads.starts_with(&["1", "2"]), "{csv}");
    for r in &rows {
        assert_eq!(r[col("size")], "1k", "{csv}");
        assert_eq!(r[col("bodies")], "1035", "{csv}");
        assert_eq!(r[col("steps")], "3", "{csv}");
        let ms: f64 = r[col("ms_per_step")].parse().unwrap();
        assert!(ms > 0.0 && ms.is_finite(), "{csv}");
        let contacts: f64 = r[col("contacts")].parse().unwrap();
        assert!(contacts > 1000.0, "a standing pyramid touches: {csv}");
        assert_eq!(r[col("state_hash")], rows[0][col("state_hash")], "{csv}");
        assert_eq!(r[col("same_bits")], "yes", "{csv}");
    }
    assert_eq!(rows[0][col("speedup")], "1.0000", "{csv}");
    let md = std::fs::read_to_string(dir.join("scaling.md")).unwrap();
    assert!(
        md.contains("| 1k | 1035 | 2 | 3 |") && md.contains("- 1k: "),
        "{md}"
    );
    let svg = std::fs::read_to_string(dir.join("scaling.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("2 threads"),
        "{svg}"
    );
}

#[test]
fn the_contention_suite_times_threads_idle_and_busy_to_the_same_bits() {
    let dir = tmp("contention-large");
    let _ = std::fs::remove_dir_all(&dir);
    let out = sandbox2d()
        .args(["bench", "--suite", "contention", "--filter", "large"])
        .args(["--steps", "3", "--repeats", "1"])
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let csv = std::fs::read_to_string(dir.join("contention.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    // idle and busy, each at the four thread settings, the same state at the end
    assert_eq!(rows.len(), 8, "{csv}");
    for (r, load) in rows.iter().zip(["idle"; 4].into_iter().chain(["busy"; 4])) {
        assert_eq!(r[col("scene")], "large_pyramid", "{csv}");
        assert_eq!(r[col("load")], load, "{csv}");
        assert_eq!(r[col("same_bits")], "yes", "{csv}");
        let ms: f64 = r[col("mean_ms")].parse().unwrap();
        assert!(ms > 0.0 && ms.is_finite(), "{csv}");
    }
    assert_eq!(rows[0][col("over_one_thread")], "1.0000", "{csv}");
    let md = std::fs::read_to_string(dir.join("contention.md")).unwrap();
    assert!(md.contains("- large_pyramid: idle "), "{md}");
    // the busy process is gone with the suite
    std::thread::sleep(std::time::Duration::from_millis(200));
    let busy = std::process::Command::new("pgrep")
        .args(["-f", "sandbox2d busy-loop"])
        .output();
    if let Ok(b) = busy {
        assert!(b.stdout.is_empty(), "a busy process outlived the suite");
    }
}

#[test]
fn the_scaling_suite_refuses_jobs_shard_and_an_unknown_size() {
    let dir = tmp("scaling-bad");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().unwrap();
    let err = refused(&["bench", "--suite", "scaling", "--jobs", "2", "--out", d]);
    assert!(err.contains("--jobs"), "{err}");
    let err = refused(&["bench", "--suite", "scaling", "--shard", "1/2", "--out", d]);
    assert!(err.contains("--shard"), "{err}");
    let err = refused(&["bench", "--suite", "scaling", "--filter", "3k", "--out", d]);
    assert!(err.contains("3k"), "{err}");
    assert!(!dir.exists(), "refused before writing anything");
}

/// Runs `bench --suite box2d --filter tumbler` (2,027 bodies) for 8 steps with `extra`
/// into a fresh folder `name`; returns the folder and what it printed.
fn bench_box2d(name: &str, extra: &[&str]) -> (std::path::PathBuf, String) {
    let dir = tmp(name);
    let _ = std::fs::remove_dir_all(&dir);
    let out = sandbox2d()
        .args([
            "bench", "--suite", "box2d", "--filter", "tumbler", "--steps", "8",
        ])
        .args(extra)
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{extra:?}: {err}");
    assert!(err.is_empty(), "{extra:?}: {err}");
    (dir, String::from_utf8(out.stdout).unwrap())
}

/// box2d.csv's rows as columns by name.
fn box2d_rows(dir: &std::path::Path) -> Vec<std::collections::HashMap<String, String>> {
    let csv = std::fs::read_to_string(dir.join("box2d.csv")).unwrap();
    let header: Vec<String> = csv
        .lines()
        .next()
        .unwrap()
        .split(',')
        .map(String::from)
        .collect();
    csv.lines()
        .skip(1)
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

#[test]
fn the_box2d_suite_runs_a_scene_on_1_and_2_threads_to_the_same_bits() {
    let (dir, said) = bench_box2d("box2d-tumbler", &[]);
    assert!(
        said.contains("box2d.csv") && said.contains("(2 rows)"),
        "{said}"
    );
    let rows = box2d_rows(&dir);
    assert_eq!(rows.len(), 2);
    for (r, threads) in rows.iter().zip(["1", "2"]) {
        assert_eq!(r["scene"], "tumbler");
        assert_eq!(r["threads"], threads);
        assert_eq!(r["steps"], "8");
        assert_eq!(r["bodies"], "2026", "2025 boxes and the drum");
        assert_eq!(r["figure"], "escaped");
        assert_eq!(r["accuracy"], "0e0", "no box left the drum in 8 steps");
        for ms in ["ms_median", "ms_mean"] {
            let x: f64 = r[ms].parse().unwrap();
            assert!(x > 0.0 && x.is_finite(), "{ms} {x}");
        }
        assert_eq!(
            r["state_hash"], rows[0]["state_hash"],
            "the same bits on 2 threads"
        );
    }
    let md = std::fs::read_to_string(dir.join("box2d.md")).unwrap();
    assert!(
        md.contains("| tumbler | 2 | 8 |") && md.contains("- tumbler: "),
        "{md}"
    );
    let svg = std::fs::read_to_string(dir.join("box2d.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("2 threads"),
        "{svg}"
    );
}

#[test]
fn box2d_shards_merge_into_the_rows_of_one_run() {
    let (whole, _) = bench_box2d("box2d-whole", &[]);
    let (one, said) = bench_box2d("box2d-shard-1", &["--shard", "1/2"]);
    assert!(said.contains("shard 1/2: 1 of 2 cases"), "{said}");
    let (two, _) = bench_box2d("box2d-shard-2", &["--shard", "2/2", "--jobs", "2"]);
    let merged = tmp("box2d-merged");
    let _ = std::fs::remove_dir_all(&merged);
    let out = sandbox2d()
        .args(["bench", "--merge"])
        .arg(two.join("results.shard-2-of-2.json"))
        .arg(one.join("results.shard-1-of-2.json"))
        .arg("--out")
        .arg(&merged)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let strip = |rows: Vec<std::collections::HashMap<String, String>>| -> Vec<Vec<String>> {
        rows.into_iter()
            .map(|r| {
                let mut v: Vec<String> = r
                    .into_iter()
                    .filter(|(k, _)| !k.ends_with("_ms") && !k.starts_with("ms_"))
                    .map(|(k, v)| format!("{k}={v}"))
                    .collect();
                v.sort();
                v
            })
            .collect()
    };
    assert_eq!(strip(box2d_rows(&whole)), strip(box2d_rows(&merged)));
}

#[test]
fn the_box2d_suite_refuses_an_unknown_scene_with_one_line_and_exit_2() {
    let dir = tmp("box2d-bad");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().unwrap();
    let err = refused(&[
        "bench", "--suite", "box2d", "--filter", "pyramidz", "--out", d,
    ]);
    assert!(err.contains("pyramidz") && err.contains("washer"), "{err}");
    assert!(!dir.exists(), "refused before writing anything");
}
