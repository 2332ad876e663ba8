//! `bench --merge`: the shard files of one run merged into the reports one unsharded
//! run writes.

use std::path::{Path, PathBuf};

use crate::bench::box2d::write_box2d;
use crate::bench::extremes::write_stability;
use crate::bench::write_reports;
use crate::failure::Failure;
use crate::paths::writable_dir;
use crate::shard::read_shard_files;

/// The files `bench --merge` may write into its `--out` folder: the reports and the
/// plots (one per scene).
fn merge_writes(name: &str) -> bool {
    matches!(name, "results.csv" | "results.md" | "stability.md") || name.ends_with(".svg")
}

/// `bench --merge`: the shard files (or the shard files in the folders) given, merged
/// into the reports of one unsharded run.
pub fn bench_merge(inputs: &[PathBuf], out: &Path, run: Option<&str>) -> Result<(), Failure> {
    use sandbox2d::bench::shard::{self, Merged};
    let files = read_shard_files(inputs, "results", Some(out), merge_writes)?;
    let merged = shard::merge(&files, run).map_err(Failure::input)?;
    writable_dir(out)?;
    match merged {
        Merged::Extremes { results } => write_stability(out, &results),
        Merged::Box2d { rows } => write_box2d(
            out,
            &rows,
            &format!("sandbox2d bench --merge ... --out {}", out.display()),
        ),
        Merged::Scenes {
            suite,
            scenes,
            rows,
        } => write_reports(out, suite, &scenes, &rows),
    }
}
