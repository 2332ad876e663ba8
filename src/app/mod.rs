//! The interactive sandbox (feature `app`): a winit window with a wgpu surface, the
//! world drawn by [`crate::render::Renderer`], and an egui side panel to pick scenes,
//! tune the solver, toggle overlays and watch the figures.
//!
//! Controls: left drag on a body pulls it with the mouse joint ([`input::drag_body`]); left
//! drag on empty space pans; the wheel zooms about the cursor; the right button held
//! pushes bodies away from the cursor; middle click or ctrl+click spawns a box,
//! shift+click a circle; Delete or Backspace removes the body under the cursor; space pauses, S steps, R resets, H hides or shows the panel; F
//! fits the view to the bodies, C follows the body last grabbed, Esc and Q quit. Left
//! and Right go a step back and on in the timeline of the last seconds (shift: a
//! second; Home and End: the oldest and newest step kept), B branches there: a pane from
//! that step with the panel's settings (`docs/timeline.md`).
//!
//! [`run`] returns [`AppError::NoDisplay`] when there is no display to open a window
//! on; the command line then renders frames headless instead.

pub mod input;
mod panel_layer;
pub mod session;
mod ui;
mod window;

use std::path::PathBuf;

use crate::defs::SolverOverrides;
use crate::render::RenderError;
use crate::scene::Scene;

pub use session::Session;

/// What to show and for how long.
#[derive(Clone, Debug)]
pub struct AppOptions {
    /// Stop after this many presented frames (and write `screenshot`); run until the
    /// window closes when `None`.
    pub frames: Option<u64>,
    /// Save the last frame as a PNG here (with `frames`).
    pub screenshot: Option<PathBuf>,
    /// Show the side panel at start (H toggles it).
    pub show_panel: bool,
}

/// What a run measured.
#[derive(Clone, Debug, PartialEq)]
pub struct RunReport {
    /// Frames presented.
    pub frames: u64,
    /// Seconds from the first frame presented to the last.
    pub seconds: f64,
    /// Median time between frames (ms).
    pub frame_ms_median: f32,
    /// 95th percentile of the time between frames (ms).
    pub frame_ms_p95: f32,
    /// The screenshot written, if any.
    pub screenshot: Option<PathBuf>,
    /// The graphics adapter the window ran on.
    pub adapter: String,
}

impl RunReport {
    /// Frames per second between the first and the last frame.
    pub fn fps(&self) -> f64 {
        if self.frames >= 2 && self.seconds > 0.0 {
            (self.frames - 1) as f64 / self.seconds
        } else {
            0.0
        }
    }
}

/// Why the window could not run.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// No display to open a window on (no X11/Wayland server, or the window was refused).
    #[error("no display: {0}")]
    NoDisplay(String),
    /// The scene's world could not be built.
    #[error("{0}")]
    Build(String),
    /// No adapter, device or surface for the window.
    #[error("{0}")]
    Gpu(String),
    /// Rendering or saving the screenshot failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The event loop failed while running.
    #[error("event loop: {0}")]
    EventLoop(String),
}

/// Opens the window on `scene` (its solver settings merged with `overrides`) and runs
/// until it is closed or `opts.frames` frames were shown.
pub fn run(
    scene: Scene,
    overrides: SolverOverrides,
    opts: AppOptions,
) -> Result<RunReport, AppError> {
    let session = Session::new(scene, overrides).map_err(AppError::Build)?;
    let event_loop = winit::event_loop::EventLoop::new().map_err(|e| {
        AppError::NoDisplay(format!("cannot open a window: {}", tidy(&e.to_string())))
    })?;
    window::App::new(opts, session).run(event_loop)
}

/// `run --compare`: opens the window on `panes` side by side, each `(label, flags)` the
/// scene with those solver flags (already merged with the command line's), stepped in
/// lock step; the mouse acts on every pane at the same world point.
pub fn run_compare(
    scene: Scene,
    panes: Vec<(String, SolverOverrides)>,
    opts: AppOptions,
) -> Result<RunReport, AppError> {
    let mut sessions = Vec::with_capacity(panes.len());
    let mut labels = Vec::with_capacity(panes.len());
    for (label, o) in panes {
        sessions.push(Session::new(scene.clone(), o).map_err(AppError::Build)?);
        labels.push(label);
    }
    if sessions.is_empty() {
        return Err(AppError::Build("--compare: no pane".into()));
    }
    let first = sessions.remove(0);
    let event_loop = winit::event_loop::EventLoop::new().map_err(|e| {
        AppError::NoDisplay(format!("cannot open a window: {}", tidy(&e.to_string())))
    })?;
    let compare = session::Compare {
        labels,
        others: sessions,
    };
    window::App::new(opts, first)
        .with_compare(compare)
        .run(event_loop)
}

/// winit's message without the source location it prefixes ("os error at FILE:LINE: ").
fn tidy(message: &str) -> String {
    message
        .strip_prefix("os error at ")
        .and_then(|rest| rest.split_once(": ").map(|(_, why)| why))
        .unwrap_or(message)
        .trim_end_matches('.')
        .to_string()
}

#[cfg(test)]
mod tests {
    #[test]
    fn tidy_drops_the_source_location() {
        assert_eq!(
            super::tidy("os error at /x/winit/src/linux/mod.rs:765: neither DISPLAY nor X is set."),
            "neither DISPLAY nor X is set"
        );
        assert_eq!(super::tidy("plain"), "plain");
    }
}
