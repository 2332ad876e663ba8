//! `bench --suite scaling`: the pyramid at each size and thread count.

use sandbox2d::bench::scaling;

use crate::args::BenchArgs;
use crate::failure::Failure;
use crate::paths::write_file;

/// What --filter picks among, for the message when it picks nothing.
const PICKS: &str = "size of the scaling suite (1k, 5k, 20k, 80k)";

/// The pyramid at each size and thread count, one run at a time (its timings are what
/// it reports), then scaling.csv, scaling.md, scaling.svg.
pub fn bench_scaling(a: &BenchArgs, sharded: bool) -> Result<(), Failure> {
    super::one_case_at_a_time(a, sharded, "scaling", super::TIMES_THREADS)?;
    let sizes = super::filtered(a, scaling::sizes(a.filter.as_deref()), PICKS)?;
    let cores = sandbox2d::threads::available();
    let threads = scaling::thread_counts(cores);
    let repeats = a.repeats.unwrap_or(scaling::REPEATS);
    let runs = scaling::runs(&sizes, &threads, repeats);
    let mut defs = Vec::new();
    let timed = super::one_at_a_time(
        &runs,
        |r| r.label(repeats),
        |r| {
            let def = super::made_once(&mut defs, r.size.base, || {
                scaling::scene(r.size.base).map_err(Failure::run)
            })?;
            let steps = a.steps.unwrap_or(r.size.steps);
            let warmup = scaling::WARMUP_STEPS.min(steps);
            scaling::run_one(def, r.threads, warmup, steps)
                .map_err(|e| Failure::run(format!("{}: {e}", r.label(repeats))))
        },
    )?;
    let rows = scaling::assemble(&runs, &timed, &threads);
    let command = super::suite_command(a, "scaling", true);
    let svg = scaling::svg(&rows).map_err(Failure::run)?;
    write_file(&a.out.join("scaling.svg"), &svg)?;
    write_file(&a.out.join("scaling.csv"), &scaling::csv(&rows))?;
    write_file(
        &a.out.join("scaling.md"),
        &scaling::markdown(&rows, repeats, cores, &command),
    )?;
    say!(
        "wrote {}: scaling.csv, scaling.md and scaling.svg ({} rows)",
        a.out.display(),
        rows.len()
    )?;
    Ok(())
}
