//! The panel as a layer: egui draws into a texture of the window's size only when the
//! panel changes (input over it, an egui animation, or the stats' refresh a few times a
//! second), and every frame lays that texture over the world with one scissored
//! triangle, and one more for each of the panes' labels (`run --compare`), which egui
//! paints into the same texture. On llvmpipe egui's own pass costs about 13 ms a frame
//! (many small triangles and draw calls), the layer about 1 ms.

/// The label of the layer's GPU objects.
const LABEL: &str = "sandbox2d panel layer";

/// Copies the layer's pixels 1:1 (premultiplied alpha, as egui writes them).
const SHADER: &str = r#"
@group(0) @binding(0) var layer: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // one triangle that covers the screen
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * vec2<f32>(2.0, -2.0) + vec2<f32>(-1.0, 1.0), 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return textureLoad(layer, vec2<i32>(p.xy), 0);
}
"#;

/// The texture, its bind group and what was painted into it.
struct Target {
    view: wgpu::TextureView,
    bind_group: wgpu::BindGroup,
    size: [u32; 2],
}

/// The panel's texture and the pipeline that lays it over a frame.
pub(super) struct PanelLayer {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
    target: Option<Target>,
    /// The pixels the panel painted, [x0, y0, x1, y1) (panel and any open popup).
    painted: Option<[u32; 4]>,
    /// The pixels of each of the panes' labels, [x0, y0, x1, y1).
    labels: Vec<[u32; 4]>,
}

impl PanelLayer {
    pub(super) fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> PanelLayer {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(LABEL),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(LABEL),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(LABEL),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let pipeline = crate::render::premultiplied_pipeline(
            device,
            &pipeline_layout,
            format,
            1,
            LABEL,
            &module,
            wgpu::PrimitiveTopology::TriangleList,
            &[],
            &[],
        );
        PanelLayer {
            pipeline,
            layout,
            format,
            target: None,
            painted: None,
            labels: Vec::new(),
        }
    }

    /// The texture view egui draws into, made (again) at `size` if it is not that size.
    pub(super) fn view(&mut self, device: &wgpu::Device, size: [u32; 2]) -> &wgpu::TextureView {
        if self.target.as_ref().is_none_or(|t| t.size != size) {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some(LABEL),
                size: wgpu::Extent3d {
                    width: size[0].max(1),
                    height: size[1].max(1),
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: self.format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(LABEL),
                layout: &self.layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                }],
            });
            self.target = Some(Target {
                view,
                bind_group,
                size,
            });
            self.painted = None;
            self.labels.clear();
        }
        &self.target.as_ref().expect("made above").view
    }

    /// Whether the layer holds a panel drawn at `size`.
    pub(super) fn ready(&self, size: [u32; 2]) -> bool {
        self.target.as_ref().is_some_and(|t| t.size == size)
    }

    /// Records what egui painted this time: the bounding box of the panel's meshes, each
    /// cut to its clip rectangle, in pixels, and the boxes of the panes' labels
    /// (`labels`, points; the meshes clipped to one of them are the label's, not the
    /// panel's). Nothing painted: the layer is skipped.
    pub(super) fn set_painted(
        &mut self,
        jobs: &[egui::ClippedPrimitive],
        pixels_per_point: f32,
        labels: &[egui::Rect],
    ) {
        let size = self.target.as_ref().map(|t| t.size);
        (self.painted, self.labels) = split_painted(jobs, pixels_per_point, size, labels);
    }

    /// The pixels the panel covers, [x0, y0, x1, y1), if any (the labels apart: the
    /// pointer over a label is over the world).
    pub(super) fn painted(&self) -> Option<[u32; 4]> {
        self.painted
    }

    /// Lays the layer over `target` (which holds the world), within what was painted.
    pub(super) fn composite(&self, encoder: &mut wgpu::CommandEncoder, target: &wgpu::TextureView) {
        let Some(t) = &self.target else {
            return;
        };
        if self.painted.is_none() && self.labels.is_empty() {
            return;
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(LABEL),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &t.bind_group, &[]);
        for [x0, y0, x1, y1] in self.painted.iter().chain(&self.labels) {
            pass.set_scissor_rect(*x0, *y0, x1 - x0, y1 - y0);
            pass.draw(0..3, 0..1);
        }
    }
}

/// What egui painted into a texture of `size`, in pixels: the panel's bounding box
/// (every mesh not clipped to within one of `labels`, see [`painted_rect`]) and each
/// label's box (`labels`, points).
fn split_painted(
    jobs: &[egui::ClippedPrimitive],
    pixels_per_point: f32,
    size: Option<[u32; 2]>,
    labels: &[egui::Rect],
) -> (Option<[u32; 4]>, Vec<[u32; 4]>) {
    // a label's meshes are clipped to its box (half a point of slack)
    let panel = jobs.iter().filter(|j| {
        !labels
            .iter()
            .any(|l| l.expand(0.5).contains_rect(j.clip_rect))
    });
    (
        painted_rect(panel, pixels_per_point, size),
        labels
            .iter()
            .filter_map(|l| pixel_rect(*l, pixels_per_point, size))
            .collect(),
    )
}

/// The bounding box in pixels, [x0, y0, x1, y1), of the meshes of `jobs` cut to their
/// clip rectangles and to a texture of `size`; `None` when nothing is painted.
fn painted_rect<'a>(
    jobs: impl IntoIterator<Item = &'a egui::ClippedPrimitive>,
    pixels_per_point: f32,
    size: Option<[u32; 2]>,
) -> Option<[u32; 4]> {
    let mut rect = egui::Rect::NOTHING;
    for job in jobs {
        if let egui::epaint::Primitive::Mesh(mesh) = &job.primitive {
            if mesh.vertices.is_empty() {
                continue;
            }
            let bounds = mesh.calc_bounds().intersect(job.clip_rect);
            if bounds.is_positive() {
                rect = rect.union(bounds);
            }
        }
    }
    pixel_rect(rect, pixels_per_point, size)
}

/// `rect` (points) in whole pixels, [x0, y0, x1, y1), one more each side for
/// antialiased edges, cut to a texture of `size`; `None` when nothing is left.
fn pixel_rect(rect: egui::Rect, pixels_per_point: f32, size: Option<[u32; 2]>) -> Option<[u32; 4]> {
    let [w, h] = size?;
    if !rect.is_positive() {
        return None;
    }
    let x0 = ((rect.min.x * pixels_per_point).floor() - 1.0).clamp(0.0, w as f32) as u32;
    let y0 = ((rect.min.y * pixels_per_point).floor() - 1.0).clamp(0.0, h as f32) as u32;
    let x1 = ((rect.max.x * pixels_per_point).ceil() + 1.0).clamp(0.0, w as f32) as u32;
    let y1 = ((rect.max.y * pixels_per_point).ceil() + 1.0).clamp(0.0, h as f32) as u32;
    (x1 > x0 && y1 > y0).then_some([x0, y0, x1, y1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use egui::epaint::{Mesh, Primitive};
    use egui::{ClippedPrimitive, Color32, Pos2, Rect};

    fn job(min: (f32, f32), max: (f32, f32), clip: Rect) -> ClippedPrimitive {
        let mut mesh = Mesh::default();
        mesh.add_colored_rect(
            Rect::from_min_max(Pos2::new(min.0, min.1), Pos2::new(max.0, max.1)),
            Color32::WHITE,
        );
        ClippedPrimitive {
            clip_rect: clip,
            primitive: Primitive::Mesh(mesh),
        }
    }

    #[test]
    fn painted_rect_is_the_clipped_union_in_pixels() {
        let everywhere = Rect::EVERYTHING;
        // a panel 0..260 x 0..720 points and a popup 100..300 x 50..80, at 2 px a point
        let jobs = [
            job((0.0, 0.0), (260.0, 720.0), everywhere),
            job((100.0, 50.0), (300.0, 80.0), everywhere),
            // clipped away entirely
            job(
                (500.0, 500.0),
                (600.0, 600.0),
                Rect::from_min_max(Pos2::ZERO, Pos2::new(10.0, 10.0)),
            ),
        ];
        assert_eq!(
            painted_rect(&jobs, 2.0, Some([2560, 1440])),
            Some([0, 0, 601, 1440])
        );
        // cut to the texture
        assert_eq!(
            painted_rect(&jobs, 2.0, Some([400, 300])),
            Some([0, 0, 400, 300])
        );
        assert_eq!(painted_rect(&[], 1.0, Some([100, 100])), None);
        assert_eq!(painted_rect(&jobs, 1.0, None), None);
    }

    #[test]
    fn the_labels_are_boxes_of_their_own_and_not_the_panel() {
        // a panel 0..300 x 0..720 points, two labels right of it, at 1 px a point
        let labels = [
            Rect::from_min_max(Pos2::new(340.0, 8.0), Pos2::new(560.0, 70.0)),
            Rect::from_min_max(Pos2::new(820.0, 8.0), Pos2::new(1040.0, 70.0)),
        ];
        let jobs = [
            job((0.0, 0.0), (300.0, 720.0), Rect::EVERYTHING),
            job((340.0, 8.0), (560.0, 70.0), labels[0]),
            job((824.0, 12.0), (1000.0, 60.0), labels[1]),
        ];
        let (panel, boxes) = split_painted(&jobs, 1.0, Some([1280, 720]), &labels);
        // the panel alone (where the pointer is the panel's), not the union with the
        // labels, which would take the whole top of the window
        assert_eq!(panel, Some([0, 0, 301, 720]));
        assert_eq!(boxes, [[339, 7, 561, 71], [819, 7, 1041, 71]]);
        // without labels every mesh is the panel's
        let (panel, boxes) = split_painted(&jobs, 1.0, Some([1280, 720]), &[]);
        assert_eq!(panel, Some([0, 0, 1001, 720]));
        assert!(boxes.is_empty());
    }
}
