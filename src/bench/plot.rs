//! One SVG per scene: the scene's error against ms per step, log scales, one curve per
//! solver family (points in order of sweeps or substeps). Unstable runs are drawn as
//! crosses; rows whose scene could not be built (n/a) are left out.

use plotters::prelude::*;

use super::{BenchScene, Family, Outcome, Row};

/// A family's colour.
fn color(f: Family) -> RGBColor {
    match f {
        Family::PgsWarmSplit => RGBColor(31, 119, 180),
        Family::PgsWarm => RGBColor(44, 160, 44),
        Family::PgsSplit => RGBColor(255, 127, 14),
        Family::PgsCold => RGBColor(148, 103, 189),
        Family::Xpbd => RGBColor(214, 39, 40),
        Family::Soft => RGBColor(23, 190, 207),
    }
}

/// One point: (ms per step, error, stable, count).
type Point = (f64, f64, bool, u32);

/// Each family's points for a scene.
type Series = Vec<(Family, Vec<Point>)>;

/// The points of each family for a scene, errors below `floor` lifted to it (a log
/// scale has no 0). `None` when no row of the scene ran.
pub fn series(scene: &BenchScene, rows: &[Row]) -> Option<(Series, f64)> {
    let mut out: Series = Vec::new();
    for fam in Family::ALL {
        let mut pts: Vec<Point> = rows
            .iter()
            .filter(|r| r.scene == scene.name && r.setting.family() == fam)
            .filter_map(|r| match &r.outcome {
                Outcome::Ran(m) if m.ms_per_step.is_finite() => {
                    let count = match r.setting.kind {
                        crate::defs::SolverKind::Pgs => r.setting.iterations,
                        crate::defs::SolverKind::Xpbd | crate::defs::SolverKind::Soft => {
                            r.setting.substeps
                        }
                    };
                    Some((
                        m.ms_per_step,
                        m.metric(scene.primary),
                        m.verdict.is_stable(),
                        count,
                    ))
                }
                _ => None,
            })
            .filter(|p| !p.1.is_nan())
            .collect();
        pts.sort_by_key(|p| p.3);
        if !pts.is_empty() {
            out.push((fam, pts));
        }
    }
    if out.is_empty() {
        return None;
    }
    let min_pos = out
        .iter()
        .flat_map(|(_, p)| p.iter().map(|q| q.1))
        .filter(|&e| e > 0.0 && e.is_finite())
        .fold(f64::INFINITY, f64::min);
    let floor = if min_pos.is_finite() {
        min_pos / 10.0
    } else {
        1e-9
    };
    for (_, pts) in &mut out {
        for p in pts.iter_mut() {
            if !(p.1 >= floor) || !p.1.is_finite() {
                p.1 = if p.1.is_infinite() { f64::MAX } else { floor };
            }
        }
    }
    Some((out, floor))
}

/// The SVG text of a scene's plot, or `None` when nothing ran.
pub fn svg(scene: &BenchScene, rows: &[Row]) -> Result<Option<String>, String> {
    let Some((series, floor)) = series(scene, rows) else {
        return Ok(None);
    };
    let all = || series.iter().flat_map(|(_, p)| p.iter());
    let (mut x0, mut x1) = all().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.0), hi.max(p.0))
    });
    let (mut y0, mut y1) = all().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.1), hi.max(p.1.min(1e30)))
    });
    x0 = (x0 / 1.5).max(1e-6);
    x1 = (x1 * 1.5).max(x0 * 10.0);
    y0 = (y0 / 2.0).max(floor / 2.0);
    y1 = (y1 * 2.0).max(y0 * 10.0);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (820, 560)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{}: {} against cost", scene.name, scene.primary.name()),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("ms per step (median)")
            .y_desc(scene.primary.axis_label())
            .x_labels(8)
            .x_label_formatter(&|v| short(*v))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|x| e(&x))?;
        for (fam, pts) in &series {
            let c = color(*fam);
            chart
                .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), c))
                .map_err(|x| e(&x))?
                .label(fam.name())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
            chart
                .draw_series(pts.iter().filter(|p| p.2).map(|p| {
                    EmptyElement::at((p.0, p.1))
                        + Circle::new((0, 0), 3, c.filled())
                        + Text::new(format!("{}", p.3), (5, -12), ("sans-serif", 11))
                }))
                .map_err(|x| e(&x))?;
            chart
                .draw_series(
                    pts.iter()
                        .filter(|p| !p.2)
                        .map(|p| Cross::new((p.0, p.1), 5, c.stroke_width(2))),
                )
                .map_err(|x| e(&x))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(Some(text))
}

/// A tick label with two or three significant digits.
pub(crate) fn short(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.1}")
    } else if v >= 0.01 {
        format!("{v:.2}")
    } else {
        format!("{v:.0e}")
    }
}
