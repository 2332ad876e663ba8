//! Side by side (`render --compare`): the panes of a [`crate::compare`] comparison drawn
//! next to each other in one frame, each through the same camera, labelled at its top
//! with its settings and figures (in the [`super::font`] bitmap font), with a divider
//! between panes.

use image::RgbaImage;

use super::font::{self, CELL_H};
use super::frames::{FrameJob, FramesError, FramesWritten, frame_name};
use super::{GifWriter, RenderError, Renderer, save_png};
use crate::compare::Pane;
use crate::draw::world::{Overlays, fill_world_draw_list};
use crate::draw::{Camera, DrawList};
use crate::world::World;

/// The label's text colour (sRGB).
const TEXT: [u8; 4] = [235, 235, 240, 255];
/// The label's backing, a translucent black that keeps it readable over bodies.
const BACKING: [u8; 4] = [0, 0, 0, 170];
/// The divider between panes.
const DIVIDER: [u8; 4] = [200, 200, 210, 255];

/// What one pane shows: its world and its label's lines.
pub struct PaneView<'a> {
    /// The pane's world.
    pub world: &'a World,
    /// The label, top to bottom.
    pub lines: Vec<String>,
}

/// The width of each of `n` panes in a frame `width` pixels wide: `width / n` (the
/// frame is `n` times that, so up to n - 1 pixels narrower than asked).
pub fn pane_width(width: u32, n: usize) -> u32 {
    (width / n.max(1) as u32).max(1)
}

/// The label's scale: font pixels 1 to 3 screen pixels, by the pane's width, and no
/// larger than lets the widest line fit.
fn label_scale(lines: &[String], pane_w: u32) -> u32 {
    let mut scale = (pane_w / 320).clamp(1, 3);
    while scale > 1 && font::text_size(lines, scale)[0] + 8 * scale > pane_w {
        scale -= 1;
    }
    scale
}

/// Draws the label at the pane's top-left over a translucent backing.
fn draw_label(img: &mut RgbaImage, lines: &[String]) {
    let scale = label_scale(lines, img.width());
    let pad = 3 * scale;
    let [w, h] = font::text_size(lines, scale);
    font::fill_rect(
        img,
        0,
        0,
        (w + 2 * pad).min(img.width()),
        h + 2 * pad,
        BACKING,
    );
    for (i, line) in lines.iter().enumerate() {
        let y = pad + i as u32 * CELL_H * scale;
        font::draw_text(img, i64::from(pad), i64::from(y), scale, TEXT, line);
    }
}

/// Renders the panes side by side through `camera` (whose size is one pane's): each
/// pane's world drawn with `overlays`, its label at its top, a divider between panes.
/// `list` is reused between calls.
pub fn render_panes(
    renderer: &mut Renderer,
    list: &mut DrawList,
    panes: &[PaneView<'_>],
    camera: &Camera,
    overlays: &Overlays,
) -> Result<RgbaImage, RenderError> {
    let [pw, ph] = camera.size;
    let mut frame = RgbaImage::new(pw * panes.len() as u32, ph);
    for (i, pane) in panes.iter().enumerate() {
        let overlays = Overlays {
            pixels_per_meter: Some(camera.pixels_per_meter),
            ..*overlays
        };
        fill_world_draw_list(list, pane.world, &overlays);
        let mut img = renderer.render_to_image(list, camera)?;
        draw_label(&mut img, &pane.lines);
        let x0 = i as u32 * pw;
        for (x, y, p) in img.enumerate_pixels() {
            frame.put_pixel(x0 + x, y, *p);
        }
    }
    // a divider 1 pixel either side of each boundary (2 in all)
    for i in 1..panes.len() {
        let x = i64::from(i as u32 * pw) - 1;
        font::fill_rect(&mut frame, x, 0, 2, ph, DIVIDER);
    }
    Ok(frame)
}

/// As [`super::render_frames`], for panes: renders `job.frames` frames of the panes side
/// by side through `camera` (one pane's size), stepping every pane `job.every` times
/// between frames, in lock step (one step each, whatever their time steps); the GIF plays
/// at the first pane's simulated speed. `on_frame(k)` is called after frame k is written.
pub fn render_compare_frames(
    panes: &mut [Pane],
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
    let Some(first) = panes.first() else {
        return Err(FramesError::Zero("panes"));
    };
    std::fs::create_dir_all(&job.out_dir).map_err(|source| FramesError::OutDir {
        path: job.out_dir.clone(),
        source,
    })?;
    let fps = 1.0 / (job.every as f32 * first.world.settings.dt);
    let mut gif = match &job.gif {
        Some(p) => Some(GifWriter::create(p, fps)?),
        None => None,
    };
    let mut list = DrawList::new();
    let mut written = FramesWritten {
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
    for k in 0..job.frames {
        if crate::output::interrupted() {
            return Err(stop(&written));
        }
        if k > 0 {
            for _ in 0..job.every {
                if crate::output::interrupted() {
                    return Err(stop(&written));
                }
                for pane in panes.iter_mut() {
                    pane.step().map_err(|source| FramesError::PaneStep {
                        pane: pane.label.clone(),
                        step: written.steps,
                        source: Box::new(source),
                    })?;
                }
                written.steps += 1;
            }
        }
        let views: Vec<PaneView<'_>> = panes
            .iter()
            .map(|p| PaneView {
                world: &p.world,
                lines: p.label_lines(),
            })
            .collect();
        let image = render_panes(renderer, &mut list, &views, camera, &job.overlays)?;
        let path = job.out_dir.join(frame_name(k));
        save_png(&path, &image)?;
        written.pngs.push(path);
        if let Some(g) = gif.as_mut() {
            g.push(image)?;
        }
        on_frame(k);
    }
    if let Some(g) = gif {
        g.finish()?;
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panes_share_the_width() {
        assert_eq!(pane_width(1280, 2), 640);
        assert_eq!(pane_width(1280, 3), 426);
        assert_eq!(pane_width(2, 4), 1);
    }

    #[test]
    fn the_label_shrinks_to_fit() {
        let lines = vec!["--solver pgs --iterations 4".to_owned()];
        assert_eq!(label_scale(&lines, 1280), 3);
        assert_eq!(label_scale(&lines, 640), 2);
        assert_eq!(label_scale(&lines, 240), 1);
    }
}
