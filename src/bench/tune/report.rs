//! What a tune reports: the Markdown and JSON reports, the SVG of cost against
//! error, and the winning setting as a `[solver]` table written into a scene file.

use super::*;

/// A measure's value for a table cell ("-" where it does not apply).
fn cell(m: &Measured, metric: Metric) -> String {
    let v = m.metric(metric);
    if !v.is_finite() {
        return "-".into();
    }
    match metric {
        Metric::PenetrationMax
        | Metric::PenetrationMean
        | Metric::JointError
        | Metric::Trajectory => {
            format!("{:.2} mm", v * 1e3)
        }
        Metric::Drift => format!("{v:.3} m"),
        Metric::EnergyDrift | Metric::Residual => format!("{v:.2e}"),
    }
}

/// A score for a table cell: normalised scores with two decimals, single measures
/// with three significant digits.
fn score_text(report: &TuneReport, score: f64) -> String {
    match report.options.metric {
        TuneMetric::Worst => format!("{score:.2}"),
        _ => format!("{score:.3e}"),
    }
}

/// The `[solver]` table that reproduces a setting (the scene's other `[solver]` keys
/// stay as they are).
pub fn solver_table(s: &Setting) -> String {
    let mut t = format!(
        "[solver]\nkind = \"{}\"\nsubsteps = {}\niterations = {}\n",
        s.kind.name(),
        s.substeps,
        s.iterations
    );
    if s.kind == SolverKind::Pgs {
        t.push_str(&format!(
            "warm_start = {}\nsplit_impulse = {}\ntolerance = 0.0\n",
            s.warm_start, s.split_impulse
        ));
    }
    t
}

/// The keys [`solver_table`] sets, as (key, value) pairs for an edit in place.
fn solver_values(s: &Setting) -> Vec<(&'static str, toml_edit::Value)> {
    let mut v: Vec<(&'static str, toml_edit::Value)> = vec![
        ("kind", s.kind.name().into()),
        ("substeps", i64::from(s.substeps).into()),
        ("iterations", i64::from(s.iterations).into()),
    ];
    if s.kind == SolverKind::Pgs {
        v.push(("warm_start", s.warm_start.into()));
        v.push(("split_impulse", s.split_impulse.into()));
        v.push(("tolerance", 0.0f64.into()));
    }
    v
}

/// The scene file's text with the setting written into its `[solver]` table (made if
/// missing), every other line, comment and key order kept. `soft_step` (the old
/// spelling of `kind`) is removed; PGS-only keys the winner does not set are left.
pub fn write_setting(text: &str, s: &Setting) -> Result<String, String> {
    let mut doc: toml_edit::DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| {
        e.to_string().lines().next().unwrap_or_default().to_string()
    })?;
    if !doc.contains_key("solver") {
        doc.insert("solver", toml_edit::Item::Table(toml_edit::Table::new()));
    }
    let table = doc["solver"]
        .as_table_like_mut()
        .ok_or("[solver] is not a table")?;
    table.remove("soft_step");
    for (key, value) in solver_values(s) {
        match table.get_mut(key) {
            // keep the key's place and its comments
            Some(item) if item.is_value() => {
                let decor = item.as_value().map(|v| v.decor().clone());
                let mut value = value;
                if let Some(d) = decor {
                    *value.decor_mut() = d;
                }
                *item = toml_edit::Item::Value(value);
            }
            _ => {
                table.insert(key, toml_edit::Item::Value(value));
            }
        }
    }
    Ok(doc.to_string())
}

/// The note beside a row: pick, cheapest close, on the front.
fn role(report: &TuneReport, i: usize) -> String {
    let mut r = Vec::new();
    if report.pick == Some(i) {
        r.push("**pick**");
    }
    if report.cheapest_close == Some(i) && report.pick != Some(i) {
        r.push("cheapest within 10%");
    }
    if report.pareto.contains(&i) {
        r.push("front");
    }
    if report.current == Some(i) {
        r.push("current");
    }
    r.join(", ")
}

/// What the score means, in one line.
pub fn metric_line(report: &TuneReport) -> String {
    match report.options.metric {
        TuneMetric::Worst if report.normalisers.is_empty() => {
            "no error measure applies to this scene (no contact, joint, resting body or closed energy): every stable setting scores 0, so the cheapest wins".into()
        }
        TuneMetric::Worst => format!(
            "score = max({}): each measure that applies to the scene divided by the best value a stable setting reached (at least its floor), and the worst of those; 1 = as right as the best setting on every measure, 3 = three times as wrong on one of them. A setting whose error is more than {} times the scene's current setting's on some measure (the error bound) is dropped",
            report
                .normalisers
                .iter()
                .map(|(m, n)| format!("{} / {}", m.name(), short_value(*m, *n)))
                .collect::<Vec<_>>()
                .join(", "),
            super::super::report::FAR
        ),
        TuneMetric::Trajectory => format!(
            "score = trajectory: the RMS distance of the bodies from their true places over the run (smaller is better), against the {}",
            report
                .truth
                .as_deref()
                .unwrap_or("true motion")
                .trim_start_matches("closed form: ")
                .trim_start_matches("reference run: ")
        ),
        m => format!(
            "score = {} (smaller is better). A setting whose error is more than {} times the scene's current setting's (the error bound) is dropped",
            m.name(),
            super::super::report::FAR
        ),
    }
}

fn short_value(m: Metric, v: f64) -> String {
    match m {
        Metric::PenetrationMax | Metric::PenetrationMean | Metric::JointError => {
            format!("{:.2} mm", v * 1e3)
        }
        Metric::Drift => format!("{v:.3} m"),
        Metric::Trajectory => format!("{:.2} mm", v * 1e3),
        _ => format!("{v:.1e}"),
    }
}

/// How many settings were tried and why each that is not the pick could not be: (kind,
/// count) for unstable, fell, error above the bound, over the budget, could not run,
/// not measured; kinds with none left out.
pub fn drop_counts(report: &TuneReport) -> Vec<(&'static str, usize)> {
    let mut c = [0usize; 6];
    for t in &report.tried {
        match t.reason {
            Some(DropReason::Unstable) => c[0] += 1,
            Some(DropReason::Fell) => c[1] += 1,
            Some(DropReason::FarAbove) => c[2] += 1,
            Some(DropReason::Failed) => c[4] += 1,
            Some(DropReason::Unmeasured) => c[5] += 1,
            None if t.score.is_some() && !(t.ms_per_step <= report.options.budget_ms) => c[3] += 1,
            None => {}
        }
    }
    [
        "unstable",
        "fell",
        "error above the bound",
        "over the budget",
        "could not run",
        "not measured",
    ]
    .into_iter()
    .zip(c)
    .filter(|&(_, n)| n > 0)
    .collect()
}

/// One line: of the settings tried, how many could not be picked and why.
fn dropped_line(report: &TuneReport) -> String {
    let counts = drop_counts(report);
    let n: usize = counts.iter().map(|c| c.1).sum();
    let total = report.tried.len();
    if n == 0 {
        return format!("Tried {total} settings; every one fits the budget and was a candidate.");
    }
    format!(
        "Tried {total} settings; {n} could not be picked: {}. Unstable: blew up or gained energy; fell: a pile meant to stand (some setting kept its top body within {RESTING_DRIFT} m) whose top body moved farther, as the bench's stack check; error above the bound: more than {} times the current setting's error (or the best, where the current setting is unstable) on some measure; over the budget: stable, but slower than {} ms/step.",
        counts
            .iter()
            .map(|(k, c)| format!("{c} {k}"))
            .collect::<Vec<_>>()
            .join(", "),
        super::super::report::FAR,
        report.options.budget_ms
    )
}

/// The scene's current setting as measured, or why it has no score.
fn current_text(report: &TuneReport) -> String {
    let Some(i) = report.current else {
        return "not measured".into();
    };
    let t = &report.tried[i];
    match (&t.dropped, t.score) {
        (Some(why), _) => format!(
            "{} ({:.4} ms/step; {why})",
            t.setting.label(),
            t.ms_per_step
        ),
        (None, Some(_)) if !(t.ms_per_step <= report.options.budget_ms) => {
            format!("{}, over the budget", summary(report, i))
        }
        _ => summary(report, i),
    }
}

/// Whether the pick is the scene's current setting, and if not how they compare.
fn verdict_text(report: &TuneReport, pick: usize) -> String {
    let p = &report.tried[pick];
    match report.current {
        Some(c) if c == pick => "the pick is the scene's current setting: keep it".into(),
        Some(c) => {
            let t = &report.tried[c];
            let score = match t.score {
                Some(v) => format!(
                    "score {} against the current {}",
                    p.score.map_or("-".into(), |s| score_text(report, s)),
                    score_text(report, v)
                ),
                None => "the current setting has no score".into(),
            };
            let close = match (p.score, t.score) {
                (Some(a), Some(b)) if b <= 1.1 * a && t.ms_per_step <= p.ms_per_step => {
                    "; the current setting is within 10% of the pick's score and no slower: keeping it costs little"
                }
                _ => "",
            };
            format!(
                "the pick differs from the scene's current setting: {score}, {:.4} against {:.4} ms/step{close}",
                p.ms_per_step, t.ms_per_step
            )
        }
        None => "the scene's current setting was not measured".into(),
    }
}

/// The one-line summary of a pick: label, cost and score.
fn summary(report: &TuneReport, i: usize) -> String {
    let t = &report.tried[i];
    format!(
        "{} ({:.4} ms/step, score {})",
        t.setting.label(),
        t.ms_per_step,
        t.score.map_or("-".into(), |s| score_text(report, s))
    )
}

/// The report as Markdown: the picks, the `[solver]` table, the Pareto front, every
/// setting tried and the dropped ones with their reasons.
pub fn markdown(report: &TuneReport) -> String {
    let o = &report.options;
    let mut s = format!(
        "# tune {}: budget {} ms/step, {} steps, metric {}\n\n{}.\n\n",
        report.scene,
        o.budget_ms,
        o.steps,
        o.metric.name(),
        metric_line(report)
    );
    if o.jobs > 1 {
        s.push_str(&format!(
            "Runs went {} at a time (`--jobs {}`): each timing was taken beside other runs \
             and reads high (about 10% on a 2-core machine), so the pick is cautious.\n\n",
            o.jobs, o.jobs
        ));
    }
    if let Some(sh) = &report.shards {
        s.push_str(&format!(
            "The grid's settings ran in {} shards (`--shard`{}) and were timed there; the \
             fine pass, and the rounds of the settings near the budget, ran in the merge. \
             Costs taken on different machines compare only as far as the machines are alike.\n\n",
            sh.count,
            sh.run
                .as_ref()
                .map_or(String::new(), |r| format!(", run {r}"))
        ));
    }
    s.push_str(&format!(
        "- the scene's current setting: {}\n",
        current_text(report)
    ));
    if let Some(p) = report.pick {
        s.push_str(&format!(
            "- most accurate within the budget: {}\n",
            summary(report, p)
        ));
        s.push_str(&format!("- {}\n", verdict_text(report, p)));
    }
    if let Some(c) = report.cheapest_close {
        s.push_str(&format!(
            "- cheapest within 10% of that accuracy: {}\n",
            summary(report, c)
        ));
    }
    if let Some(p) = report.pick {
        s.push_str(&format!(
            "\nTo use the pick, put this in the scene (or run `tune --write`):\n\n```toml\n{}```\n",
            solver_table(&report.tried[p].setting)
        ));
    }
    let header = "| setting | ms/step | score | penetration | drift | joint error | energy drift | residual | |\n|---|---|---|---|---|---|---|---|---|\n";
    let row = |i: usize| {
        let t = &report.tried[i];
        let m = t.measured();
        let c = |metric| match m {
            Some(m) if metric != Metric::EnergyDrift || report.applies.energy_drift => {
                cell(m, metric)
            }
            _ => "-".into(),
        };
        format!(
            "| {}{} | {:.4} | {} | {} | {} | {} | {} | {} | {} |\n",
            t.setting.label(),
            if t.pass == Pass::Fine { " (fine)" } else { "" },
            t.ms_per_step,
            t.score.map_or("-".into(), |v| score_text(report, v)),
            c(Metric::PenetrationMax),
            c(Metric::Drift),
            c(Metric::JointError),
            c(Metric::EnergyDrift),
            c(Metric::Residual),
            role(report, i)
        )
    };
    s.push_str("\n## The Pareto front (no other setting is both cheaper and more accurate)\n\n");
    s.push_str(header);
    for &i in &report.pareto {
        s.push_str(&row(i));
    }
    s.push_str("\n## Every setting tried\n\n");
    s.push_str(header);
    for i in 0..report.tried.len() {
        if report.tried[i].dropped.is_none() {
            s.push_str(&row(i));
        }
    }
    let dropped: Vec<&Tried> = report
        .tried
        .iter()
        .filter(|t| t.dropped.is_some())
        .collect();
    s.push_str(&format!("\n{}\n", dropped_line(report)));
    if !dropped.is_empty() {
        s.push_str("\n## Dropped (never picked)\n\n");
        for t in dropped {
            s.push_str(&format!(
                "- {}: {}\n",
                t.setting.label(),
                t.dropped.as_deref().unwrap_or_default()
            ));
        }
    }
    s
}

/// A setting as JSON.
fn setting_json(s: &Setting) -> serde_json::Value {
    serde_json::json!({
        "label": s.label(),
        "kind": s.kind.name(),
        "substeps": s.substeps,
        "iterations": s.iterations,
        "warm_start": s.warm_start,
        "split_impulse": s.split_impulse,
    })
}

/// The report as one JSON object (NaN measures as null).
pub fn json(report: &TuneReport) -> serde_json::Value {
    let num = |v: f64| {
        if v.is_finite() {
            serde_json::json!(v)
        } else {
            serde_json::Value::Null
        }
    };
    let tried: Vec<serde_json::Value> = report
        .tried
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let m = t.measured();
            let f = |metric| m.map_or(serde_json::Value::Null, |m| num(m.metric(metric)));
            serde_json::json!({
                "setting": setting_json(&t.setting),
                "pass": if t.pass == Pass::Fine { "fine" } else { "coarse" },
                "ms_per_step": num(t.ms_per_step),
                "timing_rounds": t.samples.len(),
                "score": t.score.map_or(serde_json::Value::Null, num),
                "penetration_max": f(Metric::PenetrationMax),
                "drift": f(Metric::Drift),
                "joint_error": f(Metric::JointError),
                "energy_drift": f(Metric::EnergyDrift),
                "residual": f(Metric::Residual),
                "dropped": t.dropped,
                "current": report.current == Some(i),
                "pareto": report.pareto.contains(&i),
            })
        })
        .collect();
    let at = |i: Option<usize>| {
        i.map_or(serde_json::Value::Null, |i| {
            let t = &report.tried[i];
            serde_json::json!({
                "setting": setting_json(&t.setting),
                "ms_per_step": num(t.ms_per_step),
                "score": t.score.map_or(serde_json::Value::Null, num),
            })
        })
    };
    serde_json::json!({
        "scene": report.scene,
        "budget_ms": report.options.budget_ms,
        "steps": report.options.steps,
        "rounds": report.options.rounds,
        "jobs": report.options.jobs,
        "metric": report.options.metric.name(),
        "truth": report.truth,
        "normalisers": report.normalisers.iter().map(|(m, n)| serde_json::json!({"measure": m.name(), "value": n})).collect::<Vec<_>>(),
        "current": at(report.current),
        "pick_is_current": report.pick.is_some() && report.pick == report.current,
        "pick": at(report.pick),
        "not_picked": drop_counts(report).into_iter().map(|(k, n)| (k.replace(' ', "_"), serde_json::json!(n))).collect::<serde_json::Map<String, serde_json::Value>>(),
        "cheapest_within_10_percent": at(report.cheapest_close),
        "solver_table": report.pick.map(|p| solver_table(&report.tried[p].setting)),
        "shards": report.shards.as_ref().map(|s| s.count),
        "run": report.shards.as_ref().and_then(|s| s.run.clone()),
        "tried": tried,
    })
}

/// The Pareto plot: every stable setting's score against its cost (log scales), the
/// front joined, the budget as a vertical line, the pick ringed.
pub fn svg(report: &TuneReport) -> Result<String, String> {
    use crate::bench::plot::{MARK_R, PixelBox, log_ticks, mark_box, place_labels, tick_label};
    use plotters::coord::combinators::BindKeyPoints;
    use plotters::prelude::*;
    let pts: Vec<(usize, f64, f64)> = report
        .tried
        .iter()
        .enumerate()
        .filter_map(|(i, t)| Some((i, t.ms_per_step, t.score?)))
        .filter(|p| p.1.is_finite() && p.1 > 0.0)
        .collect();
    let min_pos = pts
        .iter()
        .map(|p| p.2)
        .filter(|&v| v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let floor = if min_pos.is_finite() {
        min_pos / 10.0
    } else {
        1e-3
    };
    let y = |v: f64| v.max(floor);
    let x0 = pts
        .iter()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min)
        .min(report.options.budget_ms)
        / 1.5;
    let x1 = pts
        .iter()
        .map(|p| p.1)
        .fold(0.0f64, f64::max)
        .max(report.options.budget_ms)
        * 1.5;
    let y0 = pts.iter().map(|p| y(p.2)).fold(f64::INFINITY, f64::min) / 2.0;
    let y1 = (pts.iter().map(|p| y(p.2)).fold(0.0f64, f64::max) * 2.0).max(y0 * 10.0);
    let (x0, x1, y0, y1) = if pts.is_empty() {
        (1e-3, 1.0, 1e-3, 1.0)
    } else {
        (x0.max(1e-6), x1, y0, y1)
    };
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (820, 560)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "tune {}: {} against cost, budget {} ms/step",
                    report.scene,
                    report.options.metric.name(),
                    report.options.budget_ms
                ),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(log_ticks(x0, x1)),
                (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
            )
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("ms per step (median)")
            .y_desc(format!("score ({})", report.options.metric.name()))
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .light_line_style(WHITE)
            .draw()
            .map_err(|x| e(&x))?;
        let grey = RGBColor(150, 150, 150);
        chart
            .draw_series(
                pts.iter()
                    .map(|p| Circle::new((p.1, y(p.2)), 3, grey.filled())),
            )
            .map_err(|x| e(&x))?;
        let blue = RGBColor(31, 119, 180);
        let front: Vec<(f64, f64)> = report
            .pareto
            .iter()
            .filter_map(|&i| pts.iter().find(|p| p.0 == i))
            .map(|p| (p.1, y(p.2)))
            .collect();
        chart
            .draw_series(LineSeries::new(front.clone(), blue.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label("Pareto front")
            .legend(move |(x, yy)| PathElement::new(vec![(x, yy), (x + 20, yy)], blue));
        let front_pts: Vec<(usize, (i32, i32))> = report
            .pareto
            .iter()
            .filter_map(|&i| {
                let p = pts.iter().find(|p| p.0 == i)?;
                Some((i, chart.backend_coord(&(p.1, y(p.2)))))
            })
            .collect();
        chart
            .draw_series(report.pareto.iter().filter_map(|&i| {
                let p = pts.iter().find(|p| p.0 == i)?;
                Some(Circle::new((p.1, y(p.2)), 4, blue.filled()))
            }))
            .map_err(|x| e(&x))?;
        // the front's labels where they overlap nothing: the pick's first, then the
        // current setting's, then the rest cheapest first
        let mut order: Vec<usize> = (0..front_pts.len()).collect();
        order.sort_by_key(|&k| {
            let i = front_pts[k].0;
            (report.pick != Some(i), report.current != Some(i), k)
        });
        let at: Vec<(i32, i32)> = order.iter().map(|&k| front_pts[k].1).collect();
        let texts: Vec<String> = order
            .iter()
            .map(|&k| report.tried[front_pts[k].0].setting.label())
            .collect();
        let mut avoid: Vec<PixelBox> = pts
            .iter()
            .map(|p| mark_box(chart.backend_coord(&(p.1, y(p.2))), MARK_R))
            .collect();
        // the legend's corner (upper right)
        let (px, py) = chart.plotting_area().get_pixel_range();
        avoid.push(PixelBox {
            x: px.end - 190,
            y: py.start,
            w: 190,
            h: 130,
        });
        let area = PixelBox {
            x: px.start,
            y: py.start,
            w: px.end - px.start,
            h: py.end - py.start,
        };
        for (b, t) in place_labels(&at, &texts, 11, area, &avoid)
            .into_iter()
            .zip(&texts)
        {
            if let Some(b) = b {
                root.draw(&Text::new(t.clone(), (b.x, b.y), ("sans-serif", 11)))
                    .map_err(|x| e(&x))?;
            }
        }
        let red = RGBColor(214, 39, 40);
        let b = report.options.budget_ms;
        chart
            .draw_series(LineSeries::new(vec![(b, y0), (b, y1)], red))
            .map_err(|x| e(&x))?
            .label("budget")
            .legend(move |(x, yy)| PathElement::new(vec![(x, yy), (x + 20, yy)], red));
        if let Some(p) = report.pick.and_then(|i| pts.iter().find(|p| p.0 == i)) {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (p.1, y(p.2)),
                    8,
                    red.stroke_width(2),
                )))
                .map_err(|x| e(&x))?
                .label("pick")
                .legend(move |(x, yy)| Circle::new((x + 10, yy), 5, red.stroke_width(2)));
        }
        if let Some(p) = report.current.and_then(|i| pts.iter().find(|p| p.0 == i)) {
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at((p.1, y(p.2)))
                        + Rectangle::new([(-8, -8), (8, 8)], BLACK.stroke_width(2)),
                ))
                .map_err(|x| e(&x))?
                .label("current setting")
                .legend(move |(x, yy)| {
                    Rectangle::new([(x + 4, yy - 6), (x + 16, yy + 6)], BLACK.stroke_width(2))
                });
        }
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(|x| e(&x))?
            .label("other candidates")
            .legend(move |(x, yy)| Circle::new((x + 10, yy), 3, grey.filled()));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(text)
}
