//! Writing outputs that never look complete when they are not, and stopping a run
//! cleanly on an interrupt.
//!
//! Every file the sandbox writes (frames, GIFs, traces, bench results, plots) goes to a
//! temporary file in the same folder, `.NAME.PID.tmp`, which is renamed to `NAME` only
//! once it is complete. An error (a full disk, a folder that vanished) or an interrupt
//! leaves no file at `NAME`, the temporary one is removed, and the error names the file.
//!
//! ```
//! use std::io::Write;
//! let dir = std::env::temp_dir().join(format!("sandbox2d-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("out.txt");
//! let mut f = sandbox2d::output::AtomicFile::create(&path).unwrap();
//! writeln!(f, "hello").unwrap();
//! assert!(!path.exists()); // not complete yet
//! f.commit().unwrap();
//! assert_eq!(std::fs::read_to_string(&path).unwrap(), "hello\n");
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// An output file that could not be written: its path and why.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot write: {source}", path.display())]
pub struct OutputError {
    /// The file as the user named it (not the temporary file).
    pub path: PathBuf,
    /// The cause.
    #[source]
    pub source: std::io::Error,
}

/// A file written in full or not at all: a temporary file beside `path`, renamed to
/// `path` by [`AtomicFile::commit`]; dropped without a commit, it is removed.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    temp: PathBuf,
    out: Option<BufWriter<File>>,
}

/// The temporary name for `path`: `.NAME.PID.tmp` in the same folder (a rename within
/// one folder is atomic).
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

impl AtomicFile {
    /// Starts writing `path` (through its temporary file).
    pub fn create(path: impl AsRef<Path>) -> Result<AtomicFile, OutputError> {
        let path = path.as_ref().to_path_buf();
        let temp = temp_path(&path);
        let file = File::create(&temp).map_err(|source| OutputError {
            path: path.clone(),
            source,
        })?;
        Ok(AtomicFile {
            path,
            temp,
            out: Some(BufWriter::new(file)),
        })
    }

    /// The file as it will be named once complete.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The error for `source`, naming the file.
    pub fn error(&self, source: std::io::Error) -> OutputError {
        OutputError {
            path: self.path.clone(),
            source,
        }
    }

    /// Flushes the file and renames it to its final name.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let Some(out) = self.out.take() else {
            return Ok(());
        };
        let file = out.into_inner().map_err(|e| OutputError {
            path: self.path.clone(),
            source: std::io::Error::new(e.error().kind(), e.error().to_string()),
        })?;
        drop(file);
        std::fs::rename(&self.temp, &self.path).map_err(|source| self.error(source))?;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.out.as_mut() {
            Some(o) => o.write(buf),
            None => Err(std::io::Error::other("file already committed")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self.out.as_mut() {
            Some(o) => o.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.out.take().is_some() {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Writes `bytes` to `path` in full or not at all.
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), OutputError> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|e| f.error(e))?;
    f.commit()
}

/// Whether `a` and `b` name the same file, whether or not either exists yet: their
/// folders are compared once resolved (symbolic links, `..`), then their names.
pub fn same_file(a: &Path, b: &Path) -> bool {
    fn resolve(p: &Path) -> Option<PathBuf> {
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let name = p.file_name()?;
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Some(resolve(&parent)?.join(name))
    }
    match (resolve(a), resolve(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// Set once an interrupt (SIGINT, SIGTERM) asks the current run to stop.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Whether the run was asked to stop. Long loops (steps, frames, bench cases) check
/// this and stop cleanly: outputs not yet complete are removed, complete ones kept.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// Records an interrupt (what a signal handler calls; tests call it directly).
pub fn interrupt() {
    INTERRUPTED.store(true, Ordering::Relaxed);
}

/// Clears the interrupt flag (for tests).
pub fn clear_interrupt() {
    INTERRUPTED.store(false, Ordering::Relaxed);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("sandbox2d-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn an_uncommitted_file_leaves_nothing_and_a_committed_one_is_whole() {
        let d = dir("atomic");
        let path = d.join("out.csv");
        std::fs::write(&path, "old, complete\n").unwrap();
        {
            let mut f = AtomicFile::create(&path).unwrap();
            f.write_all(b"half a r").unwrap();
            // dropped (an error, an interrupt): the old file stays as it was
        }
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old, complete\n");
        assert_eq!(
            std::fs::read_dir(&d).unwrap().count(),
            1,
            "no temporary file left"
        );
        write_atomic(&path, b"new\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new\n");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn an_unwritable_place_is_an_error_that_names_the_file() {
        let d = dir("missing");
        let path = d.join("no_such_folder").join("results.md");
        let e = write_atomic(&path, b"x").unwrap_err();
        assert_eq!(e.path, path);
        assert!(
            e.to_string()
                .starts_with(&format!("{}: cannot write:", path.display()))
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn same_file_sees_through_spellings() {
        let d = dir("same");
        let a = d.join("a.toml");
        std::fs::write(&a, "x").unwrap();
        assert!(same_file(&a, &d.join(".").join("a.toml")));
        // a file not yet written, through a folder and back
        std::fs::create_dir_all(d.join("x")).unwrap();
        assert!(same_file(
            &d.join("new.csv"),
            &d.join("x").join("..").join("new.csv")
        ));
        assert!(!same_file(&a, &d.join("b.toml")));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
