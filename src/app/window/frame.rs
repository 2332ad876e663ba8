//! Recording a window frame: the overlays drawn over the world (the panes' labels,
//! the tools), the world and the panel's layer into the surface, and the copy of a
//! frame read back for a screenshot.

use super::*;

impl App {
    /// `run --compare`: each pane's settings and live figures at its top-left corner,
    /// drawn as segments of the bitmap font (`render::font`) over a dark box.
    pub(super) fn push_pane_labels(&mut self, now: Instant) {
        let Some(c) = self.compare.as_ref() else {
            return;
        };
        if self.labels_next.is_none_or(|t| now >= t) || self.labels.len() != c.panes() {
            // the settings wrapped to the pane's width, then the figures
            let (_, pw) = self.pane_area();
            let cell = (crate::render::font::CELL_W * LABEL_SCALE) as f32;
            let width = ((pw - 2.0 * LABEL_MARGIN_PX - 8.0) / cell).floor().max(8.0) as usize;
            self.labels = std::iter::once(&self.session)
                .chain(&c.others)
                .zip(&c.labels)
                .map(|(s, label)| {
                    let mut lines = crate::compare::wrap(label, width);
                    lines.extend(crate::compare::figure_lines(&s.figures()));
                    lines
                })
                .collect();
            self.labels_next = Some(now + PANEL_REFRESH);
        }
        let [w, h] = self.camera.size;
        let ppm = self.camera.pixels_per_meter;
        let left = self.camera.center.x - 0.5 * w as f32 / ppm;
        let top = self.camera.center.y + 0.5 * h as f32 / ppm;
        let to_world = |x: f32, y: f32| Vec2::new(left + x / ppm, top - y / ppm);
        let (area_left, pw) = self.pane_area();
        let s = LABEL_SCALE as f32;
        for (k, lines) in self.labels.iter().enumerate() {
            let x0 = area_left + k as f32 * pw + LABEL_MARGIN_PX;
            let y0 = LABEL_MARGIN_PX;
            let [tw, th] = crate::render::font::text_size(lines, LABEL_SCALE);
            let pad = 4.0;
            let (bw, bh) = (tw as f32 + 2.0 * pad, th as f32 + 2.0 * pad);
            self.list.push_box(
                to_world(x0 - pad + 0.5 * bw, y0 - pad + 0.5 * bh),
                bw / ppm,
                bh / ppm,
                0.0,
                LABEL_BACK,
                [0, 0, 0, 0],
            );
            for (row, line) in lines.iter().enumerate() {
                self.runs.clear();
                crate::render::font::text_runs(line, &mut self.runs);
                let y = y0 + (row as u32 * crate::render::font::CELL_H) as f32 * s;
                for &[a, b, r] in &self.runs {
                    // round-capped segments through the middle of the run's pixels
                    let yy = y + (r as f32 + 0.5) * s;
                    let p = to_world(x0 + (a as f32 + 0.5) * s, yy);
                    let q = to_world(x0 + (b as f32 - 0.5) * s, yy);
                    self.list.push_line(p, q, s, LABEL_COLOR);
                }
            }
        }
    }

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

/// Records one window frame into `target`: the world (cleared to the background), then
/// the panel's layer over it.
pub(super) fn encode_frame(
    g: &mut Gpu,
    encoder: &mut wgpu::CommandEncoder,
    target: &wgpu::TextureView,
    list: &DrawList,
    camera: &Camera,
    panel: bool,
) {
    g.renderer.draw(encoder, target, list, camera);
    if panel {
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
