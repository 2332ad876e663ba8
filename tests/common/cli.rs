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
