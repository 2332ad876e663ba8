//! What `bench` and `tune` share for `--shard` and `--merge`: the shard (given, or
//! this Slurm array task's), the run it belongs to, the cases it runs, and the shard
//! files a merge reads.

use std::path::{Path, PathBuf};

use sandbox2d::bench::{Shard, slurm};

use crate::failure::Failure;
use crate::paths::check_folder_outputs;

/// An environment variable, when it is set (and valid Unicode).
fn env_var(name: &str) -> Option<String> {
    std::env::var(name).ok()
}

/// `--shard I/N|auto`: the shard to run, when one is given.
pub fn resolve(shard: Option<&str>) -> Result<Option<Shard>, Failure> {
    shard
        .map(|s| slurm::resolve(s, env_var))
        .transpose()
        .map_err(Failure::input)
}

/// The run a shard belongs to: `--run-id`, else the Slurm array's job id.
pub fn run_id(given: Option<&str>) -> Result<Option<String>, Failure> {
    slurm::run_id(given, env_var).map_err(Failure::input)
}

/// `--merge`'s `--run-id`, when given, checked.
pub fn check_run_id(given: Option<&str>) -> Result<(), Failure> {
    match given {
        Some(id) => slurm::check_run_id(id).map_err(|e| Failure::input(format!("--run-id: {e}"))),
        None => Ok(()),
    }
}

/// The indices of the cases a run of `total` cases runs: its shard's, or all.
pub fn picked(part: Option<Shard>, total: usize) -> Vec<usize> {
    match part {
        Some(p) => p.indices(total),
        None => (0..total).collect(),
    }
}

/// The shard files given to `--merge`, `(name, text)` each: the files, and in each
/// folder the files `PREFIX.shard-*.json` (sorted by name, a shard's unfinished
/// `.partial.json` left out). Refused when a file the merge writes into the folder
/// `out` (`writes(name)`) would replace one of them.
pub fn read_shard_files(
    inputs: &[PathBuf],
    prefix: &str,
    out: Option<&Path>,
    writes: impl Fn(&str) -> bool,
) -> Result<Vec<(String, String)>, Failure> {
    let start = format!("{prefix}.shard-");
    let mut paths = Vec::new();
    for p in inputs {
        if p.is_dir() {
            let entries = std::fs::read_dir(p)
                .map_err(|e| Failure::input(format!("{}: cannot read: {e}", p.display())))?;
            let mut found: Vec<PathBuf> = entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                        n.starts_with(&start)
                            && n.ends_with(".json")
                            && !n.ends_with(".partial.json")
                    })
                })
                .collect();
            if found.is_empty() {
                return Err(Failure::input(format!(
                    "{}: no shard files ({prefix}.shard-I-of-N.json) in this folder",
                    p.display()
                )));
            }
            found.sort();
            paths.extend(found);
        } else {
            paths.push(p.clone());
        }
    }
    // a report or plot it writes must not replace a shard it reads
    let inputs: Vec<(&str, &Path)> = paths.iter().map(|p| ("shard file", p.as_path())).collect();
    if let Some(out) = out {
        check_folder_outputs("--out", out, writes, &inputs)?;
    }
    let mut files = Vec::with_capacity(paths.len());
    for p in &paths {
        let text = std::fs::read_to_string(p)
            .map_err(|e| Failure::input(format!("{}: cannot read: {e}", p.display())))?;
        files.push((p.display().to_string(), text));
    }
    Ok(files)
}
