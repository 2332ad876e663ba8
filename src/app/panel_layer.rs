//! The panel as a layer: egui draws into a texture of the window's size only when the
//! panel changes (input over it, an egui animation, or the stats' refresh a few times a
//! second), and every frame lays that texture over the world with one scissored
//! triangle. On llvmpipe egui's own pass costs about 13 ms a frame (many small
//! triangles and draw calls), the layer about 1 ms.

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
        }
        &self.target.as_ref().expect("made above").view
    }

    /// Whether the layer holds a panel drawn at `size`.
    pub(super) fn ready(&self, size: [u32; 2]) -> bool {
        self.target.as_ref().is_some_and(|t| t.size == size)
    }

    /// Records what egui painted this time: the bounding box of its meshes, each cut to
    /// its clip rectangle, in pixels. Nothing painted: the layer is skipped.
    pub(super) fn set_painted(&mut self, jobs: &[egui::ClippedPrimitive], pixels_per_point: f32) {
        self.painted = painted_rect(jobs, pixels_per_point, self.target.as_ref().map(|t| t.size));
    }

    /// The pixels the panel covers, [x0, y0, x1, y1), if any.
    pub(super) fn painted(&self) -> Option<[u32; 4]> {
        self.painted
    }

    /// Lays the layer over `target` (which holds the world), within what was painted.
    pub(super) fn composite(&self, encoder: &mut wgpu::CommandEncoder, target: &wgpu::TextureView) {
        let (Some(t), Some([x0, y0, x1, y1])) = (&self.target, self.painted) else {
            return;
        };
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
        pass.set_scissor_rect(x0, y0, x1 - x0, y1 - y0);
        pass.draw(0..3, 0..1);
    }
}

/// The bounding box in pixels, [x0, y0, x1, y1), of the meshes of `jobs` cut to their
/// clip rectangles and to a texture of `size`; `None` when nothing is painted.
fn painted_rect(
    jobs: &[egui::ClippedPrimitive],
    pixels_per_point: f32,
    size: Option<[u32; 2]>,
) -> Option<[u32; 4]> {
    let [w, h] = size?;
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
    if !rect.is_positive() {
        return None;
    }
    // whole pixels, one more each side for antialiased edges
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
}
