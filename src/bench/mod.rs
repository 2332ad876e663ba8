//! The bench: what each solver setting costs and how right it is, scene by scene.
//!
//! For every scene of a suite and every setting of the grid (PGS at 1..32 sweeps with
//! warm start and split impulse on and off, XPBD at 1..32 substeps, the soft step at 1..32
//! substeps), [`run_case`] builds
//! the world, steps it and records the median wall time per step over repeats, the time
//! per pipeline stage, and the accuracy measures of `shared/benchmarks.md`: penetration
//! (max, mean), drift of the tracked body (the top of a stack), joint error, energy
//! drift, the residual against the same step's MLCP solved to convergence, and a
//! stable verdict. A case that blows up is stopped early and reported unstable.
//!
//! [`report`] writes `results.csv` and `results.md`, [`plot`] one SVG per scene, and
//! [`extremes`] the one-thing-at-a-time stability sweeps behind `stability.md`;
//! [`scaling`] times the benchmark pyramid from 1k to 80k boxes on 1 and 2 threads.

// The suites, reports, plots, shards and tuner are the lab's (feature `lab`); the
// scenes, the extremes' worlds and the truth a case is measured against are not.
#[cfg(feature = "lab")]
pub mod box2d;
#[cfg(feature = "lab")]
pub mod contention;
#[cfg(feature = "lab")]
pub mod convergence;
pub mod extremes;
#[cfg(feature = "lab")]
pub mod plot;
#[cfg(feature = "lab")]
pub mod report;
#[cfg(feature = "lab")]
pub mod scaling;
pub mod scenes;
#[cfg(feature = "lab")]
pub mod shard;
#[cfg(feature = "lab")]
pub mod slurm;
pub mod truth;
#[cfg(feature = "lab")]
pub mod tune;

use std::time::Instant;

use crate::defs::{SolverKind, SolverOverrides, SolverSettings, WorldDef};
use crate::math::Vec2;
use crate::world::World;

pub use scenes::{BenchScene, Metric, Track};

/// Which scenes to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Suite {
    /// A couple of minutes: pyramid (base 20), stack, particles, pendulum, chain, and
    /// the model comparisons.
    Quick,
    /// Under 15 minutes: quick plus the large pyramid, mass ratios, friction ramp,
    /// overlap recovery, ball and chain, double pendulum.
    Standard,
    /// The stability sweeps (see [`extremes`]).
    Extremes,
    /// Box2D v3's benchmark set (see [`box2d`]).
    Box2d,
}

impl Suite {
    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Suite::Quick => "quick",
            Suite::Standard => "standard",
            Suite::Extremes => "extremes",
            Suite::Box2d => "box2d",
        }
    }
}

/// A solver family: one curve on a plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Family {
    PgsWarmSplit,
    PgsWarm,
    PgsSplit,
    PgsCold,
    Xpbd,
    /// The soft step (soft contacts and joints, substeps reusing one collide).
    Soft,
}

impl Family {
    /// Every family, in plotting order.
    pub const ALL: [Family; 6] = [
        Family::PgsWarmSplit,
        Family::PgsWarm,
        Family::PgsSplit,
        Family::PgsCold,
        Family::Xpbd,
        Family::Soft,
    ];

    /// A short name for legends and tables.
    pub fn name(self) -> &'static str {
        match self {
            Family::PgsWarmSplit => "PGS warm+split",
            Family::PgsWarm => "PGS warm",
            Family::PgsSplit => "PGS split",
            Family::PgsCold => "PGS cold",
            Family::Xpbd => "XPBD",
            Family::Soft => "Soft step",
        }
    }

    fn of(s: &SolverSettings) -> Family {
        match (s.kind, s.warm_start, s.split_impulse) {
            (SolverKind::Xpbd, _, _) => Family::Xpbd,
            (SolverKind::Soft, _, _) => Family::Soft,
            (SolverKind::Pgs, true, true) => Family::PgsWarmSplit,
            (SolverKind::Pgs, true, false) => Family::PgsWarm,
            (SolverKind::Pgs, false, true) => Family::PgsSplit,
            (SolverKind::Pgs, false, false) => Family::PgsCold,
        }
    }
}

/// One solver setting of the grid: what the bench overrides of a scene's `[solver]`
/// (the scene keeps its dt, slop and Baumgarte factor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setting {
    pub kind: SolverKind,
    /// PGS sweeps per (sub)step, or XPBD iterations per substep.
    pub iterations: u32,
    pub substeps: u32,
    pub warm_start: bool,
    pub split_impulse: bool,
    /// PGS early exit; the grid uses 0 so a row runs exactly `iterations` sweeps.
    pub tolerance: f32,
}

impl Setting {
    /// PGS with a fixed number of sweeps (tolerance 0: no early exit).
    pub fn pgs(iterations: u32, warm_start: bool, split_impulse: bool) -> Setting {
        Setting {
            kind: SolverKind::Pgs,
            iterations,
            substeps: 1,
            warm_start,
            split_impulse,
            tolerance: 0.0,
        }
    }

    /// The soft step: `substeps` substeps of `iterations` soft sweeps (and a relax sweep).
    pub fn soft(substeps: u32, iterations: u32) -> Setting {
        Setting {
            kind: SolverKind::Soft,
            iterations,
            substeps,
            warm_start: true,
            split_impulse: false,
            tolerance: 0.0,
        }
    }

    /// XPBD with one iteration per substep.
    pub fn xpbd(substeps: u32) -> Setting {
        Setting {
            kind: SolverKind::Xpbd,
            iterations: 1,
            substeps,
            warm_start: true,
            split_impulse: true,
            tolerance: 0.0,
        }
    }

    /// The solver's own defaults (the soft step: 8 substeps of 1 sweep; PGS: 10 sweeps,
    /// tolerance 1e-4, warm start, split impulse; XPBD: 20 substeps of 1 iteration), as
    /// a user gets them.
    pub fn defaults(kind: SolverKind) -> Setting {
        Setting::of(&SolverSettings::defaults(kind))
    }

    /// The grid's view of complete settings: the counts and, for PGS, the modes and
    /// tolerance. The keys a kind does not read are set as the grid sets them (the soft
    /// step reads neither split impulse nor tolerance; XPBD neither the modes nor the
    /// tolerance), so a scene's own setting equals the grid's setting of the same counts.
    pub fn of(s: &SolverSettings) -> Setting {
        match s.kind {
            SolverKind::Pgs => Setting {
                kind: SolverKind::Pgs,
                iterations: s.iterations,
                substeps: s.substeps,
                warm_start: s.warm_start,
                split_impulse: s.split_impulse,
                tolerance: s.tolerance,
            },
            SolverKind::Soft => Setting {
                warm_start: s.warm_start,
                ..Setting::soft(s.substeps, s.iterations)
            },
            SolverKind::Xpbd => Setting {
                iterations: s.iterations,
                ..Setting::xpbd(s.substeps)
            },
        }
    }

    /// The setting a scene runs at by itself: its `[solver]` table over the defaults.
    pub fn of_scene(def: &WorldDef) -> Setting {
        Setting::of(&def.solver.resolve())
    }

    pub fn family(&self) -> Family {
        Family::of(&self.resolve(&SolverOverrides::default()))
    }

    /// A short label: `pgs 8 warm+split`, `pgs 8 cold`, `xpbd 16 substeps`.
    pub fn label(&self) -> String {
        match self.kind {
            SolverKind::Soft => format!("soft {} substeps x {}", self.substeps, self.iterations)
                .replace("soft 1 substeps", "soft 1 substep"),
            SolverKind::Pgs => {
                let mode = match (self.warm_start, self.split_impulse) {
                    (true, true) => "warm+split",
                    (true, false) => "warm",
                    (false, true) => "split",
                    (false, false) => "cold",
                };
                let tol = if self.tolerance > 0.0 {
                    format!(" tol {:e}", self.tolerance)
                } else {
                    String::new()
                };
                format!("pgs {} {mode}{tol}", self.iterations)
            }
            SolverKind::Xpbd if self.iterations == 1 => format!("xpbd {} substeps", self.substeps)
                .replace("xpbd 1 substeps", "xpbd 1 substep"),
            SolverKind::Xpbd => format!(
                "xpbd {} substeps x {} iterations",
                self.substeps, self.iterations
            ),
        }
    }

    /// The complete settings: the scene's `[solver]` table with this setting on top.
    pub fn resolve(&self, scene: &SolverOverrides) -> SolverSettings {
        scene
            .merged(SolverOverrides {
                kind: Some(self.kind),
                iterations: Some(self.iterations),
                substeps: Some(self.substeps),
                warm_start: Some(self.warm_start),
                split_impulse: Some(self.split_impulse),
                tolerance: Some(self.tolerance),
                // the lab measures the solver: nothing sleeps (as in Box2D's benchmarks)
                sleep: Some(false),
                ..Default::default()
            })
            .resolve()
    }
}

/// PGS sweep counts and XPBD substep counts of the grid.
pub const GRID_COUNTS: [u32; 6] = [1, 2, 4, 8, 16, 32];

/// The settings grid: PGS at 1..32 sweeps x warm start on/off x split impulse on/off,
/// then XPBD at 1..32 substeps, then the soft step at 1..32 substeps of 1 sweep (the
/// scenes' own count: the default is 8 substeps of 1 sweep).
pub fn settings_grid() -> Vec<Setting> {
    let mut v = Vec::new();
    for (warm, split) in [(true, true), (true, false), (false, true), (false, false)] {
        for n in GRID_COUNTS {
            v.push(Setting::pgs(n, warm, split));
        }
    }
    for n in GRID_COUNTS {
        v.push(Setting::xpbd(n));
    }
    for n in GRID_COUNTS {
        v.push(Setting::soft(n, 1));
    }
    v
}

/// The largest anchor separation of the world's joints (m), or `None` for a world
/// without joints.
pub fn joint_error(world: &World) -> Option<f32> {
    (!world.joints.is_empty()).then(|| world.joint_error())
}

/// How long and how often to run a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    pub steps: u64,
    pub repeats: u32,
    /// Steps at which the residual is measured (evenly spread; 0 = none).
    pub residual_samples: u32,
    /// Sweep cap of the converged reference solve.
    pub reference_iterations: u32,
}

/// Whether a run held up, and if not, why.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    Stable,
    Unstable(String),
}

impl Verdict {
    pub fn is_stable(&self) -> bool {
        matches!(self, Verdict::Stable)
    }
}

/// The figures of one scene run at one setting.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    /// Median over repeats of each repeat's median wall time per step (ms); the first
    /// step (which builds the contact cache) and residual-sampled steps are not timed.
    pub ms_per_step: f64,
    /// Median time per stage over the timed steps of every repeat (ms): forces, broad
    /// phase, narrow phase, solve, integrate.
    pub stage_ms: [f64; 5],
    pub steps: u64,
    /// Deepest overlap seen by the narrow phase, max and mean over the steps (m).
    pub penetration_max: f64,
    pub penetration_mean: f64,
    /// How far the tracked body moved from its start (m); NaN when the scene tracks none.
    pub drift: f64,
    /// Largest joint anchor separation over the run (m); NaN without joints.
    pub joint_error: f64,
    /// (E_end - E_start) / |E_start| for a scene that conserves energy, else NaN.
    pub energy_drift: f64,
    /// ||lambda - lambda*|| / ||lambda*|| over the sampled steps, lambda* being the same
    /// step solved by PGS to convergence from the same state; NaN when not measured
    /// (no contacts, XPBD, substeps).
    pub residual: f64,
    /// The error against the scene's true motion ([`BenchScene::truth`]), when it has
    /// one (`--metric trajectory`).
    pub trajectory: Option<truth::TrajError>,
    pub verdict: Verdict,
}

impl Measured {
    /// The value of one accuracy measure (NaN where it does not apply).
    pub fn metric(&self, m: Metric) -> f64 {
        match m {
            Metric::PenetrationMax => self.penetration_max,
            Metric::PenetrationMean => self.penetration_mean,
            Metric::Drift => self.drift,
            Metric::JointError => self.joint_error,
            Metric::EnergyDrift => self.energy_drift.abs(),
            Metric::Residual => self.residual,
            Metric::Trajectory => self.trajectory.map_or(f64::NAN, |t| t.pos_rms),
        }
    }
}

/// What came of running a scene at a setting.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Ran(Measured),
    /// The scene could not be built for another reason.
    Failed(String),
}

/// One row of the results.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub scene: String,
    pub setting: Setting,
    pub outcome: Outcome,
}

/// Kinetic plus potential energy (J), the potential measured from height `floor_y`:
/// E = sum 1/2 m v^2 + 1/2 I w^2 - m g . (x - (0, floor_y)).
pub fn energy_about(world: &World, floor_y: f32) -> f64 {
    let g = world.gravity.unwrap_or(Vec2::ZERO);
    world
        .bodies
        .iter()
        .filter(|b| b.is_dynamic())
        .map(|b| {
            let v = b.velocity.as_dvec2();
            let ke = 0.5 * b.mass as f64 * v.length_squared()
                + 0.5 * b.inertia as f64 * (b.angular_velocity as f64).powi(2);
            let rel = b.position.as_dvec2() - glam::DVec2::new(0.0, floor_y as f64);
            ke - b.mass as f64 * g.as_dvec2().dot(rel)
        })
        .sum()
}

/// An energy scale for the "bounded energy" check: |E_start|, or the work of gravity
/// over 1 m on every dynamic body, or 1 J, whichever is largest.
fn energy_scale(world: &World, e_start: f64) -> f64 {
    let g = world.gravity.map_or(0.0, |g| g.length() as f64);
    let weight: f64 = world
        .bodies
        .iter()
        .filter(|b| b.is_dynamic())
        .map(|b| b.mass as f64 * g)
        .sum();
    e_start.abs().max(weight).max(1.0)
}

/// The index of the body a scene tracks, if any.
pub fn tracked_body(world: &World, track: &Track) -> Option<usize> {
    match track {
        Track::None => None,
        Track::Top => world
            .bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| b.is_dynamic())
            .max_by(|(i, a), (j, b)| a.position.y.total_cmp(&b.position.y).then(j.cmp(i)))
            .map(|(i, _)| i),
        Track::Named(name) => world.body_index(name),
    }
}

/// The median of `v` (sorted in place; the mean of the middle two for an even count;
/// NaN when empty).
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Builds a world for a scene description at a setting.
// The error is the row's outcome itself, built once per scene and setting: its size
// does not matter.
#[allow(clippy::result_large_err)]
pub fn build(def: &WorldDef, setting: &Setting) -> Result<World, Outcome> {
    let settings = setting.resolve(&def.solver);
    World::from_def(def, settings).map_err(|e| Outcome::Failed(e.to_string()))
}

/// Runs one scene at one setting: `budget.repeats` timed runs of `budget.steps` steps;
/// the accuracy figures come from the first (the runs are deterministic).
pub fn run_case(scene: &BenchScene, setting: &Setting, budget: &Budget) -> Outcome {
    let def = &scene.def;
    let mut timings = Vec::with_capacity(budget.repeats as usize);
    let mut stages: [Vec<f64>; 5] = Default::default();
    let mut first: Option<Measured> = None;
    for repeat in 0..budget.repeats.max(1) {
        let mut world = match build(def, setting) {
            Ok(w) => w,
            Err(o) => return o,
        };
        let accuracy = repeat == 0;
        // the residual against a converged solve of the same MLCP: classic PGS with one
        // substep (the soft step's rows are softened on purpose, and XPBD has no MLCP)
        let residual_on = accuracy
            && budget.residual_samples > 0
            && world.settings.kind == SolverKind::Pgs
            && world.settings.substeps == 1;
        // at most every other step is sampled, so at least half the steps are timed
        let sample_every = (budget.steps / (budget.residual_samples as u64 + 1)).max(2);
        let tracked = tracked_body(&world, &scene.track);
        let start_pos = tracked.map(|i| world.bodies[i].position);
        let e_start = energy_about(&world, scene.floor_y);
        let e_scale = energy_scale(&world, e_start);
        let mut e_max = e_start;
        let (mut pen_max, mut pen_sum) = (0.0f64, 0.0f64);
        let mut joint_max: Option<f64> = None;
        let (mut res_num, mut res_den) = (0.0f64, 0.0f64);
        let (mut lam, mut lam_ref) = (Vec::new(), Vec::new());
        // capacity bounded: `steps` may come from the command line
        let mut step_ms = Vec::with_capacity((budget.steps as usize).min(1 << 16));
        let mut failure: Option<String> = None;
        let mut steps_done = 0u64;
        let mut tracker = scene
            .truth
            .as_deref()
            .filter(|_| accuracy)
            .and_then(|t| truth::Tracker::new(t, &world));
        for k in 0..budget.steps {
            let sample = residual_on && k > 0 && k % sample_every == 0;
            if sample {
                // the same step's MLCP from the same state, solved to convergence
                let mut reference = world.clone();
                reference.settings.iterations = budget.reference_iterations;
                reference.settings.tolerance = 1e-8;
                if reference.step().is_ok() {
                    reference.contact_lambdas(&mut lam_ref);
                }
            }
            let t = Instant::now();
            let r = world.step();
            let ms = t.elapsed().as_secs_f64() * 1e3;
            match r {
                Ok(()) => {}
                Err(e) => {
                    failure = Some(format!("non-finite state at step {k}: {e}"));
                    break;
                }
            }
            steps_done += 1;
            let st = *world.stats();
            if k > 0 && !sample {
                step_ms.push(ms);
                for (acc, v) in stages.iter_mut().zip([
                    st.ms_forces,
                    st.ms_broad,
                    st.ms_narrow,
                    st.ms_solve,
                    st.ms_integrate,
                ]) {
                    acc.push(v as f64);
                }
            }
            if !accuracy {
                continue;
            }
            if sample {
                world.contact_lambdas(&mut lam);
                if lam.len() == lam_ref.len() && !lam.is_empty() {
                    for (a, b) in lam.iter().zip(&lam_ref) {
                        res_num += ((a - b) as f64).powi(2);
                        res_den += (*b as f64).powi(2);
                    }
                }
            }
            pen_max = pen_max.max(st.penetration as f64);
            pen_sum += st.penetration as f64;
            if let Some(t) = tracker.as_mut() {
                t.observe(k as usize + 1, &world);
            }
            let e = energy_about(&world, scene.floor_y);
            e_max = e_max.max(e);
            if e - e_start > BLOW_UP * e_scale {
                // far past unstable: the next steps' contact search would grow with the
                // speeds (every body reaching every other), so the case stops here
                failure = Some(format!(
                    "blew up: energy rose by {:.3e} J by step {k}; stopped",
                    e - e_start
                ));
                break;
            }
            if let Some(j) = joint_error(&world) {
                joint_max = Some(joint_max.unwrap_or(0.0).max(j as f64));
            }
        }
        timings.push(median(&mut step_ms));
        if !accuracy {
            continue;
        }
        let e_end = energy_about(&world, scene.floor_y);
        let drift = match (tracked, start_pos) {
            (Some(i), Some(p0)) => (world.bodies[i].position - p0).length() as f64,
            _ => f64::NAN,
        };
        let mut reasons = Vec::new();
        if let Some(f) = failure {
            reasons.push(f);
        } else {
            if !(e_max - e_start <= scene.energy_gain * e_scale) {
                reasons.push(format!(
                    "energy grew by {:.3} J (bound {:.3} J)",
                    e_max - e_start,
                    scene.energy_gain * e_scale
                ));
            }
            if let Some(tol) = scene.standing
                && !(drift <= tol as f64)
            {
                reasons.push(format!(
                    "stack fell: tracked body moved {drift:.3} m (> {tol} m)"
                ));
            }
        }
        let verdict = if reasons.is_empty() {
            Verdict::Stable
        } else {
            Verdict::Unstable(reasons.join("; "))
        };
        first = Some(Measured {
            ms_per_step: 0.0,
            stage_ms: [0.0; 5],
            steps: steps_done,
            penetration_max: pen_max,
            penetration_mean: pen_sum / steps_done.max(1) as f64,
            drift,
            joint_error: joint_max.unwrap_or(f64::NAN),
            energy_drift: if scene.conservative && e_start.abs() > 0.0 {
                (e_end - e_start) / e_start.abs()
            } else {
                f64::NAN
            },
            residual: if res_den > 0.0 {
                (res_num / res_den).sqrt()
            } else {
                f64::NAN
            },
            // a run stopped early has no error over the whole horizon
            trajectory: tracker
                .as_ref()
                .filter(|_| steps_done == budget.steps)
                .map(truth::Tracker::error),
            verdict,
        });
        if !first.as_ref().is_some_and(|m| m.verdict.is_stable()) {
            // an unstable run is not timed again: its cost means little
            break;
        }
    }
    let mut m = first.expect("the first repeat measures");
    m.ms_per_step = median(&mut timings);
    for (s, v) in m.stage_ms.iter_mut().zip(stages.iter_mut()) {
        *s = median(v);
    }
    Outcome::Ran(m)
}

/// What to run and how long.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Only scenes whose name contains this.
    pub filter: Option<String>,
    /// Override every scene's step count.
    pub steps: Option<u64>,
    /// Override every scene's repeat count.
    pub repeats: Option<u32>,
}

impl Options {
    /// A scene's budget with the overrides applied.
    pub fn budget(&self, scene: &BenchScene) -> Budget {
        let mut b = scene.budget;
        if let Some(s) = self.steps {
            b.steps = s;
            b.residual_samples = b.residual_samples.min((s / 2) as u32);
        }
        if let Some(r) = self.repeats {
            b.repeats = r;
        }
        b
    }

    /// The scenes of a suite that pass the filter.
    pub fn scenes(&self, suite: Suite) -> Vec<BenchScene> {
        scenes::suite(suite)
            .into_iter()
            .filter(|s| {
                self.filter.as_ref().is_none_or(|f| {
                    s.name.contains(f.as_str())
                        || scenes::FORMER_NAMES
                            .iter()
                            .any(|&(old, now)| now == s.name && old.contains(f.as_str()))
                })
            })
            .collect()
    }
}

/// Energy rise, in multiples of the scene's energy scale, at which a case is stopped as
/// blown up (unstable is already a rise of `energy_gain`, at most a few scales).
const BLOW_UP: f64 = 100.0;

/// The (scene, setting) pairs a scene runs: the grid (or, for the model comparisons,
/// each solver's defaults), and the scene's own setting ([`Setting::of_scene`]) after
/// them when it is not among them.
pub fn scene_settings(scene: &BenchScene) -> Vec<Setting> {
    let mut v = if scene.full_grid {
        settings_grid()
    } else {
        SolverKind::ALL.into_iter().map(Setting::defaults).collect()
    };
    let own = Setting::of_scene(&scene.def);
    if !v.contains(&own) {
        v.push(own);
    }
    v
}

/// Runs every scene at every setting; `progress(done, total, what)` after each case.
pub fn run_scenes(
    scenes: &[BenchScene],
    opts: &Options,
    mut progress: impl FnMut(usize, usize, &str),
) -> Vec<Row> {
    run_scenes_each(scenes, opts, |done, total, what, _| {
        progress(done, total, what);
        Ok::<(), std::convert::Infallible>(())
    })
    .map(|(rows, _)| rows)
    .unwrap_or_default()
}

/// As [`run_scenes`], handing each finished row to `on_row(done, total, what, row)` as
/// soon as it is measured (to write it out), and stopping before the next case when
/// [`crate::output::interrupted`] says so. Returns the rows and whether the suite ran
/// to the end; an error from `on_row` stops the suite and is returned.
pub fn run_scenes_each<E>(
    scenes: &[BenchScene],
    opts: &Options,
    on_row: impl FnMut(usize, usize, &str, &Row) -> Result<(), E>,
) -> Result<(Vec<Row>, bool), E> {
    let cases = cases(scenes);
    let (rows, complete) = run_cases(scenes, opts, &cases, 1, on_row)?;
    Ok((rows.into_iter().flatten().collect(), complete))
}

/// One case of a suite: a scene (its index in the suite's scenes) at one setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Case {
    pub scene: usize,
    pub setting: Setting,
}

/// Every case of the scenes, in run order: each scene's settings ([`scene_settings`]),
/// scene after scene. A case's index in this list is what `--shard` splits on.
pub fn cases(scenes: &[BenchScene]) -> Vec<Case> {
    scenes
        .iter()
        .enumerate()
        .flat_map(|(scene, sc)| {
            scene_settings(sc)
                .into_iter()
                .map(move |setting| Case { scene, setting })
        })
        .collect()
}

/// Runs `cases` (of `scenes`) on `jobs` threads at once, handing each finished row to
/// `on_row(done, total, what, row)` in the order they finish. Returns the rows in the
/// order of `cases` (`None` for a case that did not run: the suite was interrupted)
/// and whether every case ran; an error from `on_row` stops the suite and is returned.
/// The rows do not depend on `jobs` (each case runs alone on its own world), only
/// their timings do.
pub fn run_cases<E>(
    scenes: &[BenchScene],
    opts: &Options,
    cases: &[Case],
    jobs: usize,
    mut on_row: impl FnMut(usize, usize, &str, &Row) -> Result<(), E>,
) -> Result<(Vec<Option<Row>>, bool), E> {
    let total = cases.len();
    let mut done = 0;
    let what = |c: &Case| format!("{} / {}", scenes[c.scene].name, c.setting.label());
    run_jobs(
        cases,
        jobs,
        |c| {
            let sc = &scenes[c.scene];
            log::debug!("bench: {}", what(c));
            Row {
                scene: sc.name.clone(),
                setting: c.setting,
                outcome: run_case(sc, &c.setting, &opts.budget(sc)),
            }
        },
        |i, row| {
            done += 1;
            on_row(done, total, &what(&cases[i]), row)
        },
    )
}

/// Runs `run` on every item on `jobs` worker threads (1: on this thread, in order),
/// handing each result to `finished(index, result)` on this thread as it comes. No item
/// is started once [`crate::output::interrupted`] says so or `finished` has failed.
/// Returns the results by item (`None`: not run) and whether every item ran.
pub fn run_jobs<T: Sync, R: Send, E>(
    items: &[T],
    jobs: usize,
    run: impl Fn(&T) -> R + Sync,
    mut finished: impl FnMut(usize, &R) -> Result<(), E>,
) -> Result<(Vec<Option<R>>, bool), E> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let mut out: Vec<Option<R>> = items.iter().map(|_| None).collect();
    let jobs = jobs.clamp(1, items.len().max(1));
    if jobs == 1 {
        for (i, item) in items.iter().enumerate() {
            if crate::output::interrupted() {
                return Ok((out, false));
            }
            let r = run(item);
            finished(i, &r)?;
            out[i] = Some(r);
        }
        return Ok((out, true));
    }
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let (tx, rx) = std::sync::mpsc::channel::<(usize, R)>();
    std::thread::scope(|s| {
        for _ in 0..jobs {
            let tx = tx.clone();
            let (next, stop, run) = (&next, &stop, &run);
            s.spawn(move || {
                while !stop.load(Ordering::Relaxed) && !crate::output::interrupted() {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(item) = items.get(i) else { break };
                    if tx.send((i, run(item))).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx);
        // ends when every worker has finished (and dropped its sender)
        for (i, r) in rx {
            if let Err(e) = finished(i, &r) {
                stop.store(true, Ordering::Relaxed);
                return Err(e);
            }
            out[i] = Some(r);
        }
        Ok(())
    })?;
    let complete = out.iter().all(Option::is_some);
    Ok((out, complete))
}

/// One part of a suite split across runs (`--shard i/n`): the cases whose index in the
/// suite's full case list is `i - 1` modulo `n`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// 1-based: 1..=count.
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// Parses `i/n` (1 <= i <= n); the error says what is wrong in a line.
    pub fn parse(s: &str) -> Result<Shard, String> {
        let bad = |why: String| format!("--shard {s:?}: {why}");
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad("expected I/N such as 2/3 (shard I of N)".into()))?;
        let num = |v: &str| -> Result<usize, String> {
            v.trim().parse().map_err(|_| {
                bad(format!(
                    "{v:?} is not a whole number (expected I/N such as 2/3)"
                ))
            })
        };
        let (index, count) = (num(i)?, num(n)?);
        if count == 0 {
            return Err(bad("N must be at least 1".into()));
        }
        if !(1..=count).contains(&index) {
            return Err(bad(format!("I must be 1..={count} (shards count from 1)")));
        }
        Ok(Shard { index, count })
    }

    /// Whether the case at `index` (0-based, in the suite's full case list) is in
    /// this shard.
    pub fn includes(&self, index: usize) -> bool {
        index % self.count == self.index - 1
    }

    /// The indices of this shard's cases among `total`.
    pub fn indices(&self, total: usize) -> Vec<usize> {
        (0..total).filter(|&i| self.includes(i)).collect()
    }

    /// The file a shard run writes: `results.shard-I-of-N.json`.
    pub fn file_name(&self) -> String {
        format!("results.shard-{}-of-{}.json", self.index, self.count)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_jobs_gives_the_results_in_item_order_whatever_order_they_finish_in() {
        let items: Vec<u64> = (0..12).collect();
        for jobs in [1, 3, 100] {
            let mut seen = Vec::new();
            // later items finish sooner
            let (out, complete) = run_jobs(
                &items,
                jobs,
                |&i| {
                    std::thread::sleep(std::time::Duration::from_millis(2 * (12 - i)));
                    i * 10
                },
                |i, &r| {
                    seen.push((i, r));
                    Ok::<(), ()>(())
                },
            )
            .unwrap();
            assert!(complete);
            let want: Vec<Option<u64>> = items.iter().map(|i| Some(i * 10)).collect();
            assert_eq!(out, want, "jobs {jobs}");
            seen.sort();
            let each_once: Vec<(usize, u64)> = (0..12).map(|i| (i, i as u64 * 10)).collect();
            assert_eq!(seen, each_once, "jobs {jobs}");
        }
    }

    #[test]
    fn an_error_from_the_finished_callback_stops_the_jobs() {
        let items: Vec<u32> = (0..50).collect();
        let mut calls = 0;
        let r = run_jobs(
            &items,
            2,
            |&i| {
                std::thread::sleep(std::time::Duration::from_millis(1));
                i
            },
            |_, _| {
                calls += 1;
                if calls == 3 { Err("full") } else { Ok(()) }
            },
        );
        assert_eq!(r, Err("full"));
        assert_eq!(calls, 3, "no result is handed on after the error");
    }

    #[test]
    fn shards_split_the_cases_by_index_and_bad_values_are_refused() {
        let s = Shard::parse("2/3").unwrap();
        assert_eq!((s.index, s.count), (2, 3));
        assert_eq!(s.indices(8), vec![1, 4, 7]);
        assert_eq!(s.file_name(), "results.shard-2-of-3.json");
        assert_eq!(s.to_string(), "2/3");
        // the shards of a split cover every case once
        let mut all: Vec<usize> = (1..=3)
            .flat_map(|i| Shard::parse(&format!("{i}/3")).unwrap().indices(10))
            .collect();
        all.sort();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(Shard::parse("1/1").unwrap().indices(3), vec![0, 1, 2]);
        for bad in ["0/3", "4/3", "x/y", "1/0", "3", "", "1/2/3", "-1/3", "1/-3"] {
            let e = Shard::parse(bad).unwrap_err();
            assert!(e.starts_with("--shard ") && !e.contains('\n'), "{bad}: {e}");
        }
    }
}
