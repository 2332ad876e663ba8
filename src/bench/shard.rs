//! A suite split across runs and put back together: `bench --shard i/n` writes its
//! cases' rows to `results.shard-i-of-n.json` ([`scenes_json`], [`extremes_json`]);
//! `bench --merge` reads every shard of a run ([`merge`]) and writes the reports an
//! unsharded run would.
//!
//! A shard file names the run it belongs to (its run id: the Slurm array's job id or
//! `--run-id`, when there is one; suite, filter, `--steps`, `--repeats`, the shard and
//! the number of cases) and holds, per case, its index in the suite's
//! full case list, what it ran (scene and setting, or sweep, setting and value) and
//! every figure it measured; numbers are written in full (`{:e}`, which reads back
//! bit for bit, NaN and infinities included), so the merged reports are those of one
//! run.

use serde::{Deserialize, Serialize};

use super::extremes::{self, CaseResult, ExCase, SweepResult};
use super::tune::{CoarseShards, Pass, Tried, TuneMetric, TuneOptions};
use super::{BenchScene, Measured, Options, Outcome, Row, Shard, Suite, Verdict};

/// The `format` field of a shard file.
const FORMAT: &str = "sandbox2d bench shard";
/// The `version` field; a file of another version is refused.
const VERSION: u32 = 2;

/// The run a shard belongs to: shards merge only with shards of the same run.
#[derive(Clone, Debug, PartialEq)]
pub struct RunKey {
    pub suite: Suite,
    pub filter: Option<String>,
    /// `--steps`, when given.
    pub steps: Option<u64>,
    /// `--repeats`, when given.
    pub repeats: Option<u32>,
    /// The run id ([`super::slurm::run_id`]): the array job's id in a Slurm array, or
    /// `--run-id`; none for a shard run by hand.
    pub run: Option<String>,
}

/// What merging the shards of a run gives: what an unsharded run writes its reports from.
#[derive(Clone, Debug)]
pub enum Merged {
    /// The quick or standard suite: its scenes and every row, in the run's order.
    Scenes {
        suite: Suite,
        scenes: Vec<BenchScene>,
        rows: Vec<Row>,
    },
    /// The extremes suite: every sweep and setting, in the run's order.
    Extremes { results: Vec<SweepResult> },
    /// The box2d suite: every scene and thread count, in the run's order.
    Box2d { rows: Vec<super::box2d::Row> },
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Wire {
    format: String,
    version: u32,
    /// The run id, when there is one.
    run: Option<String>,
    suite: String,
    filter: Option<String>,
    steps: Option<u64>,
    repeats: Option<u32>,
    /// `i/n`
    shard: String,
    /// The number of cases of the whole run (every shard).
    cases: usize,
    #[serde(default)]
    rows: Vec<WireRow>,
    #[serde(default)]
    extremes: Vec<WireCase>,
    #[serde(default)]
    box2d: Vec<WireBox2d>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct WireBox2d {
    case: usize,
    scene: String,
    threads: usize,
    steps: u64,
    repeats: u32,
    ms_median: String,
    ms_mean: String,
    stage_ms: [String; 5],
    contacts_mean: String,
    contacts_end: u64,
    bodies: u64,
    accuracy: String,
    lost: u64,
    state_hash: String,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct WireRow {
    case: usize,
    scene: String,
    setting: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    failed: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    measured: Option<WireMeasured>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct WireMeasured {
    ms_per_step: String,
    stage_ms: [String; 5],
    steps: u64,
    penetration_max: String,
    penetration_mean: String,
    drift: String,
    joint_error: String,
    energy_drift: String,
    residual: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    unstable: Option<String>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct WireCase {
    case: usize,
    sweep: String,
    setting: String,
    value: String,
    /// held, marginal or failed
    result: String,
    text: String,
}

/// A number in full: `{:e}` is the shortest text that reads back to the same bits.
fn full(x: f64) -> String {
    format!("{x:e}")
}

fn number(s: &str) -> Result<f64, String> {
    s.parse().map_err(|_| format!("{s:?} is not a number"))
}

fn suite_of(name: &str) -> Option<Suite> {
    [Suite::Quick, Suite::Standard, Suite::Extremes, Suite::Box2d]
        .into_iter()
        .find(|s| s.name() == name)
}

fn header(key: &RunKey, shard: Shard, cases: usize) -> Wire {
    Wire {
        format: FORMAT.into(),
        version: VERSION,
        run: key.run.clone(),
        suite: key.suite.name().into(),
        filter: key.filter.clone(),
        steps: key.steps,
        repeats: key.repeats,
        shard: shard.to_string(),
        cases,
        rows: Vec::new(),
        extremes: Vec::new(),
        box2d: Vec::new(),
    }
}

fn to_text(w: &Wire) -> String {
    let mut s = serde_json::to_string_pretty(w).unwrap_or_default();
    s.push('\n');
    s
}

/// A shard file of the quick or standard suite: `rows` are (index in the full case
/// list, row); `cases` is the length of that list.
pub fn scenes_json(key: &RunKey, shard: Shard, cases: usize, rows: &[(usize, &Row)]) -> String {
    let mut w = header(key, shard, cases);
    w.rows = rows
        .iter()
        .map(|&(case, r)| {
            let (failed, measured) = wire_outcome(&r.outcome);
            WireRow {
                case,
                scene: r.scene.clone(),
                setting: r.setting.label(),
                failed,
                measured,
            }
        })
        .collect();
    to_text(&w)
}

/// A shard file of the extremes suite: `rows` are (index in the full case list, case,
/// result); `cases` is the length of that list.
pub fn extremes_json(
    key: &RunKey,
    shard: Shard,
    cases: usize,
    rows: &[(usize, &ExCase, &CaseResult)],
) -> String {
    let mut w = header(key, shard, cases);
    w.extremes = rows
        .iter()
        .map(|&(case, c, r)| {
            let (result, text) = match r {
                CaseResult::Held(t) => ("held", t),
                CaseResult::Marginal(t) => ("marginal", t),
                CaseResult::Failed(t) => ("failed", t),
            };
            WireCase {
                case,
                sweep: c.sweep.name().into(),
                setting: c.setting.label.into(),
                value: full(c.value),
                result: result.into(),
                text: text.clone(),
            }
        })
        .collect();
    to_text(&w)
}

/// An outcome as a row's `failed` and `measured` fields.
fn wire_outcome(o: &Outcome) -> (Option<String>, Option<WireMeasured>) {
    match o {
        Outcome::Failed(why) => (Some(why.clone()), None),
        Outcome::Ran(m) => (
            None,
            Some(WireMeasured {
                ms_per_step: full(m.ms_per_step),
                stage_ms: m.stage_ms.map(full),
                steps: m.steps,
                penetration_max: full(m.penetration_max),
                penetration_mean: full(m.penetration_mean),
                drift: full(m.drift),
                joint_error: full(m.joint_error),
                energy_drift: full(m.energy_drift),
                residual: full(m.residual),
                unstable: match &m.verdict {
                    Verdict::Stable => None,
                    Verdict::Unstable(why) => Some(why.clone()),
                },
            }),
        ),
    }
}

/// A shard file of the box2d suite: `rows` are (index in the full case list, row);
/// `cases` is the length of that list.
pub fn box2d_json(
    key: &RunKey,
    shard: Shard,
    cases: usize,
    rows: &[(usize, &super::box2d::Row)],
) -> String {
    let mut w = header(key, shard, cases);
    w.box2d = rows
        .iter()
        .map(|&(case, r)| WireBox2d {
            case,
            scene: r.scene.clone(),
            threads: r.threads,
            steps: r.steps,
            repeats: r.repeats,
            ms_median: full(r.ms_median),
            ms_mean: full(r.ms_mean),
            stage_ms: r.stage_ms.map(full),
            contacts_mean: full(r.contacts_mean),
            contacts_end: r.contacts_end,
            bodies: r.bodies,
            accuracy: full(r.accuracy),
            lost: r.lost,
            state_hash: format!("{:016x}", r.state_hash),
        })
        .collect();
    to_text(&w)
}

fn outcome(r: WireRow) -> Result<Outcome, String> {
    outcome_of(r.failed, r.measured)
}

fn outcome_of(failed: Option<String>, measured: Option<WireMeasured>) -> Result<Outcome, String> {
    match (failed, measured) {
        (Some(why), None) => Ok(Outcome::Failed(why)),
        (None, Some(m)) => {
            let mut stage_ms = [0.0; 5];
            for (s, t) in stage_ms.iter_mut().zip(&m.stage_ms) {
                *s = number(t)?;
            }
            Ok(Outcome::Ran(Measured {
                ms_per_step: number(&m.ms_per_step)?,
                stage_ms,
                steps: m.steps,
                penetration_max: number(&m.penetration_max)?,
                penetration_mean: number(&m.penetration_mean)?,
                drift: number(&m.drift)?,
                joint_error: number(&m.joint_error)?,
                energy_drift: number(&m.energy_drift)?,
                residual: number(&m.residual)?,
                // not sharded: `--metric trajectory` runs whole (its references are
                // worked out once per scene)
                trajectory: None,
                verdict: m.unstable.map_or(Verdict::Stable, Verdict::Unstable),
            }))
        }
        _ => Err("a row must have either \"failed\" or \"measured\"".into()),
    }
}

fn case_result(c: &WireCase) -> Result<CaseResult, String> {
    let t = c.text.clone();
    match c.result.as_str() {
        "held" => Ok(CaseResult::Held(t)),
        "marginal" => Ok(CaseResult::Marginal(t)),
        "failed" => Ok(CaseResult::Failed(t)),
        other => Err(format!("unknown result {other:?}")),
    }
}

/// A run id for messages: `run ID`, or `no run id`.
fn run_text(run: Option<&str>) -> String {
    run.map_or("no run id".into(), |r| format!("run {r}"))
}

/// Checks that the shard files `(name, run id)` are all of run `expect` (when given)
/// and all of one run: two arrays that wrote into one folder leave shards of both.
pub(crate) fn check_runs(
    shards: &[(&str, Option<&str>)],
    expect: Option<&str>,
) -> Result<(), String> {
    if let Some(want) = expect
        && let Some((name, run)) = shards.iter().find(|(_, r)| *r != Some(want))
    {
        return Err(format!(
            "{name} is a shard of {}, not of run {want}: another run wrote into this folder (give each run its own --out)",
            run_text(*run)
        ));
    }
    let Some(&(first_name, first)) = shards.first() else {
        return Ok(());
    };
    match shards.iter().find(|(_, r)| *r != first) {
        Some((name, run)) => Err(format!(
            "{name} and {first_name} are shards of different runs: {} vs {} (two runs wrote into one folder? give each run its own --out, or merge with --run-id)",
            run_text(*run),
            run_text(first)
        )),
        None => Ok(()),
    }
}

/// Checks that the shards `(name, shard)` of one run, split `n` ways, are each there
/// once; gives each shard's file name, by shard index.
pub(crate) fn check_complete<'a>(
    shards: &[(&'a str, Shard)],
    n: usize,
    run: Option<&str>,
) -> Result<Vec<&'a str>, String> {
    let mut by_shard: Vec<Option<&str>> = vec![None; n];
    for &(name, shard) in shards {
        if let Some(other) = by_shard[shard.index - 1] {
            return Err(format!("shard {shard} is given twice: {other} and {name}"));
        }
        by_shard[shard.index - 1] = Some(name);
    }
    let missing: Vec<String> = (1..=n)
        .filter(|i| by_shard[i - 1].is_none())
        .map(|i| format!("{i}/{n}"))
        .collect();
    if !missing.is_empty() {
        return Err(format!(
            "shard {} {}missing: a run split {n} ways needs every shard once (got {}; did a task fail or get cancelled?)",
            missing.join(", "),
            run.map_or(String::new(), |r| format!("of run {r} ")),
            shards
                .iter()
                .map(|(_, s)| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(by_shard.into_iter().map(|s| s.unwrap_or("?")).collect())
}

/// Reads the shard files of one run, `(name, text)` each (the name is for messages),
/// and puts their rows back in the order of the run's full case list. Refuses, with
/// a one-line reason: a file that is not a shard file, a shard of another run than
/// `run` (when given), shards of different runs (run id, suite, filter, steps,
/// repeats, shard count or case count), a shard given twice, a missing shard, and a
/// row that is not the case its index names in this build's suite.
pub fn merge(files: &[(String, String)], run: Option<&str>) -> Result<Merged, String> {
    let mut parsed = Vec::with_capacity(files.len());
    for (name, text) in files {
        let w: Wire = serde_json::from_str(text)
            .map_err(|e| format!("{name}: not a bench shard file: {e}"))?;
        if w.format != FORMAT {
            return Err(format!(
                "{name}: not a bench shard file (format {:?})",
                w.format
            ));
        }
        if w.version != VERSION {
            return Err(format!(
                "{name}: shard file version {}, this build reads version {VERSION}",
                w.version
            ));
        }
        let shard = Shard::parse(&w.shard).map_err(|e| format!("{name}: {e}"))?;
        parsed.push((name.as_str(), w, shard));
    }
    let Some((first_name, first, first_shard)) = parsed.first() else {
        return Err("no shard files to merge".into());
    };
    let runs: Vec<(&str, Option<&str>)> = parsed
        .iter()
        .map(|(name, w, _)| (*name, w.run.as_deref()))
        .collect();
    check_runs(&runs, run)?;
    for (name, w, shard) in &parsed[1..] {
        let differ = |what: &str, a: String, b: String| {
            Err(format!(
                "{name} and {first_name} are shards of different runs: {what} {a} vs {b}"
            ))
        };
        let opt = |o: &Option<String>| o.clone().map_or("none".into(), |f| format!("{f:?}"));
        let num = |o: Option<u64>| o.map_or("default".into(), |n| n.to_string());
        if w.suite != first.suite {
            return differ("suite", w.suite.clone(), first.suite.clone());
        }
        if w.filter != first.filter {
            return differ("filter", opt(&w.filter), opt(&first.filter));
        }
        if w.steps != first.steps {
            return differ("steps", num(w.steps), num(first.steps));
        }
        if w.repeats != first.repeats {
            return differ(
                "repeats",
                num(w.repeats.map(u64::from)),
                num(first.repeats.map(u64::from)),
            );
        }
        if shard.count != first_shard.count {
            return differ(
                "shard count",
                shard.count.to_string(),
                first_shard.count.to_string(),
            );
        }
        if w.cases != first.cases {
            return differ("case count", w.cases.to_string(), first.cases.to_string());
        }
    }
    let n = first_shard.count;
    let shards: Vec<(&str, Shard)> = parsed.iter().map(|(name, _, s)| (*name, *s)).collect();
    let by_shard = check_complete(&shards, n, first.run.as_deref())?;
    let suite = suite_of(&first.suite)
        .ok_or_else(|| format!("{first_name}: unknown suite {:?}", first.suite))?;
    let filter = first.filter.clone();
    let total = first.cases;
    let count_check = |have: usize| -> Result<(), String> {
        if have == total {
            Ok(())
        } else {
            Err(format!(
                "{first_name}: the run had {total} cases; this build's {} suite{} has {have} (merge with the build that ran the shards)",
                suite.name(),
                filter
                    .as_ref()
                    .map_or(String::new(), |f| format!(" with --filter {f:?}"))
            ))
        }
    };
    // a case's slot, checked: in range, in the file's shard, not seen before
    let slot = |name: &str, shard: &Shard, case: usize, filled: bool| -> Result<(), String> {
        if case >= total {
            Err(format!(
                "{name}: case {case} is past the run's {total} cases"
            ))
        } else if !shard.includes(case) {
            Err(format!("{name}: case {case} is not in shard {shard}"))
        } else if filled {
            Err(format!("{name}: case {case} is given twice"))
        } else {
            Ok(())
        }
    };
    let absent = |case: usize| {
        format!(
            "{}: case {case} of shard {}/{n} is missing (an interrupted shard run?)",
            by_shard[case % n],
            case % n + 1
        )
    };
    if suite == Suite::Box2d {
        let cases = super::box2d::cases(&super::box2d::scenes(filter.as_deref()));
        count_check(cases.len())?;
        let mut rows: Vec<Option<super::box2d::Row>> = vec![None; total];
        for (name, w, shard) in &parsed {
            if !w.rows.is_empty() || !w.extremes.is_empty() {
                return Err(format!("{name}: other suites' rows in a box2d shard"));
            }
            for r in &w.box2d {
                slot(
                    name,
                    shard,
                    r.case,
                    rows.get(r.case).is_some_and(Option::is_some),
                )?;
                let want = &cases[r.case];
                if r.scene != want.scene.name || r.threads != want.threads {
                    return Err(format!(
                        "{name}: case {} is {} on {} thread(s) here but {} in this build's suite",
                        r.case,
                        r.scene,
                        r.threads,
                        want.label()
                    ));
                }
                let num = |t: &str| number(t).map_err(|e| format!("{name}: {e}"));
                let mut stage_ms = [0.0; 5];
                for (x, t) in stage_ms.iter_mut().zip(&r.stage_ms) {
                    *x = num(t)?;
                }
                rows[r.case] = Some(super::box2d::Row {
                    scene: r.scene.clone(),
                    threads: r.threads,
                    steps: r.steps,
                    repeats: r.repeats,
                    ms_median: num(&r.ms_median)?,
                    ms_mean: num(&r.ms_mean)?,
                    stage_ms,
                    contacts_mean: num(&r.contacts_mean)?,
                    contacts_end: r.contacts_end,
                    bodies: r.bodies,
                    figure: want.scene.figure,
                    accuracy: num(&r.accuracy)?,
                    lost: r.lost,
                    state_hash: u64::from_str_radix(&r.state_hash, 16)
                        .map_err(|_| format!("{name}: bad state hash {:?}", r.state_hash))?,
                });
            }
        }
        let mut all = Vec::with_capacity(total);
        for (i, r) in rows.into_iter().enumerate() {
            all.push(r.ok_or_else(|| absent(i))?);
        }
        return Ok(Merged::Box2d { rows: all });
    }
    if suite == Suite::Extremes {
        let cases = extremes::cases(&extremes::sweeps(filter.as_deref()));
        count_check(cases.len())?;
        let mut results: Vec<Option<CaseResult>> = vec![None; total];
        for (name, w, shard) in &parsed {
            if !w.rows.is_empty() || !w.box2d.is_empty() {
                return Err(format!("{name}: scene rows in an extremes shard"));
            }
            for c in &w.extremes {
                slot(
                    name,
                    shard,
                    c.case,
                    results.get(c.case).is_some_and(Option::is_some),
                )?;
                let want = &cases[c.case];
                let value = number(&c.value).map_err(|e| format!("{name}: {e}"))?;
                if c.sweep != want.sweep.name()
                    || c.setting != want.setting.label
                    || value.to_bits() != want.value.to_bits()
                {
                    return Err(format!(
                        "{name}: case {} is {} / {} / {} here but {} in this build's suite",
                        c.case,
                        c.sweep,
                        c.setting,
                        c.value,
                        want.label()
                    ));
                }
                results[c.case] = Some(case_result(c).map_err(|e| format!("{name}: {e}"))?);
            }
        }
        let mut all = Vec::with_capacity(total);
        for (i, r) in results.into_iter().enumerate() {
            all.push(r.ok_or_else(|| absent(i))?);
        }
        return Ok(Merged::Extremes {
            results: extremes::assemble(&cases, all),
        });
    }
    let opts = Options {
        filter: filter.clone(),
        steps: first.steps,
        repeats: first.repeats,
    };
    let scenes = opts.scenes(suite);
    let cases = super::cases(&scenes);
    count_check(cases.len())?;
    let mut rows: Vec<Option<Row>> = vec![None; total];
    for (name, w, _) in &parsed {
        if !w.extremes.is_empty() || !w.box2d.is_empty() {
            return Err(format!(
                "{name}: other suites' cases in a {} shard",
                suite.name()
            ));
        }
    }
    for (name, w, shard) in parsed {
        for r in w.rows {
            slot(
                name,
                &shard,
                r.case,
                rows.get(r.case).is_some_and(Option::is_some),
            )?;
            let want = &cases[r.case];
            let scene = &scenes[want.scene].name;
            if r.scene != *scene || r.setting != want.setting.label() {
                return Err(format!(
                    "{name}: case {} is {} / {} here but {scene} / {} in this build's suite",
                    r.case,
                    r.scene,
                    r.setting,
                    want.setting.label()
                ));
            }
            let case = r.case;
            rows[case] = Some(Row {
                scene: scene.clone(),
                setting: want.setting,
                outcome: outcome(r).map_err(|e| format!("{name}: case {case}: {e}"))?,
            });
        }
    }
    let mut all = Vec::with_capacity(total);
    for (i, r) in rows.into_iter().enumerate() {
        all.push(r.ok_or_else(|| absent(i))?);
    }
    Ok(Merged::Scenes {
        suite,
        scenes,
        rows: all,
    })
}

/// The `format` field of a `tune --shard` file.
const TUNE_FORMAT: &str = "sandbox2d tune shard";
/// Its `version` field.
const TUNE_VERSION: u32 = 1;

/// The search a `tune --shard` file belongs to: shards merge only with shards of the
/// same search.
#[derive(Clone, Debug, PartialEq)]
pub struct TuneKey {
    /// The scene as the command line named it (a built-in scene or a file).
    pub scene: String,
    /// [`super::tune::scene_digest`] of the scene the shard ran.
    pub digest: String,
    /// The budget, metric, steps, rounds and jobs.
    pub options: TuneOptions,
    /// The run id, when there is one (see [`RunKey::run`]).
    pub run: Option<String>,
}

/// What merging the shards of a `tune` search gives: its key, and every setting of the
/// bench's grid, in grid order, as its shard measured and timed it.
#[derive(Clone, Debug)]
pub struct MergedTune {
    pub key: TuneKey,
    pub coarse: Vec<Tried>,
    pub shards: CoarseShards,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TuneWire {
    format: String,
    version: u32,
    run: Option<String>,
    scene: String,
    scene_digest: String,
    budget_ms: String,
    metric: String,
    steps: u64,
    rounds: u32,
    jobs: usize,
    /// `i/n`
    shard: String,
    /// The number of settings in the grid (every shard's).
    cases: usize,
    #[serde(default)]
    tried: Vec<TuneWireRow>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TuneWireRow {
    case: usize,
    setting: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    failed: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    measured: Option<WireMeasured>,
    /// Each timing round's ms/step, the accuracy run's first.
    samples: Vec<String>,
}

/// The file name of a `tune --shard I/N` run: `tune.shard-I-of-N.json`.
pub fn tune_file_name(shard: Shard) -> String {
    format!("tune.shard-{}-of-{}.json", shard.index, shard.count)
}

/// A `tune --shard` file: `rows` are (index in the bench's grid, setting as measured);
/// `cases` is the grid's length.
pub fn tune_json(key: &TuneKey, shard: Shard, cases: usize, rows: &[(usize, Tried)]) -> String {
    let o = &key.options;
    let w = TuneWire {
        format: TUNE_FORMAT.into(),
        version: TUNE_VERSION,
        run: key.run.clone(),
        scene: key.scene.clone(),
        scene_digest: key.digest.clone(),
        budget_ms: full(o.budget_ms),
        metric: o.metric.name().into(),
        steps: o.steps,
        rounds: o.rounds,
        jobs: o.jobs,
        shard: shard.to_string(),
        cases,
        tried: rows
            .iter()
            .map(|(case, t)| {
                let (failed, measured) = wire_outcome(&t.outcome);
                TuneWireRow {
                    case: *case,
                    setting: t.setting.label(),
                    failed,
                    measured,
                    samples: t.samples.iter().map(|&x| full(x)).collect(),
                }
            })
            .collect(),
    };
    let mut s = serde_json::to_string_pretty(&w).unwrap_or_default();
    s.push('\n');
    s
}

/// Reads the shard files of one `tune` search, `(name, text)` each, and puts the grid's
/// settings back in grid order. Refuses, with a one-line reason: a file that is not a
/// tune shard file, a shard of another run than `run` (when given), shards of different
/// searches (run id, scene, budget, metric, steps, rounds, jobs, shard count or grid
/// size), a shard given twice or missing, and a setting that is not the one its index
/// names in this build's grid.
pub fn merge_tune(files: &[(String, String)], run: Option<&str>) -> Result<MergedTune, String> {
    let mut parsed = Vec::with_capacity(files.len());
    for (name, text) in files {
        let w: TuneWire = serde_json::from_str(text)
            .map_err(|e| format!("{name}: not a tune shard file: {e}"))?;
        if w.format != TUNE_FORMAT {
            return Err(format!(
                "{name}: not a tune shard file (format {:?})",
                w.format
            ));
        }
        if w.version != TUNE_VERSION {
            return Err(format!(
                "{name}: tune shard file version {}, this build reads version {TUNE_VERSION}",
                w.version
            ));
        }
        let shard = Shard::parse(&w.shard).map_err(|e| format!("{name}: {e}"))?;
        parsed.push((name.as_str(), w, shard));
    }
    let Some((first_name, first, first_shard)) = parsed.first() else {
        return Err("no shard files to merge".into());
    };
    let runs: Vec<(&str, Option<&str>)> = parsed
        .iter()
        .map(|(name, w, _)| (*name, w.run.as_deref()))
        .collect();
    check_runs(&runs, run)?;
    for (name, w, shard) in &parsed[1..] {
        let fields = [
            ("scene", w.scene.clone(), first.scene.clone()),
            (
                "scene digest",
                w.scene_digest.clone(),
                first.scene_digest.clone(),
            ),
            ("budget", w.budget_ms.clone(), first.budget_ms.clone()),
            ("metric", w.metric.clone(), first.metric.clone()),
            ("steps", w.steps.to_string(), first.steps.to_string()),
            ("rounds", w.rounds.to_string(), first.rounds.to_string()),
            ("jobs", w.jobs.to_string(), first.jobs.to_string()),
            (
                "shard count",
                shard.count.to_string(),
                first_shard.count.to_string(),
            ),
            ("grid size", w.cases.to_string(), first.cases.to_string()),
        ];
        if let Some((what, a, b)) = fields.iter().find(|(_, a, b)| a != b) {
            return Err(format!(
                "{name} and {first_name} are shards of different searches: {what} {a} vs {b}"
            ));
        }
    }
    let n = first_shard.count;
    let shards: Vec<(&str, Shard)> = parsed.iter().map(|(name, _, s)| (*name, *s)).collect();
    let by_shard = check_complete(&shards, n, first.run.as_deref())?;
    let metric = TuneMetric::ALL
        .into_iter()
        .find(|m| m.name() == first.metric)
        .ok_or_else(|| format!("{first_name}: unknown metric {:?}", first.metric))?;
    let budget_ms = number(&first.budget_ms).map_err(|e| format!("{first_name}: {e}"))?;
    let grid = super::settings_grid();
    if first.cases != grid.len() {
        return Err(format!(
            "{first_name}: the search's grid had {} settings; this build's has {} (merge with the build that ran the shards)",
            first.cases,
            grid.len()
        ));
    }
    let key = TuneKey {
        scene: first.scene.clone(),
        digest: first.scene_digest.clone(),
        options: TuneOptions {
            budget_ms,
            metric,
            steps: first.steps,
            rounds: first.rounds,
            jobs: first.jobs,
        },
        run: first.run.clone(),
    };
    let shards = CoarseShards {
        count: n,
        run: first.run.clone(),
    };
    let mut coarse: Vec<Option<Tried>> = vec![None; grid.len()];
    for (name, w, shard) in parsed {
        for r in w.tried {
            let case = r.case;
            if case >= grid.len() {
                return Err(format!(
                    "{name}: case {case} is past the grid's {} settings",
                    grid.len()
                ));
            }
            if !shard.includes(case) {
                return Err(format!("{name}: case {case} is not in shard {shard}"));
            }
            if coarse[case].is_some() {
                return Err(format!("{name}: case {case} is given twice"));
            }
            let want = grid[case];
            if r.setting != want.label() {
                return Err(format!(
                    "{name}: case {case} is {} here but {} in this build's grid",
                    r.setting,
                    want.label()
                ));
            }
            let samples = r
                .samples
                .iter()
                .map(|x| number(x))
                .collect::<Result<Vec<f64>, String>>()
                .map_err(|e| format!("{name}: case {case}: {e}"))?;
            if samples.is_empty() {
                return Err(format!("{name}: case {case} has no timing"));
            }
            let outcome = outcome_of(r.failed, r.measured)
                .map_err(|e| format!("{name}: case {case}: {e}"))?;
            coarse[case] = Some(Tried {
                setting: want,
                pass: Pass::Coarse,
                outcome,
                ms_per_step: samples[0],
                samples,
                score: None,
                dropped: None,
                reason: None,
            });
        }
    }
    let mut all = Vec::with_capacity(grid.len());
    for (i, t) in coarse.into_iter().enumerate() {
        all.push(t.ok_or_else(|| {
            format!(
                "{}: setting {i} ({}) of shard {}/{n} is missing (an interrupted shard run?)",
                by_shard[i % n],
                grid[i].label(),
                i % n + 1
            )
        })?);
    }
    Ok(MergedTune {
        key,
        coarse: all,
        shards,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::Options;

    #[test]
    fn shard_files_carry_every_figure_bit_for_bit_and_merge_in_case_order() {
        let key = RunKey {
            suite: Suite::Quick,
            filter: Some("pendulum".into()),
            steps: Some(6),
            repeats: None,
            run: Some("4242".into()),
        };
        let opts = Options {
            filter: key.filter.clone(),
            steps: key.steps,
            repeats: None,
        };
        let scenes = opts.scenes(Suite::Quick);
        let cases = crate::bench::cases(&scenes);
        let odd = [
            0.1 + 0.2,
            f64::NAN,
            1e-300,
            f64::INFINITY,
            -7.25e12,
            1.0 / 3.0,
        ];
        let rows: Vec<Row> = cases
            .iter()
            .enumerate()
            .map(|(i, c)| Row {
                scene: scenes[c.scene].name.clone(),
                setting: c.setting,
                outcome: if i == 5 {
                    Outcome::Failed("no, \"quoted\"\nand a new line".into())
                } else {
                    let x = |k: usize| odd[(i + k) % odd.len()];
                    Outcome::Ran(Measured {
                        ms_per_step: x(0),
                        stage_ms: [x(1), x(2), x(3), x(4), x(5)],
                        steps: i as u64,
                        penetration_max: x(1),
                        penetration_mean: x(2),
                        drift: x(3),
                        joint_error: x(4),
                        energy_drift: x(5),
                        residual: x(0),
                        trajectory: None,
                        verdict: if i % 4 == 1 {
                            Verdict::Unstable("fell, far".into())
                        } else {
                            Verdict::Stable
                        },
                    })
                },
            })
            .collect();
        let file = |i: usize| {
            let shard = Shard { index: i, count: 2 };
            let part: Vec<(usize, &Row)> = shard
                .indices(rows.len())
                .into_iter()
                .map(|k| (k, &rows[k]))
                .collect();
            (format!("s{i}"), scenes_json(&key, shard, rows.len(), &part))
        };
        let Merged::Scenes { rows: back, .. } = merge(&[file(2), file(1)], None).unwrap() else {
            panic!("not the scene suite")
        };
        assert_eq!(format!("{back:?}"), format!("{rows:?}"));
        assert!(
            merge(&[file(2)], None)
                .unwrap_err()
                .contains("shard 1/2 of run 4242 missing")
        );
        let e = merge(&[file(1), file(1), file(2)], None).unwrap_err();
        assert!(e.contains("given twice"), "{e}");
        // the run id is kept and checked
        assert!(merge(&[file(1), file(2)], Some("4242")).is_ok());
        let e = merge(&[file(1), file(2)], Some("17")).unwrap_err();
        assert!(e.contains("not of run 17"), "{e}");
        assert!(
            merge(&[("x".into(), "{}".into())], None)
                .unwrap_err()
                .starts_with("x: not a bench shard file")
        );
    }
}
