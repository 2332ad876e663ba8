//! The README and docs/ say what is true now, in the project's own words: the history of
//! the project is its git log, so no document, comment or test carries work-log entries
//! (a work session's number, an issue's number, a dated diary line, a commit hash in
//! prose), and no document points at a path outside the repository, which a reader of
//! a clone does not have.

use std::path::{Component, Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every file under `dir` whose name ends in one of `exts`, sorted.
fn files(dir: &Path, exts: &[&str]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(files(&p, exts));
        } else if exts
            .iter()
            .any(|x| p.to_string_lossy().ends_with(&format!(".{x}")))
        {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// Commits named on purpose: the Box2D v3 version the figures were measured against.
const PINNED: &[&str] = &["617d32ab"];

/// The words of `line` (letters, digits, '-' and '_'), lower-cased.
fn words(line: &str) -> Vec<String> {
    line.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-' || c == '_'))
        .filter(|w| !w.is_empty())
        .map(str::to_ascii_lowercase)
        .collect()
}

/// A work session's number: the word session (or sessions) followed by a number.
fn names_a_session(line: &str) -> bool {
    let w = words(line);
    w.windows(2).any(|p| {
        (p[0] == "session" || p[0] == "sessions") && p[1].starts_with(|c: char| c.is_ascii_digit())
    })
}

/// An issue's number: the word issue (or issues) followed by a number.
fn names_an_issue(line: &str) -> bool {
    let w = words(line);
    w.windows(2).any(|p| {
        (p[0] == "issue" || p[0] == "issues") && p[1].starts_with(|c: char| c.is_ascii_digit())
    })
}

/// What in `line` reads as a work-log entry, if anything: a session's number, an
/// issue's number, a date (2026-11-27), a commit hash (7 to 40 hex digits, letters and
/// digits both, not one of [`PINNED`]).
fn work_log(line: &str) -> Option<String> {
    if names_a_session(line) {
        return Some("a work session's number".into());
    }
    if names_an_issue(line) {
        return Some("an issue's number".into());
    }
    for word in &words(line) {
        let b = word.as_bytes();
        let is_date = b.len() == 10
            && b[4] == b'-'
            && b[7] == b'-'
            && b.iter()
                .enumerate()
                .all(|(i, c)| i == 4 || i == 7 || c.is_ascii_digit());
        if is_date {
            return Some(format!("a date ({word})"));
        }
        let hex = (7..=40).contains(&b.len())
            && b.iter().all(|c| c.is_ascii_hexdigit())
            && b.iter().any(|c| c.is_ascii_digit())
            && b.iter().any(|c| c.is_ascii_alphabetic());
        if hex && !PINNED.contains(&word.as_str()) {
            return Some(format!("a commit hash ({word})"));
        }
    }
    None
}

/// Where `line` points outside the repository: a `../` path from the README, an
/// absolute path of the machine it was written on, or a markdown link from `file`
/// (a document in the repository) that leaves it.
fn outside(file: &Path, line: &str) -> Option<String> {
    for mark in ["/work/", "/home/", "/root/", "shared/peers", "../shared"] {
        if line.contains(mark) {
            return Some(format!("a path on another machine ({mark})"));
        }
    }
    let dir = file.parent().unwrap_or(Path::new(""));
    let mut rest = line;
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        let target = rest.split([')', '#', ' ']).next().unwrap_or("");
        if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
            continue;
        }
        // resolved against the document's folder, it must stay inside the repository
        let mut depth: i32 = dir.components().count() as i32;
        for c in Path::new(target).components() {
            match c {
                Component::ParentDir => depth -= 1,
                Component::Normal(_) => depth += 1,
                _ => return Some(format!("an absolute link ({target})")),
            }
            if depth < 0 {
                return Some(format!("a link out of the repository ({target})"));
            }
        }
    }
    if dir.as_os_str().is_empty() && line.contains("../") {
        return Some("a path above the repository (../)".into());
    }
    None
}

#[test]
fn the_detectors_find_work_log_entries_and_outside_paths() {
    let s = "session";
    let i = "issue";
    for entry in [
        format!("measured in {s} 26 on a busy hour"),
        format!("### {s}s 23 and 24: a hang"),
        "the build before (8f1d684) took 3.1 ms".to_string(),
        "2026-11-27: tried the eight-lane sweep".to_string(),
        format!("{i} 16's target"),
    ] {
        assert!(work_log(&entry).is_some(), "not found in {entry:?}");
    }
    for fine in [
        "the seed's method and the lab's reference",
        "a fresh session starts from the scene (R)",
        "Box2D v3 is commit 617d32ab",
        "1280x720 at 60 fps, 0.0072 ms/step, deadbeef",
    ] {
        assert_eq!(work_log(fine), None, "{fine:?}");
    }
    let readme = Path::new("README.md");
    let doc = Path::new("docs/cli.md");
    assert!(outside(readme, "(`../shared/peers/rapier-bench`)").is_some());
    assert!(outside(readme, "see [the peers](../peers/box2d)").is_some());
    assert!(outside(doc, "[gif](../../elsewhere/demo.gif)").is_some());
    assert!(outside(doc, "cloned at /work/peers/box2d").is_some());
    assert_eq!(outside(doc, "[gif](../assets/readme/demo.gif)"), None);
    assert_eq!(
        outside(
            readme,
            "[cli](docs/cli.md#threads), [web](https://example.org/a)"
        ),
        None
    );
}

#[test]
fn the_readme_has_no_work_log_and_no_path_outside_the_repository() {
    let path = repo().join("README.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let lines = text.lines().count();
    assert!(
        lines < 250,
        "README.md is {lines} lines; detail goes to docs/"
    );
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if let Some(what) = work_log(line).or_else(|| outside(Path::new("README.md"), line)) {
            found.push(format!("README.md:{}: {what}: {line}", i + 1));
        }
    }
    assert!(found.is_empty(), "{}", found.join("\n"));
    // its first lines give the two commands
    let head: String = text.lines().take(8).collect::<Vec<_>>().join("\n");
    assert!(head.contains("cargo run --release") && head.contains("cargo test"));
}

#[test]
fn no_document_comment_or_test_names_a_work_session_or_an_issue_and_links_stay_inside() {
    let root = repo();
    let mut found = Vec::new();
    let mut all = files(&root.join("docs"), &["md"]);
    for dir in ["src", "tests", "examples", "benches"] {
        all.extend(files(&root.join(dir), &["rs"]));
    }
    for path in &all {
        let text = std::fs::read_to_string(path).unwrap();
        let rel = path.strip_prefix(&root).unwrap();
        for (i, line) in text.lines().enumerate() {
            let md = rel.extension().is_some_and(|e| e == "md");
            let what = if names_a_session(line) {
                Some("a work session's number".to_string())
            } else if names_an_issue(line) {
                Some("an issue's number".to_string())
            } else if md {
                outside(rel, line)
            } else {
                None
            };
            if let Some(what) = what {
                found.push(format!("{}:{}: {what}", rel.display(), i + 1));
            }
        }
    }
    assert!(found.is_empty(), "{}", found.join("\n"));
}
