//! The wgpu renderer: draws a [`DrawList`] through a [`Camera`] into any colour target,
//! an off-screen texture (read back into an image) or a window surface.

use super::RenderError;
use crate::draw::{Camera, DrawList};
use bytemuck::{Pod, Zeroable};
use glam::Vec2;

/// The format off-screen frames are rendered into: sRGB, so that the bytes read back are
/// exactly the sRGB bytes a PNG stores, and blending happens in linear light.
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// Samples per pixel of the multisampled colour buffer (4x MSAA; WebGPU guarantees 4x
/// for every renderable colour format).
pub const SAMPLE_COUNT: u32 = 4;

/// The samples per pixel to use on an adapter: the `SANDBOX2D_MSAA` environment variable
/// when it is `1` or `4`; otherwise 1 on a CPU rasteriser (llvmpipe, lavapipe: there a
/// 4x multisampled 1280x720 frame costs about four times a single-sampled one, most of
/// it clearing and resolving the samples) and [`SAMPLE_COUNT`] on a GPU. Single-sampled
/// frames differ only at the edges of polygons drawn without an outline: circles, lines
/// and outlines are antialiased by their distance fields either way.
pub fn default_samples(info: &wgpu::AdapterInfo) -> u32 {
    match std::env::var("SANDBOX2D_MSAA")
        .ok()
        .as_deref()
        .map(str::trim)
    {
        Some("1") => return 1,
        Some("4") => return SAMPLE_COUNT,
        _ => {}
    }
    if info.device_type == wgpu::DeviceType::Cpu {
        1
    } else {
        SAMPLE_COUNT
    }
}

/// The camera uniform; mirrors `Globals` in `shaders/common.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Globals {
    center: [f32; 2],
    screen_center: [f32; 2],
    viewport: [f32; 2],
    scale: f32,
    outline_px: f32,
    _pad: [f32; 4],
}

/// One circle; mirrors `CircleIn` in `shaders/circle.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct CircleInstance {
    center: [f32; 2],
    radius: f32,
    angle: f32,
    has_angle: f32,
    fill: [f32; 4],
    outline: [f32; 4],
}

/// Vertices of one instanced quad: a triangle strip of its four corners
/// (`quad_corner` in `shaders/common.wgsl`), so each corner is shaded once.
const QUAD_VERTICES: std::ops::Range<u32> = 0..4;

/// One rectangle; mirrors `BoxIn` in `shaders/box.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct BoxInstance {
    center: [f32; 2],
    half_size: [f32; 2],
    rot: [f32; 2],
    fill: [f32; 4],
    outline: [f32; 4],
}

/// The most points a shape drawn as one instance has (`shaders/shape.wgsl`); polygons
/// with more are drawn as fan triangles and outline segments.
const SHAPE_POINTS: usize = 8;

/// One convex shape of 2 to [`SHAPE_POINTS`] points grown by a radius (a polygon, a
/// rounded polygon, a capsule); mirrors `ShapeIn` in `shaders/shape.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ShapeInstance {
    center: [f32; 2],
    radius: f32,
    _pad: f32,
    /// Relative to `center`, padded by repeating the last point.
    points: [[f32; 2]; SHAPE_POINTS],
    fill: [f32; 4],
    outline: [f32; 4],
}

impl ShapeInstance {
    /// `None` for what the instanced shader does not draw the same: more than
    /// [`SHAPE_POINTS`] points, fewer than 3 without a radius (only an outline), or
    /// fewer than 2.
    fn new(points: &[Vec2], radius: f32, fill: [f32; 4], outline: [f32; 4]) -> Option<Self> {
        let n = points.len();
        let drawn = n <= SHAPE_POINTS && (n >= 3 || (n == 2 && radius > 0.0));
        if !drawn {
            return None;
        }
        let center = points.iter().copied().sum::<Vec2>() / n as f32;
        let last = points[n - 1] - center;
        let mut padded = [last.to_array(); SHAPE_POINTS];
        for (slot, p) in padded.iter_mut().zip(points) {
            *slot = (*p - center).to_array();
        }
        Some(Self {
            center: center.to_array(),
            radius,
            _pad: 0.0,
            points: padded,
            fill,
            outline,
        })
    }
}

/// One segment; mirrors `LineIn` in `shaders/line.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LineInstance {
    a: [f32; 2],
    b: [f32; 2],
    width_px: f32,
    color: [f32; 4],
}

/// One polygon-fill vertex; mirrors `PolygonIn` in `shaders/polygon.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PolygonVertex {
    position: [f32; 2],
    color: [f32; 4],
}

/// An sRGB colour with straight alpha, 8 bits a channel (as draw lists hold colours),
/// to linear premultiplied, as the shaders blend: once per instance here, with a table,
/// rather than a `pow` per channel at every vertex (a CPU rasteriser pays for those).
fn premultiplied_linear(c: [u8; 4]) -> [f32; 4] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let x = i as f32 / 255.0;
            if x <= 0.04045 {
                x / 12.92
            } else {
                ((x + 0.055) / 1.055).powf(2.4)
            }
        })
    });
    let a = c[3] as f32 / 255.0;
    [
        table[c[0] as usize] * a,
        table[c[1] as usize] * a,
        table[c[2] as usize] * a,
        a,
    ]
}

/// A vertex buffer that grows (doubling) and is otherwise reused frame to frame.
struct GrowBuffer {
    label: &'static str,
    buffer: wgpu::Buffer,
    capacity: u64,
}

impl GrowBuffer {
    fn new(device: &wgpu::Device, label: &'static str, capacity: u64) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: capacity,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            label,
            buffer,
            capacity,
        }
    }

    /// Uploads `data`, reallocating first when it does not fit.
    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[u8]) {
        let needed = data.len() as u64;
        if needed > self.capacity {
            *self = Self::new(device, self.label, needed.next_power_of_two());
        }
        if !data.is_empty() {
            queue.write_buffer(&self.buffer, 0, data);
        }
    }
}

/// The multisampled colour buffer, resolved into the caller's target.
struct MsaaTarget {
    view: wgpu::TextureView,
    size: [u32; 2],
}

/// The off-screen target of [`Renderer::render_to_image`] and its read-back buffer.
struct Offscreen {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_bytes_per_row: u32,
    size: [u32; 2],
}

/// Draws [`DrawList`]s with wgpu.
///
/// One renderer serves both an off-screen texture ([`Renderer::new_headless`] and
/// [`Renderer::render_to_image`]) and a window surface ([`Renderer::new`] with the
/// surface's device, queue and format, then [`Renderer::draw`] each frame).
///
/// Boxes, circles, lines and convex shapes of up to eight points (polygons, rounded
/// polygons, capsules) are one instance each, antialiased by their distance fields;
/// polygons with more points are fan triangles with outline segments. With MSAA (4x on
/// a GPU) everything is drawn into an internal multisampled buffer that is resolved
/// into the target. Colours are sRGB; the shaders blend in linear light and write sRGB, through
/// the hardware when the target format is sRGB and by hand when it is not, so a window
/// and a PNG show the same pixels. Buffers are reused between frames.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    format: wgpu::TextureFormat,
    adapter_info: Option<wgpu::AdapterInfo>,
    globals: wgpu::Buffer,
    globals_bind_group: wgpu::BindGroup,
    box_pipeline: wgpu::RenderPipeline,
    circle_pipeline: wgpu::RenderPipeline,
    line_pipeline: wgpu::RenderPipeline,
    polygon_pipeline: wgpu::RenderPipeline,
    shape_pipeline: wgpu::RenderPipeline,
    box_buffer: GrowBuffer,
    circle_buffer: GrowBuffer,
    line_buffer: GrowBuffer,
    polygon_buffer: GrowBuffer,
    shape_buffer: GrowBuffer,
    box_data: Vec<BoxInstance>,
    circle_data: Vec<CircleInstance>,
    line_data: Vec<LineInstance>,
    polygon_data: Vec<PolygonVertex>,
    shape_data: Vec<ShapeInstance>,
    /// A rounded polygon's outline points, for one with more than [`SHAPE_POINTS`].
    rounded: Vec<Vec2>,
    /// Of `line_data`, how many are polygon outlines (the rest are the list's lines).
    outline_lines: usize,
    msaa: Option<MsaaTarget>,
    offscreen: Option<Offscreen>,
    samples: u32,
}

impl Renderer {
    /// An off-screen renderer on any adapter: the backends named by the `WGPU_BACKEND`
    /// environment variable (e.g. `gl`, `vulkan`), or all of them. Without a GPU, Mesa's
    /// llvmpipe (GL/EGL) or lavapipe (Vulkan) serve. `WGPU_ADAPTER_NAME` picks an
    /// adapter by name and `WGPU_POWER_PREF` (`low`/`high`) by power.
    ///
    /// Samples per pixel follow [`default_samples`]: 4x MSAA on a GPU, 1 on a CPU
    /// rasteriser such as llvmpipe (where MSAA costs several times the whole frame).
    ///
    /// Returns [`RenderError::NoAdapter`] when no adapter exists; never panics for that.
    pub fn new_headless() -> Result<Self, RenderError> {
        let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all());
        Self::headless(backends, None)
    }

    /// An off-screen renderer on the given backends only, ignoring `WGPU_BACKEND`, with
    /// 4x MSAA on any adapter (snapshot tests pin `wgpu::Backends::GL` so that bytes
    /// match across machines).
    pub fn new_headless_with(backends: wgpu::Backends) -> Result<Self, RenderError> {
        Self::headless(backends, Some(SAMPLE_COUNT))
    }

    /// As [`Renderer::new_headless_with`], with `samples` samples per pixel (see
    /// [`Renderer::with_samples`]).
    pub fn new_headless_with_samples(
        backends: wgpu::Backends,
        samples: u32,
    ) -> Result<Self, RenderError> {
        Self::headless(backends, Some(samples))
    }

    fn headless(backends: wgpu::Backends, samples: Option<u32>) -> Result<Self, RenderError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        // WGPU_ADAPTER_NAME, when set, chooses among the instance's adapters.
        let adapter = if std::env::var_os("WGPU_ADAPTER_NAME").is_some() {
            pollster::block_on(wgpu::util::initialize_adapter_from_env(&instance, None))
        } else {
            pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::from_env().unwrap_or_default(),
                force_fallback_adapter: false,
                compatible_surface: None,
                apply_limit_buckets: false,
            }))
        }
        .map_err(|e| RenderError::NoAdapter {
            backends: format!("{backends:?}"),
            reason: e.to_string(),
        })?;
        let info = adapter.get_info();
        log::info!(
            "render adapter: {} ({:?}, {})",
            info.name,
            info.backend,
            info.driver
        );
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("sandbox2d device"),
                required_features: wgpu::Features::empty(),
                required_limits: adapter.limits(),
                ..Default::default()
            }))?;
        let samples = samples.unwrap_or_else(|| default_samples(&info));
        let mut renderer = Self::with_samples(device, queue, OFFSCREEN_FORMAT, samples);
        renderer.adapter_info = Some(info);
        Ok(renderer)
    }

    /// A renderer on an existing device for targets of `format` (a window: the surface's
    /// device, queue and configured format; prefer an sRGB format or view format such as
    /// `Bgra8UnormSrgb`, though a non-sRGB one also renders correctly).
    /// `wgpu::Device` and `wgpu::Queue` are cheap handles: pass clones.
    pub fn new(device: wgpu::Device, queue: wgpu::Queue, format: wgpu::TextureFormat) -> Self {
        Self::with_samples(device, queue, format, SAMPLE_COUNT)
    }

    /// As [`Renderer::new`], with `samples` samples per pixel: 1 draws straight into the
    /// target (no multisampled buffer, no resolve; circles, lines and polygon outlines
    /// stay antialiased by their distance fields, only outline-less polygon edges are
    /// not), anything else gives [`SAMPLE_COUNT`].
    pub fn with_samples(
        device: wgpu::Device,
        queue: wgpu::Queue,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> Self {
        let samples = if samples <= 1 { 1 } else { SAMPLE_COUNT };
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sandbox2d globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sandbox2d globals layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<Globals>() as u64),
                },
                count: None,
            }],
        });
        let globals_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sandbox2d globals"),
            layout: &bind_group_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sandbox2d pipeline layout"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });

        let box_attributes = wgpu::vertex_attr_array![
            0 => Float32x2, 1 => Float32x2, 2 => Float32x2, 3 => Float32x4, 4 => Float32x4
        ];
        let circle_attributes = wgpu::vertex_attr_array![
            0 => Float32x2, 1 => Float32, 2 => Float32, 3 => Float32, 4 => Float32x4, 5 => Float32x4
        ];
        let line_attributes =
            wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x2, 2 => Float32, 3 => Float32x4];
        let polygon_attributes = wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x4];
        let shape_attributes = wgpu::vertex_attr_array![
            0 => Float32x4, 1 => Float32x4, 2 => Float32x4, 3 => Float32x4, 4 => Float32x4,
            5 => Float32x4, 6 => Float32x4
        ];

        // one quad per instance: a four-vertex strip, instance-rate attributes
        let instanced = |name: &str, source: &str, stride: usize, attributes| {
            create_pipeline(
                &device,
                &layout,
                format,
                samples,
                name,
                source,
                wgpu::PrimitiveTopology::TriangleStrip,
                wgpu::VertexBufferLayout {
                    array_stride: stride as u64,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes,
                },
            )
        };
        let box_pipeline = instanced(
            "box",
            include_str!("shaders/box.wgsl"),
            std::mem::size_of::<BoxInstance>(),
            &box_attributes,
        );
        let circle_pipeline = instanced(
            "circle",
            include_str!("shaders/circle.wgsl"),
            std::mem::size_of::<CircleInstance>(),
            &circle_attributes,
        );
        let line_pipeline = instanced(
            "line",
            include_str!("shaders/line.wgsl"),
            std::mem::size_of::<LineInstance>(),
            &line_attributes,
        );
        let shape_pipeline = instanced(
            "shape",
            include_str!("shaders/shape.wgsl"),
            std::mem::size_of::<ShapeInstance>(),
            &shape_attributes,
        );
        let polygon_pipeline = create_pipeline(
            &device,
            &layout,
            format,
            samples,
            "polygon",
            include_str!("shaders/polygon.wgsl"),
            wgpu::PrimitiveTopology::TriangleList,
            wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<PolygonVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &polygon_attributes,
            },
        );

        Self {
            box_buffer: GrowBuffer::new(&device, "sandbox2d boxes", 4096),
            shape_buffer: GrowBuffer::new(&device, "sandbox2d shapes", 4096),
            circle_buffer: GrowBuffer::new(&device, "sandbox2d circles", 4096),
            line_buffer: GrowBuffer::new(&device, "sandbox2d lines", 4096),
            polygon_buffer: GrowBuffer::new(&device, "sandbox2d polygons", 4096),
            device,
            queue,
            format,
            adapter_info: None,
            globals,
            globals_bind_group,
            box_pipeline,
            circle_pipeline,
            line_pipeline,
            polygon_pipeline,
            shape_pipeline,
            box_data: Vec::new(),
            circle_data: Vec::new(),
            line_data: Vec::new(),
            polygon_data: Vec::new(),
            shape_data: Vec::new(),
            rounded: Vec::new(),
            outline_lines: 0,
            msaa: None,
            offscreen: None,
            samples,
        }
    }

    /// The adapter a headless renderer runs on (`None` for [`Renderer::new`] until
    /// [`Renderer::set_adapter_info`]).
    pub fn adapter_info(&self) -> Option<&wgpu::AdapterInfo> {
        self.adapter_info.as_ref()
    }

    /// Records the adapter a renderer made with [`Renderer::new`] runs on (for reports).
    pub fn set_adapter_info(&mut self, info: wgpu::AdapterInfo) {
        self.adapter_info = Some(info);
    }

    /// Samples per pixel: 1, or [`SAMPLE_COUNT`] with a multisampled buffer resolved
    /// into the target.
    pub fn sample_count(&self) -> u32 {
        self.samples
    }

    /// The target format the pipelines were built for.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// The device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Records one frame into `encoder`: clears `target` to the list's background and
    /// draws the list through `camera`. `target` must be a single-sampled view of
    /// [`Renderer::format`] whose size is `camera.size` (a window: resize the camera with
    /// the surface). Uploads the frame's data with `queue.write_buffer`, so submit the
    /// encoder before the next call to `draw`.
    pub fn draw(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        list: &DrawList,
        camera: &Camera,
    ) {
        let size = [camera.size[0].max(1), camera.size[1].max(1)];
        self.upload(list, camera, size);
        // With MSAA: draw into the multisampled buffer, resolve into the target, and
        // discard the samples. Without: draw into the target and keep it.
        let (view, resolve_target, store) = if self.samples > 1 {
            if self.msaa.as_ref().is_none_or(|m| m.size != size) {
                self.msaa = Some(self.create_msaa(size));
            }
            let Some(msaa) = &self.msaa else { return };
            (&msaa.view, Some(target), wgpu::StoreOp::Discard)
        } else {
            (target, None, wgpu::StoreOp::Store)
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("sandbox2d frame"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(clear_color(list.background, self.format)),
                    store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.globals_bind_group, &[]);
        let line_stride = std::mem::size_of::<LineInstance>() as u64;
        let outline_lines = self.outline_lines as u32;
        let user_lines = (self.line_data.len() - self.outline_lines) as u32;
        // 1. rectangles, each with its outline
        if !self.box_data.is_empty() {
            pass.set_pipeline(&self.box_pipeline);
            pass.set_vertex_buffer(0, self.box_buffer.buffer.slice(..));
            pass.draw(QUAD_VERTICES, 0..self.box_data.len() as u32);
        }
        // 2. shapes of up to SHAPE_POINTS points, each with its outline
        if !self.shape_data.is_empty() {
            pass.set_pipeline(&self.shape_pipeline);
            pass.set_vertex_buffer(0, self.shape_buffer.buffer.slice(..));
            pass.draw(QUAD_VERTICES, 0..self.shape_data.len() as u32);
        }
        // 3. other polygons' fills
        if !self.polygon_data.is_empty() {
            pass.set_pipeline(&self.polygon_pipeline);
            pass.set_vertex_buffer(0, self.polygon_buffer.buffer.slice(..));
            pass.draw(0..self.polygon_data.len() as u32, 0..1);
        }
        // 4. their outlines (the first lines in the line buffer)
        if outline_lines > 0 {
            pass.set_pipeline(&self.line_pipeline);
            pass.set_vertex_buffer(0, self.line_buffer.buffer.slice(..));
            pass.draw(QUAD_VERTICES, 0..outline_lines);
        }
        // 5. circles
        if !self.circle_data.is_empty() {
            pass.set_pipeline(&self.circle_pipeline);
            pass.set_vertex_buffer(0, self.circle_buffer.buffer.slice(..));
            pass.draw(QUAD_VERTICES, 0..self.circle_data.len() as u32);
        }
        // 6. the list's lines, over everything. A buffer offset rather than a first
        // instance, which GLES lacks.
        if user_lines > 0 {
            pass.set_pipeline(&self.line_pipeline);
            pass.set_vertex_buffer(
                0,
                self.line_buffer
                    .buffer
                    .slice(outline_lines as u64 * line_stride..),
            );
            pass.draw(QUAD_VERTICES, 0..user_lines);
        }
    }

    /// Renders one frame off-screen and reads it back: `camera.size` pixels, sRGB RGBA.
    /// Any size works (rows are padded to 256 bytes for the copy and unpadded here).
    /// Needs a renderer made for [`OFFSCREEN_FORMAT`] (as [`Renderer::new_headless`] is).
    pub fn render_to_image(
        &mut self,
        list: &DrawList,
        camera: &Camera,
    ) -> Result<image::RgbaImage, RenderError> {
        let [width, height] = camera.size;
        let max = self.device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::InvalidSize { width, height, max });
        }
        if self.format != OFFSCREEN_FORMAT {
            return Err(RenderError::WrongFormat {
                format: format!("{:?}", self.format),
            });
        }
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        if self
            .offscreen
            .as_ref()
            .is_none_or(|o| o.size != camera.size)
        {
            self.offscreen = Some(self.create_offscreen(camera.size));
        }
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sandbox2d offscreen"),
            });
        let offscreen = self
            .offscreen
            .take()
            .ok_or(RenderError::Gpu("no off-screen target".into()))?;
        self.draw(&mut encoder, &offscreen.view, list, camera);
        encoder.copy_texture_to_buffer(
            offscreen.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &offscreen.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(offscreen.padded_bytes_per_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([encoder.finish()]);
        let result = self.read_back(&offscreen);
        self.offscreen = Some(offscreen);
        if let Some(err) = pollster::block_on(scope.pop()) {
            return Err(RenderError::Gpu(err.to_string()));
        }
        result
    }

    /// Maps the read-back buffer and copies the rows, unpadded, into an image.
    fn read_back(&self, offscreen: &Offscreen) -> Result<image::RgbaImage, RenderError> {
        let [width, height] = offscreen.size;
        let (tx, rx) = std::sync::mpsc::channel();
        offscreen
            .readback
            .map_async(wgpu::MapMode::Read, .., move |r| {
                // The receiver outlives the poll below; a failed send cannot happen.
                let _ = tx.send(r);
            });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Gpu(format!("poll: {e}")))?;
        rx.recv()
            .map_err(|_| RenderError::Gpu("read-back callback never ran".into()))?
            .map_err(|e| RenderError::Gpu(format!("map read-back buffer: {e}")))?;
        let row = width as usize * 4;
        let mut pixels = Vec::with_capacity(row * height as usize);
        {
            let view = offscreen
                .readback
                .get_mapped_range(..)
                .map_err(|e| RenderError::Gpu(format!("read-back view: {e}")))?;
            for y in 0..height as usize {
                let start = y * offscreen.padded_bytes_per_row as usize;
                pixels.extend_from_slice(&view[start..start + row]);
            }
        }
        offscreen.readback.unmap();
        image::RgbaImage::from_raw(width, height, pixels)
            .ok_or(RenderError::Gpu("read-back size mismatch".into()))
    }

    /// Number of outline segments the list's polygons produce (drawn before its lines).
    /// Fills the CPU-side arrays from the list and uploads them and the camera.
    fn upload(&mut self, list: &DrawList, camera: &Camera, size: [u32; 2]) {
        let globals = Globals {
            center: camera.center.to_array(),
            screen_center: (Vec2::new(size[0] as f32, size[1] as f32) * 0.5).to_array(),
            viewport: [size[0] as f32, size[1] as f32],
            scale: camera.pixels_per_meter,
            outline_px: list.outline_width_px.max(0.0),
            _pad: [0.0; 4],
        };
        self.queue
            .write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));

        // What reaches far past the image is cut down to what can show, in f64, before
        // it meets the GPU's f32 and its rasteriser (`crate::draw::clip`).
        use crate::draw::clip::{self, CircleCut};
        self.box_data.clear();
        for r in &list.boxes {
            let r = match clip::cut_box(r, camera) {
                Ok(None) => *r,
                Ok(Some(cut)) => cut,
                Err(()) => continue,
            };
            self.box_data.push(BoxInstance {
                center: r.center.to_array(),
                half_size: r.half_size.to_array(),
                rot: r.rot.to_array(),
                fill: premultiplied_linear(r.fill),
                outline: premultiplied_linear(r.outline),
            });
        }

        self.polygon_data.clear();
        self.shape_data.clear();
        self.line_data.clear();
        let outline_px = list.outline_width_px;

        self.circle_data.clear();
        // a circle whose rim crosses the image far from its centre: drawn as the
        // polygon of its visible part, after the polygons
        let mut rims: Vec<(Vec<Vec2>, crate::Color, crate::Color)> = Vec::new();
        for c in &list.circles {
            let c = match clip::cut_circle(c, camera) {
                CircleCut::Keep => *c,
                CircleCut::Cover(k) => k,
                CircleCut::Nothing => continue,
                CircleCut::Polygon(p) => {
                    rims.push((p, c.fill, c.outline));
                    continue;
                }
            };
            self.circle_data.push(CircleInstance {
                center: c.center.to_array(),
                radius: c.radius,
                angle: c.angle.unwrap_or(0.0),
                has_angle: if c.angle.is_some() { 1.0 } else { 0.0 },
                fill: premultiplied_linear(c.fill),
                outline: premultiplied_linear(c.outline),
            });
        }

        let (mut cut_points, mut huge_rounded) = (Vec::new(), Vec::new());
        let polygons = list
            .polygons
            .iter()
            .map(|poly| (list.points_of(poly), poly.radius, poly.fill, poly.outline));
        let rims = rims.iter().map(|(p, f, o)| (p.as_slice(), 0.0, *f, *o));
        for (points, radius, fill, outline) in polygons.chain(rims) {
            let (fill_linear, outline_linear) =
                (premultiplied_linear(fill), premultiplied_linear(outline));
            let mut p = points;
            let mut radius = radius;
            if radius > 0.0
                && !p.is_empty()
                && clip::cut_polygon(p, camera, &mut cut_points).is_some()
            {
                // a huge rounded shape: its outline, then cut as a polygon
                huge_rounded.clear();
                crate::draw::rounded_points(p, radius, &mut huge_rounded);
                p = &huge_rounded;
                radius = 0.0;
            }
            if p.len() >= 3
                && radius == 0.0
                && clip::cut_polygon(p, camera, &mut cut_points).is_some()
            {
                if cut_points.len() < 3 {
                    continue;
                }
                p = &cut_points;
            } else if let Some(shape) = ShapeInstance::new(p, radius, fill_linear, outline_linear) {
                self.shape_data.push(shape);
                continue;
            }
            if radius > 0.0 && !p.is_empty() {
                self.rounded.clear();
                crate::draw::rounded_points(p, radius, &mut self.rounded);
                p = &self.rounded;
            }
            // Fan triangulation of a convex polygon: (p0, p_i, p_i+1).
            if p.len() >= 3 && fill[3] > 0 {
                let v = |q: Vec2| PolygonVertex {
                    position: q.to_array(),
                    color: fill_linear,
                };
                for i in 1..p.len() - 1 {
                    self.polygon_data.extend([v(p[0]), v(p[i]), v(p[i + 1])]);
                }
            }
            if outline[3] > 0 && outline_px > 0.0 && p.len() >= 2 {
                let n = p.len();
                let edges = if n == 2 { 1 } else { n };
                for i in 0..edges {
                    let (a, b) = match clip::cut_segment(p[i], p[(i + 1) % n], camera) {
                        None => (p[i], p[(i + 1) % n]),
                        Some(Some(ab)) => ab,
                        Some(None) => continue,
                    };
                    self.line_data.push(LineInstance {
                        a: a.to_array(),
                        b: b.to_array(),
                        width_px: outline_px,
                        color: outline_linear,
                    });
                }
            }
        }
        self.outline_lines = self.line_data.len();
        for l in &list.lines {
            let (a, b) = match clip::cut_segment(l.a, l.b, camera) {
                None => (l.a, l.b),
                Some(Some(ab)) => ab,
                Some(None) => continue,
            };
            self.line_data.push(LineInstance {
                a: a.to_array(),
                b: b.to_array(),
                width_px: l.width_px,
                color: premultiplied_linear(l.color),
            });
        }

        self.box_buffer.upload(
            &self.device,
            &self.queue,
            bytemuck::cast_slice(&self.box_data),
        );
        self.circle_buffer.upload(
            &self.device,
            &self.queue,
            bytemuck::cast_slice(&self.circle_data),
        );
        self.line_buffer.upload(
            &self.device,
            &self.queue,
            bytemuck::cast_slice(&self.line_data),
        );
        self.polygon_buffer.upload(
            &self.device,
            &self.queue,
            bytemuck::cast_slice(&self.polygon_data),
        );
        self.shape_buffer.upload(
            &self.device,
            &self.queue,
            bytemuck::cast_slice(&self.shape_data),
        );
    }

    fn create_msaa(&self, size: [u32; 2]) -> MsaaTarget {
        let texture = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("sandbox2d msaa"),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: self.samples,
            dimension: wgpu::TextureDimension::D2,
            format: self.format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        MsaaTarget {
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            size,
        }
    }

    fn create_offscreen(&self, size: [u32; 2]) -> Offscreen {
        let texture = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("sandbox2d offscreen"),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OFFSCREEN_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        // Copies need rows aligned to 256 bytes.
        let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let padded_bytes_per_row = (size[0] * 4).div_ceil(align) * align;
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sandbox2d read-back"),
            size: padded_bytes_per_row as u64 * size[1] as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Offscreen {
            texture,
            view,
            readback,
            padded_bytes_per_row,
            size,
        }
    }
}

/// A pipeline drawing `topology` from one vertex buffer, premultiplied-alpha blending,
/// `samples` samples per pixel; `source` is prepended with `shaders/common.wgsl`.
#[allow(clippy::too_many_arguments)]
fn create_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    samples: u32,
    name: &str,
    source: &str,
    topology: wgpu::PrimitiveTopology,
    buffer: wgpu::VertexBufferLayout<'_>,
) -> wgpu::RenderPipeline {
    let code = format!("{}\n{}", include_str!("shaders/common.wgsl"), source);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(name),
        source: wgpu::ShaderSource::Wgsl(code.into()),
    });
    premultiplied_pipeline(
        device,
        layout,
        format,
        samples,
        name,
        &module,
        topology,
        &[("ENCODE_SRGB", if format.is_srgb() { 0.0 } else { 1.0 })],
        &[Some(buffer)],
    )
}

/// A pipeline of `module`'s `vs_main` and `fs_main` drawing `topology` from `buffers`
/// with premultiplied-alpha blending into `format` at `samples` samples per pixel (the
/// window's panel layer uses it too).
#[allow(clippy::too_many_arguments)]
pub(crate) fn premultiplied_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    samples: u32,
    name: &str,
    module: &wgpu::ShaderModule,
    topology: wgpu::PrimitiveTopology,
    constants: &[(&str, f64)],
    buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
) -> wgpu::RenderPipeline {
    let compilation_options = wgpu::PipelineCompilationOptions {
        constants,
        ..Default::default()
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(name),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: compilation_options.clone(),
            buffers,
        },
        primitive: wgpu::PrimitiveState {
            topology,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: None,
        multisample: wgpu::MultisampleState {
            count: samples,
            ..Default::default()
        },
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options,
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The clear colour for an sRGB background: linear for an sRGB target (the hardware
/// encodes it), the sRGB values themselves for a non-sRGB one.
fn clear_color(c: crate::Color, format: wgpu::TextureFormat) -> wgpu::Color {
    let f = |v: u8| {
        let x = v as f64 / 255.0;
        if !format.is_srgb() {
            x
        } else if x <= 0.04045 {
            x / 12.92
        } else {
            ((x + 0.055) / 1.055).powf(2.4)
        }
    };
    wgpu::Color {
        r: f(c[0]),
        g: f(c[1]),
        b: f(c[2]),
        a: c[3] as f64 / 255.0,
    }
}
