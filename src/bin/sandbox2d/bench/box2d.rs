//! `bench --suite box2d`: each of Box2D's benchmark scenes on 1 and 2 threads, then
//! box2d.csv, box2d.md and box2d.svg (or, with --shard, the shard's file).

use std::path::Path;

use sandbox2d::bench::{self, Shard, box2d, shard};

use crate::args::BenchArgs;
use crate::failure::Failure;
use crate::paths::write_file;
use crate::progress::bench_progress;

pub fn bench_box2d(a: &BenchArgs, part: Option<Shard>, key: shard::RunKey) -> Result<(), Failure> {
    let what = format!(
        "scene of the box2d suite ({})",
        box2d::SCENES.map(|s| s.name).join(", ")
    );
    let scenes = super::filtered(a, box2d::scenes(a.filter.as_deref()), &what)?;
    let all = box2d::cases(&scenes);
    let picked = crate::shard::picked(part, all.len());
    let cases: Vec<box2d::Case> = picked.iter().map(|&i| all[i]).collect();
    let repeats = a.repeats.unwrap_or(1);
    let bar = bench_progress(cases.len());
    if let Some(c) = cases.first() {
        bar.set_message(c.label());
    }
    let mut done = 0;
    let (results, complete) = bench::run_jobs(
        &cases,
        a.jobs,
        |c| box2d::run_case(c, a.steps, repeats),
        |i, r| {
            done += 1;
            bar.set_position(done as u64);
            bar.set_message(cases.get(i + 1).map_or(String::new(), |c| c.label()));
            match r {
                Ok(_) => Ok(()),
                Err(e) => Err(Failure::run(e.clone())),
            }
        },
    )?;
    bar.finish_and_clear();
    if !complete {
        return Err(Failure::nothing_written());
    }
    let rows: Vec<box2d::Row> = results.into_iter().flatten().flatten().collect();
    if let Some(p) = part {
        let indexed: Vec<(usize, &box2d::Row)> = picked.iter().copied().zip(&rows).collect();
        let path = a.out.join(p.file_name());
        write_file(&path, &shard::box2d_json(&key, p, all.len(), &indexed))?;
        return super::say_shard_written(&path, p, rows.len(), all.len());
    }
    write_box2d(&a.out, &rows, &super::suite_command(a, "box2d", true))
}

/// Writes the box2d suite's reports into `out`.
pub fn write_box2d(out: &Path, rows: &[box2d::Row], command: &str) -> Result<(), Failure> {
    write_file(
        &out.join("box2d.svg"),
        &box2d::svg(rows).map_err(Failure::run)?,
    )?;
    write_file(&out.join("box2d.csv"), &box2d::csv(rows))?;
    write_file(&out.join("box2d.md"), &box2d::markdown(rows, command))?;
    say!(
        "wrote {}: box2d.csv, box2d.md and box2d.svg ({} rows)",
        out.display(),
        rows.len()
    )
}
