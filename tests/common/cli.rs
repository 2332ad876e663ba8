//! The binary as a user runs it, and a scratch folder per test binary and process.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::Command;

/// The release-or-debug `sandbox2d` binary cargo built for these tests.
pub fn sandbox2d() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sandbox2d"))
}

/// A path named `name` in this test binary's scratch folder (created if missing):
/// `$TMP/sandbox2d-<test binary>-<pid>/name`.
pub fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "sandbox2d-{}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The files left in `dir` and below whose names end in `.tmp` (a command's temporary
/// files: none may be left, whatever happened).
pub fn temporaries(dir: &std::path::Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(temporaries(&p));
        } else if p.to_string_lossy().ends_with(".tmp") {
            out.push(p.display().to_string());
        }
    }
    out
}

/// Runs the binary with `args` in `cwd` under bash's limits (`limits`: e.g. `ulimit -f
/// 4`; the binary ignores SIGXFSZ, so a write past a file-size limit fails with EFBIG as
/// a write to a full disk fails with ENOSPC), with no display.
pub fn limited(limits: &str, args: &[&str], cwd: &std::path::Path) -> std::process::Output {
    Command::new("bash")
        .arg("-c")
        .arg(format!("{limits}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_sandbox2d"))
        .args(args)
        .current_dir(cwd)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap()
}

/// Starts the binary with `args` in `dir` (stderr kept, stdout dropped) and waits up to
/// a minute for the temporary file of its output `name` to appear; whether it did (the
/// run has begun writing).
pub fn start_writing(
    args: &[&str],
    dir: &std::path::Path,
    name: &str,
) -> (std::process::Child, bool) {
    let child = sandbox2d()
        .args(args)
        .current_dir(dir)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let temp = dir.join(format!(".{name}.{}.tmp", child.id()));
    let t = std::time::Instant::now();
    while !temp.exists() && t.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    (child, temp.exists())
}
