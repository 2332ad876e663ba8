//! One SVG per scene: the scene's error against ms per step, log scales, one curve per
//! solver family (points in order of sweeps or substeps), and a legend beside the plot
//! that says what each mark means. Rows whose scene could not be built (n/a) are left
//! out. [`log_ticks`] and [`place_labels`] serve `tune`'s plot too.

use plotters::coord::combinators::BindKeyPoints;
use plotters::prelude::*;

use super::report::{Judge, Standing};
use super::{BenchScene, Family, Outcome, Row, Setting};

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

/// How a point is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    /// A candidate (stable, within the scene's error bound): a filled dot.
    Candidate,
    /// Stable but above the scene's error bound: a hollow ring.
    Far,
    /// Unstable, or its stack fell: a cross.
    Fell,
}

/// One point: (ms per step, error, mark, count, the scene's own setting).
pub type Point = (f64, f64, Mark, u32, bool);

/// Each family's points for a scene.
type Series = Vec<(Family, Vec<Point>)>;

/// The points of each family for a scene, errors below `floor` lifted to it (a log
/// scale has no 0). `None` when no row of the scene ran.
pub fn series(scene: &BenchScene, rows: &[Row]) -> Option<(Series, f64)> {
    let judge = Judge::of(scene, rows);
    let own = Setting::of_scene(&scene.def);
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
                    let mark = match judge.standing(r) {
                        Standing::Candidate(_) => Mark::Candidate,
                        Standing::Far(_) => Mark::Far,
                        _ => Mark::Fell,
                    };
                    Some((
                        m.ms_per_step,
                        m.metric(scene.primary),
                        mark,
                        count,
                        r.setting == own,
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

/// Tick values of a log axis over `lo..hi`: the powers of ten, with 2 and 5 times them
/// when the range spans fewer than four decades, and with 1..9 times them when it spans
/// less than one (so every axis has several labelled ticks).
pub fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let decades = (hi / lo).log10();
    let steps: &[f64] = if decades < 1.0 {
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
    } else if decades < 4.0 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let mut k = lo.log10().floor() as i32;
    let mut v = Vec::new();
    while 10f64.powi(k) <= hi {
        for &m in steps {
            let t = m * 10f64.powi(k);
            if t >= lo && t <= hi {
                v.push(t);
            }
        }
        k += 1;
    }
    // very wide ranges: every other decade
    while v.len() > 12 {
        v = v.into_iter().step_by(2).collect();
    }
    v
}

/// A tick label: plain decimals from 0.001 to 9999 ("0.002", "0.5", "20"), else
/// "2e-5".
pub fn tick_label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if (1e-3..1e4).contains(&v.abs()) {
        let digits = (-(v.abs().log10().floor()) as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.0e}");
        s.replace("e-0", "e-")
    }
}

/// A box in pixels: the left, top, width and height.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelBox {
    pub x: i32,
    pub y: i32,
    pub w: i32,
    pub h: i32,
}

impl PixelBox {
    /// Whether the two boxes share any area.
    pub fn overlaps(&self, o: &PixelBox) -> bool {
        self.x < o.x + o.w && o.x < self.x + self.w && self.y < o.y + o.h && o.y < self.y + self.h
    }

    /// Whether this box lies wholly inside `o`.
    pub fn inside(&self, o: &PixelBox) -> bool {
        self.x >= o.x
            && self.y >= o.y
            && self.x + self.w <= o.x + o.w
            && self.y + self.h <= o.y + o.h
    }
}

/// The size in pixels a label of `text` takes at font size `size`: a generous 0.62 em a
/// character (sans-serif digits and lower case are narrower), one em and a bit high.
pub fn text_box(text: &str, size: i32) -> (i32, i32) {
    let w = (text.chars().count() as f64 * size as f64 * 0.62).ceil() as i32;
    (w, size + 2)
}

/// Places a label beside each point: at the first of eight places around it (right
/// above, right below, left above, left below, above, below, right, left) where it lies
/// inside `area` and overlaps neither a label placed before nor any box of `avoid` (the
/// marks, a legend). Points come in priority order; a label that fits nowhere is left
/// out (`None`), so no two labels ever overlap.
pub fn place_labels(
    points: &[(i32, i32)],
    texts: &[String],
    size: i32,
    area: PixelBox,
    avoid: &[PixelBox],
) -> Vec<Option<PixelBox>> {
    let mut placed: Vec<PixelBox> = Vec::new();
    points
        .iter()
        .zip(texts)
        .map(|(&(px, py), text)| {
            let (w, h) = text_box(text, size);
            // clear of the point's own mark
            let gap = MARK_R + 1;
            let spots = [
                (px + gap, py - gap - h),
                (px + gap, py + gap),
                (px - gap - w, py - gap - h),
                (px - gap - w, py + gap),
                (px - w / 2, py - gap - 2 - h),
                (px - w / 2, py + gap + 2),
                (px + gap + 2, py - h / 2),
                (px - gap - 2 - w, py - h / 2),
            ];
            let spot = spots
                .into_iter()
                .map(|(x, y)| PixelBox { x, y, w, h })
                .find(|b| {
                    b.inside(&area)
                        && !placed.iter().any(|p| p.overlaps(b))
                        && !avoid.iter().any(|p| p.overlaps(b))
                });
            if let Some(b) = spot {
                placed.push(b);
            }
            spot
        })
        .collect()
}

/// The box a mark of radius `r` takes around a point.
pub fn mark_box((x, y): (i32, i32), r: i32) -> PixelBox {
    PixelBox {
        x: x - r,
        y: y - r,
        w: 2 * r + 1,
        h: 2 * r + 1,
    }
}

/// Plot and legend sizes (pixels).
const WIDTH: u32 = 1000;
const HEIGHT: u32 = 600;
const LEGEND: u32 = 250;
const LABEL_SIZE: i32 = 11;
/// The half size of the box a mark takes (the own setting's square is 8 px out).
pub const MARK_R: i32 = 8;

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
        let root = SVGBackend::with_string(&mut text, (WIDTH, HEIGHT)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let (left, right) = root.split_horizontally(WIDTH - LEGEND);
        let mut chart = ChartBuilder::on(&left)
            .caption(
                format!("{}: {} against cost", scene.name, scene.primary.name()),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(log_ticks(x0, x1)),
                (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
            )
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("ms per step (median)")
            .y_desc(scene.primary.axis_label())
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .light_line_style(WHITE)
            .draw()
            .map_err(|x| e(&x))?;
        let mut marks = Vec::new();
        let mut labels = Vec::new();
        for (fam, pts) in &series {
            let c = color(*fam);
            chart
                .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), c.mix(0.6)))
                .map_err(|x| e(&x))?;
            for p in pts {
                let at = chart.backend_coord(&(p.0, p.1));
                marks.push(mark_box(at, MARK_R));
                labels.push((p.2, at, format!("{}", p.3)));
                let area = chart.plotting_area();
                let pt = EmptyElement::at((p.0, p.1));
                match p.2 {
                    Mark::Candidate => area.draw(&(pt + Circle::new((0, 0), 3, c.filled()))),
                    Mark::Far => area.draw(&(pt + Circle::new((0, 0), 4, c.stroke_width(1)))),
                    Mark::Fell => area.draw(&(pt + Cross::new((0, 0), 5, c.stroke_width(2)))),
                }
                .map_err(|x| e(&x))?;
                if p.4 {
                    chart
                        .plotting_area()
                        .draw(
                            &(EmptyElement::at((p.0, p.1))
                                + Rectangle::new([(-8, -8), (8, 8)], BLACK.stroke_width(2))),
                        )
                        .map_err(|x| e(&x))?;
                }
            }
        }
        // labels: the candidates' first, then the rest, each where it overlaps nothing
        labels.sort_by_key(|l| l.0 != Mark::Candidate);
        let (px, py) = chart.plotting_area().get_pixel_range();
        let area = PixelBox {
            x: px.start,
            y: py.start,
            w: px.end - px.start,
            h: py.end - py.start,
        };
        let at: Vec<(i32, i32)> = labels.iter().map(|l| l.1).collect();
        let texts: Vec<String> = labels.iter().map(|l| l.2.clone()).collect();
        for (b, t) in place_labels(&at, &texts, LABEL_SIZE, area, &marks)
            .into_iter()
            .zip(&texts)
        {
            if let Some(b) = b {
                root.draw(&Text::new(
                    t.clone(),
                    (b.x, b.y),
                    ("sans-serif", LABEL_SIZE)
                        .into_font()
                        .color(&RGBColor(60, 60, 60)),
                ))
                .map_err(|x| e(&x))?;
            }
        }
        let fams: Vec<Family> = series.iter().map(|(f, _)| *f).collect();
        legend(&right, &fams).map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(Some(text))
}

/// The legend beside the plot: each family's colour, then what the marks and the
/// numbers mean.
fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    fams: &[Family],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = ("sans-serif", 13).into_font();
    let x = 10;
    let mut y = 40;
    let grey = RGBColor(90, 90, 90);
    area.draw(&Text::new("solver (line colour)", (x, y), font.clone()))?;
    y += 22;
    for &f in fams {
        let c = color(f);
        area.draw(&PathElement::new(
            vec![(x, y + 7), (x + 24, y + 7)],
            c.stroke_width(3),
        ))?;
        area.draw(&Text::new(f.name(), (x + 32, y), font.clone()))?;
        y += 20;
    }
    y += 14;
    area.draw(&Text::new("marks", (x, y), font.clone()))?;
    y += 22;
    let rows: [(&str, u8); 4] = [
        ("stable: a candidate", 0),
        ("stable, above the bound", 1),
        ("unstable or fell (X)", 2),
        ("the scene's own setting", 3),
    ];
    for (what, k) in rows {
        let c = (x + 12, y + 7);
        match k {
            0 => area.draw(&Circle::new(c, 3, grey.filled()))?,
            1 => area.draw(&Circle::new(c, 4, grey.stroke_width(1)))?,
            2 => area.draw(&Cross::new(c, 5, grey.stroke_width(2)))?,
            _ => area.draw(&Rectangle::new(
                [(c.0 - 8, c.1 - 8), (c.0 + 8, c.1 + 8)],
                BLACK.stroke_width(2),
            ))?,
        }
        area.draw(&Text::new(what, (x + 32, y), font.clone()))?;
        y += 20;
    }
    let small = ("sans-serif", 12).into_font().color(&grey);
    y += 10;
    for line in [
        "Above the bound: more than 10",
        "times the error of the scene's",
        "own setting on some measure",
        "(not a candidate; results.md).",
        "",
        "Numbers beside the marks: PGS",
        "sweeps, or XPBD / soft step",
        "substeps (a label that would",
        "overlap another is left out).",
    ] {
        area.draw(&Text::new(line, (x, y), small.clone()))?;
        y += 16;
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axes_get_several_ticks_and_plain_labels() {
        // a narrow range (one decade or less) still gets several ticks
        let t = log_ticks(0.03, 0.2);
        assert!(t.len() >= 4, "{t:?}");
        assert!(t.iter().all(|&v| (0.03..=0.2).contains(&v)));
        // a wide one is thinned, never empty
        let t = log_ticks(1e-9, 1e3);
        assert!((3..=12).contains(&t.len()), "{t:?}");
        let t = log_ticks(0.01, 10.0);
        assert_eq!(t.len(), 10, "{t:?}"); // 1, 2, 5 in three decades, and 10
        assert_eq!(tick_label(0.002), "0.002");
        assert_eq!(tick_label(0.5), "0.5");
        assert_eq!(tick_label(20.0), "20");
        assert_eq!(tick_label(2e-5), "2e-5");
        assert_eq!(tick_label(3e5), "3e5");
    }

    #[test]
    fn placed_labels_never_overlap_each_other_or_the_marks_and_stay_inside() {
        let area = PixelBox {
            x: 0,
            y: 0,
            w: 400,
            h: 300,
        };
        // 30 points piled within a few pixels (as six solver families' 1-sweep points
        // are), and a lone one
        let mut pts: Vec<(i32, i32)> = (0..30).map(|i| (200 + i % 4, 150 + i % 3)).collect();
        pts.push((50, 250));
        let texts: Vec<String> = (0..pts.len()).map(|i| format!("{}", i * 7)).collect();
        let marks: Vec<PixelBox> = pts.iter().map(|&p| mark_box(p, MARK_R)).collect();
        let placed = place_labels(&pts, &texts, 11, area, &marks);
        let boxes: Vec<PixelBox> = placed.iter().flatten().copied().collect();
        assert!(boxes.len() >= 5, "only {} placed", boxes.len());
        assert!(boxes.len() < 30, "the pile cannot hold 30 labels");
        for (i, a) in boxes.iter().enumerate() {
            assert!(a.inside(&area), "{a:?}");
            for b in &boxes[i + 1..] {
                assert!(!a.overlaps(b), "{a:?} overlaps {b:?}");
            }
            for m in &marks {
                assert!(!a.overlaps(m), "{a:?} covers the mark {m:?}");
            }
        }
        // the lone point keeps its label, beside it
        let lone = placed[30].expect("a lone point is labelled");
        assert!(
            (lone.x - 50).abs() < 40 && (lone.y - 250).abs() < 30,
            "{lone:?}"
        );
        // a point at the area's edge is labelled on the side that fits
        let edge = place_labels(&[(398, 2)], &["32".into()], 11, area, &[]);
        assert!(edge[0].unwrap().inside(&area));
    }
}
