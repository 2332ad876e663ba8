//! The bench's written results: `results.csv`, `results.md` (tables, the settings no
//! other setting dominates, the model comparisons).

use std::fmt::Write as _;

use super::scenes::MODEL_PAIRS;
use super::{BenchScene, Measured, Outcome, Row, Suite};
use crate::defs::SolverKind;

/// The columns of results.csv, in order.
pub const CSV_COLUMNS: &[&str] = &[
    "scene",
    "solver",
    "iterations",
    "substeps",
    "warm_start",
    "split_impulse",
    "tolerance",
    "ms_per_step",
    "ms_forces",
    "ms_broad",
    "ms_narrow",
    "ms_solve",
    "ms_integrate",
    "penetration_max",
    "penetration_mean",
    "drift",
    "joint_error",
    "energy_drift",
    "residual",
    "trajectory_rms",
    "trajectory_max",
    "angle_rms",
    "angle_max",
    "stable",
    "note",
];

/// A number for the CSV: empty when it does not apply (NaN).
fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.6e}")
    } else if x.is_nan() {
        String::new()
    } else {
        format!("{x}")
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The `stable` column: yes, no, or n/a with why.
pub fn stable_text(o: &Outcome) -> &'static str {
    match o {
        Outcome::Ran(m) if m.verdict.is_stable() => "yes",
        Outcome::Ran(_) => "no",
        Outcome::Failed(_) => "n/a (build failed)",
    }
}

fn note(o: &Outcome) -> String {
    match o {
        Outcome::Ran(m) => match &m.verdict {
            super::Verdict::Stable => String::new(),
            super::Verdict::Unstable(why) => why.clone(),
        },
        Outcome::Failed(why) => why.clone(),
    }
}

/// results.csv: one row per scene and setting.
pub fn csv(rows: &[Row]) -> String {
    let mut out = CSV_COLUMNS.join(",");
    out.push('\n');
    for r in rows {
        let s = &r.setting;
        let mut f = vec![
            csv_field(&r.scene),
            // "pgs", "xpbd", or "soft" (PGS's soft step)
            s.kind.name().to_string(),
            s.iterations.to_string(),
            s.substeps.to_string(),
            s.warm_start.to_string(),
            s.split_impulse.to_string(),
            s.tolerance.to_string(),
        ];
        match &r.outcome {
            Outcome::Ran(m) => {
                f.push(num(m.ms_per_step));
                f.extend(m.stage_ms.iter().map(|&x| num(x)));
                for x in [
                    m.penetration_max,
                    m.penetration_mean,
                    m.drift,
                    m.joint_error,
                    m.energy_drift,
                    m.residual,
                ] {
                    f.push(num(x));
                }
                let t = m.trajectory;
                for x in [
                    t.map(|t| t.pos_rms),
                    t.map(|t| t.pos_max),
                    t.map(|t| t.angle_rms),
                    t.map(|t| t.angle_max),
                ] {
                    f.push(num(x.unwrap_or(f64::NAN)));
                }
            }
            _ => f.extend(std::iter::repeat_n(String::new(), 16)),
        }
        f.push(stable_text(&r.outcome).to_string());
        f.push(csv_field(&note(&r.outcome)));
        out.push_str(&f.join(","));
        out.push('\n');
    }
    out
}

/// Whether `a` is at least as accurate as `b` on the scene's measures: stable when b
/// is, and no worse on each measure both have (a measure only b has counts against a).
fn at_least_as_accurate(scene: &BenchScene, a: &Measured, b: &Measured) -> bool {
    if b.verdict.is_stable() && !a.verdict.is_stable() {
        return false;
    }
    scene.metrics.iter().all(|&m| {
        let (x, y) = (a.metric(m), b.metric(m));
        match (x.is_nan(), y.is_nan()) {
            (true, true) => true,
            (true, false) => false,
            (false, true) => true,
            (false, false) => x <= y,
        }
    })
}

/// Step times closer than this fraction count as a tie (timing noise on a shared machine).
pub const COST_NOISE: f64 = 0.05;

/// Whether `a` is strictly more accurate than `b` on some measure of the scene.
fn more_accurate_somewhere(scene: &BenchScene, a: &Measured, b: &Measured) -> bool {
    (a.verdict.is_stable() && !b.verdict.is_stable())
        || scene.metrics.iter().any(|&m| a.metric(m) < b.metric(m))
}

/// `a` dominates `b`: at least as accurate, and cheaper (or within [`COST_NOISE`] of
/// b's cost and strictly more accurate on some measure).
pub fn dominates(scene: &BenchScene, a: &Measured, b: &Measured) -> bool {
    if !at_least_as_accurate(scene, a, b) {
        return false;
    }
    a.ms_per_step < b.ms_per_step
        || (a.ms_per_step <= b.ms_per_step * (1.0 + COST_NOISE)
            && more_accurate_somewhere(scene, a, b))
}

/// The rows of `scene` that ran and that no other row dominates, cheapest first. Only
/// stable rows compete when any row is stable (an unstable setting is no choice).
pub fn non_dominated<'a>(scene: &BenchScene, rows: &'a [Row]) -> Vec<&'a Row> {
    let mut ran: Vec<(&Row, &Measured)> = rows
        .iter()
        .filter(|r| r.scene == scene.name)
        .filter_map(|r| match &r.outcome {
            Outcome::Ran(m) => Some((r, m)),
            _ => None,
        })
        .collect();
    if ran.iter().any(|(_, m)| m.verdict.is_stable()) {
        ran.retain(|(_, m)| m.verdict.is_stable());
    }
    let mut front: Vec<(&Row, &Measured)> = ran
        .iter()
        .filter(|(_, b)| !ran.iter().any(|(_, a)| dominates(scene, a, b)))
        .copied()
        .collect();
    front.sort_by(|x, y| x.1.ms_per_step.total_cmp(&y.1.ms_per_step));
    front.into_iter().map(|(r, _)| r).collect()
}

fn sig(x: f64) -> String {
    if x.is_nan() {
        "".into()
    } else if x == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.2e}")
    }
}

/// A one-line summary of a row's accuracy, naming the scene's measures.
fn accuracy_line(scene: &BenchScene, m: &Measured) -> String {
    scene
        .metrics
        .iter()
        .filter(|&&k| !m.metric(k).is_nan())
        .map(|&k| format!("{} {}", k.name(), sig(m.metric(k))))
        .collect::<Vec<_>>()
        .join(", ")
}

/// results.md: per scene the table, the non-dominated settings and the plot; then the
/// model comparisons.
pub fn markdown(suite: Suite, scenes: &[BenchScene], rows: &[Row], plots: &[String]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Bench results: suite `{}`\n", suite.name());
    let _ = writeln!(
        s,
        "ms/step is the median over repeats of each repeat's median step time (the first step, \
         which builds the contact cache, and residual-sampled steps are not timed); stage \
         columns are median ms per step. penetration is the deepest overlap the narrow phase \
         sees (m); drift is how far the tracked body moved (m); energy drift is \
         (E_end - E_start) / |E_start| with the potential measured from the lowest point; \
         residual is ||lambda - lambda*|| / ||lambda*|| over sampled steps, lambda* the same \
         step's contact MLCP solved from the same state by PGS to tolerance 1e-8 (or its \
         sweep cap); stable means no NaN, energy rose by less than half its scale, and a \
         stack's tracked body moved less than 0.5 m. PGS rows of the grid run a fixed number \
         of sweeps (tolerance 0). A setting dominates another when it is at least as accurate on every measure of the \
         scene (and stable when the other is) and cheaper, or within 5% of its cost (timing \
         noise) and strictly more accurate on some measure. \
         n/a (build failed): the scene could not be built with that setting.\n"
    );
    for sc in scenes {
        let _ = writeln!(s, "## {}\n\n{}\n", sc.name, sc.about);
        // `--metric trajectory`: what the runs were compared with
        let traj = sc.truth.as_ref().is_some_and(|t| t.measures());
        match sc.truth.as_deref() {
            Some(super::truth::Truth::Unmeasured(why)) => {
                let _ = writeln!(s, "Trajectory error: not measured: {why}.\n");
            }
            Some(t) => {
                let _ = writeln!(s, "Trajectory error against the {}.\n", t.describe());
            }
            None => {}
        }
        if let Some(p) = plots
            .iter()
            .find(|p| p.starts_with(&format!("{}.svg", sc.name)))
        {
            let _ = writeln!(s, "![{} error against cost]({p})\n", sc.name);
        }
        let (head, rule) = if traj {
            (
                " traj. RMS (m) | traj. worst (m) | angle RMS (rad) |",
                "---|---|---|",
            )
        } else {
            ("", "")
        };
        let _ = writeln!(
            s,
            "| setting | ms/step | solve ms | pen. max | pen. mean | drift | joint err. | energy drift | residual |{head} stable |\n|---|---|---|---|---|---|---|---|---|{rule}---|"
        );
        for r in rows.iter().filter(|r| r.scene == sc.name) {
            match &r.outcome {
                Outcome::Ran(m) => {
                    let st = match &m.verdict {
                        super::Verdict::Stable => "yes".to_string(),
                        super::Verdict::Unstable(w) => format!("no: {w}"),
                    };
                    let t = if traj {
                        let f = |v: Option<f64>| format!(" {} |", sig(v.unwrap_or(f64::NAN)));
                        let e = m.trajectory;
                        f(e.map(|e| e.pos_rms))
                            + &f(e.map(|e| e.pos_max))
                            + &f(e.map(|e| e.angle_rms))
                    } else {
                        String::new()
                    };
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} | {} | {} | {} | {} | {} |{t} {} |",
                        r.setting.label(),
                        sig(m.ms_per_step),
                        sig(m.stage_ms[3]),
                        sig(m.penetration_max),
                        sig(m.penetration_mean),
                        sig(m.drift),
                        sig(m.joint_error),
                        sig(m.energy_drift),
                        sig(m.residual),
                        st
                    );
                }
                o => {
                    let _ = writeln!(
                        s,
                        "| {} | | | | | | | | |{} {} |",
                        r.setting.label(),
                        if traj { " | | |" } else { "" },
                        stable_text(o)
                    );
                }
            }
        }
        let front = non_dominated(sc, rows);
        if front.is_empty() {
            let _ = writeln!(s, "\nNot dominated: none ran.\n");
        } else {
            let _ = writeln!(
                s,
                "\nNot dominated (stable settings, cheapest first; nothing else is cheaper and at least as accurate):\n"
            );
            for r in front {
                if let Outcome::Ran(m) = &r.outcome {
                    let _ = writeln!(
                        s,
                        "- {}: {} ms/step; {}{}",
                        r.setting.label(),
                        sig(m.ms_per_step),
                        accuracy_line(sc, m),
                        if m.verdict.is_stable() {
                            ""
                        } else {
                            " (unstable)"
                        }
                    );
                }
            }
            let _ = writeln!(s);
        }
    }
    let pairs: Vec<_> = MODEL_PAIRS
        .iter()
        .filter(|(a, b, _)| {
            scenes.iter().any(|s| s.name == *a) && scenes.iter().any(|s| s.name == *b)
        })
        .collect();
    if !pairs.is_empty() {
        let _ = writeln!(
            s,
            "## Model only what a scene requires\n\nSolver defaults (PGS 10 sweeps, tolerance 1e-4). Median ms per step by stage.\n\n\
             | scene | solver | ms/step | forces | broad | narrow | solve | integrate |\n|---|---|---|---|---|---|---|---|"
        );
        for (a, b, what) in &pairs {
            for name in [a, b] {
                for r in rows
                    .iter()
                    .filter(|r| r.scene == **name && r.setting.kind == SolverKind::Pgs)
                {
                    if let Outcome::Ran(m) = &r.outcome {
                        let st = m.stage_ms;
                        let _ = writeln!(
                            s,
                            "| {} | {} | {} | {} | {} | {} | {} | {} |",
                            r.scene,
                            r.setting.label(),
                            sig(m.ms_per_step),
                            sig(st[0]),
                            sig(st[1]),
                            sig(st[2]),
                            sig(st[3]),
                            sig(st[4])
                        );
                    }
                }
            }
            if let (Some(x), Some(y)) = (pgs_ms(rows, a), pgs_ms(rows, b)) {
                let _ = writeln!(s, "| {what}: {a} / {b} = {:.2} | | | | | | | |", x / y);
            }
        }
        let _ = writeln!(s);
    }
    s
}

fn pgs_ms(rows: &[Row], scene: &str) -> Option<f64> {
    rows.iter()
        .filter(|r| r.scene == scene && r.setting.kind == SolverKind::Pgs)
        .find_map(|r| match &r.outcome {
            Outcome::Ran(m) => Some(m.ms_per_step),
            _ => None,
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::{Setting, Verdict, scenes};

    fn m(ms: f64, pen: f64, stable: bool) -> Measured {
        Measured {
            ms_per_step: ms,
            stage_ms: [0.0; 5],
            steps: 10,
            penetration_max: pen,
            penetration_mean: pen / 2.0,
            drift: f64::NAN,
            joint_error: f64::NAN,
            energy_drift: f64::NAN,
            residual: 0.5,
            trajectory: None,
            verdict: if stable {
                Verdict::Stable
            } else {
                Verdict::Unstable("fell".into())
            },
        }
    }

    fn sc() -> BenchScene {
        let mut s = scenes::suite(Suite::Quick).remove(0);
        s.metrics = vec![
            crate::bench::Metric::PenetrationMax,
            crate::bench::Metric::PenetrationMean,
        ];
        s
    }

    #[test]
    fn cheaper_and_as_accurate_dominates_and_nothing_else_does() {
        let s = sc();
        assert!(dominates(&s, &m(1.0, 0.01, true), &m(2.0, 0.01, true)));
        assert!(dominates(&s, &m(1.0, 0.005, true), &m(2.0, 0.01, true)));
        // cheaper but less accurate, or as accurate but not cheaper
        assert!(!dominates(&s, &m(1.0, 0.02, true), &m(2.0, 0.01, true)));
        assert!(!dominates(&s, &m(2.0, 0.01, true), &m(2.0, 0.01, true)));
        // within the timing noise, the more accurate one wins, and only it
        assert!(dominates(&s, &m(2.05, 0.005, true), &m(2.0, 0.01, true)));
        assert!(!dominates(&s, &m(2.0, 0.01, true), &m(2.05, 0.005, true)));
        assert!(!dominates(&s, &m(2.5, 0.005, true), &m(2.0, 0.01, true)));
        // an unstable run never dominates a stable one
        assert!(!dominates(&s, &m(1.0, 0.001, false), &m(2.0, 0.01, true)));
        // a measure only the other has counts against
        let mut a = m(1.0, 0.01, true);
        a.penetration_mean = f64::NAN;
        assert!(!dominates(&s, &a, &m(2.0, 0.01, true)));
    }

    #[test]
    fn the_front_keeps_the_stable_non_dominated_rows_cheapest_first() {
        let s = sc();
        let row = |n: u32, meas: Measured| Row {
            scene: s.name.clone(),
            setting: Setting::pgs(n, true, true),
            outcome: Outcome::Ran(meas),
        };
        let rows = vec![
            row(1, m(0.5, 0.3, false)),
            row(2, m(1.0, 0.02, true)),
            row(4, m(2.0, 0.03, true)),
            row(8, m(3.0, 0.01, true)),
        ];
        let front: Vec<u32> = non_dominated(&s, &rows)
            .iter()
            .map(|r| r.setting.iterations)
            .collect();
        assert_eq!(front, vec![2, 8]);
        let text = csv(&rows);
        assert_eq!(text.lines().count(), 5);
        assert_eq!(text.lines().next().unwrap(), CSV_COLUMNS.join(","));
        assert!(text.lines().nth(1).unwrap().contains(",no,fell"));
    }
}
