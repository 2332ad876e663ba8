//! Window smoke test: opens the real window under Xvfb, runs 30 frames and checks the
//! screenshot is a picture of the scene, not a blank.
//!
//! Runs only when `SANDBOX2D_WINDOW_TEST=1` and `xvfb-run` is on the PATH (`.ci/run`
//! sets the variable after installing xvfb); otherwise it says why and passes.
#![cfg(feature = "app")]

use std::path::PathBuf;
use std::process::Command;

fn xvfb_run() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("xvfb-run"))
        .find(|p| p.is_file())
}

/// Runs `sandbox2d run ARGS --screenshot FILE` under xvfb-run and returns the
/// screenshot and stdout; `None` (after saying why) unless `SANDBOX2D_WINDOW_TEST=1`.
fn screenshot(name: &str, args: &[&str]) -> Option<(image::RgbaImage, String)> {
    if std::env::var("SANDBOX2D_WINDOW_TEST").as_deref() != Ok("1") {
        eprintln!("SKIPPED: set SANDBOX2D_WINDOW_TEST=1 to open a window under xvfb-run");
        return None;
    }
    let Some(xvfb) = xvfb_run() else {
        panic!("SANDBOX2D_WINDOW_TEST=1 but xvfb-run is not on the PATH (apt-get install xvfb)");
    };
    let dir = std::env::temp_dir().join(format!("sandbox2d-window-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let shot = dir.join(name);
    let _ = std::fs::remove_file(&shot);
    let out = Command::new(xvfb)
        .args(["-a", "-s", "-screen 0 1600x900x24"])
        .arg(env!("CARGO_BIN_EXE_sandbox2d"))
        .arg("run")
        .args(args)
        .arg("--screenshot")
        .arg(&shot)
        .current_dir(&dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let img = image::open(&shot)
        .unwrap_or_else(|e| panic!("{}: {e}\n{stdout}\n{stderr}", shot.display()))
        .to_rgba8();
    Some((img, stdout))
}

#[test]
fn window_opens_under_xvfb_and_draws_the_scene() {
    let Some((img, stdout)) = screenshot("shot.png", &["pyramid", "--frames", "30"]) else {
        return;
    };
    // The window opened: no headless fallback, and the frame rate was measured.
    assert!(!stdout.contains("no display"), "{stdout}");
    assert!(
        stdout.contains("30 frames") && stdout.contains("fps"),
        "{stdout}"
    );
    assert_eq!(img.dimensions(), (1280, 720), "the window's size in pixels");
    // The world area: right of the side panel (260 points wide at 1 pixel a point,
    // on the left), so the panel's own widgets and text cannot make a blank world pass.
    let world_x0 = 400;
    let world: Vec<[u8; 4]> = img
        .enumerate_pixels()
        .filter(|(x, _, _)| *x >= world_x0)
        .map(|(_, _, p)| p.0)
        .collect();
    let mut colours = world.clone();
    colours.sort_unstable();
    colours.dedup();
    assert!(
        colours.len() >= 8,
        "only {} distinct colours right of x = {world_x0}: a blank world?",
        colours.len()
    );
    // The pyramid covers a good part of it: at least 5% of the world area's pixels are
    // not the most common colour (the background).
    let mut counts = std::collections::HashMap::new();
    for p in &world {
        *counts.entry(*p).or_insert(0usize) += 1;
    }
    let background = counts
        .iter()
        .max_by_key(|(_, n)| **n)
        .map(|(c, _)| *c)
        .unwrap();
    let drawn = world.iter().filter(|p| **p != background).count();
    assert!(
        drawn * 20 >= world.len(),
        "only {drawn} of {} world-area pixels differ from the background {background:?}",
        world.len()
    );
}

#[test]
fn every_compare_pane_draws_its_scene_beside_the_panel() {
    // three panes right of the panel: each must show its pyramid (a pane whose items
    // were all culled, or drawn under the panel, would be blank)
    let args = [
        "pyramid",
        "--frames",
        "30",
        "--compare",
        "--solver soft",
        "--compare",
        "--solver pgs",
        "--compare",
        "--solver xpbd",
    ];
    let Some((img, _)) = screenshot("panes.png", &args) else {
        return;
    };
    let (w, h) = img.dimensions();
    let background = *img.get_pixel(w - 1, h - 1);
    // the panes share the window right of the panel (about 300 px); below the labels
    let (x0, y0) = (310u32, 120u32);
    let pw = (w - x0) / 3;
    for k in 0..3 {
        let (a, b) = (x0 + k * pw, x0 + (k + 1) * pw);
        let mut drawn = 0usize;
        let mut all = 0usize;
        for y in y0..h {
            for x in a..b {
                all += 1;
                drawn += usize::from(*img.get_pixel(x, y) != background);
            }
        }
        assert!(
            drawn * 50 >= all,
            "pane {} (x {a}..{b}): only {drawn} of {all} pixels drawn",
            k + 1
        );
    }
}
