//! `bench --suite convergence`: each solver's empirical order of accuracy.
//!
//! Every scene here has a closed form ([`super::truth::Exact`]): a projectile with
//! linear drag, the pendulum at 90 degrees, a mass on a spring, and two contact scenes,
//! a disk rolling down a ramp and a box sliding to rest. Each solver runs each scene
//! for [`HORIZON`] seconds at dt = [`DT0`] (1/15 s), then halved [`LEVELS`] - 1 times (its
//! substeps and sweeps per step kept, so each halving doubles the work), and the error
//! is the worst distance of a body from its exact place at the times every level
//! shares (every DT0). If the error behaves as C dt^p, ln error against ln dt is a
//! line of slope p: [`fit`] takes the least-squares slope over the levels whose error
//! is well above what f32's rounding of the positions alone can add up to
//! ([`Level::rounding`]: below it, the rounding is what is measured, not the method).
//! p = 1 is first order (halving dt halves the error), p = 2 second order (a
//! quarter). The report gives each solver's order per scene, the slopes between
//! successive levels, and a plot (`convergence.svg`); `docs/accuracy.md` says what the
//! orders mean for the trade between speed and accuracy.

use crate::defs::{SolverKind, SolverOverrides, WorldDef};
use crate::scene;
use crate::world::World;

use super::truth::Exact;

/// The coarsest step (s).
pub const DT0: f64 = 1.0 / 15.0;
/// Steps tried: DT0, DT0/2, ... DT0/2^(LEVELS-1).
pub const LEVELS: usize = 7;
/// Seconds each run lasts.
pub const HORIZON: f64 = 2.0;
/// A level is fitted when its error is above this many times its
/// [`Level::rounding`].
pub const ROUNDING_MARGIN: f64 = 1.0;

/// A scene of the suite.
#[derive(Clone, Debug)]
pub struct ConvScene {
    pub name: &'static str,
    pub about: &'static str,
    pub def: WorldDef,
}

const PROJECTILE: &str = include_str!("../../assets/bench/projectile_drag.toml");
const PENDULUM: &str = include_str!("../../assets/bench/pendulum.toml");
const SPRING: &str = include_str!("../../assets/bench/spring.toml");
const ROLLING: &str = include_str!("../../assets/bench/rolling_disk.toml");
const SLIDING: &str = include_str!("../../assets/bench/sliding_box.toml");

/// The suite's scenes whose name contains `filter` (all without one).
pub fn scenes(filter: Option<&str>) -> Vec<ConvScene> {
    let all = [
        (
            "projectile_drag",
            "a ball thrown under gravity and linear drag (assets/bench/projectile_drag.toml)",
            PROJECTILE,
        ),
        (
            "pendulum",
            "a point mass on a rigid 2 m rod released horizontal (assets/bench/pendulum.toml)",
            PENDULUM,
        ),
        (
            "spring",
            "a mass on a spring, omega = 10 rad/s (assets/bench/spring.toml)",
            SPRING,
        ),
        (
            "rolling_disk",
            "contact: a disk rolling down a 20-degree ramp (assets/bench/rolling_disk.toml)",
            ROLLING,
        ),
        (
            "sliding_box",
            "contact: a box sliding to rest on friction (assets/bench/sliding_box.toml)",
            SLIDING,
        ),
    ];
    all.into_iter()
        .filter(|(name, _, _)| filter.is_none_or(|f| name.contains(f)))
        .map(|(name, about, text)| ConvScene {
            name,
            about,
            def: match scene::load_str(text, &format!("assets/bench/{name}.toml")) {
                Ok(s) => s.world,
                Err(e) => panic!("embedded convergence scene {name}: {e}"),
            },
        })
        .collect()
}

/// One run of a scene at one step.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// The step (s).
    pub dt: f64,
    /// The worst distance from the exact place over the shared times (m); NaN when the
    /// run failed.
    pub error: f64,
    /// The worst angle error at those times (rad).
    pub angle_error: f64,
    /// What f32's rounding alone can add up to (m): each update of a position (a
    /// step's or a substep's) rounds to half an f32 ulp of the largest coordinate the
    /// motion reaches, and each update of a velocity to half an ulp of the largest
    /// speed, which the rest of the run (on average half the horizon) turns into a
    /// distance. Over many small updates the roundings can fall the same way (x += v h
    /// with v nearly constant does), so they add up: updates x (ulp(x) + ulp(v) T / 2) / 2.
    pub rounding: f64,
    /// Why the run stopped early, if it did.
    pub failed: Option<String>,
}

/// A fitted order: the slope of ln error against ln dt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    pub order: f64,
    /// Levels fitted (those above [`ROUNDING_MARGIN`] times their rounding).
    pub used: usize,
    /// The worst distance of a fitted point from the line, in ln error (a straight
    /// line is 0; 0.1 is 10%).
    pub scatter: f64,
}

/// One solver on one scene: every level and the fit.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub scene: String,
    pub kind: SolverKind,
    /// The solver's settings other than dt, as a label.
    pub settings: String,
    /// The closed form compared with.
    pub exact: String,
    pub levels: Vec<Level>,
    pub fit: Option<Fit>,
}

/// Whether a level's error says something of the method (it is above its rounding).
pub fn fitted(l: &Level) -> bool {
    l.error.is_finite() && l.error > ROUNDING_MARGIN * l.rounding
}

/// The least-squares slope of ln error against ln dt over the levels [`fitted`];
/// `None` with fewer than 3 of them.
pub fn fit(levels: &[Level]) -> Option<Fit> {
    let pts: Vec<(f64, f64)> = levels
        .iter()
        .filter(|l| fitted(l))
        .map(|l| (l.dt.ln(), l.error.ln()))
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let order = sxy / sxx;
    let scatter = pts
        .iter()
        .map(|p| (p.1 - (my + order * (p.0 - mx))).abs())
        .fold(0.0, f64::max);
    Some(Fit {
        order,
        used: pts.len(),
        scatter,
    })
}

/// The slopes between successive levels (NaN where either is not [`fitted`]).
pub fn local_orders(levels: &[Level]) -> Vec<f64> {
    levels
        .windows(2)
        .map(|w| {
            if fitted(&w[0]) && fitted(&w[1]) {
                (w[0].error / w[1].error).ln() / (w[0].dt / w[1].dt).ln()
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// The settings a solver runs a scene with: the scene's `[solver]`, the solver's own
/// defaults for what it does not set, nothing asleep, and `dt`.
fn settings(def: &WorldDef, kind: SolverKind, dt: f64) -> crate::defs::SolverSettings {
    def.solver
        .merged(SolverOverrides {
            kind: Some(kind),
            dt: Some(dt as f32),
            sleep: Some(false),
            ..Default::default()
        })
        .resolve()
}

/// Runs `scene` under `kind` at every level.
pub fn run(scene: &ConvScene, kind: SolverKind) -> Result<Series, String> {
    let base = settings(&scene.def, kind, DT0);
    let label = format!("{} substeps x {} sweeps", base.substeps, base.iterations);
    let mut exact_text = String::new();
    let mut levels = Vec::with_capacity(LEVELS);
    for i in 0..LEVELS {
        let per = 1u64 << i;
        let dt = DT0 / per as f64;
        let mut w = World::from_def(&scene.def, settings(&scene.def, kind, dt))
            .map_err(|e| format!("{}: {e}", scene.name))?;
        let exact = Exact::of(&w, HORIZON).map_err(|e| format!("{}: {e}", scene.name))?;
        exact_text = exact.describe();
        let bodies = exact.bodies();
        let samples = (HORIZON / DT0).round() as u64;
        let (mut err, mut aerr) = (0.0f64, 0.0f64);
        let mut speed = 0.0f64;
        // the largest coordinate the motion reaches
        let mut reach = bodies
            .iter()
            .map(|&b| w.world_position_index(b).abs().max_element())
            .fold(0.0f64, f64::max);
        let mut failed = None;
        'run: for j in 1..=samples {
            for _ in 0..per {
                if let Err(e) = w.step() {
                    failed = Some(e.to_string());
                    break 'run;
                }
            }
            let t = j as f64 * DT0;
            for (k, &b) in bodies.iter().enumerate() {
                let want = exact.pose(k, t);
                reach = reach.max(want.p.abs().max_element());
                speed = speed.max(f64::from(w.bodies[b].velocity.abs().max_element()));
                err = err.max((w.world_position_index(b) - want.p).length());
                aerr = aerr.max((w.bodies[b].angle as f64 - want.angle).abs());
            }
        }
        let updates = (samples * per * u64::from(w.settings.substeps.max(1))) as f64;
        // an f32 ulp at x: 2^(exponent - 23)
        let ulp = |x: f64| {
            f64::from(f32::from_bits((x as f32).max(1e-3).to_bits() & 0x7f80_0000))
                * f64::from(f32::EPSILON)
        };
        levels.push(Level {
            dt,
            error: if failed.is_some() { f64::NAN } else { err },
            angle_error: if failed.is_some() { f64::NAN } else { aerr },
            rounding: updates * (ulp(reach) + ulp(speed) * HORIZON / 2.0) / 2.0,
            failed,
        });
    }
    let fit = fit(&levels);
    Ok(Series {
        scene: scene.name.to_string(),
        kind,
        settings: label,
        exact: exact_text,
        levels,
        fit,
    })
}

/// Every scene under every solver; `progress(done, total, what)` after each.
pub fn run_all(
    scenes: &[ConvScene],
    mut progress: impl FnMut(usize, usize, &str),
) -> Result<Vec<Series>, String> {
    let total = scenes.len() * SolverKind::ALL.len();
    let mut out = Vec::with_capacity(total);
    for sc in scenes {
        for kind in SolverKind::ALL {
            if crate::output::interrupted() {
                return Err("interrupted".into());
            }
            out.push(run(sc, kind)?);
            progress(out.len(), total, &format!("{} / {}", sc.name, kind.label()));
        }
    }
    Ok(out)
}

fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.6e}")
    } else {
        String::new()
    }
}

/// convergence.csv: one row per scene, solver and level.
pub fn csv(series: &[Series]) -> String {
    let mut s = String::from(
        "scene,solver,settings,dt,position_error,angle_error,rounding,fitted,order,note\n",
    );
    for x in series {
        let order = x.fit.map_or(String::new(), |f| format!("{:.4}", f.order));
        for l in &x.levels {
            s.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{}\n",
                x.scene,
                x.kind.name(),
                x.settings,
                num(l.dt),
                num(l.error),
                num(l.angle_error),
                num(l.rounding),
                fitted(l),
                order,
                l.failed.as_deref().unwrap_or("").replace(',', ";")
            ));
        }
    }
    s
}

/// An order for a table cell.
fn order_text(f: Option<Fit>) -> String {
    match f {
        Some(f) => format!("**{:.2}**", f.order),
        None => "-".into(),
    }
}

/// convergence.md: the orders by scene and solver, then each series' levels.
pub fn markdown(series: &[Series], command: &str) -> String {
    let mut s = format!(
        "# Order of accuracy\n\nEach solver at its own defaults (substeps and sweeps per step kept), dt = 1/{:.0} s halved {} times, {HORIZON} s per run; the error is the worst distance of a body from its exact place at the times every level shares (every 1/{:.0} s). The order is the least-squares slope of ln error against ln dt over the levels whose error is above what f32's rounding alone can add up to there (each position update half an ulp of the largest coordinate, each velocity update half an ulp of the largest speed times half the horizon; the levels left out are in brackets). Produced by `{command}`; `docs/accuracy.md` says what the orders mean.\n\n",
        1.0 / DT0,
        LEVELS - 1,
        1.0 / DT0
    );
    let mut names: Vec<&str> = series.iter().map(|x| x.scene.as_str()).collect();
    names.dedup();
    s.push_str("| scene |");
    for k in SolverKind::ALL {
        s.push_str(&format!(" {} |", k.label()));
    }
    s.push_str("\n|---|");
    for _ in SolverKind::ALL {
        s.push_str("---|");
    }
    s.push('\n');
    for name in &names {
        s.push_str(&format!("| {name} |"));
        for k in SolverKind::ALL {
            let f = series
                .iter()
                .find(|x| x.scene == *name && x.kind == k)
                .and_then(|x| x.fit);
            s.push_str(&format!(" {} |", order_text(f)));
        }
        s.push('\n');
    }
    s.push_str("\n![error against dt](convergence.svg)\n");
    for name in &names {
        let first = series.iter().find(|x| x.scene == *name);
        s.push_str(&format!(
            "\n## {name}\n\n{}.\n\n| solver | settings | order | fitted levels | scatter | errors (m) from dt = 1/{:.0} s down | slopes between levels |\n|---|---|---|---|---|---|---|\n",
            first.map_or("", |x| x.exact.as_str()),
            1.0 / DT0
        ));
        for x in series.iter().filter(|x| x.scene == *name) {
            let errs: Vec<String> = x
                .levels
                .iter()
                .map(|l| match &l.failed {
                    Some(_) => "failed".into(),
                    None if fitted(l) => format!("{:.2e}", l.error),
                    None => format!("({:.2e})", l.error),
                })
                .collect();
            let slopes: Vec<String> = local_orders(&x.levels)
                .iter()
                .map(|p| {
                    if p.is_finite() {
                        format!("{p:.2}")
                    } else {
                        "-".into()
                    }
                })
                .collect();
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} |\n",
                x.kind.label(),
                x.settings,
                order_text(x.fit),
                x.fit.map_or("-".into(), |f| f.used.to_string()),
                x.fit.map_or("-".into(), |f| format!("{:.2}", f.scatter)),
                errs.join(", "),
                slopes.join(", ")
            ));
        }
    }
    s
}

/// A solver's colour on the plot.
fn color(k: SolverKind) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match k {
        SolverKind::Soft => RGBColor(23, 190, 207),
        SolverKind::Pgs => RGBColor(31, 119, 180),
        SolverKind::Xpbd => RGBColor(214, 39, 40),
    }
}

/// convergence.svg: one panel per scene, error against dt on log-log axes, a line per
/// solver (its order in the legend), and grey guides of slope 1 and 2.
pub fn svg(series: &[Series]) -> Result<String, String> {
    use plotters::prelude::*;
    let mut names: Vec<&str> = series.iter().map(|x| x.scene.as_str()).collect();
    names.dedup();
    let cols = 3usize.min(names.len().max(1));
    let rows = names.len().div_ceil(cols).max(1);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (420 * cols as u32, 360 * rows as u32))
            .into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let panels = root.split_evenly((rows, cols));
        for (name, area) in names.iter().zip(panels.iter()) {
            let of: Vec<&Series> = series.iter().filter(|x| x.scene == *name).collect();
            let pts = || {
                of.iter()
                    .flat_map(|x| x.levels.iter())
                    .filter(|l| l.error.is_finite() && l.error > 0.0)
            };
            let x0 = pts().map(|l| l.dt).fold(f64::INFINITY, f64::min) / 1.5;
            let x1 = pts().map(|l| l.dt).fold(0.0f64, f64::max) * 1.5;
            let y0 = pts().map(|l| l.error).fold(f64::INFINITY, f64::min) / 3.0;
            let y1 = pts().map(|l| l.error).fold(0.0f64, f64::max) * 3.0;
            if !(x0.is_finite() && y0.is_finite() && x1 > x0 && y1 > y0) {
                continue;
            }
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{name}: error against dt"), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(58)
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                .map_err(|x| e(&x))?;
            chart
                .configure_mesh()
                .x_desc("dt (s)")
                .y_desc("worst position error (m)")
                .x_label_formatter(&|v| format!("{v:.0e}"))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(|x| e(&x))?;
            // guides through the top-right corner's first point: slopes 1 and 2
            let top = of
                .iter()
                .filter_map(|x| x.levels.first())
                .filter(|l| l.error.is_finite())
                .map(|l| l.error)
                .fold(0.0f64, f64::max);
            if top > 0.0 {
                for (p, label) in [(1.0, "slope 1"), (2.0, "slope 2")] {
                    // from the coarsest dt down to where it leaves the panel
                    let y_top = top * 1.3;
                    let x_end = x0.max(DT0 * (y0 / y_top).powf(1.0 / p));
                    let line: Vec<(f64, f64)> = [DT0, x_end]
                        .iter()
                        .map(|&dt| (dt, y_top * (dt / DT0).powf(p)))
                        .collect();
                    let grey = RGBColor(170, 170, 170);
                    chart
                        .draw_series(LineSeries::new(line.clone(), grey.stroke_width(1)))
                        .map_err(|x| e(&x))?;
                    if let Some(&(x, y)) = line.last() {
                        chart
                            .draw_series(std::iter::once(Text::new(
                                label.to_string(),
                                (x, y),
                                ("sans-serif", 11).into_font().color(&grey),
                            )))
                            .map_err(|x| e(&x))?;
                    }
                }
            }
            for x in &of {
                let c = color(x.kind);
                let line: Vec<(f64, f64)> = x
                    .levels
                    .iter()
                    .filter(|l| l.error.is_finite() && l.error > 0.0)
                    .map(|l| (l.dt, l.error.max(y0)))
                    .collect();
                let legend = match x.fit {
                    Some(f) => format!("{}: order {:.2}", x.kind.label(), f.order),
                    None => format!("{}: no fit", x.kind.label()),
                };
                chart
                    .draw_series(LineSeries::new(line.clone(), c.stroke_width(2)))
                    .map_err(|x| e(&x))?
                    .label(legend)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                    });
                // fitted levels filled, the ones left out (at f32's rounding) hollow
                chart
                    .draw_series(
                        x.levels
                            .iter()
                            .filter(|l| l.error.is_finite() && l.error > 0.0)
                            .map(|l| {
                                let style = if fitted(l) {
                                    c.filled()
                                } else {
                                    c.stroke_width(1)
                                };
                                Circle::new((l.dt, l.error.max(y0)), 3, style)
                            }),
                    )
                    .map_err(|x| e(&x))?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .draw()
                .map_err(|x| e(&x))?;
        }
        root.present().map_err(|x| e(&x))?;
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_recovers_a_known_slope_and_leaves_out_the_floor() {
        let levels: Vec<Level> = (0..LEVELS)
            .map(|i| {
                let dt = DT0 / (1u64 << i) as f64;
                Level {
                    dt,
                    // order 2 down to the rounding, then rounding noise under it
                    error: (3.0 * dt * dt).max(1e-4),
                    angle_error: 0.0,
                    rounding: 1e-4,
                    failed: None,
                }
            })
            .collect();
        let f = fit(&levels).unwrap();
        assert!((f.order - 2.0).abs() < 1e-9, "{f:?}");
        assert!(f.used < LEVELS, "the points under the floor are left out");
        assert!(f.scatter < 1e-9);
        let l = local_orders(&levels);
        assert!((l[0] - 2.0).abs() < 1e-9);
        assert!(fit(&levels[..2]).is_none(), "two points are no fit");
    }

    #[test]
    fn every_scene_of_the_suite_has_its_closed_form() {
        for sc in scenes(None) {
            let w = World::from_def(&sc.def, settings(&sc.def, SolverKind::Soft, DT0)).unwrap();
            let e = Exact::of(&w, HORIZON).unwrap_or_else(|e| panic!("{}: {e}", sc.name));
            assert!(!e.bodies().is_empty(), "{}", sc.name);
        }
    }
}
