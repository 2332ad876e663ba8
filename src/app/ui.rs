//! The egui side panel: scene picker, run controls, and sections that fold (controls,
//! solver settings, timeline, overlays, live figures, plots of the last seconds drawn
//! with `egui_plot`, and the time of a step and a frame by part).

use egui::{Color32, Pos2, Rect, Sense, Ui, Vec2 as EVec2};

use super::session::{HISTORY_SECONDS, Sample, Session, reachable};
use crate::defs::SolverKind;
use crate::scene;

/// What the panel asks the window to do after a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PanelActions {
    /// Reset the camera to the scene's (a new scene was loaded, or reset pressed).
    pub reset_camera: bool,
    /// Add a pane with the panel's settings, from the world as it is (at an earlier
    /// step: branch there).
    pub add_pane: bool,
    /// Step every pane once (paused).
    pub step: bool,
    /// Put every pane at this step of its timeline.
    pub seek: Option<u64>,
}

/// Frame-rate figures the window measures, shown in the panel.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameStats {
    /// Frames per second over the last second.
    pub fps: f32,
    /// Bodies drawn.
    pub bodies: usize,
    /// A frame's phases (ms), the mean over recent frames, as [`FRAME_PHASES`] names them.
    pub phase_ms: [f32; 6],
}

/// The phases of a window frame and their colours, in the order they run: the draw
/// list, the panel (egui, when it is due), acquiring the surface, encoding and
/// submitting, present (the rasteriser's work included), and waiting for the
/// simulation's steps after it (they run on their own thread from submit on, beside
/// present, so only what is left of them after present shows here).
pub const FRAME_PHASES: [(&str, Color32); 6] = [
    ("draw list", Color32::from_rgb(80, 160, 255)),
    ("panel", Color32::from_rgb(230, 200, 70)),
    ("acquire", Color32::from_rgb(150, 150, 150)),
    ("encode", Color32::from_rgb(90, 210, 140)),
    ("present", Color32::from_rgb(210, 110, 230)),
    ("step wait", Color32::from_rgb(255, 150, 70)),
];

/// The time step slider's range (s): 1/1000 to 1/15.
pub const MIN_DT: f32 = 0.001;
pub const MAX_DT: f32 = 1.0 / 15.0;

/// The scene's name as the panel shows it: a built-in scene's id (`ball_and_chain`, as
/// `sandbox2d scenes` lists it and the command line takes it), or a file's name.
pub fn scene_label(source: &str) -> String {
    match source.strip_prefix("builtin:") {
        Some(id) => id.to_string(),
        None => std::path::Path::new(source)
            .file_name()
            .map_or_else(|| source.to_string(), |f| f.to_string_lossy().into_owned()),
    }
}

/// The panel's width (points), margins included. Fixed whatever the solver's settings
/// show, so that the panes right of it never move under it.
pub const PANEL_WIDTH: f32 = 300.0;

/// Draws the panel on the left of `ui`; returns what the window should do.
///
/// `others` are the panes after the first (`--compare`, or added from the panel): their
/// figures go into the same plots, a line per pane.
pub fn panel(ui: &mut Ui, s: &mut Session, others: &[Session], frame: FrameStats) -> PanelActions {
    let mut actions = PanelActions::default();
    egui::Panel::left("sandbox2d_panel")
        .exact_size(PANEL_WIDTH)
        .resizable(false)
        .show(ui, |ui| {
            // the scroll bar always shown: what is below the fold is there to scroll to
            egui::ScrollArea::vertical()
                .scroll_bar_visibility(egui::scroll_area::ScrollBarVisibility::AlwaysVisible)
                .show(ui, |ui| {
                    contents(ui, s, others, frame, &mut actions);
                });
        });
    actions
}

/// Each pane's line in the plots, left to right, when there is more than one pane.
const PANE_COLORS: [Color32; 4] = [
    Color32::from_rgb(90, 200, 255),
    Color32::from_rgb(255, 120, 90),
    Color32::from_rgb(140, 230, 120),
    Color32::from_rgb(230, 200, 70),
];

fn contents(
    ui: &mut Ui,
    s: &mut Session,
    others: &[Session],
    frame: FrameStats,
    actions: &mut PanelActions,
) {
    ui.heading("sandbox2d");
    // the keys first, folded, so that they never fall off the bottom of a short window
    egui::CollapsingHeader::new("controls")
        .default_open(false)
        .show(ui, |ui| {
            ui.small("left drag on a body: pull it (spring)");
            ui.small("left drag on empty space: pan");
            ui.small("wheel: zoom about the cursor");
            ui.small("right button held: push bodies away");
            ui.small("middle click / ctrl+click: spawn a box");
            ui.small("shift+click: spawn a circle");
            ui.small("Delete / Backspace: remove the body under the cursor");
            ui.small("T: ray tool on / off: a ray from the cursor to where it goes");
            ui.small("space: pause, S: step, R: reset, H: hide this panel");
            ui.small("F: fit the view, C: follow the grabbed body, Esc / Q: quit");
            ui.small("V: tint by speed, then by constraint error, then off");
            ui.small("Z: sleeping bodies dimmed or not");
            ui.small("ctrl+S: save the state to sandbox2d_state.json, ctrl+L: reload it");
            ui.small(
                "Left / Right: a step back / on, shift: a second; Home / End: oldest / newest kept",
            );
            ui.small("B: branch here: a pane from this step with the settings above");
        });

    // Scene picker: the names `sandbox2d scenes` lists and the command line takes, each
    // with its description on hover.
    let current = scene_label(&s.scene.source);
    let mut pick: Option<&str> = None;
    let picker = egui::ComboBox::from_label("scene")
        .selected_text(&current)
        .show_ui(ui, |ui| {
            for name in scene::builtin_names() {
                let item = ui.selectable_label(current == *name, *name);
                let item = match scene::builtin_description(name) {
                    Some(d) => item.on_hover_text(d),
                    None => item,
                };
                if item.clicked() {
                    pick = Some(name);
                }
            }
        });
    if let Some(d) = &s.scene.description {
        picker.response.on_hover_text(d.as_str());
    }
    if let Some(name) = pick {
        match s.load_scene(name) {
            Ok(()) => actions.reset_camera = true,
            Err(e) => s.error = Some(e),
        }
    }

    ui.horizontal(|ui| {
        let label = if s.paused { "Run" } else { "Pause" };
        if ui.button(label).on_hover_text("Space").clicked() {
            s.set_paused(!s.paused);
        }
        if ui.button("Step").on_hover_text("S").clicked() {
            actions.step = true;
        }
        if ui.button("Reset").on_hover_text("R").clicked() {
            s.reset();
            actions.reset_camera = true;
        }
    });
    if let Some(err) = &s.error {
        ui.colored_label(Color32::from_rgb(255, 110, 100), format!("error: {err}"));
    }
    if let Some(note) = &s.note {
        ui.small(note.as_str());
    }

    let state = if s.paused { "paused" } else { "running" };
    egui::CollapsingHeader::new(format!(
        "solver: {} ({state})",
        s.world.settings.kind.label()
    ))
    .id_salt("solver")
    .default_open(true)
    .show(ui, |ui| solver(ui, s, actions));

    egui::CollapsingHeader::new("timeline")
        .default_open(false)
        .show(ui, |ui| timeline(ui, s, others, actions));

    egui::CollapsingHeader::new("overlays")
        .default_open(false)
        .show(ui, |ui| overlays(ui, s));

    if let Some(text) = s.ray_text() {
        ui.separator();
        ui.label(text);
    }

    egui::CollapsingHeader::new("figures")
        .default_open(true)
        .show(ui, |ui| figures(ui, s, frame));
    egui::CollapsingHeader::new(format!("plots, last {HISTORY_SECONDS:.0} s"))
        .id_salt("plots")
        .default_open(true)
        .show(ui, |ui| plots(ui, s, others));
    egui::CollapsingHeader::new("time by stage and phase")
        .id_salt("stages")
        .default_open(false)
        .show(ui, |ui| {
            let last = s.last().copied().unwrap_or_default();
            profiler(ui, &last.stage_ms);
            stacked_bar(
                ui,
                "a frame by phase, recent mean",
                &FRAME_PHASES,
                &frame.phase_ms,
            );
        });
}

/// The solver section: the kind, its own settings, the time scale.
fn solver(ui: &mut Ui, s: &mut Session, actions: &mut PanelActions) {
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
        SolverKind::Soft => ("sweeps/substep", 8),
        SolverKind::Pgs => ("PGS sweeps", 100),
        SolverKind::Xpbd => ("iterations/substep", 8),
    };
    ui.add(egui::Slider::new(&mut st.iterations, 1..=it_max).text(it_label));
    ui.add(egui::Slider::new(&mut st.substeps, 1..=64).text("substeps"));
    ui.add(
        egui::Slider::new(&mut st.dt, MIN_DT..=MAX_DT)
            .logarithmic(true)
            .text("dt (s)")
            .custom_formatter(|v, _| format!("{v:.4} (1/{:.0})", 1.0 / v)),
    );
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
    if has("block_solve") {
        ui.checkbox(&mut st.block_solve, "block solve (2 points together)");
    }
    if has("sleep") {
        ui.checkbox(&mut st.sleep, "sleep (islands at rest)");
    }
    if s.settings != before {
        s.apply_settings();
    }
    if !s.viewing_past()
        && ui
            .button("add a pane with these settings")
            .on_hover_text(
                "a pane beside the others, going on from this world as it is now with the \
                 settings above (4 panes at most); set other settings here afterwards to \
                 compare them",
            )
            .clicked()
    {
        actions.add_pane = true;
    }
    ui.add(
        egui::Slider::new(&mut s.time_scale, 0.05..=4.0)
            .logarithmic(true)
            .text("time scale"),
    );
}

/// The overlays section.
fn overlays(ui: &mut Ui, s: &mut Session) {
    ui.checkbox(&mut s.overlays.contacts, "contacts (normal ~ lambda)");
    ui.checkbox(&mut s.overlays.aabbs, "bounding boxes");
    ui.checkbox(&mut s.overlays.velocities, "velocities");
    ui.checkbox(&mut s.overlays.sleeping, "sleeping bodies dimmed (Z)");
    ui.horizontal(|ui| {
        use crate::draw::Tint;
        ui.label("tint (V)");
        for (t, name) in [
            (Tint::Off, "off"),
            (Tint::Speed, "speed"),
            (Tint::Error, "error"),
        ] {
            ui.selectable_value(&mut s.overlays.tint, t, name);
        }
    });
}

/// The timeline: a scrubber over the steps every pane keeps, buttons to step back and
/// on, "branch here", and what the keyframes take in memory.
fn timeline(ui: &mut Ui, s: &Session, others: &[Session], actions: &mut PanelActions) {
    let now = s.world.step_count();
    let dt = f64::from(s.world.settings.dt);
    let t_now = s.world.time();
    let time_of = move |k: u64| t_now + (k as f64 - now as f64) * dt;
    match reachable(s, others) {
        Some((lo, hi)) => {
            ui.label(format!(
                "timeline: step {now} ({:.2} s) of {lo}..{hi}",
                t_now
            ));
            let mut k = now.clamp(lo, hi);
            let span = format!("{:.2} .. {:.2} s", time_of(lo), time_of(hi));
            let slider = ui.add_enabled(
                hi > lo,
                egui::Slider::new(&mut k, lo..=hi)
                    .show_value(false)
                    .text(span),
            );
            if slider.changed() && k != now {
                actions.seek = Some(k);
            }
            ui.horizontal(|ui| {
                let go = |ui: &mut Ui, text: &str, hover: &str, to: u64, on: bool| {
                    ui.add_enabled(on, egui::Button::new(text))
                        .on_hover_text(hover)
                        .clicked()
                        .then_some(to)
                };
                let back = now.saturating_sub(1).max(lo);
                let picked = [
                    go(ui, "|<", "Home: the oldest step kept", lo, now > lo),
                    go(ui, "<", "Left: a step back", back, now > lo),
                    go(ui, ">", "Right: a step on", now + 1, now < hi),
                    go(ui, ">|", "End: the newest step", hi, now < hi),
                ];
                if let Some(to) = picked.into_iter().flatten().next() {
                    actions.seek = Some(to);
                }
            });
            if s.viewing_past()
                && ui
                    .button("branch here with these settings")
                    .on_hover_text(
                        "B: a pane beside this one, going on from this step with the \
                         settings above; this pane keeps the settings it ran with",
                    )
                    .clicked()
            {
                actions.add_pane = true;
            }
        }
        None => {
            ui.label("timeline: nothing kept yet");
        }
    }
    let mut bytes = s.timeline.memory().0;
    for o in others {
        bytes += o.timeline.memory().0;
    }
    ui.small(s.timeline_text());
    if !others.is_empty() {
        ui.small(format!(
            "all {} panes: {} (each at most {})",
            others.len() + 1,
            crate::timeline::mib(bytes),
            crate::timeline::mib(super::session::TIMELINE_BYTES)
        ));
    }
}

/// The live figures of the last step.
fn figures(ui: &mut Ui, s: &Session, frame: FrameStats) {
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
            let asleep = s.world.bodies.iter().filter(|b| b.asleep).count();
            if asleep > 0 {
                row("asleep", asleep.to_string());
            }
            row("joints", s.world.joints.len().to_string());
            row("sim time", format!("{:.2} s", s.world.time()));
            row("ms / step", format!("{:.3} (mean {mean_ms:.3})", last.ms));
            row("contacts", last.contacts.to_string());
            // the soft step's constraint colours (what its threads split)
            let colors = s.world.stats().colors;
            if colors > 0 && last.contacts > 0 {
                row("colours", colors.to_string());
            }
            row("sweeps / step", last.iterations.to_string());
            row("residual", format!("{:.2e}", last.residual));
            row("penetration", format!("{:.4} m", last.penetration));
        });
}

/// The plots of the last seconds: one line per pane (this panel's pane first).
fn plots(ui: &mut Ui, s: &Session, others: &[Session]) {
    let panes: Vec<&Session> = std::iter::once(s).chain(others).collect();
    let now = s.world.time();
    // (seconds before now, value) of each pane's samples
    let series = |f: &dyn Fn(&Sample) -> Option<f64>| -> Vec<Vec<[f64; 2]>> {
        panes
            .iter()
            .map(|p| {
                p.history
                    .iter()
                    .filter_map(|x| Some([x.t - now, f(x)?]))
                    .collect()
            })
            .collect()
    };
    plot(
        ui,
        "ms / step",
        &series(&|x| Some(f64::from(x.ms))),
        Color32::from_rgb(90, 200, 255),
    );
    if panes.iter().any(|p| !p.world.joints.is_empty()) {
        plot(
            ui,
            "joint error (m)",
            &series(&|x| Some(f64::from(x.joint_error))),
            Color32::from_rgb(230, 200, 70),
        );
    }
    plot(
        ui,
        "|energy drift| (relative)",
        &series(&|x| Some(x.energy_drift.abs())),
        Color32::from_rgb(200, 120, 255),
    );
    plot(
        ui,
        "deepest penetration (m)",
        &series(&|x| Some(f64::from(x.penetration))),
        Color32::from_rgb(255, 170, 80),
    );
    let residual = series(&|x| x.mlcp_residual.map(f64::from));
    if residual.iter().any(|r| !r.is_empty()) {
        plot(
            ui,
            "residual vs converged MLCP (relative)",
            &residual,
            Color32::from_rgb(120, 230, 200),
        );
    }
}

/// The stages of a step and their colours, in pipeline order.
pub const STAGES: [(&str, Color32); 5] = [
    ("forces", Color32::from_rgb(150, 150, 150)),
    ("broad", Color32::from_rgb(80, 160, 255)),
    ("narrow", Color32::from_rgb(90, 210, 140)),
    ("solve", Color32::from_rgb(255, 150, 70)),
    ("integrate", Color32::from_rgb(210, 110, 230)),
];

/// The last step's time split by stage: a stacked bar and, under it, each stage's ms.
fn profiler(ui: &mut Ui, stage_ms: &[f32; 5]) {
    stacked_bar(ui, "last step by stage", &STAGES, stage_ms);
}

/// A stacked bar of `parts` (ms), titled with their total, and each part's ms under it.
fn stacked_bar<const N: usize>(
    ui: &mut Ui,
    title: &str,
    names: &[(&str, Color32); N],
    parts: &[f32; N],
) {
    let total: f32 = parts.iter().map(|v| v.max(0.0)).sum();
    ui.small(format!("{title} ({total:.3} ms)"));
    let width = ui.available_width().max(120.0);
    let (response, painter) = ui.allocate_painter(EVec2::new(width, 14.0), Sense::hover());
    let rect = response.rect;
    painter.rect_filled(rect, 2.0, Color32::from_gray(28));
    let mut x = rect.left();
    for ((_, color), share) in names.iter().zip(shares(parts)) {
        let w = rect.width() * share;
        painter.rect_filled(
            Rect::from_min_size(Pos2::new(x, rect.top()), EVec2::new(w, rect.height())),
            0.0,
            *color,
        );
        x += w;
    }
    ui.horizontal_wrapped(|ui| {
        for ((name, color), ms) in names.iter().zip(parts) {
            ui.colored_label(*color, format!("{name} {ms:.3}"));
        }
    });
}

/// Each part's share of the total (they sum to 1; all 0 when nothing was timed).
fn shares<const N: usize>(parts: &[f32; N]) -> [f32; N] {
    let total: f32 = parts.iter().map(|v| v.max(0.0)).sum();
    if total <= 0.0 || !total.is_finite() {
        return [0.0; N];
    }
    parts.map(|v| v.max(0.0) / total)
}

/// A line plot of each of `lines` (points of (seconds before now, value)) with axes:
/// one line in `color`, or with several (one per pane) each in its pane's colour, with
/// a legend. The y axis starts at 0; the title gives the latest value and the maximum.
fn plot(ui: &mut Ui, label: &str, lines: &[Vec<[f64; 2]>], color: Color32) {
    let max = lines.iter().flatten().map(|p| p[1]).fold(0.0f64, f64::max);
    let latest = lines.first().and_then(|l| l.last()).map_or(0.0, |p| p[1]);
    ui.label(format!("{label}: {latest:.3} (max {max:.3})"));
    let mut p = egui_plot::Plot::new(label)
        .height(100.0)
        .include_x(-HISTORY_SECONDS)
        .include_x(0.0)
        .include_y(0.0)
        .include_y(if max > 0.0 { max } else { 1e-3 })
        .allow_zoom(false)
        .allow_drag(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
        .allow_double_click_reset(false)
        .show_grid(true)
        // a label each second (s before now) and three or four on the y axis
        .custom_x_axes(vec![
            egui_plot::AxisHints::new_x()
                .label_spacing(30.0..=40.0)
                .formatter(|m, _| format!("{:.0} s", m.value)),
        ])
        // three or four labelled lines on the y axis, at a round step
        .y_grid_spacer(egui_plot::uniform_grid_spacer(|g| {
            let step = nice_step((g.bounds.1 - g.bounds.0) / 3.0);
            [step, 5.0 * step, 10.0 * step]
        }))
        .custom_y_axes(vec![
            egui_plot::AxisHints::new_y()
                .label_spacing(14.0..=20.0)
                .min_thickness(40.0)
                .formatter(|m, _| short_number(m.value)),
        ]);
    if lines.len() > 1 {
        p = p.legend(egui_plot::Legend::default().position(egui_plot::Corner::LeftTop));
    }
    p.show(ui, |pu| {
        for (k, points) in lines.iter().enumerate() {
            let (name, c) = if lines.len() == 1 {
                (label.to_string(), color)
            } else {
                (
                    format!("pane {}", k + 1),
                    PANE_COLORS[k % PANE_COLORS.len()],
                )
            };
            pu.line(
                egui_plot::Line::new(name, points.clone())
                    .color(c)
                    .width(1.5),
            );
        }
    });
}

/// The smallest of 1, 2 and 5 times a power of ten that is at least `x` (> 0).
fn nice_step(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&s| s >= x * (1.0 - 1e-9))
        .unwrap_or(10.0 * p)
}

/// A tick label in at most about five characters: 0, 0.25, 1.5e-3, 120.
fn short_number(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-2..1e4).contains(&a) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.chars().take(6).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_picker_names_a_scene_as_the_command_line_does() {
        assert_eq!(scene_label("builtin:ball_and_chain"), "ball_and_chain");
        assert_eq!(scene_label("/tmp/x/my scene.toml"), "my scene.toml");
        assert_eq!(scene_label("scenes/a.toml"), "a.toml");
        // every built-in scene loads under the name the picker shows
        for name in scene::builtin_names() {
            let sc = scene::load(name).unwrap();
            assert_eq!(scene_label(&sc.source), *name);
        }
    }

    #[test]
    fn the_profiler_bar_splits_the_step_by_stage() {
        let split = shares(&[0.0, 1.0, 1.0, 2.0, 0.0]);
        assert_eq!(split, [0.0, 0.25, 0.25, 0.5, 0.0]);
        // the frame's six phases the same way
        assert_eq!(
            shares(&[1.0, 0.0, 0.0, 1.0, 2.0, 0.0]),
            [0.25, 0.0, 0.0, 0.25, 0.5, 0.0]
        );
        assert_eq!(shares(&[0.0; 5]), [0.0; 5]);
        // a stage that measured nothing sane takes no width
        assert_eq!(
            shares(&[f32::NAN, 1.0, 0.0, 0.0, 0.0]),
            [0.0, 1.0, 0.0, 0.0, 0.0]
        );
    }

    #[test]
    fn plot_grid_steps_are_round() {
        assert!((nice_step(0.18) - 0.2).abs() < 1e-12, "0.18");
        assert!((nice_step(0.2) - 0.2).abs() < 1e-12, "0.2");
        assert!((nice_step(0.03) - 0.05).abs() < 1e-12, "0.03");
        assert!((nice_step(7.0) - 10.0).abs() < 1e-12, "7.0");
        assert!((nice_step(1.0) - 1.0).abs() < 1e-12, "1.0");
        assert!((nice_step(0.0) - 1.0).abs() < 1e-12, "0.0");
    }

    #[test]
    fn plot_tick_labels_are_short() {
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(0.25), "0.25");
        assert_eq!(short_number(120.0), "120");
        assert_eq!(short_number(0.1000001), "0.1");
        assert_eq!(short_number(0.004), "4e-3");
        assert_eq!(short_number(-0.5), "-0.5");
    }

    #[test]
    fn the_dt_slider_reaches_the_common_steps() {
        for hz in [15.0f32, 30.0, 60.0, 120.0, 240.0, 1000.0] {
            assert!((MIN_DT..=MAX_DT).contains(&(1.0 / hz)), "1/{hz}");
        }
    }
}
