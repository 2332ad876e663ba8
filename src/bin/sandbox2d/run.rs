//! `sandbox2d run`: the window on a scene (or, without a display or the window
//! feature, its frames headless into ./out).

use std::path::{Path, PathBuf};

use sandbox2d::output;
use sandbox2d::scene::Scene;

use crate::args::{RunArgs, pane_label, parse_compare};
use crate::failure::Failure;
use crate::load::build;
use crate::paths::{
    check_distinct, check_folder_outputs, frame_it_writes, is_frame_name, scene_file,
};
use crate::render::{print_written, render_job};

/// Frames the headless fallback of `run` writes when `--frames` is not given.
const FALLBACK_FRAMES: u32 = 120;

pub fn run(a: &RunArgs) -> Result<(), Failure> {
    // Refuse a bad scene or flag before any window opens.
    if let (Some(shot), Some(file)) = (&a.screenshot, scene_file(&a.scene)) {
        check_distinct(&[("--screenshot", shot)], &[("scene file", &file)])?;
    }
    let (sc, _, _) = build(&a.scene, &a.solver)?;
    // --compare: each pane's flags over the command line's, checked before any window
    let mut panes = Vec::new();
    if !a.compare.is_empty() {
        let flags = parse_compare(&a.compare)?;
        for (v, f) in a.compare.iter().zip(&flags) {
            let f = f.over(&a.solver);
            build(&a.scene, &f)?;
            panes.push((pane_label(v), f.overrides()));
        }
    }
    #[cfg(feature = "app")]
    {
        use sandbox2d::app::{AppError, AppOptions};
        let opts = AppOptions {
            frames: a.frames,
            screenshot: a.screenshot.clone(),
            show_panel: !a.no_panel,
        };
        for (i, (label, _)) in panes.iter().enumerate() {
            say!("pane {}: {label}", i + 1)?;
        }
        let shown = if panes.is_empty() {
            sandbox2d::app::run(sc.clone(), a.solver.overrides(), opts)
        } else {
            sandbox2d::app::run_compare(sc.clone(), panes.clone(), opts)
        };
        match shown {
            Ok(report) => {
                say!(
                    "sandbox2d: {} frames in {:.2} s: {:.1} fps (frame time median {:.1} ms, p95 {:.1} ms) on {}",
                    report.frames,
                    report.seconds,
                    report.fps(),
                    report.frame_ms_median,
                    report.frame_ms_p95,
                    if report.adapter.is_empty() {
                        "?"
                    } else {
                        &report.adapter
                    }
                )?;
                if let Some(p) = &report.screenshot {
                    say!("screenshot: {}", p.display())?;
                }
                return Ok(());
            }
            Err(AppError::NoDisplay(why)) => {
                say!(
                    "sandbox2d: no display ({why}); rendering {:?} headless into ./out instead",
                    sc.name
                )?;
            }
            Err(AppError::Build(e)) => return Err(Failure::input(e)),
            Err(e) => return Err(Failure::run(e)),
        }
    }
    #[cfg(not(feature = "app"))]
    say!(
        "sandbox2d: built without the window (feature \"app\"); rendering {:?} headless into ./out instead",
        sc.name
    )?;
    run_headless(a, &sc)
}

/// `run` without a display: frames of the scene into ./out (and the last one to
/// `--screenshot`).
fn run_headless(a: &RunArgs, sc: &Scene) -> Result<(), Failure> {
    let out = PathBuf::from("out");
    let frames = match a.frames {
        Some(0) => return Err(Failure::input("--frames must be at least 1")),
        Some(n) => u32::try_from(n).map_err(|_| {
            Failure::input(format!("--frames must be at most {}, got {n}", u32::MAX))
        })?,
        None => FALLBACK_FRAMES,
    };
    if let Some(shot) = &a.screenshot {
        let mut inputs: Vec<(&str, PathBuf)> = vec![("output folder", out.clone())];
        if let Some(file) = scene_file(&a.scene) {
            inputs.push(("scene file", file));
        }
        if let Some(frame) = frame_it_writes(shot, &out, frames) {
            inputs.push(("frame it writes", frame));
        }
        let inputs: Vec<(&str, &Path)> = inputs.iter().map(|(w, p)| (*w, p.as_path())).collect();
        check_distinct(&[("--screenshot", shot)], &inputs)?;
    }
    if let Some(file) = scene_file(&a.scene) {
        check_folder_outputs(
            "the headless frames (./out)",
            &out,
            |n| is_frame_name(n, frames),
            &[("scene file", &file)],
        )?;
    }
    let (_, mut world, _) = build(&a.scene, &a.solver)?;
    let job = sandbox2d::render::FrameJob {
        frames,
        every: 1,
        out_dir: out.clone(),
        gif: None,
        overlays: sandbox2d::draw::Overlays::NONE,
    };
    let written = render_job(sc, &mut world, sc.camera.size, &job)?;
    print_written(&written, &out)?;
    if let (Some(shot), Some(last)) = (&a.screenshot, written.pngs.last()) {
        let bytes = std::fs::read(last)
            .map_err(|e| Failure::run(format!("{}: cannot read: {e}", last.display())))?;
        output::write_atomic(shot, &bytes).map_err(Failure::run)?;
        say!("screenshot: {}", shot.display())?;
    }
    Ok(())
}
