//! `sandbox2d tune`: the most accurate solver setting within a budget of ms per step
//! for one scene (or, with --shard and --merge, a search split over a Slurm array).

use std::path::Path;

use sandbox2d::SolverKind;
use sandbox2d::bench::{shard, tune};
use sandbox2d::scene::{self, Scene};

use crate::args::{MetricArg, TuneArgs};
use crate::failure::{self, Failure};
use crate::paths::{check_folder_outputs, scene_file, writable_dir, write_file};
use crate::progress::progress;

/// The files `tune --out` writes.
const TUNE_FILES: [&str; 4] = ["tune.md", "tune.json", "pareto.svg", "solver.toml"];

/// The most steps `tune` runs a setting for (each of some 40 settings runs them
/// `--rounds` times).
const MAX_TUNE_STEPS: u64 = 1_000_000;

pub fn tune(a: &TuneArgs) -> Result<(), Failure> {
    if !a.merge.is_empty() {
        return tune_merge(a);
    }
    let (Some(scene_name), Some(budget_ms)) = (a.scene.as_deref(), a.budget_ms) else {
        return Err(Failure::input("give a scene and --budget-ms (or --merge)"));
    };
    if !(budget_ms.is_finite() && budget_ms > 0.0) {
        return Err(Failure::input(format!(
            "--budget-ms must be a positive number of milliseconds, got {budget_ms}"
        )));
    }
    if !(1..=MAX_TUNE_STEPS).contains(&a.steps) {
        return Err(Failure::input(format!(
            "--steps must be 1..={MAX_TUNE_STEPS}, got {}",
            a.steps
        )));
    }
    if !(1..=20).contains(&a.rounds) {
        return Err(Failure::input(format!(
            "--rounds must be 1..=20, got {}",
            a.rounds
        )));
    }
    if a.jobs == 0 {
        return Err(Failure::input("--jobs must be at least 1"));
    }
    let part = crate::shard::resolve(a.shard.as_deref())?;
    let run = match part {
        Some(_) => {
            if a.json || a.write {
                return Err(Failure::input(
                    "--shard writes a shard file for --merge: --json and --write go with the merge",
                ));
            }
            if a.out.is_none() {
                return Err(Failure::input(
                    "--shard needs --out, the folder for tune.shard-I-of-N.json",
                ));
            }
            crate::shard::run_id(a.run_id.as_deref())?
        }
        None if a.run_id.is_some() => {
            return Err(Failure::input(
                "--run-id names the run of a shard: give it with --shard or --merge",
            ));
        }
        None => None,
    };
    let file = scene_file(scene_name);
    if a.write && file.is_none() {
        return Err(Failure::input(format!(
            "--write: \"{scene_name}\" is a built-in scene, not a file; copy assets/scenes/{scene_name}.toml and tune the copy"
        )));
    }
    let metric = match a.metric {
        MetricArg::Worst => tune::TuneMetric::Worst,
        MetricArg::Penetration => tune::TuneMetric::Penetration,
        MetricArg::Drift => tune::TuneMetric::Drift,
        MetricArg::JointError => tune::TuneMetric::JointError,
        MetricArg::EnergyDrift => tune::TuneMetric::EnergyDrift,
        MetricArg::Residual => tune::TuneMetric::Residual,
        MetricArg::Trajectory => tune::TuneMetric::Trajectory,
    };
    if let (Some(out), Some(f)) = (&a.out, &file) {
        check_folder_outputs(
            "--out",
            out,
            |n| TUNE_FILES.contains(&n),
            &[("scene file", f)],
        )?;
    }
    let sc = scene::load(scene_name).map_err(Failure::input)?;
    if let Some(out) = &a.out {
        writable_dir(out)?;
    }
    let options = tune::TuneOptions {
        budget_ms,
        metric,
        steps: a.steps,
        rounds: a.rounds,
        jobs: a.jobs,
    };
    let bar = progress(
        Some(sandbox2d::bench::settings_grid().len() as u64),
        "{bar:40} {pos}/{len} runs {elapsed} {msg}",
    );
    failure::graceful();
    let on_run = |done: usize, total: usize, what: &str| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        bar.set_message(what.to_string());
    };
    if let (Some(p), Some(out)) = (part, &a.out) {
        let rows = tune::tune_shard(scene_name, &sc.world, &options, p, on_run);
        bar.finish_and_clear();
        let rows = rows.map_err(|e| tune_failure(&sc, budget_ms, e))?;
        let key = shard::TuneKey {
            scene: scene_name.to_string(),
            digest: tune::scene_digest(&sc.world),
            options,
            run,
        };
        let cases = sandbox2d::bench::settings_grid().len();
        let path = out.join(shard::tune_file_name(p));
        write_file(&path, &shard::tune_json(&key, p, cases, &rows))?;
        return say!(
            "wrote {} (shard {p}: {} of {cases} settings)",
            path.display(),
            rows.len()
        );
    }
    let result = tune::tune(scene_name, &sc.world, &options, on_run);
    bar.finish_and_clear();
    let report = result.map_err(|e| tune_failure(&sc, budget_ms, e))?;
    tune_output(a, &sc, file.as_deref(), &report)
}

/// A search that ended without a pick, as the command reports it.
fn tune_failure(sc: &Scene, budget_ms: f64, e: tune::TuneError) -> Failure {
    use tune::TuneError;
    match e {
        TuneError::Interrupted => {
            Failure::interrupted(format!("{}: interrupted; nothing was written", sc.source))
        }
        e @ TuneError::OverBudget { .. } => {
            Failure::input(format!("{}: {e} (budget {budget_ms} ms/step)", sc.source))
        }
        e @ TuneError::NoTruth(_) => Failure::input(format!("{}: {e}", sc.source)),
        e => Failure::run(format!("{}: {e}", sc.source)),
    }
}

/// `tune --merge`: the shards of one search's coarse pass (files, or folders of
/// `tune.shard-I-of-N.json`), then the fine pass and the pick here.
fn tune_merge(a: &TuneArgs) -> Result<(), Failure> {
    crate::shard::check_run_id(a.run_id.as_deref())?;
    let files = crate::shard::read_shard_files(&a.merge, "tune", a.out.as_deref(), |n| {
        TUNE_FILES.contains(&n)
    })?;
    let merged = shard::merge_tune(&files, a.run_id.as_deref()).map_err(Failure::input)?;
    let key = &merged.key;
    let sc = scene::load(&key.scene).map_err(|e| {
        Failure::input(format!(
            "the shards' scene {:?} does not load here: {e}",
            key.scene
        ))
    })?;
    let digest = tune::scene_digest(&sc.world);
    if digest != key.digest {
        return Err(Failure::input(format!(
            "{}: not the scene the shards ran (it changed since: digest {digest}, the shards' {})",
            sc.source, key.digest
        )));
    }
    let file = scene_file(&key.scene);
    if a.write && file.is_none() {
        return Err(Failure::input(format!(
            "--write: \"{}\" is a built-in scene, not a file; copy assets/scenes/{}.toml and tune the copy",
            key.scene, key.scene
        )));
    }
    if let Some(out) = &a.out {
        writable_dir(out)?;
    }
    let bar = progress(None, "{bar:40} {pos}/{len} runs {elapsed} {msg}");
    failure::graceful();
    let result = tune::tune_merged(
        &key.scene,
        &sc.world,
        &key.options,
        merged.coarse,
        merged.shards,
        |done, total, what| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            bar.set_message(what.to_string());
        },
    );
    bar.finish_and_clear();
    let report = result.map_err(|e| tune_failure(&sc, key.options.budget_ms, e))?;
    tune_output(a, &sc, file.as_deref(), &report)
}

/// Prints a search's report (or its JSON), writes its files into --out, and with
/// --write the pick into the scene file.
fn tune_output(
    a: &TuneArgs,
    sc: &Scene,
    file: Option<&Path>,
    report: &tune::TuneReport,
) -> Result<(), Failure> {
    let pick = report.pick.map(|p| report.tried[p].setting);
    if let Some(out) = &a.out {
        write_file(&out.join("tune.md"), &tune::markdown(report))?;
        write_file(
            &out.join("tune.json"),
            &format!("{:#}\n", tune::json(report)),
        )?;
        write_file(
            &out.join("pareto.svg"),
            &tune::svg(report).map_err(Failure::run)?,
        )?;
        if let Some(p) = &pick {
            write_file(&out.join("solver.toml"), &tune::solver_table(p))?;
        }
    }
    if a.json {
        say!("{}", tune::json(report))?;
    } else {
        say_part!("{}", tune::markdown(report))?;
        if let Some(out) = &a.out {
            say!(
                "\nwrote {}: tune.md, tune.json, pareto.svg, solver.toml",
                out.display()
            )?;
        }
    }
    if let (true, Some(path), Some(p)) = (a.write, file, &pick) {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Failure::run(format!("{}: cannot read: {e}", path.display())))?;
        let new = tune::write_setting(&text, p)
            .map_err(|e| Failure::run(format!("{}: {e}", path.display())))?;
        // the edited file must still load, and to the setting it was given
        let check = scene::load_str(&new, &path.display().to_string()).map_err(|e| {
            Failure::run(format!(
                "{}: the edited scene does not load: {e}",
                path.display()
            ))
        })?;
        let got = check.world.solver.resolve();
        let want = p.resolve(&sc.world.solver);
        let same = got.kind == want.kind
            && got.substeps == want.substeps
            && got.iterations == want.iterations
            && (want.kind != SolverKind::Pgs
                || (got.warm_start == want.warm_start
                    && got.split_impulse == want.split_impulse
                    && got.tolerance == want.tolerance));
        if !same {
            return Err(Failure::run(format!(
                "{}: the edited [solver] table does not give {}; the file was left as it was",
                path.display(),
                p.label()
            )));
        }
        write_file(path, &new)?;
        if !a.json {
            say!("wrote the pick ({}) into {}", p.label(), path.display())?;
        }
    }
    Ok(())
}
