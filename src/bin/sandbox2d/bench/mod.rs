//! `sandbox2d bench`: the quick and standard suites here; each other suite in its file
//! (`extremes.rs`, `scaling.rs`, `contention.rs`, `convergence.rs`, `box2d.rs`), and
//! `--merge` in `merge.rs`. What the suites' setups share is here too: the folder and
//! the filter checked, the shard's key and the command a report quotes.

use std::path::Path;

use sandbox2d::bench::{self, Shard, Suite, shard};
use sandbox2d::output;

use crate::args::{BenchArgs, SuiteArg};
use crate::failure::{self, Failure};
use crate::paths::{writable_dir, write_file};
use crate::progress::bench_progress;

mod box2d;
pub mod contention;
mod convergence;
mod extremes;
mod merge;
mod scaling;

pub fn bench(a: &BenchArgs) -> Result<(), Failure> {
    if !a.merge.is_empty() {
        crate::shard::check_run_id(a.run_id.as_deref())?;
        return merge::bench_merge(&a.merge, &a.out, a.run_id.as_deref());
    }
    if a.steps == Some(0) {
        return Err(Failure::input("--steps must be at least 1"));
    }
    if a.repeats == Some(0) {
        return Err(Failure::input("--repeats must be at least 1"));
    }
    if a.jobs == 0 {
        return Err(Failure::input("--jobs must be at least 1"));
    }
    let part = crate::shard::resolve(a.shard.as_deref())?;
    if a.metric.is_some() && !matches!(a.suite, SuiteArg::Quick | SuiteArg::Standard) {
        return Err(Failure::input(
            "--metric trajectory: for the quick and standard suites (the convergence suite measures against the closed forms itself)",
        ));
    }
    if a.metric.is_some() && part.is_some() {
        return Err(Failure::input(
            "--metric trajectory does not shard: each scene's reference is worked out once, in one run",
        ));
    }
    if a.run_id.is_some() && part.is_none() {
        return Err(Failure::input(
            "--run-id names the run of a shard: give it with --shard or --merge",
        ));
    }
    let run = match part {
        Some(_) => crate::shard::run_id(a.run_id.as_deref())?,
        None => None,
    };
    let suite = match a.suite {
        SuiteArg::Quick => Suite::Quick,
        SuiteArg::Standard => Suite::Standard,
        SuiteArg::Extremes => {
            return extremes::bench_extremes(a, part, run_key(a, Suite::Extremes, run));
        }
        SuiteArg::Scaling => return scaling::bench_scaling(a, part.is_some()),
        SuiteArg::Contention => return contention::bench_contention(a, part.is_some()),
        SuiteArg::Convergence => return convergence::bench_convergence(a, part.is_some()),
        SuiteArg::Box2d => return box2d::bench_box2d(a, part, run_key(a, Suite::Box2d, run)),
    };
    bench_scenes(a, suite, part, run_key(a, suite, run))
}

/// The quick and standard suites: every scene under every setting of the grid, then
/// results.csv, results.md and the plots (or, with --shard, the shard's file).
fn bench_scenes(
    a: &BenchArgs,
    suite: Suite,
    part: Option<Shard>,
    key: shard::RunKey,
) -> Result<(), Failure> {
    let opts = bench::Options {
        filter: a.filter.clone(),
        steps: a.steps,
        repeats: a.repeats,
    };
    let what = format!("scene of the {} suite", suite.name());
    let mut scenes = filtered(a, opts.scenes(suite), &what)?;
    if a.metric.is_some() {
        failure::graceful();
        let bar = bench_progress(scenes.len());
        bar.set_message("the true motions (references)");
        bench::truth::attach(
            &mut scenes,
            |sc| opts.budget(sc).steps,
            |done, _, name| {
                bar.set_position(done as u64);
                bar.set_message(format!("truth of {name}"));
            },
        );
        bar.finish_and_clear();
        if output::interrupted() {
            return Err(Failure::nothing_written());
        }
    }
    let all = bench::cases(&scenes);
    let picked = crate::shard::picked(part, all.len());
    let cases: Vec<bench::Case> = picked.iter().map(|&i| all[i]).collect();
    let total = cases.len();
    let bar = bench_progress(total);
    // Each finished case's row goes at once to a temporary file kept as
    // results.partial.csv (a shard's as results.shard-I-of-N.partial.csv) when the suite
    // stops early: interrupted, failed (a full disk), or interrupted twice; it then
    // holds whole rows only. A complete suite's reports replace it.
    failure::graceful();
    let partial_path = a.out.join(match part {
        Some(p) => format!("results.shard-{}-of-{}.partial.csv", p.index, p.count),
        None => "results.partial.csv".to_string(),
    });
    let mut partial = output::RowFile::create(&partial_path).map_err(Failure::input)?;
    partial
        .push(&format!("{}\n", bench::report::CSV_COLUMNS.join(",")))
        .map_err(Failure::run)?;
    let run = bench::run_cases(&scenes, &opts, &cases, a.jobs, |done, _, what, row| {
        bar.set_position(done as u64);
        bar.set_message(what.to_string());
        let csv = bench::report::csv(std::slice::from_ref(row));
        let line = csv.split_once('\n').map_or("", |(_, rest)| rest);
        partial.push(line).map_err(Failure::run)
    });
    bar.finish_and_clear();
    // a run that stops early keeps the finished rows and says where
    let kept = |partial: output::RowFile| {
        let rows = partial.rows().saturating_sub(1);
        match partial.keep() {
            Ok(p) => format!(
                "kept the {rows} finished case(s) of {total} in {}",
                p.display()
            ),
            Err(e) => format!("the finished cases were not kept: {e}"),
        }
    };
    let keep = |partial: output::RowFile, mut f: Failure| {
        f.message += &format!("; {}", kept(partial));
        f
    };
    let (rows, complete) = match run {
        Ok(r) => r,
        Err(f) => return Err(keep(partial, f)),
    };
    if !complete {
        let what = if part.is_some() {
            "the shard file was"
        } else {
            "results.csv, results.md and the plots were"
        };
        return Err(Failure::interrupted(format!(
            "interrupted: {}; {what} not written",
            kept(partial)
        )));
    }
    let rows: Vec<bench::Row> = rows.into_iter().flatten().collect();
    if let Some(p) = part {
        let indexed: Vec<(usize, &bench::Row)> = picked.iter().copied().zip(&rows).collect();
        let path = a.out.join(p.file_name());
        if let Err(f) = write_file(&path, &shard::scenes_json(&key, p, all.len(), &indexed)) {
            return Err(keep(partial, f));
        }
        drop(partial);
        // an earlier run's unfinished rows are superseded
        let _ = std::fs::remove_file(&partial_path);
        return say_shard_written(&path, p, rows.len(), all.len());
    }
    if let Err(f) = write_reports(&a.out, suite, &scenes, &rows) {
        return Err(keep(partial, f));
    }
    drop(partial);
    // an earlier run's unfinished rows are superseded
    let _ = std::fs::remove_file(&partial_path);
    Ok(())
}

/// What a shard's file says of its run: the suite and the flags that pick its cases.
fn run_key(a: &BenchArgs, suite: Suite, run: Option<String>) -> shard::RunKey {
    shard::RunKey {
        suite,
        filter: a.filter.clone(),
        steps: a.steps,
        repeats: a.repeats,
        run,
    }
}

/// Tells where a shard's file went and how many of the suite's cases it holds.
fn say_shard_written(path: &Path, p: Shard, ran: usize, total: usize) -> Result<(), Failure> {
    say!(
        "wrote {} (shard {p}: {} of {} cases)",
        path.display(),
        ran,
        total
    )
}

/// Why the scaling and contention suites run one case at a time.
const TIMES_THREADS: &str = "runs one case at a time (it times threads against each other)";

/// Refuses --jobs and --shard for a suite that runs its cases one at a time on the
/// threads it sets (`why` says why, after the suite's name).
fn one_case_at_a_time(a: &BenchArgs, sharded: bool, suite: &str, why: &str) -> Result<(), Failure> {
    if sharded || a.jobs != 1 {
        return Err(Failure::input(format!(
            "--suite {suite} {why}: --jobs and --shard do not apply"
        )));
    }
    Ok(())
}

/// What --filter picked of a suite (`picked`), refused when it is nothing (`what` names
/// what the suite has, e.g. "scene of the box2d suite (...)"); the results folder is
/// made ready before anything runs.
fn filtered<T>(a: &BenchArgs, picked: Vec<T>, what: &str) -> Result<Vec<T>, Failure> {
    if picked.is_empty() {
        return Err(Failure::input(format!(
            "--filter {:?} matches no {what}",
            a.filter.clone().unwrap_or_default()
        )));
    }
    writable_dir(&a.out)?;
    Ok(picked)
}

/// The command a suite's report quotes to run it again: the suite, the flags given of
/// --filter, --steps and --repeats (`counts`: whether the suite takes the last two),
/// --jobs when not 1, and --out.
fn suite_command(a: &BenchArgs, suite: &str, counts: bool) -> String {
    let mut command = format!("sandbox2d bench --suite {suite}");
    if let Some(f) = &a.filter {
        command.push_str(&format!(" --filter {f}"));
    }
    if counts {
        if let Some(s) = a.steps {
            command.push_str(&format!(" --steps {s}"));
        }
        if let Some(r) = a.repeats {
            command.push_str(&format!(" --repeats {r}"));
        }
    }
    if a.jobs != 1 {
        command.push_str(&format!(" --jobs {}", a.jobs));
    }
    command.push_str(&format!(" --out {}", a.out.display()));
    command
}

/// The world of a scene a suite runs several times, made once: `defs` holds those made
/// so far, by `key`.
fn made_once<K: PartialEq, D>(
    defs: &mut Vec<(K, D)>,
    key: K,
    make: impl FnOnce() -> Result<D, Failure>,
) -> Result<&D, Failure> {
    let i = match defs.iter().position(|(k, _)| *k == key) {
        Some(i) => i,
        None => {
            defs.push((key, make()?));
            defs.len() - 1
        }
    };
    Ok(&defs[i].1)
}

/// Runs a suite's `runs` one at a time (`run` each, `label` naming it on the progress
/// bar and in the log), stopping with nothing written on an interrupt.
fn one_at_a_time<R, T>(
    runs: &[R],
    label: impl Fn(&R) -> String,
    mut run: impl FnMut(&R) -> Result<T, Failure>,
) -> Result<Vec<T>, Failure> {
    let bar = bench_progress(runs.len());
    let mut timed = Vec::with_capacity(runs.len());
    for (i, r) in runs.iter().enumerate() {
        if output::interrupted() {
            return Err(Failure::nothing_written());
        }
        bar.set_message(label(r));
        log::debug!("bench: {}", label(r));
        timed.push(run(r)?);
        bar.set_position(i as u64 + 1);
    }
    bar.finish_and_clear();
    Ok(timed)
}

/// Writes a suite's reports into `out`: one plot per scene, results.csv, results.md.
pub fn write_reports(
    out: &Path,
    suite: Suite,
    scenes: &[bench::BenchScene],
    rows: &[bench::Row],
) -> Result<(), Failure> {
    let mut plots = Vec::new();
    for sc in scenes {
        if let Some(svg) = bench::plot::svg(sc, rows).map_err(Failure::run)? {
            let name = format!("{}.svg", sc.name);
            write_file(&out.join(&name), &svg)?;
            plots.push(name);
        }
    }
    write_file(&out.join("results.csv"), &bench::report::csv(rows))?;
    write_file(
        &out.join("results.md"),
        &bench::report::markdown(suite, scenes, rows, &plots),
    )?;
    say!(
        "wrote {}: results.csv, results.md and {} plot(s) ({} rows)",
        out.display(),
        plots.len(),
        rows.len()
    )?;
    Ok(())
}
