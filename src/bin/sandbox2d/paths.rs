//! Where a command writes: its output paths checked against its inputs and each
//! other, result files written whole, the results folder made ready.

use std::path::{Path, PathBuf};

use sandbox2d::output;
#[cfg(feature = "lab")]
use sandbox2d::output::AtomicFile;
use sandbox2d::scene;

use crate::failure::Failure;

/// Refuses an output path that is one of the run's inputs or another of its outputs.
pub fn check_distinct(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), Failure> {
    for (i, (what, p)) in outputs.iter().enumerate() {
        if p.is_dir() {
            return Err(Failure::input(format!(
                "{}: {what} is a folder; give a file name",
                p.display()
            )));
        }
        for (other, q) in inputs.iter().chain(&outputs[..i]) {
            if output::same_file(p, q) {
                return Err(Failure::input(format!(
                    "{}: {what} would overwrite the {other} ({})",
                    p.display(),
                    q.display()
                )));
            }
        }
    }
    Ok(())
}

/// Refuses a run whose writes into the folder `dir` would replace one of its inputs:
/// `writes(name)` says whether the run writes a file of that name there (`what`, the
/// flag that names the folder, goes into the message).
#[cfg(any(feature = "render", feature = "lab"))]
pub fn check_folder_outputs(
    what: &str,
    dir: &Path,
    writes: impl Fn(&str) -> bool,
    inputs: &[(&str, &Path)],
) -> Result<(), Failure> {
    for (other, q) in inputs {
        let Some(name) = q.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        let p = dir.join(name);
        if writes(name) && output::same_file(&p, q) {
            return Err(Failure::input(format!(
                "{}: {what} would overwrite the {other} ({})",
                p.display(),
                q.display()
            )));
        }
    }
    Ok(())
}

/// Whether `name` is one of the frames `frame_0000.png` .. of a run of `frames` frames.
#[cfg(feature = "render")]
pub fn is_frame_name(name: &str, frames: u32) -> bool {
    name.strip_prefix("frame_")
        .and_then(|r| r.strip_suffix(".png"))
        .and_then(|d| d.parse::<u32>().ok())
        .is_some_and(|k| k < frames && sandbox2d::render::frame_name(k) == name)
}

/// The frame of a run of `frames` frames into `dir` that `file` would overwrite, when
/// its name is one of them.
#[cfg(feature = "render")]
pub fn frame_it_writes(file: &Path, dir: &Path, frames: u32) -> Option<PathBuf> {
    let name = file.file_name()?.to_str()?;
    is_frame_name(name, frames).then(|| dir.join(name))
}

/// The scene file a name loads, when it is a file and not a built-in scene.
pub fn scene_file(name: &str) -> Option<PathBuf> {
    scene::builtin(name).is_none().then(|| PathBuf::from(name))
}

/// Writes a result file in full or not at all.
#[cfg(feature = "lab")]
pub fn write_file(path: &Path, text: &str) -> Result<(), Failure> {
    output::write_atomic(path, text.as_bytes()).map_err(Failure::run)
}

#[cfg(feature = "lab")]
/// Creates the results folder and checks that a file can be written in it, before any
/// case runs (rather than after minutes of measuring).
pub fn writable_dir(dir: &Path) -> Result<(), Failure> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Failure::input(format!("{}: cannot create: {e}", dir.display())))?;
    let probe = dir.join("results.csv");
    // created and dropped uncommitted: the temporary file is removed again
    AtomicFile::create(&probe).map_err(|e| {
        Failure::input(format!(
            "{}: cannot write in this folder: {}",
            dir.display(),
            e.source
        ))
    })?;
    Ok(())
}
