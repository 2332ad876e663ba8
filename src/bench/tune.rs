//! `sandbox2d tune`: for one scene and a budget in ms per step, the most accurate
//! setting that fits.
//!
//! The search runs the bench's grid ([`super::settings_grid`]: classic PGS at 1..32
//! sweeps in its four modes, XPBD at 1..32 substeps, the soft step at 1..32 substeps of
//! 1 sweep) and the scene's own setting, then a finer pass around each solver's best setting within the budget
//! (the counts between its neighbours on the grid; for the soft step also 1 and 3
//! sweeps a substep). Each setting's accuracy comes from one run ([`super::run_case`]: the runs
//! are deterministic); its cost is the median of that run's ms/step and of further timing
//! rounds, taken turn about over every candidate still in contention so that the
//! machine's noise falls on all of them alike; a candidate within [`EDGE`] of the
//! budget gets as many rounds again. Runs can go several at once ([`TuneOptions::jobs`]),
//! each round's in the same order.
//!
//! The error is one measure the user names, or by default the scene's *worst* measure
//! normalised by the best value any stable setting reached: a score of 1 is as right as
//! the best setting on every measure that applies, 2 is twice as wrong on one of them.
//! Which measures apply is read from the scene and the runs (see [`Applies`]). A
//! setting that goes unstable anywhere in the run is never picked; the report lists it
//! with the reason.
//!
//! The search can be split over machines (a Slurm job array): [`tune_shard`] runs one
//! shard of the grid (accuracy runs and timing rounds), and [`tune_merged`] takes every
//! shard's settings and runs the rest (the fine pass, its rounds, the rounds near the
//! budget) as [`tune`] would; `bench::shard` writes and reads the shards' files.

use crate::defs::{BodyType, SolverKind, WorldDef};
use crate::math::Vec2;

use super::{BenchScene, Budget, Measured, Metric, Outcome, Setting, Shard, Track, run_case};

mod report;

pub use report::{json, markdown, metric_line, solver_table, svg, write_setting};

/// What `tune` minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TuneMetric {
    /// The worst of the measures that apply, each divided by the best value any stable
    /// setting reached.
    Worst,
    /// Deepest overlap over the run (m).
    Penetration,
    /// How far the top body moved from its start (m).
    Drift,
    /// Largest joint anchor separation over the run (m).
    JointError,
    /// |E_end - E_start| / |E_start| (energy measured above a floor one scene height
    /// below the lowest body).
    EnergyDrift,
    /// Relative distance of the contact impulses from the same step's MLCP solved to
    /// convergence (classic PGS with one substep only).
    Residual,
    /// The RMS distance of the bodies from their true places over the run: the scene's
    /// closed form when it has one, else a reference run at a 16th of its step with
    /// converged solves ([`super::truth`]); refused for a scene whose motion is chaotic
    /// over the run.
    Trajectory,
}

impl TuneMetric {
    /// Every metric, in the order the command line lists them.
    pub const ALL: [TuneMetric; 7] = [
        TuneMetric::Worst,
        TuneMetric::Penetration,
        TuneMetric::Drift,
        TuneMetric::JointError,
        TuneMetric::EnergyDrift,
        TuneMetric::Residual,
        TuneMetric::Trajectory,
    ];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            TuneMetric::Worst => "worst",
            TuneMetric::Penetration => "penetration",
            TuneMetric::Drift => "drift",
            TuneMetric::JointError => "joint_error",
            TuneMetric::EnergyDrift => "energy_drift",
            TuneMetric::Residual => "residual",
            TuneMetric::Trajectory => "trajectory",
        }
    }

    /// The bench measure behind a single metric (`None` for [`TuneMetric::Worst`]).
    pub fn measure(self) -> Option<Metric> {
        match self {
            TuneMetric::Worst => None,
            TuneMetric::Penetration => Some(Metric::PenetrationMax),
            TuneMetric::Drift => Some(Metric::Drift),
            TuneMetric::JointError => Some(Metric::JointError),
            TuneMetric::EnergyDrift => Some(Metric::EnergyDrift),
            TuneMetric::Residual => Some(Metric::Residual),
            TuneMetric::Trajectory => Some(Metric::Trajectory),
        }
    }
}

/// The measures of the default ("worst") score, in report order.
pub const WORST_MEASURES: [Metric; 4] = [
    Metric::PenetrationMax,
    Metric::Drift,
    Metric::JointError,
    Metric::EnergyDrift,
];

/// Below these a measure is as good as exact: a best value under the floor is lifted to
/// it before dividing (so one setting at 1e-9 does not make every other one "infinitely"
/// worse): 0.1 mm of overlap, 1 mm of drift, 0.1 mm of joint separation, 1e-4 of the
/// energy, 1e-3 of residual.
pub fn floor(m: Metric) -> f64 {
    match m {
        Metric::PenetrationMax | Metric::PenetrationMean => 1e-4,
        Metric::Drift => 1e-3,
        Metric::JointError => 1e-4,
        Metric::EnergyDrift => 1e-4,
        Metric::Residual => 1e-3,
        Metric::Trajectory => 1e-4,
    }
}

/// Drift of the top body counts only in a scene without joints that starts at rest and
/// where some stable setting kept the top body within this distance (m): a pile meant to
/// stand (a ball pit's top ball falls metres under every setting).
pub const RESTING_DRIFT: f64 = 0.5;

/// A setting whose median cost lies within this fraction of the budget (either side)
/// is timed for as many rounds again before the pick.
pub const EDGE: f64 = 0.25;

/// How the search runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TuneOptions {
    /// The most a step may cost (median ms/step).
    pub budget_ms: f64,
    pub metric: TuneMetric,
    /// Steps of every run.
    pub steps: u64,
    /// Timing rounds (the accuracy run is the first).
    pub rounds: u32,
    /// Runs at once, one thread each (1: one after another), as the bench's `--jobs`:
    /// the scores are the same whatever `jobs`; the timings are of runs taken beside
    /// each other, so on a machine whose cores share much they read high.
    pub jobs: usize,
}

/// Which pass proposed a setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// The bench's grid.
    Coarse,
    /// Around each solver kind's best setting of the coarse pass.
    Fine,
}

/// One setting as `tune` measured it.
#[derive(Clone, Debug)]
pub struct Tried {
    pub setting: Setting,
    pub pass: Pass,
    /// The accuracy run (and its stability verdict), or why it could not run.
    pub outcome: Outcome,
    /// Each round's median ms/step.
    pub samples: Vec<f64>,
    /// Median of `samples`.
    pub ms_per_step: f64,
    /// The error `tune` minimises (smaller is better); `None` for a dropped setting.
    pub score: Option<f64>,
    /// Why the setting can never be picked (unstable, fell, error far above the best,
    /// could not run, not measured).
    pub dropped: Option<String>,
    /// The kind of reason in `dropped`.
    pub reason: Option<DropReason>,
}

/// Why a setting is never picked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DropReason {
    /// The scene could not be built with it.
    Failed,
    /// It blew up or gained energy (the bench's verdict).
    Unstable,
    /// A pile meant to stand fell: its top body moved more than [`RESTING_DRIFT`] (the
    /// bench's stack check, whose bound is the same 0.5 m).
    Fell,
    /// Its error is more than [`super::report::FAR`] times the scene's own setting's on
    /// some measure scored (the best's, where the own setting is unstable).
    FarAbove,
    /// The named metric is not measured for it.
    Unmeasured,
}

impl Tried {
    /// The accuracy run's figures, when it ran.
    pub fn measured(&self) -> Option<&Measured> {
        match &self.outcome {
            Outcome::Ran(m) => Some(m),
            Outcome::Failed(_) => None,
        }
    }
}

/// The measures that apply to a scene, read from the scene and from its runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Applies {
    /// Overlap: some run saw a contact.
    pub penetration: bool,
    /// Drift: the scene is a jointless pile that starts at rest, and some stable setting
    /// kept its top body within [`RESTING_DRIFT`].
    pub drift: bool,
    /// Joint error: the scene has joints.
    pub joint_error: bool,
    /// Energy: nothing in the scene adds or takes energy (no drag, forces, motors, joint
    /// damping, kinematic bodies) and no run saw a contact.
    pub energy_drift: bool,
}

impl Applies {
    /// The measures of the default score.
    pub fn measures(&self) -> Vec<Metric> {
        WORST_MEASURES
            .into_iter()
            .filter(|m| match m {
                Metric::PenetrationMax => self.penetration,
                Metric::Drift => self.drift,
                Metric::JointError => self.joint_error,
                Metric::EnergyDrift => self.energy_drift,
                _ => false,
            })
            .collect()
    }
}

/// What `tune` found.
#[derive(Clone, Debug)]
pub struct TuneReport {
    pub scene: String,
    pub options: TuneOptions,
    /// Every setting tried, coarse pass first.
    pub tried: Vec<Tried>,
    pub applies: Applies,
    /// For the default score: each counted measure and the value it is divided by (the
    /// best any stable setting reached, lifted to [`floor`]).
    pub normalisers: Vec<(Metric, f64)>,
    /// The scene's own setting, its `[solver]` table (index into `tried`: the grid's
    /// setting of the same counts, or one the fine pass adds).
    pub current: Option<usize>,
    /// The most accurate setting within the budget (index into `tried`).
    pub pick: Option<usize>,
    /// The cheapest setting whose score is within 10% of the pick's.
    pub cheapest_close: Option<usize>,
    /// The settings no other beats on both cost and error, cheapest first.
    pub pareto: Vec<usize>,
    /// With `--metric trajectory`: the true motion the runs were compared with.
    pub truth: Option<String>,
    /// When the grid's settings ran in shards (`tune --shard`, then `--merge`): how
    /// many, and their run.
    pub shards: Option<CoarseShards>,
}

/// The shards a search's coarse pass ran in.
#[derive(Clone, Debug, PartialEq)]
pub struct CoarseShards {
    /// How many shards (N of `--shard I/N`).
    pub count: usize,
    /// Their run id, when they had one (the Slurm array's job id, or `--run-id`).
    pub run: Option<String>,
}

/// Why `tune` has no answer.
#[derive(Clone, Debug, PartialEq)]
pub enum TuneError {
    /// Every setting went unstable or could not run.
    NothingStable,
    /// Even the cheapest stable setting within the error bound costs more than the
    /// budget.
    OverBudget { cheapest: String, ms: f64 },
    /// Stopped by an interrupt before the search finished.
    Interrupted,
    /// `--metric trajectory` on a scene with no true motion to compare with (chaotic
    /// over the run, or a reference that could not run), and why.
    NoTruth(String),
}

impl std::fmt::Display for TuneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TuneError::NothingStable => write!(f, "no setting of the grid runs the scene stably"),
            TuneError::OverBudget { cheapest, ms } => write!(
                f,
                "no setting fits the budget: the cheapest stable one within the error bound, {cheapest}, takes {ms:.4} ms/step"
            ),
            TuneError::Interrupted => write!(f, "interrupted before the search finished"),
            TuneError::NoTruth(why) => write!(
                f,
                "--metric trajectory: no true motion to compare with: {why}"
            ),
        }
    }
}

/// The scene as the bench runs it for `tune`: the top body tracked, energy always
/// measured (whether it counts is decided from the runs), nothing required to stand.
pub fn bench_scene(name: &str, def: &WorldDef, steps: u64) -> BenchScene {
    BenchScene {
        name: name.to_string(),
        about: String::new(),
        def: def.clone(),
        track: Track::Top,
        floor_y: energy_floor(def),
        conservative: true,
        standing: None,
        energy_gain: 0.5,
        primary: Metric::PenetrationMax,
        metrics: WORST_MEASURES.to_vec(),
        full_grid: true,
        budget: Budget {
            steps,
            repeats: 1,
            residual_samples: 0,
            reference_iterations: 1000,
        },
        truth: None,
    }
}

/// A floor for potential energy one scene height below the lowest body (so a pendulum
/// released at its pivot's height starts with energy of the order of what it swings).
fn energy_floor(def: &WorldDef) -> f32 {
    let ys = || def.bodies.iter().map(|b| b.position.y);
    let lo = ys().fold(f32::INFINITY, f32::min);
    let hi = ys().fold(f32::NEG_INFINITY, f32::max);
    if !lo.is_finite() {
        return 0.0;
    }
    // a chain hanging from its anchor reaches down by its joints' lengths
    let joints: f32 = def
        .joints
        .iter()
        .map(|j| {
            let [a, b] = j
                .bodies
                .map(|i| def.bodies.get(i).map_or(Vec2::ZERO, |b| b.position));
            (a - b).length().max(j.length.unwrap_or(0.0))
        })
        .sum();
    lo - (hi - lo).max(joints).max(1.0)
}

/// What [`score_all`] needs to know of the scene itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneFlags {
    /// Nothing in the scene adds or takes energy (no drag, forces, kinematic bodies,
    /// motors, servos or joint damping).
    pub closed: bool,
    /// A pile meant to stand: every body starts at rest and no joint moves anything
    /// (a chain or a pendulum swings from rest, so its top body's path is motion, not
    /// error).
    pub at_rest: bool,
    /// The scene's own setting (its `[solver]` table), whose error sets the bound.
    pub own: Option<Setting>,
}

impl SceneFlags {
    pub fn of(def: &WorldDef) -> SceneFlags {
        SceneFlags {
            closed: closed_system(def),
            at_rest: def.joints.is_empty() && starts_at_rest(def),
            own: Some(Setting::of_scene(def)),
        }
    }
}

/// Whether nothing in the scene itself adds or takes energy.
fn closed_system(def: &WorldDef) -> bool {
    def.drag.is_none()
        && def.forces.is_empty()
        && def
            .bodies
            .iter()
            .all(|b| b.body_type != BodyType::Kinematic)
        && def
            .joints
            .iter()
            .all(|j| j.motor.is_none() && j.servo.is_none() && j.damping == Default::default())
}

fn starts_at_rest(def: &WorldDef) -> bool {
    def.bodies
        .iter()
        .all(|b| b.velocity == Vec2::ZERO && b.angular_velocity == 0.0)
}

/// The neighbours of a coarse setting that the grid skipped.
pub fn fine_candidates(best: &Setting) -> Vec<Setting> {
    let around = |n: u32| -> Vec<u32> {
        let mut v = vec![(n * 3).div_ceil(4), n * 3 / 2];
        v.retain(|&k| k >= 1 && k != n);
        v.dedup();
        v
    };
    match best.kind {
        SolverKind::Pgs => around(best.iterations)
            .into_iter()
            .map(|n| Setting::pgs(n, best.warm_start, best.split_impulse))
            .collect(),
        SolverKind::Xpbd => around(best.substeps)
            .into_iter()
            .map(Setting::xpbd)
            .collect(),
        SolverKind::Soft => {
            let mut v: Vec<Setting> = around(best.substeps)
                .into_iter()
                .map(|n| Setting::soft(n, best.iterations))
                .collect();
            for it in [best.iterations - 1, best.iterations + 1] {
                if it >= 1 {
                    v.push(Setting::soft(best.substeps, it));
                }
            }
            v
        }
    }
}

/// The median of the finite values of `v` (NaN when none is).
fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    super::median(&mut s)
}

/// The runs of one search: the scene, the budgets of its accuracy and timing runs, how
/// many go at once, and the progress count.
struct Search<P> {
    scene: BenchScene,
    /// The scene's own setting.
    own: Setting,
    accuracy: Budget,
    timing: Budget,
    jobs: usize,
    rounds: usize,
    done: usize,
    total: usize,
    progress: P,
}

impl<P: FnMut(usize, usize, &str)> Search<P> {
    /// With `--metric trajectory`, first the true motion (a reference run, or the
    /// scene's closed form), which every run is then compared with.
    fn new(
        name: &str,
        def: &WorldDef,
        options: &TuneOptions,
        mut progress: P,
    ) -> Result<Search<P>, TuneError> {
        let mut scene = bench_scene(name, def, options.steps);
        if options.metric == TuneMetric::Trajectory {
            progress(0, 0, "the true motion (a reference run)");
            let truth = super::truth::Truth::for_scene(
                def,
                options.steps,
                Ok(super::truth::RefSpec::CONVERGED_PGS),
            );
            if crate::output::interrupted() {
                return Err(TuneError::Interrupted);
            }
            match truth {
                super::truth::Truth::Unmeasured(why) => return Err(TuneError::NoTruth(why)),
                t => scene.truth = Some(std::sync::Arc::new(t)),
            }
        }
        let accuracy = Budget {
            residual_samples: if options.metric == TuneMetric::Residual {
                4.min((options.steps / 2) as u32)
            } else {
                0
            },
            ..scene.budget
        };
        let timing = Budget {
            residual_samples: 0,
            ..scene.budget
        };
        Ok(Search {
            scene,
            own: Setting::of_scene(def),
            accuracy,
            timing,
            jobs: options.jobs.max(1),
            rounds: options.rounds.max(1) as usize,
            done: 0,
            total: 0,
            progress,
        })
    }

    /// The accuracy runs of `settings` (the first timing of each), in order.
    fn measure(&mut self, settings: &[Setting], pass: Pass) -> Result<Vec<Tried>, TuneError> {
        let outcomes = run_all(
            &self.scene,
            settings,
            &self.accuracy,
            self.jobs,
            (&mut self.done, self.total),
            &mut self.progress,
        )?;
        Ok(settings
            .iter()
            .zip(outcomes)
            .map(|(s, outcome)| {
                let ms = match &outcome {
                    Outcome::Ran(m) => m.ms_per_step,
                    Outcome::Failed(_) => f64::NAN,
                };
                Tried {
                    setting: *s,
                    pass,
                    outcome,
                    samples: vec![ms],
                    ms_per_step: ms,
                    score: None,
                    dropped: None,
                    reason: None,
                }
            })
            .collect())
    }

    /// `n` more timing rounds over `list`, turn about (each round's runs `jobs` at
    /// once); each setting's cost is then the median of its samples.
    fn time_rounds(
        &mut self,
        tried: &mut [Tried],
        list: &[usize],
        n: usize,
    ) -> Result<(), TuneError> {
        let settings: Vec<Setting> = list.iter().map(|&i| tried[i].setting).collect();
        for _ in 0..n {
            let outcomes = run_all(
                &self.scene,
                &settings,
                &self.timing,
                self.jobs,
                (&mut self.done, self.total),
                &mut self.progress,
            )?;
            for (&i, outcome) in list.iter().zip(outcomes) {
                if let Outcome::Ran(m) = outcome {
                    tried[i].samples.push(m.ms_per_step);
                }
            }
        }
        for t in tried.iter_mut() {
            t.ms_per_step = median(&t.samples);
        }
        Ok(())
    }

    /// The fine pass's settings and their accuracy runs, appended to `tried`: around
    /// each solver kind's most accurate setting that fits (by its cost so far), so that
    /// a kind just behind on the grid can still win between its grid points. Settings
    /// of equal score (they ran alike, such as PGS with and without split impulse on a
    /// scene where it never acts) are parted by grid order, not by cost: which
    /// neighbours are tried does not hang on timing noise, or on which machine timed a
    /// shard.
    fn fine_pass(
        &mut self,
        tried: &mut Vec<Tried>,
        options: &TuneOptions,
        flags: SceneFlags,
    ) -> Result<(), TuneError> {
        score_all(tried, options, flags);
        let mut fine: Vec<Setting> = Vec::new();
        for kind in SolverKind::ALL {
            let of_kind: Vec<Tried> = tried
                .iter()
                .filter(|t| t.setting.kind == kind)
                .cloned()
                .collect();
            if let Some(best) = seed_within(&of_kind, options.budget_ms) {
                for s in fine_candidates(&of_kind[best].setting) {
                    if !tried.iter().any(|t| t.setting == s) && !fine.contains(&s) {
                        fine.push(s);
                    }
                }
            }
        }
        // the scene's own setting, to be scored beside the pick
        if !tried.iter().any(|t| t.setting == self.own) && !fine.contains(&self.own) {
            fine.push(self.own);
        }
        self.total += fine.len() * self.rounds;
        let measured = self.measure(&fine, Pass::Fine)?;
        tried.extend(measured);
        Ok(())
    }

    /// The timing rounds the pick depends on, then the pick: the settings whose cost
    /// is within [`EDGE`] of the budget get as many rounds again; then the scores, the
    /// pick, the cheapest close one and the front.
    fn conclude(
        &mut self,
        name: &str,
        options: &TuneOptions,
        flags: SceneFlags,
        mut tried: Vec<Tried>,
        shards: Option<CoarseShards>,
    ) -> Result<TuneReport, TuneError> {
        // the settings whose cost is within EDGE of the budget decide the pick by a
        // noisy margin: they get as many rounds again
        let edge: Vec<usize> = contenders(&tried, options.budget_ms, 0..tried.len())
            .into_iter()
            .filter(|&i| (tried[i].ms_per_step / options.budget_ms - 1.0).abs() <= EDGE)
            .collect();
        self.total += edge.len() * self.rounds;
        self.time_rounds(&mut tried, &edge, self.rounds)?;
        let (applies, normalisers) = score_all(&mut tried, options, flags);
        let stable: Vec<usize> = (0..tried.len())
            .filter(|&i| tried[i].score.is_some())
            .collect();
        if stable.is_empty() {
            return Err(TuneError::NothingStable);
        }
        let pick = best_within(&tried, options.budget_ms);
        let Some(pick) = pick else {
            let cheapest = stable
                .iter()
                .copied()
                .min_by(|&a, &b| tried[a].ms_per_step.total_cmp(&tried[b].ms_per_step))
                .expect("not empty");
            return Err(TuneError::OverBudget {
                cheapest: tried[cheapest].setting.label(),
                ms: tried[cheapest].ms_per_step,
            });
        };
        let limit = tried[pick].score.unwrap_or(0.0) * 1.1;
        let cheapest_close = stable
            .iter()
            .copied()
            .filter(|&i| tried[i].score.is_some_and(|s| s <= limit))
            .min_by(|&a, &b| {
                tried[a]
                    .ms_per_step
                    .total_cmp(&tried[b].ms_per_step)
                    .then(a.cmp(&b))
            });
        let pareto = pareto_front(&tried);
        let current = tried.iter().position(|t| t.setting == self.own);
        Ok(TuneReport {
            scene: name.to_string(),
            options: *options,
            tried,
            applies,
            normalisers,
            current,
            pick: Some(pick),
            cheapest_close,
            pareto,
            truth: self.scene.truth.as_ref().map(|t| t.describe()),
            shards,
        })
    }
}

/// The settings among `range` still in contention for timing rounds: stable, and whose
/// first timing is within twice the budget.
fn contenders(tried: &[Tried], budget_ms: f64, range: std::ops::Range<usize>) -> Vec<usize> {
    range
        .filter(|&i| {
            tried[i].measured().is_some_and(|m| m.verdict.is_stable())
                && tried[i].samples[0] <= 2.0 * budget_ms
        })
        .collect()
}

/// Runs the search. `progress(done, total, what)` after each run (the total grows when
/// the fine pass and the timing rounds are known). Stops between runs when
/// [`crate::output::interrupted`] says so.
pub fn tune(
    name: &str,
    def: &WorldDef,
    options: &TuneOptions,
    progress: impl FnMut(usize, usize, &str),
) -> Result<TuneReport, TuneError> {
    let flags = SceneFlags::of(def);
    let mut s = Search::new(name, def, options, progress)?;
    let coarse = super::settings_grid();
    s.total = coarse.len() * s.rounds;
    let mut tried = s.measure(&coarse, Pass::Coarse)?;
    s.fine_pass(&mut tried, options, flags)?;
    // timing rounds, turn about, over every stable setting that could still fit
    let all = contenders(&tried, options.budget_ms, 0..tried.len());
    s.total = s.done + all.len() * (s.rounds - 1);
    s.time_rounds(&mut tried, &all, s.rounds - 1)?;
    s.conclude(name, options, flags, tried, None)
}

/// One shard of the search's coarse pass (`tune --shard`): the grid's settings whose
/// index is `shard.index - 1` modulo `shard.count`, each's accuracy run, then the
/// timing rounds, turn about, over those still in contention (as [`tune`] times them).
/// Gives (index in the grid, setting as measured), in grid order.
pub fn tune_shard(
    name: &str,
    def: &WorldDef,
    options: &TuneOptions,
    shard: Shard,
    progress: impl FnMut(usize, usize, &str),
) -> Result<Vec<(usize, Tried)>, TuneError> {
    let mut s = Search::new(name, def, options, progress)?;
    let grid = super::settings_grid();
    let picked = shard.indices(grid.len());
    let settings: Vec<Setting> = picked.iter().map(|&i| grid[i]).collect();
    s.total = settings.len() * s.rounds;
    let mut tried = s.measure(&settings, Pass::Coarse)?;
    let list = contenders(&tried, options.budget_ms, 0..tried.len());
    s.total = s.done + list.len() * (s.rounds - 1);
    s.time_rounds(&mut tried, &list, s.rounds - 1)?;
    Ok(picked.into_iter().zip(tried).collect())
}

/// The rest of the search once the shards of its coarse pass are merged (`tune
/// --merge`): `coarse` is every grid setting, in grid order, as its shard measured and
/// timed it. Runs the fine pass and its timing rounds, then the rounds the pick depends
/// on (within [`EDGE`] of the budget), here, and picks as [`tune`] does.
pub fn tune_merged(
    name: &str,
    def: &WorldDef,
    options: &TuneOptions,
    coarse: Vec<Tried>,
    shards: CoarseShards,
    progress: impl FnMut(usize, usize, &str),
) -> Result<TuneReport, TuneError> {
    let flags = SceneFlags::of(def);
    let mut s = Search::new(name, def, options, progress)?;
    let mut tried = coarse;
    for t in &mut tried {
        t.ms_per_step = median(&t.samples);
    }
    let first_fine = tried.len();
    s.fine_pass(&mut tried, options, flags)?;
    let fine = contenders(&tried, options.budget_ms, first_fine..tried.len());
    s.total = s.done + fine.len() * (s.rounds - 1);
    s.time_rounds(&mut tried, &fine, s.rounds - 1)?;
    s.conclude(name, options, flags, tried, Some(shards))
}

/// A digest of the scene as `tune` runs it (every value of its description, bit for
/// bit): the shards of one search and its merge must run the same scene.
pub fn scene_digest(def: &WorldDef) -> String {
    struct Fnv(u64);
    impl std::fmt::Write for Fnv {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            for b in s.bytes() {
                self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
            }
            Ok(())
        }
    }
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    let _ = std::fmt::Write::write_fmt(&mut h, format_args!("{def:?}"));
    format!("{:016x}", h.0)
}

/// Runs every setting of `settings` on `scene`, `jobs` at once, counting each into
/// `count` (runs done, runs in all) and reporting it to `progress`; the outcomes in
/// the settings' order, or `Interrupted` when a run was left out.
fn run_all(
    scene: &BenchScene,
    settings: &[Setting],
    budget: &Budget,
    jobs: usize,
    count: (&mut usize, usize),
    progress: &mut impl FnMut(usize, usize, &str),
) -> Result<Vec<Outcome>, TuneError> {
    let (done, total) = count;
    let (outcomes, complete) = super::run_jobs(
        settings,
        jobs,
        |s| run_case(scene, s, budget),
        |i, _| {
            *done += 1;
            progress(*done, total, &settings[i].label());
            Ok::<(), TuneError>(())
        },
    )?;
    if !complete {
        return Err(TuneError::Interrupted);
    }
    Ok(outcomes.into_iter().map(|o| o.expect("complete")).collect())
}

/// The most accurate stable setting whose cost fits (ties: the earlier), for the fine
/// pass to search around.
fn seed_within(tried: &[Tried], budget_ms: f64) -> Option<usize> {
    (0..tried.len())
        .filter(|&i| tried[i].score.is_some() && tried[i].ms_per_step <= budget_ms)
        .min_by(|&a, &b| {
            let (sa, sb) = (tried[a].score.unwrap_or(0.0), tried[b].score.unwrap_or(0.0));
            sa.total_cmp(&sb).then(a.cmp(&b))
        })
}

/// The most accurate stable setting whose cost fits (ties: the cheaper, then the
/// earlier).
fn best_within(tried: &[Tried], budget_ms: f64) -> Option<usize> {
    (0..tried.len())
        .filter(|&i| tried[i].score.is_some() && tried[i].ms_per_step <= budget_ms)
        .min_by(|&a, &b| {
            let (sa, sb) = (tried[a].score.unwrap_or(0.0), tried[b].score.unwrap_or(0.0));
            sa.total_cmp(&sb)
                .then(tried[a].ms_per_step.total_cmp(&tried[b].ms_per_step))
                .then(a.cmp(&b))
        })
}

/// The stable settings not beaten on both cost and score by another, cheapest first.
pub fn pareto_front(tried: &[Tried]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..tried.len())
        .filter(|&i| tried[i].score.is_some() && tried[i].ms_per_step.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        tried[a]
            .ms_per_step
            .total_cmp(&tried[b].ms_per_step)
            .then(
                tried[a]
                    .score
                    .unwrap_or(0.0)
                    .total_cmp(&tried[b].score.unwrap_or(0.0)),
            )
            .then(a.cmp(&b))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        let s = tried[i].score.unwrap_or(0.0);
        if s < best {
            front.push(i);
            best = s;
        }
    }
    front
}

/// Decides which measures apply, and gives every setting its score or the reason it is
/// dropped. Returns what applies and the normalisers of the default score.
pub fn score_all(
    tried: &mut [Tried],
    options: &TuneOptions,
    flags: SceneFlags,
) -> (Applies, Vec<(Metric, f64)>) {
    for t in tried.iter_mut() {
        (t.reason, t.dropped) = match &t.outcome {
            Outcome::Failed(e) => (
                Some(DropReason::Failed),
                Some(format!("could not run: {e}")),
            ),
            Outcome::Ran(m) => match &m.verdict {
                super::Verdict::Unstable(why) => {
                    (Some(DropReason::Unstable), Some(format!("unstable: {why}")))
                }
                super::Verdict::Stable => (None, None),
            },
        };
        t.score = None;
    }
    let ran = || tried.iter().filter_map(|t| t.measured());
    fn best_of(tried: &[Tried], m: Metric) -> f64 {
        tried
            .iter()
            .filter(|t| t.dropped.is_none())
            .filter_map(|t| t.measured())
            .map(|x| x.metric(m))
            .filter(|v| v.is_finite())
            .fold(f64::INFINITY, f64::min)
    }
    let applies = Applies {
        penetration: ran().any(|m| m.penetration_max > 0.0),
        drift: false,
        joint_error: ran().any(|m| m.joint_error.is_finite()),
        energy_drift: false,
    };
    let energy_possible = !applies.penetration && ran().any(|m| m.energy_drift.is_finite());
    let applies = Applies {
        drift: flags.at_rest && best_of(tried, Metric::Drift) <= RESTING_DRIFT,
        energy_drift: energy_possible && flags.closed,
        ..applies
    };
    // a pile meant to stand (some setting kept it up) fell under the settings whose top
    // body moved more than the bench's bound: unstable, as the bench says
    if applies.drift {
        for t in tried.iter_mut().filter(|t| t.dropped.is_none()) {
            let d = t.measured().map_or(f64::NAN, |m| m.drift);
            if d > RESTING_DRIFT {
                t.reason = Some(DropReason::Fell);
                t.dropped = Some(format!(
                    "fell: the top body moved {d:.3} m (> {RESTING_DRIFT} m)"
                ));
            }
        }
    }
    let normalisers: Vec<(Metric, f64)> = applies
        .measures()
        .into_iter()
        .map(|m| (m, best_of(tried, m).max(floor(m))))
        .collect();
    // the error bound: FAR times the scene's own setting's error on each measure
    // scored (at least FAR times the floor), or FAR times the best where the own
    // setting is not among the stable ones
    let far = super::report::FAR;
    let own = tried
        .iter()
        .find(|t| Some(t.setting) == flags.own && t.dropped.is_none())
        .and_then(|t| t.measured().cloned());
    let scored: Vec<Metric> = match options.metric.measure() {
        Some(m) => vec![m],
        None => applies.measures(),
    };
    let bounds: Vec<(Metric, f64)> = scored
        .iter()
        .map(|&m| {
            let base = own
                .as_ref()
                .map(|o| o.metric(m))
                .filter(|v| v.is_finite())
                .unwrap_or_else(|| best_of(tried, m));
            (m, far * base.max(floor(m)))
        })
        .collect();
    let whose = if own.is_some() {
        "the current setting's error"
    } else {
        "the best error"
    };
    for t in tried.iter_mut() {
        if t.dropped.is_some() {
            continue;
        }
        let Some(m) = t.measured() else { continue };
        let score = match options.metric.measure() {
            Some(metric) => {
                let v = m.metric(metric);
                if !v.is_finite() {
                    t.reason = Some(DropReason::Unmeasured);
                    t.dropped = Some(format!("{} is not measured here", options.metric.name()));
                    continue;
                }
                v
            }
            None => normalisers
                .iter()
                .map(|&(metric, n)| m.metric(metric) / n)
                .fold(0.0f64, |a, v| if v.is_nan() { a } else { a.max(v) }),
        };
        if let Some((k, v)) = super::report::above_bound(&bounds, m) {
            let b = bounds.iter().find(|b| b.0 == k).map_or(f64::NAN, |b| b.1);
            t.reason = Some(DropReason::FarAbove);
            t.dropped = Some(format!(
                "error above the bound: {} {v:.3e} > {b:.3e} ({far} times {whose})",
                k.name()
            ));
        } else {
            t.score = Some(score);
        }
    }
    (applies, normalisers)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::Verdict;

    fn measured(pen: f64, drift: f64, stable: bool) -> Measured {
        Measured {
            ms_per_step: 0.0,
            stage_ms: [0.0; 5],
            steps: 10,
            penetration_max: pen,
            penetration_mean: pen / 2.0,
            drift,
            joint_error: f64::NAN,
            energy_drift: f64::NAN,
            residual: f64::NAN,
            trajectory: None,
            verdict: if stable {
                Verdict::Stable
            } else {
                Verdict::Unstable("energy grew".into())
            },
        }
    }

    fn tried(iterations: u32, ms: f64, m: Measured) -> Tried {
        Tried {
            setting: Setting::pgs(iterations, true, true),
            pass: Pass::Coarse,
            outcome: Outcome::Ran(m),
            samples: vec![ms],
            ms_per_step: ms,
            score: None,
            dropped: None,
            reason: None,
        }
    }

    const RESTING: SceneFlags = SceneFlags {
        closed: false,
        at_rest: true,
        own: None,
    };

    fn options(budget_ms: f64) -> TuneOptions {
        TuneOptions {
            budget_ms,
            metric: TuneMetric::Worst,
            steps: 10,
            rounds: 1,
            jobs: 1,
        }
    }

    #[test]
    fn the_worst_score_divides_each_measure_by_the_best_stable_value() {
        let mut t = vec![
            tried(1, 1.0, measured(0.010, 0.002, true)),
            tried(2, 2.0, measured(0.002, 0.004, true)),
            // the most accurate on both, but unstable: it sets no normaliser
            tried(3, 0.5, measured(0.0001, 0.0001, false)),
        ];
        let (applies, norm) = score_all(&mut t, &options(10.0), RESTING);
        assert!(applies.penetration && applies.drift);
        assert!(!applies.joint_error && !applies.energy_drift);
        assert_eq!(
            norm,
            vec![(Metric::PenetrationMax, 0.002), (Metric::Drift, 0.002)]
        );
        // 0.010 / 0.002 = 5 (penetration is its worst); 0.004 / 0.002 = 2 (drift)
        assert!((t[0].score.unwrap() - 5.0).abs() < 1e-12);
        assert!((t[1].score.unwrap() - 2.0).abs() < 1e-12);
        assert!(t[2].score.is_none());
        assert!(t[2].dropped.as_deref().unwrap().starts_with("unstable"));
    }

    #[test]
    fn an_unstable_or_over_budget_setting_is_never_picked() {
        let mut t = vec![
            tried(1, 1.0, measured(0.010, 0.010, true)),
            tried(2, 3.0, measured(0.001, 0.001, true)),
            tried(3, 0.2, measured(0.0001, 0.0001, false)),
        ];
        score_all(&mut t, &options(2.0), RESTING);
        // the unstable one is cheapest and most accurate; the second is over budget
        assert_eq!(best_within(&t, 2.0), Some(0));
        assert_eq!(best_within(&t, 5.0), Some(1));
        assert_eq!(best_within(&t, 0.5), None);
        assert_eq!(pareto_front(&t), vec![0, 1]);
    }

    #[test]
    fn drift_counts_only_in_a_scene_meant_to_rest() {
        // every setting lets the top body move metres: the scene is not a resting one
        let mut t = vec![
            tried(1, 1.0, measured(0.010, 3.0, true)),
            tried(2, 2.0, measured(0.002, 2.0, true)),
        ];
        let (applies, norm) = score_all(&mut t, &options(10.0), RESTING);
        assert!(!applies.drift);
        assert_eq!(norm.len(), 1);
        // a scene that starts moving never counts drift either
        let mut t = vec![tried(1, 1.0, measured(0.010, 0.001, true))];
        let moving = SceneFlags {
            closed: false,
            at_rest: false,
            own: None,
        };
        assert!(!score_all(&mut t, &options(10.0), moving).0.drift);
    }

    #[test]
    fn a_named_metric_drops_the_settings_that_do_not_measure_it() {
        let mut t = vec![tried(1, 1.0, measured(0.010, 0.010, true))];
        let o = TuneOptions {
            metric: TuneMetric::Residual,
            ..options(10.0)
        };
        score_all(&mut t, &o, RESTING);
        assert!(t[0].score.is_none());
        assert!(t[0].dropped.as_deref().unwrap().contains("residual"));
    }

    #[test]
    fn the_fine_pass_fills_between_the_grid_counts() {
        let labels = |v: Vec<Setting>| v.iter().map(|s| s.label()).collect::<Vec<_>>();
        assert_eq!(
            labels(fine_candidates(&Setting::pgs(8, true, false))),
            ["pgs 6 warm", "pgs 12 warm"]
        );
        assert_eq!(
            labels(fine_candidates(&Setting::soft(4, 2))),
            [
                "soft 3 substeps x 2",
                "soft 6 substeps x 2",
                "soft 4 substeps x 1",
                "soft 4 substeps x 3"
            ]
        );
        assert_eq!(
            labels(fine_candidates(&Setting::xpbd(1))),
            ["xpbd 1 substep"][..0]
        );
        assert_eq!(
            labels(fine_candidates(&Setting::xpbd(2))),
            ["xpbd 3 substeps"]
        );
    }

    #[test]
    fn write_setting_keeps_comments_and_order_and_drops_the_old_spelling() {
        let text = "# my scene\nname = \"s\"\n\n[solver]\n# the step\ndt = 0.01 # small\nsoft_step = true\niterations = 4 # keep this comment\n\n[[body]]\nname = \"b\"\n";
        let out = write_setting(text, &Setting::pgs(16, true, false)).unwrap();
        assert!(out.starts_with("# my scene\nname = \"s\"\n"));
        assert!(out.contains("# the step\ndt = 0.01 # small\n"));
        assert!(out.contains("iterations = 16 # keep this comment\n"));
        assert!(!out.contains("soft_step"));
        for line in [
            "kind = \"pgs\"",
            "substeps = 1",
            "warm_start = true",
            "split_impulse = false",
            "tolerance = 0.0",
        ] {
            assert!(out.contains(line), "{line} missing from:\n{out}");
        }
        // [solver] stays before the bodies
        assert!(out.find("[solver]").unwrap() < out.find("[[body]]").unwrap());
        // and a file without [solver] gains one
        let out = write_setting("name = \"s\"\n", &Setting::soft(4, 2)).unwrap();
        assert!(
            out.contains("[solver]\nkind = \"soft\"\nsubsteps = 4\niterations = 2\n"),
            "{out}"
        );
    }

    #[test]
    fn the_report_states_the_current_setting_the_pick_and_why_others_were_dropped() {
        let current = Setting::pgs(4, true, true);
        let flags = SceneFlags {
            own: Some(current),
            ..RESTING
        };
        let mut t = vec![
            // the current setting: 4 mm of overlap, 2 mm of drift
            tried(4, 1.0, measured(0.004, 0.002, true)),
            // the pick: more accurate, within the budget
            tried(8, 1.5, measured(0.002, 0.002, true)),
            // the most accurate, but over the budget
            tried(16, 3.0, measured(0.001, 0.001, true)),
            // above the bound: 50 mm of overlap is more than 10 times the current's 4
            tried(2, 0.5, measured(0.05, 0.002, true)),
            // the top fell 0.8 m: a fallen pile, as the bench says
            tried(1, 0.3, measured(0.003, 0.8, true)),
            // unstable
            tried(3, 0.2, measured(0.001, 0.001, false)),
        ];
        let o = options(2.0);
        let (applies, normalisers) = score_all(&mut t, &o, flags);
        let reasons: Vec<Option<DropReason>> = t.iter().map(|t| t.reason).collect();
        assert_eq!(
            reasons,
            [
                None,
                None,
                None,
                Some(DropReason::FarAbove),
                Some(DropReason::Fell),
                Some(DropReason::Unstable)
            ]
        );
        assert!(t[3].dropped.as_deref().unwrap().contains("penetration_max"));
        assert!(
            t[4].dropped
                .as_deref()
                .unwrap()
                .starts_with("fell: the top body moved 0.800 m")
        );
        let report = TuneReport {
            scene: "s".into(),
            options: o,
            pick: best_within(&t, o.budget_ms),
            current: Some(0),
            cheapest_close: None,
            pareto: pareto_front(&t),
            tried: t,
            applies,
            normalisers,
            truth: None,
            shards: None,
        };
        assert_eq!(report.pick, Some(1));
        let md = markdown(&report);
        // scores: each measure over the best stable one (1 mm overlap, 1 mm drift)
        for line in [
            "- the scene's current setting: pgs 4 warm+split (1.0000 ms/step, score 4.00)",
            "- most accurate within the budget: pgs 8 warm+split (1.5000 ms/step, score 2.00)",
            "- the pick differs from the scene's current setting: score 2.00 against the current 4.00, 1.5000 against 1.0000 ms/step",
            "Tried 6 settings; 4 could not be picked: 1 unstable, 1 fell, 1 error above the bound, 1 over the budget.",
            "score = max(penetration_max / 1.00 mm, drift / 0.001 m)",
        ] {
            assert!(md.contains(line), "missing {line:?} in:\n{md}");
        }
        let j = json(&report);
        assert_eq!(j["pick_is_current"], false);
        assert_eq!(j["not_picked"]["over_the_budget"], 1);
        assert_eq!(j["current"]["setting"]["label"], "pgs 4 warm+split");
        // when the pick is the current setting, the report says to keep it
        let report = TuneReport {
            current: Some(1),
            ..report
        };
        assert!(markdown(&report).contains("- the pick is the scene's current setting: keep it"));
        // a current setting within 10% of the pick's score, and cheaper, is worth keeping
        let mut close = report.clone();
        close.current = Some(0);
        close.tried[0].score = Some(2.1);
        assert!(markdown(&close).contains("keeping it costs little"));
    }
}
