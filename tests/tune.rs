//! `sandbox2d tune`: its pick checked against a full run of the bench's grid, its
//! refusals, and `--write`.

use sandbox2d::bench::tune::{self, TuneMetric, TuneOptions};
use sandbox2d::bench::{Budget, Outcome, Setting, Verdict, run_case, settings_grid};

mod common;
use common::cli::{sandbox2d, tmp};

/// Runs `tune` with a budget every setting fits, then the whole grid on its own, and
/// checks that no stable grid setting is more accurate than the pick, by the pick's own
/// measure.
fn check_pick_beats_the_grid(scene: &str, metric: TuneMetric, steps: u64) {
    let def = sandbox2d::scene::load(scene).unwrap().world;
    let options = TuneOptions {
        budget_ms: 1e9,
        metric,
        steps,
        rounds: 1,
        jobs: 1,
    };
    let report = tune::tune(scene, &def, &options, |_, _, _| {}).unwrap();
    let pick = &report.tried[report.pick.expect("a pick within a huge budget")];
    let pick_score = pick.score.unwrap();
    let m = pick.measured().unwrap();
    assert!(m.verdict.is_stable(), "{scene}: picked an unstable setting");

    // the grid, run apart from tune
    let bench_scene = tune::bench_scene(scene, &def, steps);
    let budget = Budget {
        steps,
        repeats: 1,
        residual_samples: 0,
        reference_iterations: 1000,
    };
    let mut stable = 0;
    for setting in settings_grid() {
        let Outcome::Ran(g) = run_case(&bench_scene, &setting, &budget) else {
            continue;
        };
        if !g.verdict.is_stable() {
            continue;
        }
        stable += 1;
        let score = match metric.measure() {
            Some(measure) => g.metric(measure),
            None => report
                .normalisers
                .iter()
                .map(|&(measure, n)| g.metric(measure) / n)
                .fold(0.0, f64::max),
        };
        assert!(
            pick_score <= score,
            "{scene}, {}: tune picked {} (score {pick_score}) but {} scores {score}",
            metric.name(),
            pick.setting.label(),
            setting.label()
        );
    }
    assert!(stable > 10, "{scene}: only {stable} stable grid settings");
}

#[test]
fn with_a_large_budget_the_pick_is_the_most_accurate_setting_of_the_grid() {
    check_pick_beats_the_grid("stack", TuneMetric::Worst, 120);
    check_pick_beats_the_grid("stack", TuneMetric::Penetration, 120);
    check_pick_beats_the_grid("chain", TuneMetric::JointError, 120);
}

#[test]
fn the_worst_score_counts_what_the_scene_has() {
    // a stack: overlap and the top box's drift; no joints, and contacts take energy
    let stack = sandbox2d::scene::load("stack").unwrap().world;
    let options = TuneOptions {
        budget_ms: 1e9,
        metric: TuneMetric::Worst,
        steps: 60,
        rounds: 1,
        jobs: 1,
    };
    let r = tune::tune("stack", &stack, &options, |_, _, _| {}).unwrap();
    assert!(r.applies.penetration && r.applies.drift);
    assert!(!r.applies.joint_error && !r.applies.energy_drift);
    // a pendulum: joints and a closed energy, no contact
    let pendulum = sandbox2d::scene::load("pendulum").unwrap().world;
    let r = tune::tune("pendulum", &pendulum, &options, |_, _, _| {}).unwrap();
    assert!(
        r.applies.joint_error && r.applies.energy_drift,
        "{:?}",
        r.applies
    );
    assert!(!r.applies.penetration);
}

#[test]
fn tune_flags_as_fallen_what_the_bench_finds_fallen_and_reports_the_current_setting() {
    // the bench's stack (15 boxes, the tracked top may move 0.5 m) and tune's view of the
    // same scene, over the same steps
    let steps = 150;
    let def = sandbox2d::scene::load("stack").unwrap().world;
    let options = TuneOptions {
        budget_ms: 1e9,
        metric: TuneMetric::Worst,
        steps,
        rounds: 1,
        jobs: 1,
    };
    let r = tune::tune("stack", &def, &options, |_, _, _| {}).unwrap();
    let mut bench_scene = sandbox2d::bench::scenes::suite(sandbox2d::bench::Suite::Quick)
        .into_iter()
        .find(|s| s.name == "stack")
        .unwrap();
    bench_scene.budget.steps = steps;
    bench_scene.budget.repeats = 1;
    bench_scene.budget.residual_samples = 0;
    let mut fell = 0;
    for setting in settings_grid() {
        let Outcome::Ran(b) = run_case(&bench_scene, &setting, &bench_scene.budget) else {
            panic!("{} did not run", setting.label());
        };
        let t = r.tried.iter().find(|t| t.setting == setting).unwrap();
        let bench_fell = matches!(&b.verdict, Verdict::Unstable(why) if why.contains("fell"));
        let tune_fell = t.reason == Some(tune::DropReason::Fell);
        assert_eq!(
            bench_fell,
            tune_fell,
            "{}: the bench says {:?}, tune {:?}",
            setting.label(),
            b.verdict,
            t.dropped
        );
        fell += usize::from(tune_fell);
    }
    assert!(
        fell > 0,
        "some setting of the grid lets 15 boxes fall in {steps} steps"
    );
    // the scene's own setting is tried and named, with its score
    let cur = r.current.expect("the current setting is tried");
    let c = &r.tried[cur];
    assert_eq!(c.setting, Setting::soft(8, 1));
    let md = tune::markdown(&r);
    let line = format!(
        "- the scene's current setting: soft 8 substeps x 1 ({:.4} ms/step, score {:.2})",
        c.ms_per_step,
        c.score.expect("the stack stands at its own setting")
    );
    assert!(md.contains(&line), "missing {line:?} in:\n{md}");
    let verdict = if r.pick == r.current {
        "- the pick is the scene's current setting"
    } else {
        "- the pick differs from the scene's current setting: score "
    };
    assert!(md.contains(verdict), "{md}");
    // the count of fallen settings in the report's tally
    assert!(md.contains(&format!(" {fell} fell")), "{md}");
    // an error above the bound is more than 10 times the current setting's on a measure
    let cm = c.measured().unwrap();
    for t in r
        .tried
        .iter()
        .filter(|t| t.reason == Some(tune::DropReason::FarAbove))
    {
        let m = t.measured().unwrap();
        assert!(
            r.normalisers
                .iter()
                .any(|&(k, _)| m.metric(k) > 10.0 * cm.metric(k).max(tune::floor(k))),
            "{}: {:?}",
            t.setting.label(),
            t.dropped
        );
    }
}

#[test]
fn runs_side_by_side_score_as_they_do_one_after_another() {
    let def = sandbox2d::scene::load("stack").unwrap().world;
    let run = |jobs| {
        let options = TuneOptions {
            budget_ms: 1e9,
            // a raw measure: the default score divides by the best value among the
            // settings tried, and which settings the fine pass tries can change with
            // the timings (equal errors are parted by cost)
            metric: TuneMetric::Penetration,
            steps: 60,
            rounds: 2,
            jobs,
        };
        tune::tune("stack", &def, &options, |_, _, _| {}).unwrap()
    };
    let (alone, side_by_side) = (run(1), run(2));
    let mut compared = 0;
    for a in &alone.tried {
        let Some(b) = side_by_side.tried.iter().find(|b| b.setting == a.setting) else {
            assert_eq!(a.pass, tune::Pass::Fine, "{}", a.setting.label());
            continue;
        };
        compared += 1;
        assert_eq!(
            a.score.map(f64::to_bits),
            b.score.map(f64::to_bits),
            "{}",
            a.setting.label()
        );
        // every stable setting fits a budget this large, so each is timed `rounds`
        // times either way
        if a.score.is_some() {
            assert_eq!(a.samples.len(), 2, "{}", a.setting.label());
            assert_eq!(b.samples.len(), 2, "{}", b.setting.label());
        }
    }
    assert!(compared >= settings_grid().len(), "{compared}");
    // the report says how its timings were taken
    assert!(tune::markdown(&side_by_side).contains("`--jobs 2`"));
    assert!(!tune::markdown(&alone).contains("--jobs"));
    assert_eq!(
        alone.tried[alone.pick.unwrap()].score,
        side_by_side.tried[side_by_side.pick.unwrap()].score
    );
}

#[test]
fn a_budget_below_the_cheapest_setting_is_refused_with_exit_2_and_one_line() {
    let out = sandbox2d()
        .args(["tune", "pendulum", "--budget-ms", "1e-9", "--steps", "20"])
        .args(["--rounds", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("no setting fits the budget"), "{err}");
    assert!(err.contains("ms/step"), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn bad_arguments_are_refused_before_any_run() {
    for (args, what) in [
        (&["--budget-ms", "0"][..], "--budget-ms"),
        (&["--budget-ms", "nan"][..], "--budget-ms"),
        (&["--budget-ms", "1", "--steps", "0"][..], "--steps"),
        (&["--budget-ms", "1", "--jobs", "0"][..], "--jobs"),
        (&["--budget-ms", "1", "--write"][..], "built-in"),
    ] {
        let out = sandbox2d()
            .args(["tune", "stack"])
            .args(args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(what), "{args:?}: {err}");
    }
}

#[test]
fn write_puts_the_pick_into_the_scene_file_and_keeps_the_rest() {
    let path = tmp("tuned.toml");
    let original = format!(
        "# a stack to tune\n{}",
        include_str!("../assets/scenes/stack.toml")
    );
    std::fs::write(&path, &original).unwrap();
    let out = sandbox2d()
        .arg("tune")
        .arg(&path)
        .args(["--budget-ms", "1000", "--steps", "30", "--rounds", "1"])
        .args(["--json", "--write"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let pick = &v["pick"]["setting"];
    let written = std::fs::read_to_string(&path).unwrap();
    assert!(written.starts_with("# a stack to tune\n"));
    // every line of the original but the [solver] values is still there
    for line in original
        .lines()
        .filter(|l| !l.contains('=') || l.starts_with("name"))
    {
        assert!(written.contains(line), "lost {line:?}");
    }
    let scene = sandbox2d::scene::load_file(&path).unwrap();
    let s = scene.world.solver.resolve();
    assert_eq!(s.kind.name(), pick["kind"].as_str().unwrap());
    assert_eq!(s.substeps as u64, pick["substeps"].as_u64().unwrap());
    assert_eq!(s.iterations as u64, pick["iterations"].as_u64().unwrap());
}
