//! The README's commands, run as a user would copy them: every `sandbox2d` command in
//! its `sh` blocks that is quick (`scenes`, `simulate`, `render`) runs in a scratch
//! folder, in the README's order, and does what the README says: it succeeds, prints,
//! and writes the frames, GIF, trace and state it names. The window (`run`, which needs
//! a display), `bench` and `tune` (minutes each; their flags have tests of their own in
//! tests/bench.rs and tests/tune.rs) are left out, and listed so that a new kind of
//! command in the README is not skipped unseen.

#![cfg(feature = "render")]

mod common;

use common::cli::{sandbox2d, tmp};
use std::path::Path;

/// The README's `sh` blocks, one command per line (continuations joined, comments cut).
fn readme_commands() -> Vec<String> {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md"))
        .expect("README.md");
    let mut out = Vec::new();
    let mut in_sh = false;
    let mut pending = String::new();
    for line in text.lines() {
        if line.starts_with("```") {
            in_sh = line.trim() == "```sh";
            continue;
        }
        if !in_sh {
            continue;
        }
        let code = line.split("  #").next().unwrap_or("").trim_end();
        if let Some(head) = code.strip_suffix('\\') {
            pending.push_str(head);
            pending.push(' ');
            continue;
        }
        pending.push_str(code);
        let cmd = pending.split_whitespace().collect::<Vec<_>>().join(" ");
        pending.clear();
        if !cmd.is_empty() {
            out.push(cmd);
        }
    }
    out
}

/// Words of a command line, double quotes grouping.
fn words(cmd: &str) -> Vec<String> {
    let (mut out, mut word, mut quoted, mut any) = (Vec::new(), String::new(), false, false);
    for ch in cmd.chars() {
        match ch {
            '"' => {
                quoted = !quoted;
                any = true;
            }
            c if c.is_whitespace() && !quoted => {
                if any {
                    out.push(std::mem::take(&mut word));
                    any = false;
                }
            }
            c => {
                word.push(c);
                any = true;
            }
        }
    }
    if any {
        out.push(word);
    }
    out
}

fn value<'a>(args: &'a [String], flag: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == flag)
        .and_then(|i| args.get(i + 1))
        .map(String::as_str)
}

#[test]
fn the_readmes_quick_commands_do_what_it_says() {
    let commands = readme_commands();
    let dir = tmp("readme");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("assets/readme")).unwrap();
    std::fs::create_dir_all(dir.join("docs")).unwrap();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    // the README's own scene files, and `my_scene.toml` (its example of "your scene")
    std::fs::copy(
        repo.join("assets/readme/demo.toml"),
        dir.join("assets/readme/demo.toml"),
    )
    .unwrap();
    std::fs::copy(
        repo.join("assets/scenes/stack.toml"),
        dir.join("my_scene.toml"),
    )
    .unwrap();
    let scratch = dir.to_str().unwrap().to_owned();

    let (mut ran, mut skipped) = (Vec::new(), Vec::new());
    for cmd in &commands {
        let w = words(cmd);
        if w.first().map(String::as_str) != Some("sandbox2d") {
            skipped.push(cmd.clone());
            continue;
        }
        let sub = w.get(1).map(String::as_str).unwrap_or("");
        if !matches!(sub, "scenes" | "simulate" | "render") {
            assert!(
                matches!(sub, "run" | "bench" | "tune"),
                "a README command of a kind this test does not know: {cmd}"
            );
            skipped.push(cmd.clone());
            continue;
        }
        // absolute scratch paths of the README go to this test's folder
        let args: Vec<String> = w[1..]
            .iter()
            .map(|a| a.replacen("/tmp/", &format!("{scratch}/tmp_"), 1))
            .collect();
        let out = sandbox2d().args(&args).current_dir(&dir).output().unwrap();
        assert!(
            out.status.success(),
            "`{cmd}` failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        match sub {
            "scenes" => assert!(String::from_utf8_lossy(&out.stdout).contains("pyramid")),
            "simulate" => {
                let text = String::from_utf8_lossy(&out.stdout);
                if args.iter().any(|a| a == "--json") {
                    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
                    assert!(v["state_hash"].is_string(), "`{cmd}`: {text}");
                } else {
                    assert!(text.contains("ms/step"), "`{cmd}`: {text}");
                }
                for flag in ["--trace", "--save-state"] {
                    if let Some(file) = value(&args, flag) {
                        let meta = std::fs::metadata(dir.join(file))
                            .unwrap_or_else(|e| panic!("`{cmd}` wrote no {file}: {e}"));
                        assert!(meta.len() > 0, "`{cmd}`: {file} is empty");
                    }
                }
            }
            "render" => {
                let frames: usize = value(&args, "--frames").unwrap().parse().unwrap();
                let folder = dir.join(value(&args, "--out").unwrap());
                let pngs = std::fs::read_dir(&folder)
                    .unwrap()
                    .filter(|e| {
                        e.as_ref()
                            .unwrap()
                            .file_name()
                            .to_string_lossy()
                            .ends_with(".png")
                    })
                    .count();
                assert_eq!(pngs, frames, "`{cmd}`: {pngs} frames in {folder:?}");
                if let Some(gif) = value(&args, "--gif") {
                    let bytes = std::fs::read(dir.join(gif)).unwrap();
                    assert!(bytes.starts_with(b"GIF89a"), "`{cmd}`: {gif} is not a GIF");
                }
            }
            _ => unreachable!(),
        }
        ran.push(cmd.clone());
    }
    // the blocks were found and most of what they show is run here
    assert!(ran.len() >= 10, "ran {ran:?}, skipped {skipped:?}");
    assert!(ran.iter().any(|c| c.contains("--load-state")));
    assert!(ran.iter().any(|c| c.contains("--compare")));
}
