//! `bench --suite extremes`: the stability sweeps, then stability.md (or, with
//! --shard, the shard's file).

use std::path::Path;

use sandbox2d::bench::{self, Shard, extremes, shard};

use crate::args::BenchArgs;
use crate::failure::Failure;
use crate::paths::write_file;
use crate::progress::bench_progress;

pub fn bench_extremes(
    a: &BenchArgs,
    part: Option<Shard>,
    key: shard::RunKey,
) -> Result<(), Failure> {
    let sweeps = super::filtered(a, extremes::sweeps(a.filter.as_deref()), "sweep")?;
    let all = extremes::cases(&sweeps);
    let picked = crate::shard::picked(part, all.len());
    let cases: Vec<extremes::ExCase> = picked.iter().map(|&i| all[i]).collect();
    let bar = bench_progress(cases.len());
    let mut done = 0;
    let (results, complete) = bench::run_jobs(
        &cases,
        a.jobs,
        |c| c.run(),
        |i, _| {
            done += 1;
            bar.set_position(done as u64);
            bar.set_message(cases[i].label());
            Ok::<(), Failure>(())
        },
    )?;
    bar.finish_and_clear();
    if !complete {
        return Err(Failure::nothing_written());
    }
    let results: Vec<extremes::CaseResult> = results.into_iter().flatten().collect();
    if let Some(p) = part {
        let rows: Vec<_> = picked
            .iter()
            .zip(&cases)
            .zip(&results)
            .map(|((&i, c), r)| (i, c, r))
            .collect();
        let path = a.out.join(p.file_name());
        write_file(&path, &shard::extremes_json(&key, p, all.len(), &rows))?;
        return super::say_shard_written(&path, p, cases.len(), all.len());
    }
    write_stability(&a.out, &extremes::assemble(&cases, results))
}

/// Writes stability.md (the extremes suite's report) into `out`.
pub fn write_stability(out: &Path, results: &[extremes::SweepResult]) -> Result<(), Failure> {
    let path = out.join("stability.md");
    write_file(&path, &extremes::markdown(results))?;
    say!("wrote {}", path.display())?;
    Ok(())
}
