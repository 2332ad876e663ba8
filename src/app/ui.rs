//! The egui side panel: scene picker, solver settings, run controls, overlay toggles,
//! live figures and a plot of the last seconds (drawn with egui's painter).

use egui::{Color32, Pos2, Rect, Sense, Stroke, Ui, Vec2 as EVec2};

use super::session::{HISTORY_SECONDS, Session};
use crate::defs::SolverKind;
use crate::scene;

/// What the panel asks the window to do after a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PanelActions {
    /// Reset the camera to the scene's (a new scene was loaded, or reset pressed).
    pub reset_camera: bool,
}

/// Frame-rate figures the window measures, shown in the panel.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameStats {
    /// Frames per second over the last second.
    pub fps: f32,
    /// Bodies drawn.
    pub bodies: usize,
}

/// Default panel width (points).
pub const PANEL_WIDTH: f32 = 260.0;

/// Draws the panel on the left of `ui`; returns what the window should do.
pub fn panel(ui: &mut Ui, s: &mut Session, frame: FrameStats) -> PanelActions {
    let mut actions = PanelActions::default();
    egui::Panel::left("sandbox2d_panel")
        .default_size(PANEL_WIDTH)
        .resizable(false)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                contents(ui, s, frame, &mut actions);
            });
        });
    actions
}

fn contents(ui: &mut Ui, s: &mut Session, frame: FrameStats, actions: &mut PanelActions) {
    ui.heading("sandbox2d");

    // Scene picker.
    let current = s.scene.name.clone();
    let mut pick: Option<&str> = None;
    egui::ComboBox::from_label("scene")
        .selected_text(&current)
        .show_ui(ui, |ui| {
            for name in scene::builtin_names() {
                if ui
                    .selectable_label(s.scene.source == format!("builtin:{name}"), *name)
                    .clicked()
                {
                    pick = Some(name);
                }
            }
        });
    if let Some(name) = pick {
        match s.load_scene(name) {
            Ok(()) => actions.reset_camera = true,
            Err(e) => s.error = Some(e),
        }
    }

    ui.horizontal(|ui| {
        let label = if s.paused { "Run" } else { "Pause" };
        if ui.button(label).on_hover_text("Space").clicked() {
            s.paused = !s.paused;
        }
        if ui.button("Step").on_hover_text("S").clicked() {
            s.paused = true;
            s.step_once();
        }
        if ui.button("Reset").on_hover_text("R").clicked() {
            s.reset();
            actions.reset_camera = true;
        }
    });
    if let Some(err) = &s.error {
        ui.colored_label(Color32::from_rgb(255, 110, 100), format!("error: {err}"));
    }

    ui.separator();
    ui.label(format!(
        "solver: {} (running)",
        s.world.settings.kind.label()
    ));
    let mut kind = s.settings.kind;
    ui.horizontal(|ui| {
        for k in SolverKind::ALL {
            ui.selectable_value(&mut kind, k, k.label());
        }
    });
    if kind != s.settings.kind {
        s.switch_solver(kind);
    }
    let before = s.settings;
    // only the running kind's own settings
    let keys = crate::defs::SolverSettings::keys(s.settings.kind);
    let has = |k: &str| keys.contains(&k);
    let st = &mut s.settings;
    let (it_label, it_max) = match st.kind {
        SolverKind::Soft => ("soft sweeps / substep", 8),
        SolverKind::Pgs => ("PGS sweeps", 100),
        SolverKind::Xpbd => ("XPBD iterations / substep", 8),
    };
    ui.add(egui::Slider::new(&mut st.iterations, 1..=it_max).text(it_label));
    ui.add(egui::Slider::new(&mut st.substeps, 1..=64).text("substeps"));
    if has("baumgarte") {
        ui.add(egui::Slider::new(&mut st.baumgarte, 0.0..=1.0).text("baumgarte"));
    }
    if has("slop") {
        ui.add(
            egui::Slider::new(&mut st.slop, 0.0..=0.05)
                .text("slop (m)")
                .max_decimals(4),
        );
    }
    if has("contact_hertz") {
        ui.add(egui::Slider::new(&mut st.contact_hertz, 1.0..=240.0).text("contact Hz"));
        ui.add(egui::Slider::new(&mut st.joint_hertz, 1.0..=240.0).text("joint Hz"));
        ui.add(
            egui::Slider::new(&mut st.joint_damping_ratio, 0.0..=20.0).text("joint damping ratio"),
        );
    }
    if has("warm_start") {
        ui.checkbox(&mut st.warm_start, "warm start");
    }
    if has("split_impulse") {
        ui.checkbox(&mut st.split_impulse, "split impulse");
    }
    if s.settings != before {
        s.apply_settings();
    }
    ui.add(
        egui::Slider::new(&mut s.time_scale, 0.05..=4.0)
            .logarithmic(true)
            .text("time scale"),
    );

    ui.separator();
    ui.label("overlays");
    ui.checkbox(&mut s.overlays.contacts, "contacts (normal ~ lambda)");
    ui.checkbox(&mut s.overlays.aabbs, "bounding boxes");
    ui.checkbox(&mut s.overlays.velocities, "velocities");

    ui.separator();
    stats(ui, s, frame);

    ui.separator();
    ui.collapsing("controls", |ui| {
        ui.small("left drag on a body: pull it (spring)");
        ui.small("left drag on empty space: pan");
        ui.small("wheel: zoom about the cursor");
        ui.small("right button held: push bodies away");
        ui.small("middle click / ctrl+click: spawn a box");
        ui.small("shift+click: spawn a circle");
        ui.small("space: pause, S: step, R: reset, H: hide this panel");
        ui.small("F: fit the view, C: follow the grabbed body, Esc / Q: quit");
    });
}

fn stats(ui: &mut Ui, s: &Session, frame: FrameStats) {
    let last = s.last().copied().unwrap_or_default();
    let n = s.history.len().max(1) as f32;
    let mean_ms = s.history.iter().map(|x| x.ms).fold(0.0f32, |a, b| a + b) / n;
    egui::Grid::new("sandbox2d_stats")
        .num_columns(2)
        .show(ui, |ui| {
            let mut row = |k: &str, v: String| {
                ui.label(k);
                ui.monospace(v);
                ui.end_row();
            };
            row("fps", format!("{:.0}", frame.fps));
            row("bodies", frame.bodies.to_string());
            row("sim time", format!("{:.2} s", s.world.time()));
            row("ms / step", format!("{:.3} (mean {mean_ms:.3})", last.ms));
            row("contacts", last.contacts.to_string());
            row("sweeps / step", last.iterations.to_string());
            row("residual", format!("{:.2e}", last.residual));
            row("penetration", format!("{:.4} m", last.penetration));
        });
    plot(
        ui,
        "ms / step",
        s.history.iter().map(|x| x.ms),
        Color32::from_rgb(90, 200, 255),
    );
    plot(
        ui,
        "deepest penetration (m)",
        s.history.iter().map(|x| x.penetration),
        Color32::from_rgb(255, 170, 80),
    );
}

/// A small line plot of `values` (oldest first) scaled from 0 to their maximum, under a
/// label with the maximum.
fn plot(ui: &mut Ui, label: &str, values: impl ExactSizeIterator<Item = f32>, color: Color32) {
    let width = ui.available_width().max(120.0);
    let n = values.len();
    let values: Vec<f32> = values.collect();
    let max = values.iter().copied().fold(0.0f32, f32::max);
    ui.small(format!(
        "{label}, last {HISTORY_SECONDS:.0} s (max {max:.3})"
    ));
    let (response, painter) = ui.allocate_painter(EVec2::new(width, 48.0), Sense::hover());
    let rect: Rect = response.rect;
    painter.rect_filled(rect, 2.0, Color32::from_gray(28));
    if n >= 2 && max > 0.0 {
        let points: Vec<Pos2> = values
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let x = rect.left() + rect.width() * i as f32 / (n - 1) as f32;
                let y = rect.bottom() - (rect.height() - 4.0) * (v / max).clamp(0.0, 1.0) - 2.0;
                Pos2::new(x, y)
            })
            .collect();
        painter.line(points, Stroke::new(1.5, color));
    }
}
