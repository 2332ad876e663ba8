//! The window: winit 0.30's `ApplicationHandler`, a wgpu surface the world is drawn
//! into with [`Renderer::draw`], and the egui panel over it.

use std::sync::Arc;
use std::time::Instant;

use glam::Vec2;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, ModifiersState, NamedKey};
use winit::window::{Window, WindowId};

use super::input::SpawnKind;
use super::panel_layer::PanelLayer;
use super::session::{Compare, Emitter, Session};
use super::ui::{self, FrameStats, PANEL_WIDTH};
use super::{AppError, AppOptions, RunReport};
use crate::draw::world::{Overlays, fill_world_draw_list, scene_camera, world_bounds};
use crate::draw::{Camera, DrawList};
use crate::render::{Renderer, save_png};

mod frame;

use frame::{Capture, draw_panel, encode_frame};

/// Radius of the force emitter in pixels (converted to metres at the current zoom).
const EMITTER_RADIUS_PX: f32 = 110.0;
/// Colour of the drag spring and the emitter's ring.
const TOOL_COLOR: [u8; 4] = [255, 255, 255, 200];
/// The ray tool (T): the ray, and its hit point and normal.
const RAY_COLOR: [u8; 4] = [255, 230, 90, 230];
const RAY_HIT_COLOR: [u8; 4] = [255, 80, 200, 255];
/// Length of the drawn hit normal (px).
const RAY_NORMAL_PX: f32 = 40.0;
/// What the panel's frame and margins add to its width (px).
const PANEL_FRAME_PX: f32 = 32.0;

/// The line between `--compare` panes.
const DIVIDER_COLOR: [u8; 4] = [200, 200, 210, 255];
/// `run --compare` labels: text and the box behind it.
const LABEL_COLOR: egui::Color32 = egui::Color32::from_rgb(235, 235, 240);
const LABEL_BACK: egui::Color32 = egui::Color32::from_black_alpha(160);
/// A pane label's font size, its margin from the pane's corner and its box's padding
/// around the text (points).
const LABEL_FONT_PT: f32 = 14.0;
const LABEL_MARGIN_PT: f32 = 8.0;
const LABEL_PAD_PT: f32 = 4.0;
/// How often the panel is redrawn when nothing touches it (its live figures and plots).
const PANEL_REFRESH: std::time::Duration = std::time::Duration::from_millis(250);

/// Everything that lives while the window does.
struct Gpu {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    renderer: Renderer,
    egui_renderer: egui_wgpu::Renderer,
    egui_state: egui_winit::State,
    /// The panel, drawn by egui when it changes and laid over every frame.
    panel: PanelLayer,
}

/// What the mouse is doing to the view.
#[derive(Default)]
struct Mouse {
    /// Cursor position in physical pixels.
    cursor: Vec2,
    /// Left button dragging empty space.
    panning: bool,
    modifiers: ModifiersState,
}

pub(super) struct App {
    opts: AppOptions,
    session: Session,
    camera: Camera,
    list: DrawList,
    gpu: Option<Gpu>,
    mouse: Mouse,
    /// A failure that ended the event loop.
    fatal: Option<AppError>,
    /// Frames presented.
    frames: u64,
    first_frame: Option<Instant>,
    last_frame: Option<Instant>,
    /// Summed wall time (ms) of each part of a frame: the draw list, egui, acquiring
    /// the surface texture, encoding and submitting, presenting (the rasteriser's work
    /// included), and waiting for the simulation's steps (run on their own thread from
    /// submit on) after presenting.
    phase_ms: [f64; 6],
    /// Summed time (ms) of the simulation's steps on their own thread, which overlaps
    /// presenting.
    sim_ms: f64,
    /// The frame phases (ms) the panel shows: the mean over the frames between its
    /// last two refreshes (most frames run no panel and half of them no step, so one
    /// frame alone says little).
    last_phase_ms: [f32; 6],
    /// Phases summed since the panel last ran, and over how many frames.
    phase_since: ([f64; 6], u32),
    /// The side panel is shown (H toggles it).
    panel_visible: bool,
    /// The body last grabbed with the mouse (C makes the camera follow it).
    selected: Option<usize>,
    /// The camera keeps this body at the centre of the free area.
    follow: Option<usize>,
    /// The panel must be drawn again (input over it, an egui animation, a resize).
    panel_dirty: bool,
    /// When the panel's figures are next refreshed, if not dirty before.
    panel_next: Option<Instant>,
    /// When the simulation last advanced (its clock).
    last_advance: Option<Instant>,
    /// Presentation times of the frames of the last second, for the panel's fps.
    recent: std::collections::VecDeque<Instant>,
    /// Time between consecutive frames (ms).
    frame_ms: Vec<f32>,
    /// The last frame, read back for `--screenshot`.
    screenshot: Option<image::RgbaImage>,
    /// The screenshot was written.
    screenshot_done: bool,
    /// `run --compare`: the panes after the first, drawn to its right.
    compare: Option<Compare>,
    /// One pane's draw list, before it is moved into place in `list`.
    pane_list: DrawList,
    /// With panes: the first pane's settings when its label was last written (the
    /// panel edits them; the label then follows).
    first_settings: Option<crate::defs::SolverSettings>,
}

impl App {
    pub(super) fn new(opts: AppOptions, session: Session) -> App {
        let panel_visible = opts.show_panel;
        App {
            opts,
            session,
            camera: Camera::default(),
            list: DrawList::new(),
            compare: None,
            pane_list: DrawList::new(),
            first_settings: None,
            gpu: None,
            mouse: Mouse::default(),
            fatal: None,
            frames: 0,
            first_frame: None,
            last_frame: None,
            last_advance: None,
            panel_visible,
            selected: None,
            follow: None,
            panel_dirty: true,
            panel_next: None,
            phase_ms: [0.0; 6],
            sim_ms: 0.0,
            last_phase_ms: [0.0; 6],
            phase_since: ([0.0; 6], 0),
            recent: Default::default(),
            frame_ms: Vec::new(),
            screenshot: None,
            screenshot_done: false,
        }
    }

    /// Runs the event loop to the end.
    pub(super) fn run(mut self, event_loop: EventLoop<()>) -> Result<RunReport, AppError> {
        event_loop
            .run_app(&mut self)
            .map_err(|e| AppError::EventLoop(e.to_string()))?;
        if let Some(e) = self.fatal.take() {
            return Err(e);
        }
        let seconds = match (self.first_frame, self.last_frame) {
            (Some(a), Some(b)) => (b - a).as_secs_f64(),
            _ => 0.0,
        };
        let n = self.frames.max(1) as f64;
        let [list, ui, acquire, submit, present, wait] = self.phase_ms.map(|v| v / n);
        let sim = self.sim_ms / n;
        log::info!(
            "mean ms a frame: draw list {list:.2}, panel {ui:.2}, acquire {acquire:.2}, \
             encode and submit {submit:.2}, present {present:.2}, then waiting for the \
             step {wait:.2}; the simulation's steps (on their own thread, beside \
             present) {sim:.2}"
        );
        let mut sorted = self.frame_ms.clone();
        sorted.sort_by(f32::total_cmp);
        let pick = |q: f64| {
            sorted
                .get(((sorted.len().max(1) - 1) as f64 * q).round() as usize)
                .copied()
                .unwrap_or(0.0)
        };
        Ok(RunReport {
            frames: self.frames,
            seconds,
            frame_ms_median: pick(0.5),
            frame_ms_p95: pick(0.95),
            screenshot: self
                .screenshot_done
                .then(|| self.opts.screenshot.clone())
                .flatten(),
            adapter: self.adapter_name(),
        })
    }

    fn adapter_name(&self) -> String {
        self.gpu
            .as_ref()
            .and_then(|g| g.renderer.adapter_info().map(|i| i.name.clone()))
            .unwrap_or_default()
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: AppError) {
        log::error!("{e}");
        self.fatal = Some(e);
        event_loop.exit();
    }

    /// The window's pixels per point (for the panel's width in pixels).
    fn panel_px(&self) -> f32 {
        if !self.panel_visible {
            return 0.0;
        }
        let scale = self
            .gpu
            .as_ref()
            .map(|g| g.window.scale_factor() as f32)
            .unwrap_or(1.0);
        PANEL_WIDTH * scale
    }

    /// `run --compare`: shows `compare`'s panes to the right of the first.
    pub(super) fn with_compare(mut self, compare: Compare) -> App {
        self.compare = Some(compare);
        self
    }

    /// The window's title: the scene, and with `--compare` the panes' labels left to
    /// right.
    fn title(&self) -> String {
        match &self.compare {
            Some(c) => format!(
                "sandbox2d - {} - {}",
                self.session.scene.name,
                c.labels.join(" | ")
            ),
            None => format!("sandbox2d - {}", self.session.scene.name),
        }
    }

    /// The panes side by side (1 without `--compare`).
    fn panes(&self) -> usize {
        self.compare.as_ref().map_or(1, Compare::panes)
    }

    /// Where pane `k` is drawn: its world moved right by `k` panes' width (m) under
    /// the window's one camera.
    fn pane_offset(&self, k: usize) -> Vec2 {
        let (_, pw) = self.pane_area();
        Vec2::new(k as f32 * pw / self.camera.pixels_per_meter, 0.0)
    }

    /// With `--compare`: the panes share the window right of the panel (when it is
    /// shown). Returns the first pane's left edge and a pane's width (px).
    fn pane_area(&self) -> (f32, f32) {
        let w = self.camera.size[0] as f32;
        let left = if self.panel_visible && self.panes() > 1 {
            // the panel's width and its frame
            (self.panel_px() + PANEL_FRAME_PX).min(0.5 * w)
        } else {
            0.0
        };
        let pw = ((w - left) / self.panes() as f32).floor().max(1.0);
        (left, pw)
    }

    /// The scene's camera for the window, framing the area right of the panel.
    fn reset_camera(&mut self) {
        let n = self.panes();
        if n > 1 {
            // Compare: the scene framed in the first pane, the window's camera moved so
            // the panes sit side by side right of the panel
            let [w, h] = self.camera.size;
            let (left, pw) = self.pane_area();
            let mut cam = scene_camera(
                &self.session.scene.camera,
                [pw as u32, h],
                &self.session.world,
            );
            cam.size = [w, h];
            // the first pane's centre is at x = left + pw / 2 on the screen
            cam.center.x += (0.5 * w as f32 - left - 0.5 * pw) / cam.pixels_per_meter;
            self.camera = cam;
            return;
        }
        let [w, h] = self.camera.size;
        let panel = self.panel_px().min(w as f32 * 0.5);
        let free = [(w as f32 - panel).max(1.0) as u32, h];
        let mut cam = scene_camera(&self.session.scene.camera, free, &self.session.world);
        cam.size = [w, h];
        // Shift the view left by half the panel so the scene sits in the free area.
        cam.center.x -= 0.5 * panel / cam.pixels_per_meter;
        self.camera = cam;
    }

    /// F: zooms and centres so every body fits the area beside the panel.
    fn fit_view(&mut self) {
        let Some((lo, hi)) = world_bounds(&self.session.world) else {
            return;
        };
        let [w, h] = self.camera.size;
        let panel = self.panel_px().min(w as f32 * 0.5);
        let mut cam = self.camera;
        cam.size = [(w as f32 - panel).max(1.0) as u32, h];
        cam.fit(lo, hi, 0.05 * cam.size[0].min(h) as f32);
        cam.size = [w, h];
        cam.center.x -= 0.5 * panel / cam.pixels_per_meter;
        self.camera = cam;
    }

    /// C: keeps the followed body at the centre of the area beside the panel.
    fn follow_camera(&mut self) {
        let Some(b) = self.follow.and_then(|i| self.session.world.bodies.get(i)) else {
            self.follow = None;
            return;
        };
        let [w, _] = self.camera.size;
        let panel = self.panel_px().min(w as f32 * 0.5);
        let mut c = b.position;
        c.x -= 0.5 * panel / self.camera.pixels_per_meter;
        self.camera.center = c;
    }

    fn create_gpu(&mut self, event_loop: &ActiveEventLoop) -> Result<(), AppError> {
        let attrs = Window::default_attributes()
            .with_title(self.title())
            .with_inner_size(winit::dpi::LogicalSize::new(1280.0, 720.0));
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .map_err(|e| AppError::NoDisplay(format!("cannot create a window: {e}")))?,
        );
        let desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        ));
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| AppError::Gpu(format!("cannot create a surface: {e}")))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::from_env().unwrap_or_default(),
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            apply_limit_buckets: false,
        }))
        .map_err(|e| AppError::Gpu(format!("no graphics adapter for the window: {e}")))?;
        let info = adapter.get_info();
        log::info!(
            "window adapter: {} ({:?}, {})",
            info.name,
            info.backend,
            info.driver
        );
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("sandbox2d window device"),
            required_features: wgpu::Features::empty(),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| AppError::Gpu(format!("could not create a GPU device: {e}")))?;
        let caps = surface.get_capabilities(&adapter);
        // An sRGB format, so the window shows the same bytes as a PNG of the same list.
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| AppError::Gpu("the surface supports no format".into()))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            desired_maximum_frame_latency: 2,
            present_mode: wgpu::PresentMode::AutoVsync,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&device, &config);
        let samples = crate::render::default_samples(&info);
        let mut renderer = Renderer::with_samples(device.clone(), queue.clone(), format, samples);
        log::info!("window: {format:?}, {samples} sample(s) per pixel");
        renderer.set_adapter_info(info);
        let egui_renderer =
            egui_wgpu::Renderer::new(&device, format, egui_wgpu::RendererOptions::default());
        let panel = PanelLayer::new(&device, format);
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx,
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(device.limits().max_texture_dimension_2d as usize),
        );
        self.camera.size = [config.width, config.height];
        self.gpu = Some(Gpu {
            window,
            surface,
            device,
            queue,
            config,
            renderer,
            egui_renderer,
            egui_state,
            panel,
        });
        self.reset_camera();
        Ok(())
    }

    fn resize(&mut self, width: u32, height: u32) {
        let Some(g) = self.gpu.as_mut() else { return };
        if width == 0 || height == 0 {
            return;
        }
        g.config.width = width;
        g.config.height = height;
        g.surface.configure(&g.device, &g.config);
        self.camera.size = [width, height];
    }

    /// Draws the world and the panel, presents while the world steps on a thread of its
    /// own; takes the screenshot and stops after `--frames`.
    ///
    /// The order overlaps the big costs: the draw list is filled from the world as it
    /// is, the frame is encoded and submitted (a CPU rasteriser such as llvmpipe starts
    /// on it in its own threads), then the simulation steps towards the next frame on a
    /// scoped thread while this one presents (waiting for the rasteriser, the surface's
    /// blit and the copy to the window server), and the frame ends when both are done.
    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        self.follow_camera();
        if self.session.ray.is_some() {
            // the bodies (or the camera under a still cursor) moved: cast again
            self.session.aim_ray(self.cursor_world());
        }
        let overlays = Overlays {
            pixels_per_meter: Some(self.camera.pixels_per_meter),
            ..self.session.overlays
        };
        let offsets: Vec<Vec2> = (0..self.panes()).map(|k| self.pane_offset(k)).collect();
        // (before `compare` is taken out below: the area depends on the pane count)
        let (area_left, pw) = self.pane_area();
        if let Some(c) = self.compare.take() {
            // Compare: each pane's list moved into place, then the tools in each pane
            // and a divider between panes (a body may spill over it).
            self.list.clear();
            let worlds =
                std::iter::once(&self.session.world).chain(c.others.iter().map(|o| &o.world));
            // each pane's items only inside its own part of the window (world x)
            let ppm = self.camera.pixels_per_meter;
            let left = self.camera.center.x - 0.5 * self.camera.size[0] as f32 / ppm;
            for (k, world) in worlds.enumerate() {
                fill_world_draw_list(&mut self.pane_list, world, &overlays);
                let x0 = left + (area_left + k as f32 * pw) / ppm;
                self.list
                    .append_within(&self.pane_list, offsets[k], x0..x0 + pw / ppm);
            }
            self.list.background = self.pane_list.background;
            self.list.outline_width_px = self.pane_list.outline_width_px;
            self.compare = Some(c);
            for k in 0..self.panes() {
                self.pane_list.clear();
                std::mem::swap(&mut self.list, &mut self.pane_list);
                self.push_tools();
                std::mem::swap(&mut self.list, &mut self.pane_list);
                let off = self.pane_offset(k);
                self.list.append_translated(&self.pane_list, off);
            }
            let [w, h] = self.camera.size;
            let ppm = self.camera.pixels_per_meter;
            let left = self.camera.center.x - 0.5 * w as f32 / ppm;
            let half_h = h as f32 / ppm;
            let (area_left, _) = self.pane_area();
            for k in 1..self.panes() {
                let x = left + area_left / ppm + self.pane_offset(k).x;
                let cy = self.camera.center.y;
                self.list.push_line(
                    Vec2::new(x, cy - half_h),
                    Vec2::new(x, cy + half_h),
                    2.0,
                    DIVIDER_COLOR,
                );
            }
        } else {
            fill_world_draw_list(&mut self.list, &self.session.world, &overlays);
            self.push_tools();
        }

        let Some(g) = self.gpu.as_mut() else { return };
        // The panel: egui runs only when it is due (see PanelLayer); otherwise last
        // time's layer is laid over the world again.
        let fps = self.recent.len() as f32;
        let frame_stats = FrameStats {
            fps,
            bodies: self.session.world.bodies.len(),
            phase_ms: self.last_phase_ms,
        };
        let t_list = Instant::now();
        let size = [g.config.width, g.config.height];
        let visible = self.panel_visible;
        // with panes, egui also paints their labels (into the same layer), panel or not
        let labelled = self.compare.is_some();
        let layer = visible || labelled;
        let due = layer
            && (self.panel_dirty
                || self.panel_next.is_none_or(|t| now >= t)
                || !g.panel.ready(size));
        let mut actions = ui::PanelActions::default();
        let mut drawn: Option<(Vec<egui::ClippedPrimitive>, f32, Vec<egui::Rect>)> = None;
        let mut free: Vec<egui::TextureId> = Vec::new();
        if !layer {
            // Keep egui's input queue from growing while it is not run. Only the queue:
            // `take_egui_input` would also ask the window server for the window's
            // position, size and state (round trips, about 0.8 ms a frame under Xvfb).
            g.egui_state.egui_input_mut().events.clear();
        } else if due {
            let (sum, n) = &mut self.phase_since;
            if *n > 0 {
                let k = *n as f64;
                for (last, s) in self.last_phase_ms.iter_mut().zip(sum.iter()) {
                    *last = (s / k) as f32;
                }
            }
            *sum = [0.0; 6];
            *n = 0;
            let frame_stats = FrameStats {
                phase_ms: self.last_phase_ms,
                ..frame_stats
            };
            let raw = g.egui_state.take_egui_input(&g.window);
            let ctx = g.egui_state.egui_ctx().clone();
            let session = &mut self.session;
            let compare = self.compare.as_ref();
            let others = compare.map_or(&[][..], |c| &c.others[..]);
            let mut label_boxes = Vec::new();
            let mut out = ctx.run_ui(raw, |ui| {
                if visible {
                    actions = ui::panel(ui, session, others, frame_stats);
                }
                if let Some(c) = compare {
                    // the panes in points; the labels start right of the panel
                    let ppp = ui.ctx().pixels_per_point();
                    let h = size[1] as f32 / ppp;
                    let panes: Vec<egui::Rect> = (0..c.panes())
                        .map(|k| {
                            let x = (area_left + k as f32 * pw) / ppp;
                            egui::Rect::from_min_size(egui::pos2(x, 0.0), egui::vec2(pw / ppp, h))
                        })
                        .collect();
                    let free_left = ui.available_rect_before_wrap().left();
                    let figures = std::iter::once(&*session)
                        .chain(&c.others)
                        .map(Session::figures);
                    let labels = c.labels.iter().map(String::as_str).zip(figures);
                    label_boxes = frame::paint_pane_labels(ui.ctx(), &panes, free_left, labels);
                }
            });
            g.egui_state
                .handle_platform_output(&g.window, std::mem::take(&mut out.platform_output));
            // an animation (a popup opening, a header folding) wants the next frame too
            self.panel_dirty = out
                .viewport_output
                .get(&egui::ViewportId::ROOT)
                .is_some_and(|v| v.repaint_delay.is_zero());
            if self.panel_dirty {
                log::debug!("panel repaint asked: {:?}", ctx.repaint_causes());
            }
            self.panel_next = Some(now + PANEL_REFRESH);
            let jobs = ctx.tessellate(std::mem::take(&mut out.shapes), out.pixels_per_point);
            // New and changed textures go up before painting; freed ones go after it.
            let mut textures = std::mem::take(&mut out.textures_delta);
            for (id, deltas) in textures.set.drain() {
                for delta in &deltas {
                    g.egui_renderer
                        .update_texture(&g.device, &g.queue, id, delta);
                }
            }
            free = textures.free.drain().collect();
            drawn = Some((jobs, out.pixels_per_point, label_boxes));
        }

        let t_ui = Instant::now();
        let texture = match g.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            other => {
                if matches!(
                    other,
                    wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost
                ) {
                    g.surface.configure(&g.device, &g.config);
                }
                log::debug!("skipping a frame: {other:?}");
                // what egui drew this time was not recorded
                self.panel_dirty = true;
                for id in &free {
                    g.egui_renderer.free_texture(id);
                }
                g.window.request_redraw();
                return;
            }
        };
        let t_acquire = Instant::now();
        let view = texture
            .texture
            .create_view(&wgpu::TextureViewDescriptor::default());
        let mut encoder = g
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sandbox2d window frame"),
            });
        let mut extra = Vec::new();
        if let Some((jobs, pixels_per_point, label_boxes)) = &drawn {
            let screen = egui_wgpu::ScreenDescriptor {
                size_in_pixels: size,
                pixels_per_point: *pixels_per_point,
            };
            extra =
                g.egui_renderer
                    .update_buffers(&g.device, &g.queue, &mut encoder, jobs, &screen);
            draw_panel(g, &mut encoder, jobs, &screen);
            g.panel.set_painted(jobs, *pixels_per_point, label_boxes);
        }
        encode_frame(g, &mut encoder, &view, &self.list, &self.camera, layer);
        // The last frame of a --frames run with --screenshot: the same passes again into
        // a texture that can be read back (a surface texture cannot, on every backend).
        let last = self.opts.frames.is_some_and(|n| self.frames + 1 >= n);
        let capture = match (&self.opts.screenshot, last) {
            (Some(_), true) if Capture::supports(g.config.format) => {
                let c = Capture::new(
                    &g.device,
                    g.config.format,
                    [g.config.width, g.config.height],
                );
                let capture_view = c
                    .texture
                    .create_view(&wgpu::TextureViewDescriptor::default());
                encode_frame(
                    g,
                    &mut encoder,
                    &capture_view,
                    &self.list,
                    &self.camera,
                    layer,
                );
                c.copy(&mut encoder);
                Some(c)
            }
            _ => None,
        };
        g.queue
            .submit(extra.into_iter().chain(std::iter::once(encoder.finish())));
        let t_submit = Instant::now();
        // The simulation's steps for the next frame, on their own thread while this
        // thread presents (the rasteriser finishing the frame, the surface's blit and the
        // copy to the window server). Wall time from the last advance to this one (a
        // skipped frame's time carries over). Nothing drawn depends on the world any more:
        // the draw list was uploaded at submit.
        let real_dt = self
            .last_advance
            .replace(t_submit)
            .map(|t| (t_submit - t).as_secs_f64())
            .unwrap_or(0.0);
        let session = &mut self.session;
        let compare = &mut self.compare;
        let (steps, sim_ms, read, t_present) = std::thread::scope(|scope| {
            let stepping = scope.spawn(move || {
                let t = Instant::now();
                let steps = session.advance(real_dt);
                if let Some(c) = compare.as_mut() {
                    c.follow(session, steps);
                }
                (steps, t.elapsed().as_secs_f64() * 1e3)
            });
            let read = capture.map(|c| c.read(&g.device));
            g.window.pre_present_notify();
            g.queue.present(texture);
            let t_present = Instant::now();
            // a panic in the step goes on here, as it would have on this thread
            let (steps, sim_ms) = stepping
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p));
            (steps, sim_ms, read, t_present)
        });
        let t_stepped = Instant::now();
        log::debug!(
            "frame {}: real dt {real_dt:.4} s, {steps} step(s), paused {}",
            self.frames,
            self.session.paused
        );
        self.sim_ms += sim_ms;
        match read {
            Some(Ok(img)) => self.screenshot = Some(img),
            Some(Err(e)) => {
                self.fail(event_loop, e);
                return;
            }
            None => {}
        }
        let Some(g) = self.gpu.as_mut() else { return };
        self.phase_since.1 += 1;
        for ((acc, since), d) in self.phase_ms.iter_mut().zip(&mut self.phase_since.0).zip([
            t_list - now,
            t_ui - t_list,
            t_acquire - t_ui,
            t_submit - t_acquire,
            t_present - t_submit,
            t_stepped - t_present,
        ]) {
            *acc += d.as_secs_f64() * 1e3;
            *since += d.as_secs_f64() * 1e3;
        }
        for id in &free {
            g.egui_renderer.free_texture(id);
        }

        // Frame timing.
        let presented = Instant::now();
        if let Some(prev) = self.last_frame {
            self.frame_ms.push((presented - prev).as_secs_f32() * 1e3);
        }
        self.first_frame.get_or_insert(presented);
        self.last_frame = Some(presented);
        self.recent.push_back(presented);
        while self
            .recent
            .front()
            .is_some_and(|t| (presented - *t).as_secs_f32() > 1.0)
        {
            self.recent.pop_front();
        }
        self.frames += 1;

        if actions.step {
            self.step_all();
        }
        if let Some(k) = actions.seek {
            self.seek_all(k);
        }
        if actions.add_pane {
            self.add_pane();
        }
        if let Some(c) = self.compare.as_mut() {
            let now = self.session.world.settings;
            if self.first_settings.is_some_and(|was| was != now) {
                let s = &self.session;
                let base = s.scene.world.solver.merged(s.cli_overrides).resolve();
                c.labels[0] = super::session::settings_label(&now, &base);
                // egui paints the labels: the next frame shows the new one
                self.panel_dirty = true;
                if let Some(g) = &self.gpu {
                    g.window.set_title(&self.title());
                }
            }
            self.first_settings = Some(now);
        }
        if actions.reset_camera {
            self.reset_camera();
            if let Some(g) = &self.gpu {
                g.window.set_title(&self.title());
            }
        }

        if self.opts.frames.is_some_and(|n| self.frames >= n) {
            if let Err(e) = self.save_screenshot() {
                self.fail(event_loop, e);
                return;
            }
            event_loop.exit();
            return;
        }
        if let Some(g) = &self.gpu {
            g.window.request_redraw();
        }
    }

    /// The panel's "add a pane" or "branch here" (B): a pane from the first pane's
    /// world as it is, with the panel's settings.
    fn add_pane(&mut self) {
        match Compare::add_pane(&mut self.compare, &mut self.session) {
            Ok(()) => {
                self.session.note = Some(format!("{} panes", self.panes()));
                // the panes share the width: frame the scene in the first again
                self.reset_camera();
                self.first_settings = None;
                if let Some(g) = &self.gpu {
                    g.window.set_title(&self.title());
                }
            }
            Err(e) => self.session.error = Some(format!("add a pane: {e}")),
        }
        self.panel_dirty = true;
    }

    /// S (and the panel's Step): every pane one step on, paused.
    fn step_all(&mut self) {
        self.session.paused = true;
        let stepped = u32::from(self.session.step_once());
        if let Some(c) = self.compare.as_mut() {
            c.follow(&self.session, stepped);
        }
        self.panel_dirty = true;
    }

    /// Puts every pane at step `k` of its timeline (paused), within what they all keep.
    fn seek_all(&mut self, k: u64) {
        let others = self.compare.as_ref().map_or(&[][..], |c| &c.others[..]);
        let Some((lo, hi)) = super::session::reachable(&self.session, others) else {
            return;
        };
        let k = k.clamp(lo, hi);
        self.session.seek(k);
        if let Some(c) = self.compare.as_mut() {
            c.seek(k);
        }
        self.panel_dirty = true;
    }

    /// Left / Right (shift: a second's steps) and Home / End: where the timeline goes.
    fn scrub(&mut self, by: i64) {
        let others = self.compare.as_ref().map_or(&[][..], |c| &c.others[..]);
        let Some((lo, hi)) = super::session::reachable(&self.session, others) else {
            if by > 0 {
                self.step_all();
            }
            return;
        };
        let now = self.session.world.step_count();
        if by > 0 && now >= hi {
            // at the newest step kept: a step on is a new step
            self.step_all();
            return;
        }
        let to = now.saturating_add_signed(by).clamp(lo, hi);
        if to != now || !self.session.paused {
            self.seek_all(to);
        }
    }

    /// Writes the last frame (world and panel, as the window showed it) to
    /// `--screenshot`, if given. On a surface format that cannot be read back as RGBA,
    /// the world alone (the same DrawList and camera, rendered off-screen).
    fn save_screenshot(&mut self) -> Result<(), AppError> {
        let (Some(path), Some(g)) = (self.opts.screenshot.clone(), self.gpu.as_ref()) else {
            return Ok(());
        };
        let image = match self.screenshot.take() {
            Some(image) => image,
            None => Renderer::with_samples(
                g.device.clone(),
                g.queue.clone(),
                crate::render::OFFSCREEN_FORMAT,
                g.renderer.sample_count(),
            )
            .render_to_image(&self.list, &self.camera)?,
        };
        save_png(&path, &image)?;
        self.screenshot_done = true;
        Ok(())
    }

    /// The world point under the cursor; with `--compare`, in the pane it is over (the
    /// same point in every pane's world).
    fn cursor_world(&self) -> Vec2 {
        let at = self.camera.screen_to_world(self.mouse.cursor);
        let n = self.panes();
        if n == 1 {
            return at;
        }
        let (left, pw) = self.pane_area();
        let k = (((self.mouse.cursor.x - left) / pw).floor().max(0.0) as usize).min(n - 1);
        at - self.pane_offset(k)
    }

    /// Spawns a body at `at` in every pane.
    fn spawn(&mut self, kind: SpawnKind, at: Vec2) {
        self.session.spawn(kind, at);
        if let Some(c) = self.compare.as_mut() {
            c.spawn(kind, at);
        }
    }

    fn mouse_button(&mut self, state: ElementState, button: MouseButton, egui_wants: bool) {
        let at = self.cursor_world();
        let pressed = state == ElementState::Pressed;
        if pressed && egui_wants {
            return;
        }
        let shift = self.mouse.modifiers.shift_key();
        let ctrl = self.mouse.modifiers.control_key();
        match (button, pressed) {
            (MouseButton::Left, true) if shift => self.spawn(SpawnKind::Circle, at),
            (MouseButton::Left, true) if ctrl => self.spawn(SpawnKind::Box, at),
            (MouseButton::Left, true) if !self.session.grab(at) => self.mouse.panning = true,
            (MouseButton::Left, true) => {
                if let Some(c) = self.compare.as_mut() {
                    c.grab(at);
                }
                self.selected = self.session.drag.map(|d| d.body);
            }
            (MouseButton::Left, false) => {
                self.session.drag = None;
                self.mouse.panning = false;
            }
            (MouseButton::Middle, true) => self.spawn(SpawnKind::Box, at),
            (MouseButton::Right, true) => {
                self.session.emitter = Some(Emitter {
                    center: at,
                    radius: EMITTER_RADIUS_PX / self.camera.pixels_per_meter,
                });
            }
            (MouseButton::Right, false) => self.session.emitter = None,
            _ => {}
        }
    }

    fn cursor_moved(&mut self, to: Vec2) {
        let delta = to - self.mouse.cursor;
        self.mouse.cursor = to;
        if self.mouse.panning {
            self.camera.pan_pixels(delta);
        }
        let at = self.cursor_world();
        if let Some(d) = self.session.drag.as_mut() {
            d.target = at;
        }
        if let Some(e) = self.session.emitter.as_mut() {
            e.center = at;
        }
        if self.session.ray.is_some() {
            self.session.aim_ray(at);
            self.panel_dirty = true;
        }
    }

    fn key(&mut self, key: &Key, event_loop: &ActiveEventLoop) {
        let ctrl = self.mouse.modifiers.control_key();
        let state_file = std::path::Path::new(super::session::STATE_FILE);
        match key {
            Key::Character(c) if ctrl && c.eq_ignore_ascii_case("s") => {
                self.session.save_state(state_file);
                self.panel_dirty = true;
            }
            Key::Character(c) if ctrl && c.eq_ignore_ascii_case("l") => {
                // with --compare: into every pane, each keeping its solver
                match self.compare.as_mut() {
                    Some(c) => c.load_state(&mut self.session, state_file),
                    None => self.session.load_state(state_file),
                }
                (self.follow, self.selected) = (None, None);
                self.panel_dirty = true;
            }
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Character(c) if c.eq_ignore_ascii_case("q") => event_loop.exit(),
            Key::Character(c) if c.eq_ignore_ascii_case("f") => {
                self.follow = None;
                self.fit_view();
            }
            Key::Character(c) if c.eq_ignore_ascii_case("c") => {
                // toggles following the body last grabbed
                self.follow = match self.follow {
                    Some(_) => None,
                    None => self.selected,
                };
            }
            Key::Named(NamedKey::Delete | NamedKey::Backspace) => {
                let at = self.cursor_world();
                if self.session.delete_at(at) {
                    if let Some(c) = self.compare.as_mut() {
                        c.delete_at(at);
                    }
                    // indices moved: forget the body followed or last grabbed
                    (self.follow, self.selected) = (None, None);
                    self.panel_dirty = true;
                }
            }
            Key::Named(NamedKey::Space) => {
                self.session.set_paused(!self.session.paused);
                self.panel_dirty = true;
            }
            Key::Character(c) if c.eq_ignore_ascii_case("s") => self.step_all(),
            Key::Named(k @ (NamedKey::ArrowLeft | NamedKey::ArrowRight)) => {
                let second = (1.0 / self.session.world.settings.dt).round().max(1.0) as i64;
                let n = if self.mouse.modifiers.shift_key() {
                    second
                } else {
                    1
                };
                self.scrub(if *k == NamedKey::ArrowLeft { -n } else { n });
            }
            Key::Named(NamedKey::Home) => self.scrub(i64::MIN / 2),
            Key::Named(NamedKey::End) => {
                let others = self.compare.as_ref().map_or(&[][..], |c| &c.others[..]);
                if let Some((_, hi)) = super::session::reachable(&self.session, others) {
                    self.seek_all(hi);
                }
            }
            Key::Character(c) if c.eq_ignore_ascii_case("b") => self.add_pane(),
            Key::Character(c) if c.eq_ignore_ascii_case("r") => {
                self.session.reset();
                if let Some(c) = self.compare.as_mut() {
                    c.reset();
                }
                (self.follow, self.selected) = (None, None);
                self.reset_camera();
            }
            Key::Character(c) if c.eq_ignore_ascii_case("v") => {
                self.session.overlays.tint = self.session.overlays.tint.next();
                self.panel_dirty = true;
            }
            Key::Character(c) if c.eq_ignore_ascii_case("t") => {
                // the ray tool: from the cursor now to wherever it goes
                self.session.toggle_ray(self.cursor_world());
                self.panel_dirty = true;
            }
            Key::Character(c) if c.eq_ignore_ascii_case("z") => {
                self.session.overlays.sleeping = !self.session.overlays.sleeping;
                self.panel_dirty = true;
            }
            Key::Character(c) if c.eq_ignore_ascii_case("h") => {
                let (left, pw) = self.pane_area();
                self.panel_visible = !self.panel_visible;
                self.panel_dirty = true;
                if self.panes() > 1 {
                    // the panes now share another width: keep the first pane's centre
                    // on its scene
                    let (left2, pw2) = self.pane_area();
                    let moved = (left2 + 0.5 * pw2) - (left + 0.5 * pw);
                    self.camera.center.x -= moved / self.camera.pixels_per_meter;
                }
            }
            _ => {}
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_some() {
            return;
        }
        if let Err(e) = self.create_gpu(event_loop) {
            self.fail(event_loop, e);
            return;
        }
        if let Some(g) = &self.gpu {
            g.window.request_redraw();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(g) = self.gpu.as_mut() else { return };
        let response = g.egui_state.on_window_event(&g.window, &event);
        let ctx = g.egui_state.egui_ctx();
        // egui runs only when the panel is due, so its own idea of where the pointer is
        // may be old: whether the pointer is over the panel comes from what the panel
        // painted last and the cursor now.
        let painted = g.panel.painted().filter(|_| self.panel_visible);
        let over = |p: Vec2| {
            painted.is_some_and(|[x0, y0, x1, y1]| {
                p.x >= x0 as f32 && p.x < x1 as f32 && p.y >= y0 as f32 && p.y < y1 as f32
            })
        };
        let before = self.mouse.cursor;
        let now = match &event {
            WindowEvent::CursorMoved { position, .. } => {
                Vec2::new(position.x as f32, position.y as f32)
            }
            _ => before,
        };
        let using = ctx.egui_is_using_pointer();
        let egui_pointer = response.consumed || using || over(now);
        let egui_keys = ctx.egui_wants_keyboard_input();
        // the pointer over the world (dragging bodies, panning) leaves the panel alone;
        // over it or leaving it (hover), the keys and a resize redraw it; a redraw
        // request (every frame) does not
        let for_panel = match &event {
            WindowEvent::CursorMoved { .. }
            | WindowEvent::MouseInput { .. }
            | WindowEvent::MouseWheel { .. }
            | WindowEvent::CursorLeft { .. }
            | WindowEvent::Touch(_) => using || over(before) || over(now),
            WindowEvent::KeyboardInput { .. }
            | WindowEvent::Ime(_)
            | WindowEvent::Resized(_)
            | WindowEvent::ScaleFactorChanged { .. }
            | WindowEvent::Focused(_)
            | WindowEvent::ThemeChanged(_) => true,
            _ => false,
        };
        if response.repaint && for_panel {
            self.panel_dirty = true;
            g.window.request_redraw();
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => self.resize(size.width, size.height),
            WindowEvent::RedrawRequested => self.frame(event_loop),
            WindowEvent::ModifiersChanged(m) => self.mouse.modifiers = m.state(),
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor_moved(Vec2::new(position.x as f32, position.y as f32))
            }
            WindowEvent::MouseInput { state, button, .. } => {
                self.mouse_button(state, button, egui_pointer)
            }
            WindowEvent::MouseWheel { delta, .. } if !egui_pointer => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 50.0,
                };
                self.camera
                    .zoom_about(self.mouse.cursor, 1.15f32.powf(lines));
            }
            WindowEvent::KeyboardInput { event, .. }
                if !egui_keys && event.state == ElementState::Pressed && !event.repeat =>
            {
                self.key(&event.logical_key, event_loop)
            }
            _ => {}
        }
    }
}
