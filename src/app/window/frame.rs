//! Recording a window frame: the panes' labels (painted by egui), the tools drawn over
//! the world, the world and the panel's layer into the surface, and the copy of a
//! frame read back for a screenshot.

use super::*;

/// `run --compare`: each pane's label (its settings wrapped to the pane's width, then its
/// live figures) at the pane's top-left corner, in egui's monospace font over a
/// translucent box, on a layer of its own under any popup. `panes` are the panes' rects
/// (points) left to right; `free_left` is where the panel ends (points): no label
/// starts left of it. Each label is clipped to its box, itself inside its pane. Returns
/// the boxes (points), which the panel layer lays over the world beside the panel.
pub(super) fn paint_pane_labels<'a>(
    ctx: &egui::Context,
    panes: &[egui::Rect],
    free_left: f32,
    labels: impl Iterator<Item = (&'a str, crate::compare::Figures)>,
) -> Vec<egui::Rect> {
    let font = egui::FontId::monospace(LABEL_FONT_PT);
    let advance = ctx.fonts_mut(|f| f.glyph_width(&font, '0')).max(1.0);
    let layer = egui::LayerId::new(egui::Order::Background, egui::Id::unique("pane labels"));
    let painter = ctx.layer_painter(layer);
    let mut boxes = Vec::with_capacity(panes.len());
    for (pane, (settings, figures)) in panes.iter().zip(labels) {
        let min = egui::pos2(pane.left().max(free_left), pane.top())
            + egui::vec2(1.0, 1.0) * LABEL_MARGIN_PT;
        let room = pane.right() - min.x - LABEL_MARGIN_PT - 2.0 * LABEL_PAD_PT;
        let columns = (room / advance).floor().max(8.0) as usize;
        let mut lines = crate::compare::wrap(settings, columns);
        lines.extend(crate::compare::figure_lines(&figures));
        let galley = painter.layout_no_wrap(lines.join("\n"), font.clone(), LABEL_COLOR);
        let size = galley.size() + egui::vec2(2.0, 2.0) * LABEL_PAD_PT;
        let boxed = egui::Rect::from_min_size(min, size).intersect(*pane);
        if !boxed.is_positive() {
            continue;
        }
        let painter = painter.with_clip_rect(boxed);
        painter.rect_filled(boxed, 3.0, LABEL_BACK);
        painter.galley(
            min + egui::vec2(1.0, 1.0) * LABEL_PAD_PT,
            galley,
            LABEL_COLOR,
        );
        boxes.push(boxed);
    }
    boxes
}

impl App {
    /// The drag spring and the emitter's ring, over the world.
    pub(super) fn push_tools(&mut self) {
        if let Some(d) = self.session.drag
            && let Some(b) = self.session.world.bodies.get(d.body)
        {
            let p = b.position + b.rot.rotate(d.local_point);
            self.list.push_line(p, d.target, 1.5, TOOL_COLOR);
            self.list.push_line(p, p, 6.0, TOOL_COLOR);
        }
        if let Some(e) = self.session.emitter {
            self.list
                .push_circle(e.center, e.radius, None, [255, 255, 255, 18], TOOL_COLOR);
        }
        if let Some(r) = self.session.ray {
            // the ray up to what it hits (or the cursor), the hit point, and the
            // surface's normal there, 40 px long
            let (dot, _) = crate::draw::world::mark_sizes_px(Some(self.camera.pixels_per_meter));
            self.list.push_line(r.origin, r.reach(), 1.5, RAY_COLOR);
            self.list.push_line(r.origin, r.origin, dot, RAY_COLOR);
            if let Some(h) = r.hit {
                let normal = h.normal * (RAY_NORMAL_PX / self.camera.pixels_per_meter);
                self.list
                    .push_line(h.point, h.point + normal, 2.0, RAY_HIT_COLOR);
                self.list
                    .push_line(h.point, h.point, 2.0 * dot, RAY_HIT_COLOR);
            }
        }
    }
}

/// Records one window frame into `target`: the world (cleared to the background), then,
/// with `layer`, egui's layer (the panel, the panes' labels) over it.
pub(super) fn encode_frame(
    g: &mut Gpu,
    encoder: &mut wgpu::CommandEncoder,
    target: &wgpu::TextureView,
    list: &DrawList,
    camera: &Camera,
    layer: bool,
) {
    g.renderer.draw(encoder, target, list, camera);
    if layer {
        g.panel.composite(encoder, target);
    }
}

/// Draws egui's output into the panel's layer, cleared to transparent first.
pub(super) fn draw_panel(
    g: &mut Gpu,
    encoder: &mut wgpu::CommandEncoder,
    jobs: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
) {
    let view = g.panel.view(&g.device, screen.size_in_pixels);
    let mut pass = encoder
        .begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("sandbox2d egui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
        .forget_lifetime();
    g.egui_renderer.render(&mut pass, jobs, screen);
}

/// A texture of the surface's format and size that a frame is also drawn into, and the
/// buffer it is copied to, for `--screenshot`.
pub(super) struct Capture {
    pub(super) texture: wgpu::Texture,
    buffer: wgpu::Buffer,
    format: wgpu::TextureFormat,
    size: [u32; 2],
    padded_row: u32,
}

impl Capture {
    /// Formats read back as 4 bytes a pixel, RGBA or BGRA.
    pub(super) fn supports(format: wgpu::TextureFormat) -> bool {
        use wgpu::TextureFormat as F;
        matches!(
            format,
            F::Rgba8Unorm | F::Rgba8UnormSrgb | F::Bgra8Unorm | F::Bgra8UnormSrgb
        )
    }

    pub(super) fn new(
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        size: [u32; 2],
    ) -> Capture {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("sandbox2d screenshot"),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        // Copies need rows aligned to 256 bytes.
        let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let padded_row = (size[0] * 4).div_ceil(align) * align;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sandbox2d screenshot read-back"),
            size: padded_row as u64 * size[1] as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Capture {
            texture,
            buffer,
            format,
            size,
            padded_row,
        }
    }

    pub(super) fn copy(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_texture_to_buffer(
            self.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &self.buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.size[1]),
                },
            },
            wgpu::Extent3d {
                width: self.size[0],
                height: self.size[1],
                depth_or_array_layers: 1,
            },
        );
    }

    /// Waits for the copy and returns the pixels as RGBA (BGRA surfaces are swizzled).
    pub(super) fn read(self, device: &wgpu::Device) -> Result<image::RgbaImage, AppError> {
        let (tx, rx) = std::sync::mpsc::channel();
        self.buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| AppError::Gpu(format!("screenshot: poll: {e}")))?;
        rx.recv()
            .map_err(|_| AppError::Gpu("screenshot: read-back never ran".into()))?
            .map_err(|e| AppError::Gpu(format!("screenshot: map: {e}")))?;
        let [w, h] = self.size;
        let row = w as usize * 4;
        let mut pixels = Vec::with_capacity(row * h as usize);
        {
            let view = self
                .buffer
                .get_mapped_range(..)
                .map_err(|e| AppError::Gpu(format!("screenshot: view: {e}")))?;
            for y in 0..h as usize {
                let start = y * self.padded_row as usize;
                pixels.extend_from_slice(&view[start..start + row]);
            }
        }
        self.buffer.unmap();
        if matches!(
            self.format,
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
        ) {
            for px in pixels.chunks_exact_mut(4) {
                px.swap(0, 2);
            }
        }
        // The surface may be opaque-ignoring; a PNG of the window is opaque.
        for px in pixels.chunks_exact_mut(4) {
            px[3] = 255;
        }
        image::RgbaImage::from_raw(w, h, pixels)
            .ok_or_else(|| AppError::Gpu("screenshot: size mismatch".into()))
    }
}
