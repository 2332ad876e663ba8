//! Side by side (`render --compare`): the panes of a [`crate::compare`] comparison drawn
//! next to each other in one frame, each through the same camera, labelled at its top
//! with its settings and figures (in the Hack font, rasterised by [`super::text`]), with
//! a divider between panes.

use image::RgbaImage;

use super::frames::{FrameJob, FramesError, FramesWritten, frame_name};
use super::text;
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

/// The padding (px) between a label's text and the edge of its backing at `px` pixels.
fn label_pad(px: f32) -> u32 {
    (px / 4.0).round().max(2.0) as u32
}

/// The label's font size (px): a 36th of the pane's width within 12 to 24 px, then
/// smaller, down to 8 px, until the widest line and its padding fit the pane.
fn label_px(lines: &[String], pane_w: u32) -> f32 {
    let mut px = (pane_w as f32 / 36.0).round().clamp(12.0, 24.0);
    while px > 8.0 && text::text_size(lines, px)[0] + 2 * label_pad(px) > pane_w {
        px -= 1.0;
    }
    px
}

/// The size in pixels of the box that [`render_panes`] draws a pane's label in, at the
/// pane's top-left corner, in a pane of `pane` pixels: the text and its padding, cut to
/// the pane.
pub fn label_box(lines: &[String], pane: [u32; 2]) -> [u32; 2] {
    let px = label_px(lines, pane[0]);
    let pad = label_pad(px);
    let [w, h] = text::text_size(lines, px);
    [(w + 2 * pad).min(pane[0]), (h + 2 * pad).min(pane[1])]
}

/// Draws the label at the pane's top-left over a translucent backing, both cut to the
/// pane (`img`).
fn draw_label(img: &mut RgbaImage, lines: &[String]) {
    let px = label_px(lines, img.width());
    let pad = label_pad(px);
    let [w, h] = label_box(lines, [img.width(), img.height()]);
    text::fill_rect(img, 0, 0, w, h, BACKING);
    let line_h = text::line_height(px);
    for (i, line) in lines.iter().enumerate() {
        let y = pad + i as u32 * line_h;
        text::draw_text(img, pad as f32, y as f32, px, TEXT, line);
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
        text::fill_rect(&mut frame, x, 0, 2, ph, DIVIDER);
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
    fn the_label_grows_with_the_pane_and_shrinks_to_fit() {
        let lines = vec!["--solver pgs --iterations 4".to_owned()];
        let fits =
            |px: f32, pane_w: u32| text::text_size(&lines, px)[0] + 2 * label_pad(px) <= pane_w;
        // wide panes: a 36th of the width, at most 24 px
        assert_eq!(label_px(&lines, 1280), 24.0);
        assert_eq!(label_px(&lines, 640), 18.0);
        assert_eq!(label_px(&lines, 320), 12.0);
        // narrow ones: the largest size that fits
        for pane_w in [135, 150] {
            let px = label_px(&lines, pane_w);
            assert!(px > 8.0 && px < 12.0, "{px} px in {pane_w}");
            assert!(fits(px, pane_w) && !fits(px + 1.0, pane_w));
        }
        // too narrow for any: the smallest size, cut at the pane's edge
        assert_eq!(label_px(&lines, 60), 8.0);
        assert_eq!(label_box(&lines, [60, 40])[0], 60);
    }
}
