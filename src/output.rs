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
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// The temporary files being written now: what a process that must end at once (a
/// second interrupt) removes before it goes, so that it leaves nothing half-written.
static LIVE: Mutex<Vec<Live>> = Mutex::new(Vec::new());

/// A temporary file being written, and for a [`RowFile`] the name it is kept under
/// and how many of its bytes are whole rows.
struct Live {
    temp: PathBuf,
    keep: Option<(PathBuf, Arc<AtomicU64>)>,
}

fn live() -> std::sync::MutexGuard<'static, Vec<Live>> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Creates the temporary file `temp` and records it as incomplete, in one step under
/// the record's lock: [`abandon`] never misses a file that exists.
pub fn create_tracked(temp: &Path) -> std::io::Result<File> {
    create_recorded(temp, None)
}

fn create_recorded(temp: &Path, keep: Option<(PathBuf, Arc<AtomicU64>)>) -> std::io::Result<File> {
    let mut list = live();
    let f = File::create(temp)?;
    list.push(Live {
        temp: temp.to_path_buf(),
        keep,
    });
    Ok(f)
}

/// Forgets `temp` (renamed to its final name, or removed).
pub fn untrack(temp: &Path) {
    let mut list = live();
    if let Some(i) = list.iter().rposition(|l| l.temp == temp) {
        list.swap_remove(i);
    }
}

/// Ends the process at once with `code`: removes every temporary file still being
/// written (a [`RowFile`] is kept under its name instead, cut to its last whole row),
/// prints `error: MESSAGE` and what it removed and kept as one line on stderr, and
/// exits. The record stays locked to the end, so no new temporary file appears
/// meanwhile. For a second interrupt, which must not wait for a step to finish.
pub fn abandon(code: i32, message: &str) -> ! {
    if !claim_last_word() {
        // the command is saying its own last line and ending: one line is enough
        loop {
            std::thread::park();
        }
    }
    let list = live();
    let mut removed = 0;
    let mut kept = Vec::new();
    for l in list.iter() {
        match &l.keep {
            Some((path, whole)) => {
                if keep_rows(&l.temp, path, whole.load(Ordering::SeqCst)).is_ok() {
                    kept.push(path.display().to_string());
                }
            }
            None => {
                if std::fs::remove_file(&l.temp).is_ok() {
                    removed += 1;
                }
            }
        }
    }
    let mut tail = match removed {
        0 => String::new(),
        1 => "; removed 1 incomplete file".to_owned(),
        n => format!("; removed {n} incomplete files"),
    };
    if !kept.is_empty() {
        tail += &format!("; kept the finished rows in {}", kept.join(", "));
    }
    let _ = writeln!(
        std::io::stderr(),
        "error: {}",
        crate::scene::escape_controls(&format!("{message}{tail}"))
    );
    std::process::exit(code);
}

/// Cuts `temp` to its first `whole` bytes and renames it to `path`.
fn keep_rows(temp: &Path, path: &Path, whole: u64) -> std::io::Result<()> {
    std::fs::OpenOptions::new()
        .write(true)
        .open(temp)?
        .set_len(whole)?;
    std::fs::rename(temp, path)
}

/// A file of rows that grows as a long run goes (the bench's partial results): the
/// rows go to a temporary file at once, each written whole or cut off again. A run
/// that completes drops it (removed); one that stops early, fails, or is abandoned
/// ([`abandon`]) keeps it under its name, holding only whole rows.
#[derive(Debug)]
pub struct RowFile {
    path: PathBuf,
    temp: PathBuf,
    file: File,
    /// Bytes of whole rows so far.
    whole: Arc<AtomicU64>,
    rows: u64,
}

impl RowFile {
    /// Starts the rows of `path` (through its temporary file).
    pub fn create(path: impl AsRef<Path>) -> Result<RowFile, OutputError> {
        let path = path.as_ref().to_path_buf();
        let temp = temp_path(&path);
        let whole = Arc::new(AtomicU64::new(0));
        let file =
            create_recorded(&temp, Some((path.clone(), whole.clone()))).map_err(|source| {
                OutputError {
                    path: path.clone(),
                    source,
                }
            })?;
        Ok(RowFile {
            path,
            temp,
            file,
            whole,
            rows: 0,
        })
    }

    /// The name the rows are kept under.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Rows written whole so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Appends `row` (one line, with its newline) whole, or not at all: a write that
    /// fails part way is cut off again, and the error names the file.
    pub fn push(&mut self, row: &str) -> Result<(), OutputError> {
        // under the record's lock: an abandon cuts the file between rows, never in one
        let _lock = live();
        let whole = self.whole.load(Ordering::SeqCst);
        match self.file.write_all(row.as_bytes()) {
            Ok(()) => {
                self.whole.store(whole + row.len() as u64, Ordering::SeqCst);
                self.rows += 1;
                Ok(())
            }
            Err(source) => {
                let _ = self.file.set_len(whole);
                Err(OutputError {
                    path: self.path.clone(),
                    source,
                })
            }
        }
    }

    /// Keeps the whole rows under the file's name (a run that stopped early).
    pub fn keep(self) -> Result<PathBuf, OutputError> {
        let done = keep_rows(&self.temp, &self.path, self.whole.load(Ordering::SeqCst));
        untrack(&self.temp);
        done.map_err(|source| OutputError {
            path: self.path.clone(),
            source,
        })?;
        Ok(self.path.clone())
    }
}

impl Drop for RowFile {
    fn drop(&mut self) {
        // kept: renamed, so this finds nothing; else the rows are not wanted
        let _ = std::fs::remove_file(&self.temp);
        untrack(&self.temp);
    }
}

/// Asks the system to let a write that passes the file size limit (`ulimit -f`) fail
/// with an error, rather than end the process by SIGXFSZ with no word and a temporary
/// file left behind: the error then names the file, and the temporary file is removed
/// as on any write error. The command line calls this first thing.
pub fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to SIG_IGN runs no code of ours in a
    // signal handler; it is what `trap '' XFSZ` does in a shell.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

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
        let file = create_tracked(&temp).map_err(|source| OutputError {
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

    /// Flushes the file and renames it to its final name. On an error (the last
    /// buffered bytes do not fit on the disk, the rename fails) the temporary file is
    /// removed and nothing is left at the final name.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let Some(out) = self.out.take() else {
            return Ok(());
        };
        let done = out
            .into_inner()
            .map_err(|e| std::io::Error::new(e.error().kind(), e.error().to_string()))
            .and_then(|file| {
                drop(file);
                std::fs::rename(&self.temp, &self.path)
            });
        if done.is_err() {
            let _ = std::fs::remove_file(&self.temp);
        }
        untrack(&self.temp);
        done.map_err(|source| self.error(source))
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
            untrack(&self.temp);
        }
    }
}

/// Writes `bytes` to `path` in full or not at all.
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), OutputError> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|e| f.error(e))?;
    f.commit()
}

/// Whether `a` and `b` name the same file, whether or not either exists yet: two files
/// that exist are the same when they are one file on the disk (hard links too, on
/// Unix); otherwise their folders are compared once resolved (symbolic links, `..`),
/// then their names.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
        use std::os::unix::fs::MetadataExt;
        return (x.dev(), x.ino()) == (y.dev(), y.ino());
    }
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

/// Set by whoever says the process's last line: the command's own failure, or an
/// interrupt that ends it at once ([`abandon`]). The other keeps quiet, so a second
/// interrupt that comes while a stopped run says why it stopped adds no second line.
static LAST_WORD: AtomicBool = AtomicBool::new(false);

/// Claims the process's last line on stderr: true for the first caller only.
pub fn claim_last_word() -> bool {
    !LAST_WORD.swap(true, Ordering::SeqCst)
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
