//! The command line's arguments: one struct per command, and the solver flags that
//! `simulate`, `render` and `run` share (also parsed from each `--compare` value).

use std::path::PathBuf;

use clap::{Args, Parser, ValueEnum};
use sandbox2d::scene;
use sandbox2d::{SolverKind, SolverOverrides};

#[cfg(feature = "render")]
use crate::DEFAULT_SCENE;
use crate::failure::{Failure, one_line};

/// Debug overlays for `render`.
#[cfg(feature = "render")]
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OverlayArg {
    /// Contact points and normals (length by normal impulse).
    Contacts,
    /// Bounding boxes.
    Aabbs,
    /// Velocities.
    Velocities,
}

#[cfg(feature = "render")]
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TintArg {
    /// Each body by its speed (blue at rest, red from 5 m/s).
    Speed,
    /// Each body by its constraint error: deepest contact overlap, largest joint
    /// separation (red from 5 cm).
    Error,
}

#[cfg(feature = "render")]
#[derive(Args)]
pub struct RenderArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    pub scene: String,
    /// Frames to write; frame 0 is the initial state.
    #[arg(long)]
    pub frames: u32,
    /// Steps between frames.
    #[arg(long, default_value_t = 1)]
    pub every: u32,
    /// Folder for frame_0000.png, frame_0001.png, ... (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Frame size in pixels (default: the scene's camera size).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<[u32; 2]>,
    /// Also write an animated GIF, played at simulated speed.
    #[arg(long, value_name = "FILE")]
    pub gif: Option<PathBuf>,
    /// Debug overlays, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub overlays: Vec<OverlayArg>,
    /// Colour each body by a measure instead of its own colour.
    #[arg(long, value_enum)]
    pub tint: Option<TintArg>,
    /// Side by side: one pane per --compare (2 to 4), each the scene with these solver
    /// flags over the others, e.g. --compare "--solver pgs --iterations 4" --compare
    /// "--solver soft"; the panes share --size's width.
    #[arg(long, value_name = "SETTINGS", allow_hyphen_values = true)]
    pub compare: Vec<String>,
    /// Start at step K: of the run saved in --run (stepped again under the run's own
    /// settings), or of the scene run K steps under this command line's solver flags.
    /// With --compare every pane starts from that same world and goes on with its own
    /// settings (a branch at step K); frame 0 is step K.
    #[arg(long, value_name = "K")]
    pub from_step: Option<u64>,
    /// A run saved by `simulate --save-run`, to start from its step --from-step.
    #[arg(long, value_name = "FILE", requires = "from_step")]
    pub run: Option<PathBuf>,
    #[command(flatten)]
    pub solver: SolverFlags,
}

#[cfg(feature = "render")]
#[derive(Args)]
pub struct RunArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    #[arg(default_value = DEFAULT_SCENE)]
    pub scene: String,
    /// Stop after this many frames and print the measured frame rate.
    #[arg(long)]
    pub frames: Option<u64>,
    /// With --frames: save the last frame as a PNG.
    #[arg(long, value_name = "FILE", requires = "frames")]
    pub screenshot: Option<PathBuf>,
    /// Start with the side panel hidden (H shows it).
    #[arg(long)]
    pub no_panel: bool,
    /// Side by side: one pane per --compare (2 to 4), each the scene with these solver
    /// flags over the others, stepped in lock step; the mouse acts on every pane.
    #[arg(long, value_name = "SETTINGS", allow_hyphen_values = true)]
    pub compare: Vec<String>,
    #[command(flatten)]
    pub solver: SolverFlags,
}

/// Parses `WxH` (e.g. `1280x720`), each side 1..=16384.
#[cfg(feature = "render")]
fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT such as 1280x720, got \"{s}\""))?;
    let side = |v: &str| -> Result<u32, String> {
        let n: u32 = v
            .trim()
            .parse()
            .map_err(|_| format!("\"{v}\" is not a whole number of pixels"))?;
        let max = sandbox2d::defs::MAX_FRAME_SIDE;
        if (1..=max).contains(&n) {
            Ok(n)
        } else {
            Err(format!("each side must be 1..={max} pixels, got {n}"))
        }
    };
    Ok([side(w)?, side(h)?])
}

#[cfg(feature = "lab")]
#[derive(Clone, Copy, ValueEnum)]
pub enum SuiteArg {
    Quick,
    Standard,
    Extremes,
    Scaling,
    Contention,
    Convergence,
    Box2d,
}

#[cfg(feature = "lab")]
#[derive(Args)]
pub struct BenchArgs {
    /// Which scenes: quick (a couple of minutes), standard (under 15), extremes (the
    /// stability sweeps), scaling (the benchmark pyramid at 1k, 5k, 20k and 80k boxes on
    /// 1 and 2 threads, and every core above 2: scaling.csv, scaling.md, scaling.svg; a
    /// few minutes; --filter picks sizes by label, e.g. 5k; it sets its own thread counts
    /// (--threads does not apply) and refuses --jobs and --shard), contention (the large
    /// pyramid and many pyramids on 1 and 2 threads, idle and beside a busy process the
    /// suite starts and stops: contention.csv, contention.md; a few minutes; as scaling,
    /// it sets its own threads and refuses --jobs and --shard), convergence (each
    /// solver's order of accuracy on the closed-form scenes: convergence.csv,
    /// convergence.md and convergence.svg; seconds; refuses --jobs and --shard), box2d
    /// (Box2D v3's ten benchmarks as scenes/box2d/*.toml at Box2D's step counts on 1 and
    /// 2 threads: box2d.csv, box2d.md, box2d.svg; --filter picks scenes by name).
    #[arg(long, value_enum, default_value = "quick")]
    pub suite: SuiteArg,
    /// Directory for the results (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Only the scenes (or sweeps, or scaling sizes such as 5k) whose name contains this.
    #[arg(long)]
    pub filter: Option<String>,
    /// Steps per run instead of each scene's own count (for quick checks).
    #[arg(long, hide = true)]
    pub steps: Option<u64>,
    /// Timed repeats instead of each scene's own count.
    #[arg(long, hide = true)]
    pub repeats: Option<u32>,
    /// Run this many cases (scene x setting) at once, one thread each. The rows and
    /// their order are the same as with --jobs 1; only the timing columns differ.
    /// Concurrent cases perturb each other's timings (they share cores, caches and
    /// memory bandwidth, worst on a small machine), so the published figures are
    /// measured with --jobs 1. Not for --suite scaling.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub jobs: usize,
    /// Run only shard I of N (1-based, e.g. 2/3): the cases whose 0-based index in the
    /// suite's full case list (scene by scene, each scene's settings in order; for
    /// extremes: sweep, setting, value) is I-1 modulo N. Writes
    /// results.shard-I-of-N.json into --out instead of the reports; --merge builds
    /// them from all N shards. `auto`: this Slurm array task's shard (task MIN runs
    /// 1/N, ..., task MAX N/N, from SLURM_ARRAY_TASK_ID, _MIN, _MAX, _COUNT, _STEP).
    /// Not for --suite scaling.
    #[arg(long, value_name = "I/N|auto", allow_hyphen_values = true)]
    pub shard: Option<String>,
    /// The run a shard belongs to, written into its file (default: SLURM_ARRAY_JOB_ID
    /// in a Slurm array); with --merge, every shard must be of this run.
    #[arg(long, value_name = "ID")]
    pub run_id: Option<String>,
    /// Merge shard files (results.shard-I-of-N.json, or folders holding them) into the
    /// results.csv, results.md and plots (or stability.md) that one unsharded run would
    /// write into --out. Every shard of the run is needed, once, all of one run; the
    /// suite, filter and steps come from the shards.
    #[arg(
        long,
        value_name = "FILE_OR_DIR",
        num_args = 1..,
        conflicts_with_all = ["suite", "filter", "steps", "repeats", "jobs", "shard", "metric"]
    )]
    pub merge: Vec<PathBuf>,
    /// Also measure this error, made each scene's plotted measure: trajectory, the RMS
    /// and worst distance (and angle) of the bodies from their true motion over the run,
    /// against the scene's closed form or a reference run at a 16th of its step with
    /// converged solves (each scene's reference is named in results.md; scenes whose
    /// motion is chaotic over the run are not measured, and say so). Quick and standard
    /// suites only, not sharded.
    #[arg(long, value_enum, value_name = "ERROR")]
    pub metric: Option<BenchMetricArg>,
}

/// The errors `bench --metric` adds.
#[cfg(feature = "lab")]
#[derive(Clone, Copy, ValueEnum)]
pub enum BenchMetricArg {
    /// Distance from the true motion, body by body, over the run.
    Trajectory,
}

#[cfg(feature = "lab")]
#[derive(Clone, Copy, ValueEnum)]
pub enum MetricArg {
    /// The worst of the measures that apply, each divided by the best any setting reached.
    Worst,
    /// Deepest overlap over the run.
    Penetration,
    /// How far the top body moved.
    Drift,
    /// Largest joint anchor separation.
    #[value(name = "joint_error")]
    JointError,
    /// |energy drift| of a closed scene.
    #[value(name = "energy_drift")]
    EnergyDrift,
    /// Distance from the converged MLCP of the same step (classic PGS only).
    Residual,
    /// RMS distance of the bodies from their true places over the run: the scene's
    /// closed form, else a reference run at a 16th of the step with converged solves
    /// (refused where the motion is chaotic over the run; docs/accuracy.md).
    Trajectory,
}

#[cfg(feature = "lab")]
#[derive(Args)]
pub struct TuneArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    #[arg(required_unless_present = "merge")]
    pub scene: Option<String>,
    /// The most a step may cost: median milliseconds per step on this machine.
    #[arg(long, required_unless_present = "merge")]
    pub budget_ms: Option<f64>,
    /// The error to minimise.
    #[arg(long, value_enum, default_value = "worst")]
    pub metric: MetricArg,
    /// Steps of every run.
    #[arg(long, default_value_t = 300)]
    pub steps: u64,
    /// Timing rounds per setting (taken turn about over the settings in contention).
    #[arg(long, default_value_t = 3)]
    pub rounds: u32,
    /// Runs at once, one thread each, as the bench's --jobs: every score is the same
    /// whatever N; the timings are of runs taken beside each other, which read high
    /// (about 10% on a 2-core machine), so the pick is then cautious. The default, 1,
    /// times each run alone.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub jobs: usize,
    /// Folder for tune.md, tune.json, pareto.svg and solver.toml (created if missing).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
    /// Put the pick into the scene file's [solver] table (comments and order kept).
    #[arg(long)]
    pub write: bool,
    /// Run only shard I of N of the grid's settings (their accuracy runs and timing
    /// rounds), or `auto` for this Slurm array task's shard (as bench --shard); writes
    /// tune.shard-I-of-N.json into --out. `tune --merge` then runs the fine pass and
    /// picks.
    #[arg(long, value_name = "I/N|auto", allow_hyphen_values = true)]
    pub shard: Option<String>,
    /// The run a shard belongs to, written into its file (default: SLURM_ARRAY_JOB_ID
    /// in a Slurm array); with --merge, every shard must be of this run.
    #[arg(long, value_name = "ID")]
    pub run_id: Option<String>,
    /// Merge tune shard files (tune.shard-I-of-N.json, or folders holding them): the
    /// scene, budget, metric, steps, rounds and jobs come from the shards; runs the fine
    /// pass and the rounds near the budget here, then reports as an unsharded tune.
    #[arg(
        long,
        value_name = "FILE_OR_DIR",
        num_args = 1..,
        conflicts_with_all = ["scene", "budget_ms", "metric", "steps", "rounds", "jobs", "shard"]
    )]
    pub merge: Vec<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

impl From<OnOff> for bool {
    fn from(v: OnOff) -> bool {
        matches!(v, OnOff::On)
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum SolverArg {
    /// The soft step (the default): soft contacts and joints, substeps, relax sweeps.
    Soft,
    /// Classic projected Gauss-Seidel on the contact MLCP (the seed's method).
    Pgs,
    /// Extended position-based dynamics with substeps.
    Xpbd,
}

/// Flags that override the scene's `[solver]` table.
#[derive(Args, Clone, Default)]
pub struct SolverFlags {
    /// Solver: soft (the default), pgs or xpbd. Settings the scene does not give take
    /// this solver's defaults.
    #[arg(long, value_enum)]
    pub solver: Option<SolverArg>,
    /// Time step (s).
    #[arg(long)]
    pub dt: Option<f32>,
    /// PGS sweeps per (sub)step, or XPBD iterations per substep.
    #[arg(long)]
    pub iterations: Option<u32>,
    /// Substeps per step.
    #[arg(long)]
    pub substeps: Option<u32>,
    /// PGS early exit when every |delta lambda| is below this (0 = never).
    #[arg(long)]
    pub tolerance: Option<f32>,
    /// Contact caching (warm starting).
    #[arg(long, value_enum)]
    pub warm_start: Option<OnOff>,
    /// Position error solved apart from velocities.
    #[arg(long, value_enum)]
    pub split_impulse: Option<OnOff>,
    /// PGS: a two-point manifold's normal rows solved together (2x2 LCP).
    #[arg(long, value_enum)]
    pub block_solve: Option<OnOff>,
    /// Islands at rest fall asleep (default on; benchmarks turn it off).
    #[arg(long, value_enum)]
    pub sleep: Option<OnOff>,
    /// Baumgarte factor beta in [0, 1].
    #[arg(long)]
    pub baumgarte: Option<f32>,
    /// Allowed penetration (m).
    #[arg(long)]
    pub slop: Option<f32>,
    /// Soft step: contact spring frequency (Hz).
    #[arg(long)]
    pub contact_hertz: Option<f32>,
    /// Soft step: contact spring damping ratio.
    #[arg(long)]
    pub contact_damping_ratio: Option<f32>,
    /// Soft step: fastest push-out of overlap (m/s).
    #[arg(long)]
    pub max_push_speed: Option<f32>,
    /// Soft step: rigid joints' spring frequency in the biased sweeps (Hz).
    #[arg(long)]
    pub joint_hertz: Option<f32>,
    /// Soft step: rigid joints' spring damping ratio in the biased sweeps.
    #[arg(long)]
    pub joint_damping_ratio: Option<f32>,
}

impl SolverFlags {
    pub fn overrides(&self) -> SolverOverrides {
        SolverOverrides {
            kind: self.solver.map(|s| match s {
                SolverArg::Soft => SolverKind::Soft,
                SolverArg::Pgs => SolverKind::Pgs,
                SolverArg::Xpbd => SolverKind::Xpbd,
            }),
            dt: self.dt,
            substeps: self.substeps,
            iterations: self.iterations,
            tolerance: self.tolerance,
            warm_start: self.warm_start.map(Into::into),
            baumgarte: self.baumgarte,
            slop: self.slop,
            split_impulse: self.split_impulse.map(Into::into),
            block_solve: self.block_solve.map(Into::into),
            sleep: self.sleep.map(Into::into),
            restitution_threshold: None,
            contact_hertz: self.contact_hertz,
            contact_damping_ratio: self.contact_damping_ratio,
            max_push_speed: self.max_push_speed,
            joint_hertz: self.joint_hertz,
            joint_damping_ratio: self.joint_damping_ratio,
        }
    }
}

impl SolverFlags {
    /// These flags where given, else `base`'s.
    #[cfg_attr(not(feature = "render"), allow(dead_code))]
    pub fn over(&self, base: &SolverFlags) -> SolverFlags {
        SolverFlags {
            solver: self.solver.or(base.solver),
            dt: self.dt.or(base.dt),
            iterations: self.iterations.or(base.iterations),
            substeps: self.substeps.or(base.substeps),
            tolerance: self.tolerance.or(base.tolerance),
            warm_start: self.warm_start.or(base.warm_start),
            split_impulse: self.split_impulse.or(base.split_impulse),
            block_solve: self.block_solve.or(base.block_solve),
            sleep: self.sleep.or(base.sleep),
            baumgarte: self.baumgarte.or(base.baumgarte),
            slop: self.slop.or(base.slop),
            contact_hertz: self.contact_hertz.or(base.contact_hertz),
            contact_damping_ratio: self.contact_damping_ratio.or(base.contact_damping_ratio),
            max_push_speed: self.max_push_speed.or(base.max_push_speed),
            joint_hertz: self.joint_hertz.or(base.joint_hertz),
            joint_damping_ratio: self.joint_damping_ratio.or(base.joint_damping_ratio),
        }
    }
}

/// One `--compare` value parsed by the solver flags' own parser.
#[derive(Parser)]
#[command(name = "--compare", no_binary_name = true, disable_help_flag = true)]
struct CompareArgs {
    #[command(flatten)]
    flags: SolverFlags,
}

/// Parses the `--compare` values: 2 to 4 of them, each solver flags (as on the command
/// line, split at whitespace). An error is one line naming the value and what is wrong.
#[cfg_attr(not(feature = "render"), allow(dead_code))]
pub fn parse_compare(values: &[String]) -> Result<Vec<SolverFlags>, Failure> {
    use sandbox2d::compare::{MAX_PANES, MIN_PANES};
    if !(MIN_PANES..=MAX_PANES).contains(&values.len()) {
        return Err(Failure::input(format!(
            "--compare: give it {MIN_PANES} to {MAX_PANES} times (one pane each), got {}",
            values.len()
        )));
    }
    values
        .iter()
        .map(|v| {
            let bad = |why: &str| Failure::input(format!("--compare {:?}: {why}", one_line(v)));
            let words = sandbox2d::compare::split_words(v);
            let args = CompareArgs::try_parse_from(&words).map_err(|e| {
                // clap's first line, and its list of possible values when it gives one
                let text = e.to_string();
                let mut why = text
                    .lines()
                    .next()
                    .unwrap_or("")
                    .trim_start_matches("error: ")
                    .to_owned();
                if let Some(values) = text.lines().find(|l| l.contains("[possible values")) {
                    why = format!("{why} {}", values.trim());
                }
                bad(&why)
            })?;
            check_flags(&args.flags).map_err(|f| bad(&f.message))?;
            Ok(args.flags)
        })
        .collect()
}

/// A pane's label: its `--compare` value, whitespace tidied.
#[cfg(feature = "render")]
pub fn pane_label(value: &str) -> String {
    let label = sandbox2d::compare::split_words(value).join(" ");
    if label.is_empty() {
        "(the scene's settings)".to_owned()
    } else {
        label
    }
}

/// Refuses solver flags beyond the documented bounds (the rest is checked with the
/// scene's values by the world).
pub fn check_flags(flags: &SolverFlags) -> Result<(), Failure> {
    let bounded = |flag: &str, v: Option<u32>, max: u32| match v {
        Some(n) if !(1..=max).contains(&n) => Err(Failure::input(format!(
            "--{flag} must be 1..={max}, got {n}"
        ))),
        _ => Ok(()),
    };
    bounded("iterations", flags.iterations, scene::MAX_ITERATIONS)?;
    bounded("substeps", flags.substeps, scene::MAX_SUBSTEPS)
}

#[derive(Args)]
pub struct SimulateArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    pub scene: String,
    /// Steps to run.
    #[arg(long, default_value_t = 600)]
    pub steps: u64,
    /// Print one JSON object with the figures.
    #[arg(long)]
    pub json: bool,
    /// Write body states to this CSV file: step,t,id,name,x,y,angle,vx,vy,omega.
    #[arg(long)]
    pub trace: Option<PathBuf>,
    /// Trace every K-th step.
    #[arg(long, default_value_t = 1)]
    pub trace_every: u64,
    /// Write contact and sensor events to this CSV file: step,kind,a,b,impulse (kind:
    /// begin, end, sensor_begin, sensor_end; a and b body names; impulse of a begin, N s).
    #[arg(long, value_name = "FILE.csv")]
    pub events: Option<PathBuf>,
    /// Write the world's state after the last step to this file (JSON, written whole or
    /// not at all), to go on from later with --load-state.
    #[arg(long, value_name = "FILE")]
    pub save_state: Option<PathBuf>,
    /// Start from a state written by --save-state from the same scene, and run --steps
    /// more steps; the run continues bit-identically when the solver flags are the same.
    #[arg(long, value_name = "FILE", conflicts_with = "run")]
    pub load_state: Option<PathBuf>,
    /// Save the run to this file (JSON, written whole or not at all): its first state,
    /// a keyframe every --keyframes-every steps and the state hash after the last step,
    /// so that --run FILE --from-step K can start at any of its steps (docs/timeline.md).
    #[arg(long, value_name = "FILE")]
    pub save_run: Option<PathBuf>,
    /// With --save-run: steps between keyframes (going to a step re-steps at most this
    /// many; each keyframe is a whole state).
    #[arg(long, value_name = "N", default_value_t = 60)]
    pub keyframes_every: u64,
    /// A run saved by --save-run from the same scene, to start from its step --from-step.
    #[arg(long, value_name = "FILE", requires = "from_step")]
    pub run: Option<PathBuf>,
    /// With --run: start at this step of the saved run (stepped again from its last
    /// keyframe before it under the run's own settings, bit for bit), then run --steps
    /// more steps under this command line's settings: the same as the saved run when
    /// they are the run's, a branch at step K when they are not.
    #[arg(long, value_name = "K", requires = "run")]
    pub from_step: Option<u64>,
    #[command(flatten)]
    pub solver: SolverFlags,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compare_values_parse_by_the_solver_flags_parser() {
        let values = ["--solver pgs  --iterations 4".to_owned(), String::new()];
        let flags = parse_compare(&values).map_err(|f| f.message).unwrap();
        assert!(matches!(flags[0].solver, Some(SolverArg::Pgs)));
        assert_eq!(flags[0].iterations, Some(4));
        assert!(flags[1].solver.is_none());
        let base = SolverFlags {
            iterations: Some(9),
            dt: Some(0.01),
            ..Default::default()
        };
        let merged = flags[0].over(&base);
        assert_eq!((merged.iterations, merged.dt), (Some(4), Some(0.01)));
        for (bad, names) in [
            (vec!["--solver nope", ""], "nope"),
            (vec!["--substeps 0", ""], "--substeps"),
            (vec!["--help", ""], "--help"),
            (vec![""], "2 to 4"),
        ] {
            let values: Vec<String> = bad.iter().map(|s| s.to_string()).collect();
            let Err(f) = parse_compare(&values) else {
                panic!("{bad:?} accepted")
            };
            assert_eq!(f.code, 2);
            assert!(f.message.starts_with("--compare"), "{}", f.message);
            assert!(f.message.contains(names), "{}", f.message);
            assert!(!f.message.contains('\n'), "{}", f.message);
        }
    }
}
