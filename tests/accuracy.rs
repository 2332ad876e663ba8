//! Accuracy against the true motion: the convergence suite's orders checked against
//! theory, and the trajectory error (`--metric trajectory`) checked against the closed
//! forms.

use sandbox2d::SolverKind;
use sandbox2d::bench::convergence;

mod common;
use common::cli::{sandbox2d, tmp};

/// The fitted order of `kind` on the convergence suite's `scene`.
fn order(scene: &str, kind: SolverKind) -> convergence::Series {
    let sc = convergence::scenes(Some(scene)).remove(0);
    convergence::run(&sc, kind).unwrap()
}

/// Semi-implicit Euler (every solver's integrator: v += h (g + F/m), x += h v, with the
/// drag taken implicitly) is first order: the error of the projectile halves with dt.
/// The bound 0.25 tells order 1 from 2 (and from 1/2).
#[test]
fn semi_implicit_euler_is_first_order_on_the_projectile() {
    for kind in SolverKind::ALL {
        let s = order("projectile_drag", kind);
        let f = s
            .fit
            .unwrap_or_else(|| panic!("{kind:?}: no fit: {:?}", s.levels));
        assert!(f.used >= 3, "{kind:?}: {f:?}");
        assert!(
            (f.order - 1.0).abs() < 0.25,
            "{kind:?}: order {f:?} {:?}",
            s.levels
        );
        // and level by level while the error is the method's: halving dt halves it
        for (w, p) in s
            .levels
            .windows(2)
            .zip(convergence::local_orders(&s.levels))
        {
            if p.is_finite() {
                let ratio = w[0].error / w[1].error;
                assert!(
                    (1.7..2.3).contains(&ratio),
                    "{kind:?}: {ratio} at dt {}",
                    w[1].dt
                );
            }
        }
    }
    // one substep of PGS is the plain step: without drag its error would be g t h / 2
    // exactly; with the drag's e^(-t/2) the worst error over 2 s at h = 1/15 s is
    // close to that bound (10 x 2 / 15 / 2 = 0.67 m) times the drag's slowing
    let s = order("projectile_drag", SolverKind::Pgs);
    let e0 = s.levels[0].error;
    assert!((0.1..0.67).contains(&e0), "{e0}");
}

/// The pendulum released horizontal, against its exact motion (Jacobi's sn): the
/// constrained step is first order too under each solver.
#[test]
fn the_pendulum_is_first_order_under_every_solver() {
    for kind in SolverKind::ALL {
        let s = order("pendulum", kind);
        let f = s
            .fit
            .unwrap_or_else(|| panic!("{kind:?}: no fit: {:?}", s.levels));
        assert!(f.used >= 3, "{kind:?}: {f:?}");
        assert!(
            (f.order - 1.0).abs() < 0.25,
            "{kind:?}: order {f:?} {:?}",
            s.levels
        );
    }
}

#[test]
fn the_convergence_suite_writes_its_table_and_plot() {
    let dir = tmp("convergence");
    let _ = std::fs::remove_dir_all(&dir);
    let out = sandbox2d()
        .args([
            "bench",
            "--suite",
            "convergence",
            "--filter",
            "pendulum",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let md = std::fs::read_to_string(dir.join("convergence.md")).unwrap();
    assert!(md.contains("| pendulum |"), "{md}");
    assert!(md.contains("Jacobi"), "the closed form is named: {md}");
    let svg = std::fs::read_to_string(dir.join("convergence.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("order"), "{svg}");
    let csv = std::fs::read_to_string(dir.join("convergence.csv")).unwrap();
    // a header and 3 solvers x 7 levels
    assert_eq!(csv.lines().count(), 1 + 3 * convergence::LEVELS, "{csv}");
    // a filter that matches nothing, and the options that do not apply: exit 2
    for args in [
        vec!["--filter", "nothing"],
        vec!["--jobs", "2"],
        vec!["--shard", "1/2"],
    ] {
        let out = sandbox2d()
            .args(["bench", "--suite", "convergence", "--out"])
            .arg(&dir)
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}

// ---- the trajectory error ----

use sandbox2d::bench::truth::{Exact, RefSpec, Reference, Truth};
use sandbox2d::bench::{Budget, Outcome, Setting};

/// The bench's scene of a file's text, as `tune` runs it.
fn bench_scene(text: &str, name: &str, steps: u64) -> sandbox2d::bench::BenchScene {
    let def = sandbox2d::scene::load_str(text, name).unwrap().world;
    sandbox2d::bench::tune::bench_scene(name, &def, steps)
}

/// Each setting's RMS position error against `truth`.
fn errors(sc: &sandbox2d::bench::BenchScene, truth: Truth, settings: &[Setting]) -> Vec<f64> {
    let mut sc = sc.clone();
    sc.truth = Some(std::sync::Arc::new(truth));
    let budget = Budget {
        repeats: 1,
        ..sc.budget
    };
    settings
        .iter()
        .map(|s| match sandbox2d::bench::run_case(&sc, s, &budget) {
            Outcome::Ran(m) => {
                m.trajectory
                    .unwrap_or_else(|| panic!("{}: not measured: {m:?}", s.label()))
                    .pos_rms
            }
            o => panic!("{}: {o:?}", s.label()),
        })
        .collect()
}

/// Settings of every solver whose errors differ: substeps 1 to 8, and PGS's sweeps.
fn ladder() -> Vec<Setting> {
    let mut v = Vec::new();
    for n in [1, 2, 4, 8] {
        v.push(Setting::soft(n, 2));
        v.push(Setting::xpbd(n));
    }
    v.push(Setting::pgs(2, true, true));
    v.push(Setting::pgs(10, true, true));
    v
}

/// Ranks settings by their error against the scene's closed form and against a
/// reference run (converged PGS at a 16th of the step): every pair the closed form
/// tells apart by more than 20% is ordered the same way by the reference.
fn check_ranks_like_the_closed_form(text: &str, name: &str, steps: u64) {
    let sc = bench_scene(text, name, steps);
    let w = sandbox2d::World::from_def(&sc.def, sc.def.solver.resolve()).unwrap();
    let horizon = steps as f64 * w.settings.dt as f64;
    let exact = Exact::of(&w, horizon).unwrap();
    let reference = Reference::run(&sc.def, RefSpec::CONVERGED_PGS, steps).unwrap();
    assert!(reference.trusted(), "{name}: {reference:?}");
    let settings = ladder();
    let by_exact = errors(&sc, Truth::Exact(exact), &settings);
    let by_reference = errors(&sc, Truth::Reference(reference), &settings);
    let mut pairs = 0;
    for i in 0..settings.len() {
        for j in 0..settings.len() {
            if by_exact[i] < 0.8 * by_exact[j] {
                pairs += 1;
                assert!(
                    by_reference[i] < by_reference[j],
                    "{name}: {} ({:.3e} exact, {:.3e} reference) against {} ({:.3e}, {:.3e})",
                    settings[i].label(),
                    by_exact[i],
                    by_reference[i],
                    settings[j].label(),
                    by_exact[j],
                    by_reference[j]
                );
            }
        }
    }
    // the ladder spreads the errors: most pairs are told apart
    assert!(
        pairs >= 25,
        "{name}: only {pairs} pairs told apart: {by_exact:?}"
    );
}

#[test]
fn trajectory_error_ranks_settings_as_the_closed_form_does_on_the_pendulum() {
    check_ranks_like_the_closed_form(
        include_str!("../assets/bench/pendulum.toml"),
        "pendulum",
        300,
    );
}

#[test]
fn trajectory_error_ranks_settings_as_the_closed_form_does_on_the_rolling_disk() {
    check_ranks_like_the_closed_form(
        include_str!("../assets/bench/rolling_disk.toml"),
        "rolling_disk",
        120,
    );
}

/// `bench --metric trajectory`: each scene's report names what its runs were compared
/// with: a closed form, a reference run, or why neither (chaotic over the run).
#[test]
fn the_bench_report_names_each_scenes_truth() {
    let dir = tmp("bench-trajectory");
    let run = |filter: &str, steps: &str| {
        let out_dir = dir.join(filter);
        let out = sandbox2d()
            .args(["bench", "--suite", "quick", "--metric", "trajectory"])
            .args([
                "--filter",
                filter,
                "--steps",
                steps,
                "--repeats",
                "1",
                "--out",
            ])
            .arg(&out_dir)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (
            std::fs::read_to_string(out_dir.join("results.md")).unwrap(),
            std::fs::read_to_string(out_dir.join("results.csv")).unwrap(),
        )
    };
    let (md, csv) = run("pendulum", "120");
    assert!(
        md.contains("Trajectory error against the closed form: a point mass on a rigid rod"),
        "{md}"
    );
    // the trajectory columns are filled for every row of the pendulum
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|c| *c == "trajectory_rms").unwrap();
    for row in csv.lines().skip(1) {
        let v: f64 = row.split(',').nth(col).unwrap().parse().unwrap();
        assert!(v > 0.0 && v < 1.0, "{row}");
    }
    let (md, _) = run("stack", "120");
    assert!(
        md.contains("Trajectory error against the reference run: PGS at dt/16"),
        "{md}"
    );
    let (md, _) = run("particles", "300");
    assert!(
        md.contains("Trajectory error: not measured: chaotic"),
        "{md}"
    );
    // not for the other suites, and not sharded
    for args in [
        vec!["--suite", "extremes"],
        vec!["--suite", "quick", "--shard", "1/2"],
    ] {
        let out = sandbox2d()
            .args(["bench", "--metric", "trajectory", "--out"])
            .arg(dir.join("refused"))
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}

/// `tune --metric trajectory` picks by the error against the closed form, and refuses
/// a scene whose motion is chaotic over the run.
#[test]
fn tune_picks_by_the_trajectory_error() {
    let out = sandbox2d()
        .args(["tune", "assets/bench/pendulum.toml", "--budget-ms", "5"])
        .args([
            "--metric",
            "trajectory",
            "--steps",
            "120",
            "--rounds",
            "1",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["truth"].as_str().unwrap().contains("Jacobi"), "{v}");
    let pick = v["pick"]["score"].as_f64().unwrap();
    // the pick is the smallest error among the stable settings within the budget
    let best = v["tried"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|t| t["ms_per_step"].as_f64().is_some_and(|ms| ms <= 5.0))
        .filter_map(|t| t["score"].as_f64())
        .fold(f64::INFINITY, f64::min);
    assert_eq!(pick, best);
    assert!(pick > 0.0 && pick < 0.01, "{pick}");
    let out = sandbox2d()
        .args([
            "tune",
            "particles",
            "--budget-ms",
            "5",
            "--metric",
            "trajectory",
        ])
        .args(["--steps", "300", "--rounds", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("chaotic") && err.contains("particles"),
        "{err}"
    );
}
