//! The bench's written results: `results.csv`, `results.md` (tables, the settings no
//! other setting dominates, the model comparisons).

use std::fmt::Write as _;

use super::scenes::MODEL_PAIRS;
use super::{BenchScene, Measured, Metric, Outcome, Row, Setting, Suite};

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

/// The scene's error bound is this many times the error of its own setting on each
/// measure: a setting whose error is above it on some measure is far above what the
/// scene asks for, and no candidate.
pub const FAR: f64 = 10.0;

/// The budgets of the picks, as multiples of the time of the scene's own setting.
pub const PICK_BUDGETS: [f64; 3] = [0.5, 1.0, 2.0];

/// The measured rows of a scene (those that ran).
fn ran<'a>(scene: &BenchScene, rows: &'a [Row]) -> Vec<(&'a Row, &'a Measured)> {
    rows.iter()
        .filter(|r| r.scene == scene.name)
        .filter_map(|r| match &r.outcome {
            Outcome::Ran(m) => Some((r, m)),
            _ => None,
        })
        .collect()
}

/// What the score divides by: each of the scene's measures with the best value a stable
/// row reached, lifted to its floor ([`super::tune::floor`]: below it an error counts
/// as none). A measure no stable row has is left out.
pub fn normalisers(scene: &BenchScene, rows: &[Row]) -> Vec<(Metric, f64)> {
    scene
        .metrics
        .iter()
        .filter_map(|&k| {
            let best = ran(scene, rows)
                .into_iter()
                .filter(|(_, m)| m.verdict.is_stable())
                .map(|(_, m)| m.metric(k))
                .filter(|v| v.is_finite())
                .fold(f64::INFINITY, f64::min);
            best.is_finite()
                .then(|| (k, best.max(super::tune::floor(k))))
        })
        .collect()
}

/// A row's score, as `tune` scores: the worst of its measures, each divided by its
/// normaliser (1 = as right as the best row on every measure).
pub fn score(norms: &[(Metric, f64)], m: &Measured) -> f64 {
    norms
        .iter()
        .map(|&(k, n)| m.metric(k) / n)
        .fold(0.0f64, |a, v| if v.is_nan() { a } else { a.max(v) })
}

/// The scene's error bound on each of its measures: [`FAR`] times the value its own
/// setting reached (lifted to the measure's floor), or, when its own setting did not
/// run stably, [`FAR`] times the best value a stable setting reached. The second value
/// says which (true: the own setting's).
pub fn bounds(scene: &BenchScene, rows: &[Row]) -> (Vec<(Metric, f64)>, bool) {
    let own = match own_row(scene, rows).map(|r| &r.outcome) {
        Some(Outcome::Ran(m)) if m.verdict.is_stable() => Some(m),
        _ => None,
    };
    let Some(own) = own else {
        let b = normalisers(scene, rows)
            .into_iter()
            .map(|(k, n)| (k, FAR * n))
            .collect();
        return (b, false);
    };
    let b = scene
        .metrics
        .iter()
        .map(|&k| (k, own.metric(k)))
        .filter(|(_, v)| v.is_finite())
        .map(|(k, v)| (k, FAR * v.max(super::tune::floor(k))))
        .collect();
    (b, true)
}

/// The first measure on which `m` is above its bound, with its value.
pub fn above_bound(bounds: &[(Metric, f64)], m: &Measured) -> Option<(Metric, f64)> {
    bounds
        .iter()
        .map(|&(k, b)| (k, m.metric(k), b))
        .find(|&(_, v, b)| v > b)
        .map(|(k, v, _)| (k, v))
}

/// Where a row stands for the picks and the front.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Standing {
    /// Stable and within the scene's error bound: its score.
    Candidate(f64),
    /// Went unstable, or its stack fell.
    Unstable,
    /// Stable, but above the scene's error bound on some measure: its score.
    Far(f64),
    /// Could not be built.
    NotRun,
}

/// How a scene's rows are judged: the score's normalisers and the error bounds.
#[derive(Clone, Debug)]
pub struct Judge {
    pub norms: Vec<(Metric, f64)>,
    pub bounds: Vec<(Metric, f64)>,
    /// Whether the bounds come from the scene's own setting (else from the best).
    pub own_bounds: bool,
}

impl Judge {
    pub fn of(scene: &BenchScene, rows: &[Row]) -> Judge {
        let (bounds, own_bounds) = bounds(scene, rows);
        Judge {
            norms: normalisers(scene, rows),
            bounds,
            own_bounds,
        }
    }

    /// Where `row` stands among its scene's rows.
    pub fn standing(&self, row: &Row) -> Standing {
        match &row.outcome {
            Outcome::Failed(_) => Standing::NotRun,
            Outcome::Ran(m) if !m.verdict.is_stable() => Standing::Unstable,
            Outcome::Ran(m) => {
                let s = score(&self.norms, m);
                if above_bound(&self.bounds, m).is_some() {
                    Standing::Far(s)
                } else {
                    Standing::Candidate(s)
                }
            }
        }
    }
}

/// The candidate rows of a scene with their scores and figures, in row order.
fn candidates<'a>(scene: &BenchScene, rows: &'a [Row]) -> Vec<(&'a Row, &'a Measured, f64)> {
    let judge = Judge::of(scene, rows);
    ran(scene, rows)
        .into_iter()
        .filter_map(|(r, m)| match judge.standing(r) {
            Standing::Candidate(s) => Some((r, m, s)),
            _ => None,
        })
        .collect()
}

/// The candidate rows of `scene` (stable, within its error bound) that no other
/// candidate dominates, cheapest first.
pub fn non_dominated<'a>(scene: &BenchScene, rows: &'a [Row]) -> Vec<&'a Row> {
    let cands = candidates(scene, rows);
    let mut front: Vec<(&Row, &Measured)> = cands
        .iter()
        .filter(|(_, b, _)| !cands.iter().any(|(_, a, _)| dominates(scene, a, b)))
        .map(|&(r, m, _)| (r, m))
        .collect();
    front.sort_by(|x, y| x.1.ms_per_step.total_cmp(&y.1.ms_per_step));
    front.into_iter().map(|(r, _)| r).collect()
}

/// Whether two rows measured the same on every measure of the scene (a mode that never
/// acts here, such as split impulse on a stack that never overlaps deeply).
fn same_figures(scene: &BenchScene, a: &Measured, b: &Measured) -> bool {
    scene
        .metrics
        .iter()
        .all(|&k| a.metric(k).to_bits() == b.metric(k).to_bits())
}

/// The row of the scene's own setting ([`Setting::of_scene`]), when it ran.
pub fn own_row<'a>(scene: &BenchScene, rows: &'a [Row]) -> Option<&'a Row> {
    let own = Setting::of_scene(&scene.def);
    rows.iter()
        .find(|r| r.scene == scene.name && r.setting == own)
}

/// One pick: the budget (ms/step) and the candidate with the lowest score within it
/// (ties: the cheaper, then the earlier), with its score; `None` when no candidate fits.
#[derive(Clone, Copy, Debug)]
pub struct Pick<'a> {
    /// The budget as a multiple of the scene's own setting's time.
    pub factor: f64,
    pub budget_ms: f64,
    pub pick: Option<(&'a Row, f64)>,
}

/// The picks at [`PICK_BUDGETS`] times the time of the scene's own setting, as `tune`
/// picks: the lowest score among the candidates within the budget. Empty when the
/// scene's own setting did not run stably (its time is then no measure).
pub fn picks<'a>(scene: &BenchScene, rows: &'a [Row]) -> Vec<Pick<'a>> {
    let Some(Outcome::Ran(own)) = own_row(scene, rows).map(|r| &r.outcome) else {
        return Vec::new();
    };
    if !own.verdict.is_stable() || !own.ms_per_step.is_finite() {
        return Vec::new();
    }
    let cands = candidates(scene, rows);
    PICK_BUDGETS
        .iter()
        .map(|&factor| {
            let budget_ms = factor * own.ms_per_step;
            let pick = cands
                .iter()
                .enumerate()
                .filter(|(_, (_, m, _))| m.ms_per_step <= budget_ms)
                .min_by(|(i, (_, a, sa)), (j, (_, b, sb))| {
                    sa.total_cmp(sb)
                        .then(a.ms_per_step.total_cmp(&b.ms_per_step))
                        .then(i.cmp(j))
                })
                .map(|(_, &(r, _, s))| (r, s));
            Pick {
                factor,
                budget_ms,
                pick,
            }
        })
        .collect()
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
    let _ = writeln!(
        s,
        "**score** is `tune`'s: each of the scene's measures divided by the best value a stable \
         setting reached (at least its floor: 0.1 mm of overlap or joint separation, 1 mm of \
         drift, 1e-4 of energy), and the worst of those; 1 = as right as the best setting on \
         every measure, 3 = three times as wrong on one of them. **The error bound** of a \
         scene is {FAR} times the error its own setting reaches on each measure (its \
         `[solver]` table; the soft step's defaults unless it says otherwise), each at least \
         {FAR} times the floor. A **candidate** is a stable setting within the bound on every \
         measure: a setting above it is far less accurate than the scene asks for, and never \
         a pick (its score is marked \"far\"). **What to pick**: the candidate with the \
         lowest score within {} times the time of the scene's own setting, as `tune \
         --budget-ms` picks. **The front**: the candidates no other candidate dominates.\n",
        PICK_BUDGETS
            .iter()
            .map(|f| format!("{f}"))
            .collect::<Vec<_>>()
            .join(", ")
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
            "| setting | ms/step | solve ms | pen. max | pen. mean | drift | joint err. | energy drift | residual |{head} score | stable |\n|---|---|---|---|---|---|---|---|---|{rule}---|---|"
        );
        let judge = Judge::of(sc, rows);
        let own = Setting::of_scene(&sc.def);
        for r in rows.iter().filter(|r| r.scene == sc.name) {
            let mine = if r.setting == own { " (own)" } else { "" };
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
                    let score = match judge.standing(r) {
                        Standing::Candidate(v) => format!("{v:.2}"),
                        Standing::Far(v) => format!("{v:.2} (far)"),
                        _ => String::new(),
                    };
                    let _ = writeln!(
                        s,
                        "| {}{mine} | {} | {} | {} | {} | {} | {} | {} | {} |{t} {score} | {} |",
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
                        "| {}{mine} | | | | | | | | |{} | {} |",
                        r.setting.label(),
                        if traj { " | | |" } else { "" },
                        stable_text(o)
                    );
                }
            }
        }
        scene_picks(&mut s, sc, rows);
    }
    model_section(&mut s, scenes, rows);
    s
}

/// The tally of a scene's rows by [`Standing`]: (candidates, unstable, far, not run).
fn tally(scene: &BenchScene, rows: &[Row]) -> (usize, usize, usize, usize) {
    let judge = Judge::of(scene, rows);
    let mut t = (0, 0, 0, 0);
    for r in rows.iter().filter(|r| r.scene == scene.name) {
        match judge.standing(r) {
            Standing::Candidate(_) => t.0 += 1,
            Standing::Unstable => t.1 += 1,
            Standing::Far(_) => t.2 += 1,
            Standing::NotRun => t.3 += 1,
        }
    }
    t
}

/// A row in a pick line: label, cost, score and measures.
fn pick_text(scene: &BenchScene, r: &Row, score: f64) -> String {
    match &r.outcome {
        Outcome::Ran(m) => format!(
            "{}: {} ms/step, score {:.2}; {}",
            r.setting.label(),
            sig(m.ms_per_step),
            score,
            accuracy_line(scene, m)
        ),
        o => format!("{}: {}", r.setting.label(), stable_text(o)),
    }
}

/// A scene's "what to pick": its own setting, the picks per budget, the candidates'
/// tally and the front.
fn scene_picks(s: &mut String, sc: &BenchScene, rows: &[Row]) {
    let judge = Judge::of(sc, rows);
    let norms = &judge.norms;
    let _ = writeln!(s, "\n**What to pick**\n");
    match own_row(sc, rows) {
        Some(r) => {
            let st = match judge.standing(r) {
                Standing::Candidate(v) => pick_text(sc, r, v),
                Standing::Far(v) => pick_text(sc, r, v),
                Standing::Unstable => format!(
                    "{}: unstable or fell here, so no budget is drawn from its time",
                    r.setting.label()
                ),
                Standing::NotRun => format!("{}: could not run", r.setting.label()),
            };
            let _ = writeln!(s, "- the scene's own setting: {st}");
        }
        None => {
            let _ = writeln!(s, "- the scene's own setting did not run");
        }
    }
    let own = own_row(sc, rows).map(|r| r.setting);
    for p in picks(sc, rows) {
        let what = match p.pick {
            Some((r, _)) if Some(r.setting) == own => {
                format!("the scene's own setting, {}", r.setting.label())
            }
            Some((r, v)) => pick_text(sc, r, v),
            None => "no candidate fits".to_string(),
        };
        let _ = writeln!(
            s,
            "- within {}x its time ({} ms/step): {what}",
            p.factor,
            sig(p.budget_ms)
        );
    }
    let (cand, unstable, far, not_run) = tally(sc, rows);
    let total = cand + unstable + far + not_run;
    let mut left = Vec::new();
    if unstable > 0 {
        left.push(format!("{unstable} unstable or fell"));
    }
    if far > 0 {
        left.push(format!("{far} above the error bound"));
    }
    if not_run > 0 {
        left.push(format!("{not_run} could not be built"));
    }
    let bound_text = judge
        .bounds
        .iter()
        .map(|(k, b)| format!("{} {}", k.name(), sig(*b)))
        .collect::<Vec<_>>()
        .join(", ");
    let _ = writeln!(
        s,
        "\nCandidates: {cand} of {total} settings{}. The error bound ({FAR} times {}): {bound_text}.\n",
        if left.is_empty() {
            String::new()
        } else {
            format!("; left out: {}", left.join(", "))
        },
        if judge.own_bounds {
            "the scene's own setting's error"
        } else {
            "the best stable error, the scene's own setting being unstable"
        }
    );
    let front = non_dominated(sc, rows);
    if front.is_empty() {
        let _ = writeln!(s, "The front: no candidate.\n");
        return;
    }
    let _ = writeln!(
        s,
        "The front (candidates, cheapest first; no other candidate is cheaper and at least as accurate):\n"
    );
    // settings that measured alike and cost alike (within the timing noise) make one
    // line: which of them came out cheaper is noise
    let cands = candidates(sc, rows);
    let mut named: Vec<Setting> = Vec::new();
    for r in front {
        let Outcome::Ran(m) = &r.outcome else {
            continue;
        };
        if named.contains(&r.setting) {
            continue;
        }
        named.push(r.setting);
        let mut same = Vec::new();
        for (c, cm, _) in &cands {
            if c.setting != r.setting
                && !named.contains(&c.setting)
                && same_figures(sc, m, cm)
                && (cm.ms_per_step / m.ms_per_step - 1.0).abs() <= COST_NOISE
            {
                named.push(c.setting);
                same.push(c.setting.label());
            }
        }
        let _ = writeln!(
            s,
            "- {}: {} ms/step, score {:.2}; {}{}",
            r.setting.label(),
            sig(m.ms_per_step),
            score(norms, m),
            accuracy_line(sc, m),
            if same.is_empty() {
                String::new()
            } else {
                format!(" (the same figures: {})", same.join(", "))
            }
        );
    }
    let _ = writeln!(s);
}

/// "Model only what a scene requires": each pair of scenes at their own setting (the
/// default solver), the leaner first, with the time of the stages the extra model works
/// in apart from the total.
fn model_section(s: &mut String, scenes: &[BenchScene], rows: &[Row]) {
    const STAGES: [&str; 5] = ["forces", "broad", "narrow", "solve", "integrate"];
    let own = |name: &str| -> Option<(&Row, &Measured)> {
        let sc = scenes.iter().find(|s| s.name == name)?;
        match own_row(sc, rows).map(|r| (r, &r.outcome)) {
            Some((r, Outcome::Ran(m))) => Some((r, m)),
            _ => None,
        }
    };
    let pairs: Vec<_> = MODEL_PAIRS
        .iter()
        .filter_map(|p| Some((p, own(p.lean)?, own(p.full)?)))
        .collect();
    if pairs.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "## Model only what a scene requires\n\nEach scene at its own setting: the default solver, the soft step ({}). \
         Median ms per step by stage; the leaner scene of each pair first.\n\n\
         | scene | setting | ms/step | forces | broad | narrow | solve | integrate |\n|---|---|---|---|---|---|---|---|",
        Setting::defaults(crate::defs::SolverKind::Soft).label()
    );
    for (_, (ra, a), (rb, b)) in &pairs {
        for (r, m) in [(ra, a), (rb, b)] {
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
    let _ = writeln!(s);
    for (p, (_, a), (_, b)) in &pairs {
        let stage = |m: &Measured| p.stages.iter().map(|&i| m.stage_ms[i]).sum::<f64>();
        let names = p
            .stages
            .iter()
            .map(|&i| STAGES[i])
            .collect::<Vec<_>>()
            .join(" + ");
        let ratio = |x: f64, y: f64| {
            if y > 0.0 && (x / y).is_finite() {
                format!("{:.2}", x / y)
            } else {
                "-".into()
            }
        };
        let total = a.ms_per_step / b.ms_per_step;
        let model = stage(a) / stage(b);
        let noise = if total > 1.0 && model <= 1.0 {
            format!(
                " The leaner scene measured slower in total, but not in {names}: the difference is in the stages both scenes share, timing noise."
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "- {}: {} / {} = {} in total, {} in {names} (where the extra model works): {}.{noise}",
            p.what,
            p.lean,
            p.full,
            ratio(a.ms_per_step, b.ms_per_step),
            ratio(stage(a), stage(b)),
            p.why
        );
    }
    let _ = writeln!(s);
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

    #[test]
    fn the_picks_take_the_most_accurate_candidate_within_each_budget() {
        let s = sc();
        // the scene's own setting: the soft step's defaults (the pyramid has no
        // [solver] counts of its own)
        assert_eq!(Setting::of_scene(&s.def), Setting::soft(8, 1));
        let row = |setting: Setting, meas: Measured| Row {
            scene: s.name.clone(),
            setting,
            outcome: Outcome::Ran(meas),
        };
        let rows = vec![
            // cheapest, but unstable
            row(Setting::pgs(1, true, true), m(0.1, 0.001, false)),
            // stable, but 50 times the own setting's overlap: above the bound
            row(Setting::soft(2, 1), m(0.3, 0.5, true)),
            row(Setting::soft(4, 1), m(0.5, 0.02, true)),
            row(Setting::soft(8, 1), m(1.0, 0.01, true)),
            row(Setting::pgs(8, true, true), m(1.8, 0.005, true)),
        ];
        let judge = Judge::of(&s, &rows);
        assert!(judge.own_bounds);
        // 10 times the own setting's 0.01 m (max) and 0.005 m (mean)
        assert_eq!(
            judge.bounds,
            vec![
                (Metric::PenetrationMax, 10.0 * 0.01),
                (Metric::PenetrationMean, 10.0 * 0.005)
            ]
        );
        assert_eq!(judge.standing(&rows[0]), Standing::Unstable);
        assert!(matches!(judge.standing(&rows[1]), Standing::Far(_)));
        // scores against the best stable values (pgs 8: 0.005 and 0.0025)
        assert_eq!(judge.standing(&rows[3]), Standing::Candidate(2.0));
        let picked: Vec<Option<String>> = picks(&s, &rows)
            .iter()
            .map(|p| p.pick.map(|(r, _)| r.setting.label()))
            .collect();
        assert_eq!(
            picked,
            vec![
                Some("soft 4 substeps x 1".into()),
                Some("soft 8 substeps x 1".into()),
                Some("pgs 8 warm+split".into())
            ]
        );
        // the front leaves out the unstable and the far setting
        let front: Vec<String> = non_dominated(&s, &rows)
            .iter()
            .map(|r| r.setting.label())
            .collect();
        assert_eq!(
            front,
            [
                "soft 4 substeps x 1",
                "soft 8 substeps x 1",
                "pgs 8 warm+split"
            ]
        );
        let md = markdown(Suite::Quick, std::slice::from_ref(&s), &rows, &[]);
        for line in [
            "- the scene's own setting: soft 8 substeps x 1: 1.0000 ms/step, score 2.00;",
            "- within 0.5x its time (0.5000 ms/step): soft 4 substeps x 1: 0.5000 ms/step, score 4.00;",
            "- within 1x its time (1.0000 ms/step): the scene's own setting, soft 8 substeps x 1",
            "- within 2x its time (2.0000 ms/step): pgs 8 warm+split: 1.8000 ms/step, score 1.00;",
            "Candidates: 3 of 5 settings; left out: 1 unstable or fell, 1 above the error bound.",
            "| soft 2 substeps x 1 | 0.3000 |",
            "| 100.00 (far) | yes |",
            "| soft 8 substeps x 1 (own) | 1.0000 |",
        ] {
            assert!(md.contains(line), "missing {line:?} in:\n{md}");
        }
        // a setting that measured the same at a cost within the timing noise shares its
        // line (it is dominated only by the noise)
        let mut twins = rows.clone();
        twins.push(row(Setting::pgs(8, true, false), m(1.85, 0.005, true)));
        let md = markdown(Suite::Quick, std::slice::from_ref(&s), &twins, &[]);
        assert!(
            md.contains("- pgs 8 warm+split: 1.8000 ms/step, score 1.00; penetration_max 0.0050, penetration_mean 0.0025 (the same figures: pgs 8 warm)"),
            "{md}"
        );
        // a budget nothing fits says so
        let cheap_own = vec![
            row(Setting::soft(8, 1), m(0.2, 0.01, true)),
            row(Setting::soft(4, 1), m(0.15, 0.02, true)),
        ];
        let p = picks(&s, &cheap_own);
        assert!(p[0].pick.is_none(), "0.1 ms fits nothing");
        let md = markdown(Suite::Quick, std::slice::from_ref(&s), &cheap_own, &[]);
        assert!(md.contains("- within 0.5x its time (0.1000 ms/step): no candidate fits"));
    }

    #[test]
    fn the_model_section_times_the_default_solver_and_names_the_models_stage() {
        let scenes: Vec<BenchScene> = scenes::suite(Suite::Quick)
            .into_iter()
            .filter(|s| s.name.starts_with("fall_"))
            .collect();
        assert_eq!(scenes.len(), 2);
        let row = |name: &str, ms: f64, forces: f64| {
            let mut meas = m(ms, 0.0, true);
            meas.stage_ms = [forces, 0.01, 0.0, 0.0, 0.002];
            Row {
                scene: name.into(),
                setting: Setting::defaults(crate::defs::SolverKind::Soft),
                outcome: Outcome::Ran(meas),
            }
        };
        // the leaner scene slower in total, but not in its forces stage
        let rows = vec![
            row("fall_vacuum", 0.03, 0.0005),
            row("fall_drag", 0.025, 0.002),
        ];
        let md = markdown(Suite::Quick, &scenes, &rows, &[]);
        assert!(md.contains("the soft step (soft 8 substeps x 1)"), "{md}");
        assert!(!md.contains("PGS 10 sweeps"), "{md}");
        assert!(
            md.contains("fall_vacuum / fall_drag = 1.20 in total, 0.25 in forces"),
            "{md}"
        );
        assert!(md.contains("timing noise"), "{md}");
        let vac = md.find("| fall_vacuum |").unwrap();
        assert!(vac < md.find("| fall_drag |").unwrap(), "the leaner first");
    }
}
