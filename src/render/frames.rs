//! Rendering a running world to numbered PNG frames and, optionally, an animated GIF:
//! what `sandbox2d render` does, and what `sandbox2d run` falls back to without a display.

use std::path::PathBuf;

use super::{GifWriter, RenderError, Renderer, save_png};
use crate::draw::world::{Overlays, fill_world_draw_list};
use crate::draw::{Camera, DrawList};
use crate::world::{StepError, World};

/// What to render.
#[derive(Clone, Debug)]
pub struct FrameJob {
    /// Frames to write (at least 1). Frame 0 is the initial state.
    pub frames: u32,
    /// Steps between frames (at least 1).
    pub every: u32,
    /// Folder for `frame_0000.png`, `frame_0001.png`, ... (created if missing).
    pub out_dir: PathBuf,
    /// Also write an animated GIF here, played at simulated speed.
    pub gif: Option<PathBuf>,
    /// Debug overlays.
    pub overlays: Overlays,
}

/// What a finished job wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct FramesWritten {
    /// The PNG files, in order.
    pub pngs: Vec<PathBuf>,
    /// The GIF, if one was asked for.
    pub gif: Option<PathBuf>,
    /// Steps taken.
    pub steps: u64,
}

/// Why a job stopped.
#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    /// `frames` or `every` was zero.
    #[error("{0} must be at least 1")]
    Zero(&'static str),
    /// The output folder could not be created.
    #[error("{path}: cannot create the folder: {source}")]
    OutDir {
        /// The folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Rendering or writing a frame failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// An interrupt (see [`crate::output::interrupted`]) stopped the job: the frames
    /// in `written` are complete and kept; the GIF, unfinished, is not written.
    #[error("interrupted after {} frame(s)", written.pngs.len())]
    Interrupted {
        /// What was complete when the job stopped.
        written: FramesWritten,
    },
    /// A pane of a comparison failed to step.
    #[error("pane \"{pane}\": step {step}: {source}")]
    PaneStep {
        /// The pane's settings.
        pane: String,
        /// Steps taken before the failure.
        step: u64,
        /// The cause.
        source: Box<StepError>,
    },
    /// The world failed to step.
    #[error("step {step}: {source}")]
    Step {
        /// Steps taken before the failure.
        step: u64,
        /// The cause.
        source: Box<StepError>,
    },
}

/// The file name of frame `i`: `frame_0000.png` (more digits past 9999).
pub fn frame_name(i: u32) -> String {
    format!("frame_{i:04}.png")
}

/// Renders `job.frames` frames of `world` through `camera`, stepping the world
/// `job.every` times between frames; `on_frame(k)` is called after frame k (0-based) is
/// written. The GIF plays at the simulated speed, `1 / (every * dt)` frames a second
/// (clamped to GIF's 100 fps).
pub fn render_frames(
    world: &mut World,
    camera: &Camera,
    renderer: &mut Renderer,
    job: &FrameJob,
    mut on_frame: impl FnMut(u32),
) -> Result<FramesWritten, FramesError> {
    if job.frames == 0 {
        return Err(FramesError::Zero("frames"));
    }
    if job.every == 0 {
        return Err(FramesError::Zero("every"));
    }
    std::fs::create_dir_all(&job.out_dir).map_err(|source| FramesError::OutDir {
        path: job.out_dir.clone(),
        source,
    })?;
    let fps = 1.0 / (job.every as f32 * world.settings.dt);
    let mut gif = match &job.gif {
        Some(p) => Some(GifWriter::create(p, fps)?),
        None => None,
    };
    let mut list = DrawList::new();
    let mut written = FramesWritten {
        // grown as frames are written: `frames` is the user's count, not a promise
        pngs: Vec::new(),
        gif: job.gif.clone(),
        steps: 0,
    };
    let stop = |written: &FramesWritten| FramesError::Interrupted {
        written: FramesWritten {
            gif: None,
            ..written.clone()
        },
    };
    // Wall time (s) of the steps, of the draw list and render (with the read-back), and
    // of encoding and writing the PNGs and GIF, for the log.
    let (mut t_step, mut t_render, mut t_write) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..job.frames {
        if crate::output::interrupted() {
            return Err(stop(&written));
        }
        let t0 = std::time::Instant::now();
        if k > 0 {
            for _ in 0..job.every {
                if crate::output::interrupted() {
                    return Err(stop(&written));
                }
                world.step().map_err(|source| FramesError::Step {
                    step: written.steps,
                    source: Box::new(source),
                })?;
                written.steps += 1;
            }
        }
        let t1 = std::time::Instant::now();
        let overlays = Overlays {
            pixels_per_meter: Some(camera.pixels_per_meter),
            ..job.overlays
        };
        fill_world_draw_list(&mut list, world, &overlays);
        let image = renderer.render_to_image(&list, camera)?;
        let t2 = std::time::Instant::now();
        let path = job.out_dir.join(frame_name(k));
        save_png(&path, &image)?;
        written.pngs.push(path);
        if let Some(g) = gif.as_mut() {
            g.push(image)?;
        }
        t_step += (t1 - t0).as_secs_f64();
        t_render += (t2 - t1).as_secs_f64();
        t_write += t2.elapsed().as_secs_f64();
        on_frame(k);
    }
    if let Some(g) = gif {
        g.finish()?;
    }
    let n = written.pngs.len().max(1) as f64;
    log::info!(
        "wrote {} frames to {}; ms a frame: steps {:.2}, draw list and render with \
         read-back {:.2} ({:.1} frames a second), PNG and GIF {:.2}",
        written.pngs.len(),
        job.out_dir.display(),
        t_step / n * 1e3,
        t_render / n * 1e3,
        n / t_render.max(1e-9),
        t_write / n * 1e3
    );
    Ok(written)
}
