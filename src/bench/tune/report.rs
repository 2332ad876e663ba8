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
    r.join(", ")
}

/// What the score means, in one line.
pub fn metric_line(report: &TuneReport) -> String {
    match report.options.metric {
        TuneMetric::Worst if report.normalisers.is_empty() => {
            "no error measure applies to this scene (no contact, joint, resting body or closed energy): every stable setting scores 0, so the cheapest wins".into()
        }
        TuneMetric::Worst => format!(
            "score = the worst of {} (1 = as right as the best setting on every measure)",
            report
                .normalisers
                .iter()
                .map(|(m, n)| format!("{} / {}", m.name(), short_value(*m, *n)))
                .collect::<Vec<_>>()
                .join(", ")
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
        m => format!("score = {} (smaller is better)", m.name()),
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
    if let Some(p) = report.pick {
        s.push_str(&format!(
            "- most accurate within the budget: {}\n",
            summary(report, p)
        ));
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
        "pick": at(report.pick),
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
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("ms per step (median)")
            .y_desc(format!("score ({})", report.options.metric.name()))
            .x_labels(8)
            .x_label_formatter(&|v| crate::bench::plot::short(*v))
            .y_label_formatter(&|v| format!("{v:.1e}"))
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
        chart
            .draw_series(report.pareto.iter().filter_map(|&i| {
                let p = pts.iter().find(|p| p.0 == i)?;
                Some(
                    EmptyElement::at((p.1, y(p.2)))
                        + Circle::new((0, 0), 4, blue.filled())
                        + Text::new(
                            report.tried[i].setting.label(),
                            (6, -12),
                            ("sans-serif", 11),
                        ),
                )
            }))
            .map_err(|x| e(&x))?;
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
