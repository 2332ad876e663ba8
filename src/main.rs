//! The sandbox2d command line: `scenes`, `simulate`, `render`, `run`, and (with no
//! command) the window on the default scene.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use clap::{Args, Parser, Subcommand, ValueEnum};
use sandbox2d::output::{self, AtomicFile};
use sandbox2d::scene::{self, Scene};
use sandbox2d::sim::{self, Trace};
use sandbox2d::{SolverKind, SolverOverrides, SolverSettings, World, WorldState};

/// Log levels unless RUST_LOG says otherwise: warnings, minus two harmless ones that
/// would clutter every run (egui's note that it prefers a non-sRGB surface, which we
/// choose on purpose; EGL's report of a DRI2 driver it probes and then does without).
const DEFAULT_LOG_FILTER: &str = "warn,egui_wgpu=error,wgpu_hal::gles::egl=off";

/// `println!` that fails as a run does when stdout cannot be written (a full disk, a
/// closed pipe): one line on stderr and exit 1, never a panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($arg)*).map_err(stdout_failure)
    }};
}

/// `print!`, as [`say!`].
macro_rules! say_part {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($arg)*).map_err(stdout_failure)
    }};
}

/// A write to stdout that failed.
fn stdout_failure(e: std::io::Error) -> Failure {
    Failure::run(format!("stdout: cannot write: {e}"))
}

/// The scene the plain `sandbox2d` command shows.
const DEFAULT_SCENE: &str = "pyramid_throw";

#[derive(Parser)]
#[command(
    name = "sandbox2d",
    version,
    about = "A 2D physics sandbox: the soft step, PGS and XPBD solvers, measured for speed and accuracy."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Threads a step may use: the narrow phase, the soft step's colours and integration
    /// are split between them; results are the same to the bit whatever N. Default: every
    /// core for simulate, render and run; 1 for bench and tune, whose timings are what they
    /// report (the published figures are one thread's).
    #[arg(long, global = true, value_name = "N")]
    threads: Option<usize>,
    /// Every step on exactly the threads allowed. Without it, simulate, render and run
    /// measure whether the extra threads pay (they do not while another program holds
    /// a core) and step on one thread while they do not, trying again now and then.
    #[arg(long, global = true)]
    fixed_threads: bool,
}

#[derive(Subcommand)]
enum Command {
    /// List the built-in scenes, one line each.
    Scenes,
    /// Run a scene headless and print its figures.
    Simulate(SimulateArgs),
    /// Render a scene headless to numbered PNG frames (and an animated GIF).
    #[cfg(feature = "render")]
    Render(RenderArgs),
    /// Open the sandbox window on a scene (without a display: render frames to ./out).
    #[cfg(feature = "render")]
    Run(RunArgs),
    /// Measure what each solver setting costs and how right it is: results.csv,
    /// results.md and one plot per scene (or stability.md for --suite extremes, scaling.csv,
    /// scaling.md and scaling.svg for --suite scaling) in --out.
    Bench(BenchArgs),
    /// Pick the most accurate solver setting that fits a budget in ms per step: runs the
    /// bench's grid on the scene, then a finer pass around each solver's best, and prints the
    /// pick, the cheapest setting nearly as good, and the Pareto front.
    Tune(TuneArgs),
    /// Spins on one core until its parent is gone (the contention suite's busy process).
    #[command(hide = true)]
    BusyLoop,
}

/// Debug overlays for `render`.
#[cfg(feature = "render")]
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum OverlayArg {
    /// Contact points and normals (length by normal impulse).
    Contacts,
    /// Bounding boxes.
    Aabbs,
    /// Velocities.
    Velocities,
}

#[cfg(feature = "render")]
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum TintArg {
    /// Each body by its speed (blue at rest, red from 5 m/s).
    Speed,
    /// Each body by its constraint error: deepest contact overlap, largest joint
    /// separation (red from 5 cm).
    Error,
}

#[cfg(feature = "render")]
#[derive(Args)]
struct RenderArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    scene: String,
    /// Frames to write; frame 0 is the initial state.
    #[arg(long)]
    frames: u32,
    /// Steps between frames.
    #[arg(long, default_value_t = 1)]
    every: u32,
    /// Folder for frame_0000.png, frame_0001.png, ... (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Frame size in pixels (default: the scene's camera size).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<[u32; 2]>,
    /// Also write an animated GIF, played at simulated speed.
    #[arg(long, value_name = "FILE")]
    gif: Option<PathBuf>,
    /// Debug overlays, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',')]
    overlays: Vec<OverlayArg>,
    /// Colour each body by a measure instead of its own colour.
    #[arg(long, value_enum)]
    tint: Option<TintArg>,
    /// Side by side: one pane per --compare (2 to 4), each the scene with these solver
    /// flags over the others, e.g. --compare "--solver pgs --iterations 4" --compare
    /// "--solver soft"; the panes share --size's width.
    #[arg(long, value_name = "SETTINGS", allow_hyphen_values = true)]
    compare: Vec<String>,
    /// Start at step K: of the run saved in --run (stepped again under the run's own
    /// settings), or of the scene run K steps under this command line's solver flags.
    /// With --compare every pane starts from that same world and goes on with its own
    /// settings (a branch at step K); frame 0 is step K.
    #[arg(long, value_name = "K")]
    from_step: Option<u64>,
    /// A run saved by `simulate --save-run`, to start from its step --from-step.
    #[arg(long, value_name = "FILE", requires = "from_step")]
    run: Option<PathBuf>,
    #[command(flatten)]
    solver: SolverFlags,
}

#[cfg(feature = "render")]
#[derive(Args)]
struct RunArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    #[arg(default_value = DEFAULT_SCENE)]
    scene: String,
    /// Stop after this many frames and print the measured frame rate.
    #[arg(long)]
    frames: Option<u64>,
    /// With --frames: save the last frame as a PNG.
    #[arg(long, value_name = "FILE", requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Start with the side panel hidden (H shows it).
    #[arg(long)]
    no_panel: bool,
    /// Side by side: one pane per --compare (2 to 4), each the scene with these solver
    /// flags over the others, stepped in lock step; the mouse acts on every pane.
    #[arg(long, value_name = "SETTINGS", allow_hyphen_values = true)]
    compare: Vec<String>,
    #[command(flatten)]
    solver: SolverFlags,
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

#[derive(Clone, Copy, ValueEnum)]
enum SuiteArg {
    Quick,
    Standard,
    Extremes,
    Scaling,
    Contention,
    Convergence,
    Box2d,
}

#[derive(Args)]
struct BenchArgs {
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
    suite: SuiteArg,
    /// Directory for the results (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Only the scenes (or sweeps, or scaling sizes such as 5k) whose name contains this.
    #[arg(long)]
    filter: Option<String>,
    /// Steps per run instead of each scene's own count (for quick checks).
    #[arg(long, hide = true)]
    steps: Option<u64>,
    /// Timed repeats instead of each scene's own count.
    #[arg(long, hide = true)]
    repeats: Option<u32>,
    /// Run this many cases (scene x setting) at once, one thread each. The rows and
    /// their order are the same as with --jobs 1; only the timing columns differ.
    /// Concurrent cases perturb each other's timings (they share cores, caches and
    /// memory bandwidth, worst on a small machine), so the published figures are
    /// measured with --jobs 1. Not for --suite scaling.
    #[arg(long, value_name = "N", default_value_t = 1)]
    jobs: usize,
    /// Run only shard I of N (1-based, e.g. 2/3): the cases whose 0-based index in the
    /// suite's full case list (scene by scene, each scene's settings in order; for
    /// extremes: sweep, setting, value) is I-1 modulo N. Writes
    /// results.shard-I-of-N.json into --out instead of the reports; --merge builds
    /// them from all N shards. `auto`: this Slurm array task's shard (task MIN runs
    /// 1/N, ..., task MAX N/N, from SLURM_ARRAY_TASK_ID, _MIN, _MAX, _COUNT, _STEP).
    /// Not for --suite scaling.
    #[arg(long, value_name = "I/N|auto", allow_hyphen_values = true)]
    shard: Option<String>,
    /// The run a shard belongs to, written into its file (default: SLURM_ARRAY_JOB_ID
    /// in a Slurm array); with --merge, every shard must be of this run.
    #[arg(long, value_name = "ID")]
    run_id: Option<String>,
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
    merge: Vec<PathBuf>,
    /// Also measure this error, made each scene's plotted measure: trajectory, the RMS
    /// and worst distance (and angle) of the bodies from their true motion over the run,
    /// against the scene's closed form or a reference run at a 16th of its step with
    /// converged solves (each scene's reference is named in results.md; scenes whose
    /// motion is chaotic over the run are not measured, and say so). Quick and standard
    /// suites only, not sharded.
    #[arg(long, value_enum, value_name = "ERROR")]
    metric: Option<BenchMetricArg>,
}

/// The errors `bench --metric` adds.
#[derive(Clone, Copy, ValueEnum)]
enum BenchMetricArg {
    /// Distance from the true motion, body by body, over the run.
    Trajectory,
}

#[derive(Clone, Copy, ValueEnum)]
enum MetricArg {
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

#[derive(Args)]
struct TuneArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    #[arg(required_unless_present = "merge")]
    scene: Option<String>,
    /// The most a step may cost: median milliseconds per step on this machine.
    #[arg(long, required_unless_present = "merge")]
    budget_ms: Option<f64>,
    /// The error to minimise.
    #[arg(long, value_enum, default_value = "worst")]
    metric: MetricArg,
    /// Steps of every run.
    #[arg(long, default_value_t = 300)]
    steps: u64,
    /// Timing rounds per setting (taken turn about over the settings in contention).
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// Runs at once, one thread each, as the bench's --jobs: every score is the same
    /// whatever N; the timings are of runs taken beside each other, which read high
    /// (about 10% on a 2-core machine), so the pick is then cautious. The default, 1,
    /// times each run alone.
    #[arg(long, value_name = "N", default_value_t = 1)]
    jobs: usize,
    /// Folder for tune.md, tune.json, pareto.svg and solver.toml (created if missing).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print one JSON object instead of the report.
    #[arg(long)]
    json: bool,
    /// Put the pick into the scene file's [solver] table (comments and order kept).
    #[arg(long)]
    write: bool,
    /// Run only shard I of N of the grid's settings (their accuracy runs and timing
    /// rounds), or `auto` for this Slurm array task's shard (as bench --shard); writes
    /// tune.shard-I-of-N.json into --out. `tune --merge` then runs the fine pass and
    /// picks.
    #[arg(long, value_name = "I/N|auto", allow_hyphen_values = true)]
    shard: Option<String>,
    /// The run a shard belongs to, written into its file (default: SLURM_ARRAY_JOB_ID
    /// in a Slurm array); with --merge, every shard must be of this run.
    #[arg(long, value_name = "ID")]
    run_id: Option<String>,
    /// Merge tune shard files (tune.shard-I-of-N.json, or folders holding them): the
    /// scene, budget, metric, steps, rounds and jobs come from the shards; runs the fine
    /// pass and the rounds near the budget here, then reports as an unsharded tune.
    #[arg(
        long,
        value_name = "FILE_OR_DIR",
        num_args = 1..,
        conflicts_with_all = ["scene", "budget_ms", "metric", "steps", "rounds", "jobs", "shard"]
    )]
    merge: Vec<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum)]
enum OnOff {
    On,
    Off,
}

impl From<OnOff> for bool {
    fn from(v: OnOff) -> bool {
        matches!(v, OnOff::On)
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum SolverArg {
    /// The soft step (the default): soft contacts and joints, substeps, relax sweeps.
    Soft,
    /// Classic projected Gauss-Seidel on the contact MLCP (the seed's method).
    Pgs,
    /// Extended position-based dynamics with substeps.
    Xpbd,
}

/// Flags that override the scene's `[solver]` table.
#[derive(Args, Clone, Default)]
struct SolverFlags {
    /// Solver: soft (the default), pgs or xpbd. Settings the scene does not give take
    /// this solver's defaults.
    #[arg(long, value_enum)]
    solver: Option<SolverArg>,
    /// Time step (s).
    #[arg(long)]
    dt: Option<f32>,
    /// PGS sweeps per (sub)step, or XPBD iterations per substep.
    #[arg(long)]
    iterations: Option<u32>,
    /// Substeps per step.
    #[arg(long)]
    substeps: Option<u32>,
    /// PGS early exit when every |delta lambda| is below this (0 = never).
    #[arg(long)]
    tolerance: Option<f32>,
    /// Contact caching (warm starting).
    #[arg(long, value_enum)]
    warm_start: Option<OnOff>,
    /// Position error solved apart from velocities.
    #[arg(long, value_enum)]
    split_impulse: Option<OnOff>,
    /// PGS: a two-point manifold's normal rows solved together (2x2 LCP).
    #[arg(long, value_enum)]
    block_solve: Option<OnOff>,
    /// Islands at rest fall asleep (default on; benchmarks turn it off).
    #[arg(long, value_enum)]
    sleep: Option<OnOff>,
    /// Baumgarte factor beta in [0, 1].
    #[arg(long)]
    baumgarte: Option<f32>,
    /// Allowed penetration (m).
    #[arg(long)]
    slop: Option<f32>,
    /// Soft step: contact spring frequency (Hz).
    #[arg(long)]
    contact_hertz: Option<f32>,
    /// Soft step: contact spring damping ratio.
    #[arg(long)]
    contact_damping_ratio: Option<f32>,
    /// Soft step: fastest push-out of overlap (m/s).
    #[arg(long)]
    max_push_speed: Option<f32>,
    /// Soft step: rigid joints' spring frequency in the biased sweeps (Hz).
    #[arg(long)]
    joint_hertz: Option<f32>,
    /// Soft step: rigid joints' spring damping ratio in the biased sweeps.
    #[arg(long)]
    joint_damping_ratio: Option<f32>,
}

impl SolverFlags {
    fn overrides(&self) -> SolverOverrides {
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
    fn over(&self, base: &SolverFlags) -> SolverFlags {
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
fn parse_compare(values: &[String]) -> Result<Vec<SolverFlags>, Failure> {
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

#[derive(Args)]
struct SimulateArgs {
    /// A scene file, or the name of a built-in scene (see `sandbox2d scenes`).
    scene: String,
    /// Steps to run.
    #[arg(long, default_value_t = 600)]
    steps: u64,
    /// Print one JSON object with the figures.
    #[arg(long)]
    json: bool,
    /// Write body states to this CSV file: step,t,id,name,x,y,angle,vx,vy,omega.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Trace every K-th step.
    #[arg(long, default_value_t = 1)]
    trace_every: u64,
    /// Write contact and sensor events to this CSV file: step,kind,a,b,impulse (kind:
    /// begin, end, sensor_begin, sensor_end; a and b body names; impulse of a begin, N s).
    #[arg(long, value_name = "FILE.csv")]
    events: Option<PathBuf>,
    /// Write the world's state after the last step to this file (JSON, written whole or
    /// not at all), to go on from later with --load-state.
    #[arg(long, value_name = "FILE")]
    save_state: Option<PathBuf>,
    /// Start from a state written by --save-state from the same scene, and run --steps
    /// more steps; the run continues bit-identically when the solver flags are the same.
    #[arg(long, value_name = "FILE", conflicts_with = "run")]
    load_state: Option<PathBuf>,
    /// Save the run to this file (JSON, written whole or not at all): its first state,
    /// a keyframe every --keyframes-every steps and the state hash after the last step,
    /// so that --run FILE --from-step K can start at any of its steps (docs/timeline.md).
    #[arg(long, value_name = "FILE")]
    save_run: Option<PathBuf>,
    /// With --save-run: steps between keyframes (going to a step re-steps at most this
    /// many; each keyframe is a whole state).
    #[arg(long, value_name = "N", default_value_t = 60)]
    keyframes_every: u64,
    /// A run saved by --save-run from the same scene, to start from its step --from-step.
    #[arg(long, value_name = "FILE", requires = "from_step")]
    run: Option<PathBuf>,
    /// With --run: start at this step of the saved run (stepped again from its last
    /// keyframe before it under the run's own settings, bit for bit), then run --steps
    /// more steps under this command line's settings: the same as the saved run when
    /// they are the run's, a branch at step K when they are not.
    #[arg(long, value_name = "K", requires = "run")]
    from_step: Option<u64>,
    #[command(flatten)]
    solver: SolverFlags,
}

/// A failure and the exit code it gets: 2 for bad input, 1 for a run that failed.
struct Failure {
    code: u8,
    message: String,
}

impl Failure {
    fn input(message: impl std::fmt::Display) -> Failure {
        Failure {
            code: 2,
            message: message.to_string(),
        }
    }
    fn run(message: impl std::fmt::Display) -> Failure {
        Failure {
            code: 1,
            message: message.to_string(),
        }
    }
    /// Stopped by SIGINT or SIGTERM: exit 130, as a shell reports a Ctrl-C.
    fn interrupted(message: impl std::fmt::Display) -> Failure {
        Failure {
            code: 130,
            message: message.to_string(),
        }
    }
}

/// Set by a command that stops cleanly on an interrupt (it checks
/// [`output::interrupted`] and removes what is incomplete); otherwise an interrupt ends
/// the process at once, as it would without a handler.
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// SIGINT / SIGTERM: the first asks a graceful command to stop; a second, or any while
/// no graceful command runs, exits at once with 130.
fn install_interrupt_handler() {
    let _ = ctrlc::set_handler(|| {
        if !GRACEFUL.load(Ordering::Relaxed) {
            output::abandon(130, "interrupted");
        } else if !output::interrupted() {
            output::interrupt();
        } else {
            // the temporary files still being written are removed; a file of finished
            // rows (the bench's partial results) is kept, cut to its last whole row
            output::abandon(130, "interrupted again: stopped at once");
        }
    });
}

/// The message on one line: control characters (a newline, a carriage return, an
/// escape) written as Rust escapes, so no input can split or spoof it.
fn one_line(s: &str) -> String {
    scene::escape_controls(s)
}

/// A progress bar on stderr that appears only when stderr is a terminal and the work
/// has taken more than two seconds; its elapsed time ticks even while one long step runs.
fn progress(len: Option<u64>, template: &str) -> indicatif::ProgressBar {
    let b = indicatif::ProgressBar::with_draw_target(len, indicatif::ProgressDrawTarget::hidden());
    b.set_style(
        indicatif::ProgressStyle::with_template(template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    if std::io::stderr().is_terminal() {
        let shown = b.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs(2));
            if !shown.is_finished() {
                shown.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                shown.enable_steady_tick(Duration::from_millis(200));
            }
        });
    }
    b
}

/// Refuses an output path that is one of the run's inputs or another of its outputs.
fn check_distinct(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), Failure> {
    for (i, (what, p)) in outputs.iter().enumerate() {
        if p.is_dir() {
            return Err(Failure::input(format!(
                "{}: {what} is a folder; give a file name",
                p.display()
            )));
        }
        for (other, q) in inputs.iter().chain(&outputs[..i]) {
            if output::same_file(p, q) {
                return Err(Failure::input(format!(
                    "{}: {what} would overwrite the {other} ({})",
                    p.display(),
                    q.display()
                )));
            }
        }
    }
    Ok(())
}

/// An environment variable, when it is set (and valid Unicode).
fn env_var(name: &str) -> Option<String> {
    std::env::var(name).ok()
}

/// Refuses a run whose writes into the folder `dir` would replace one of its inputs:
/// `writes(name)` says whether the run writes a file of that name there (`what`, the
/// flag that names the folder, goes into the message).
fn check_folder_outputs(
    what: &str,
    dir: &Path,
    writes: impl Fn(&str) -> bool,
    inputs: &[(&str, &Path)],
) -> Result<(), Failure> {
    for (other, q) in inputs {
        let Some(name) = q.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        let p = dir.join(name);
        if writes(name) && output::same_file(&p, q) {
            return Err(Failure::input(format!(
                "{}: {what} would overwrite the {other} ({})",
                p.display(),
                q.display()
            )));
        }
    }
    Ok(())
}

/// Whether `name` is one of the frames `frame_0000.png` .. of a run of `frames` frames.
#[cfg_attr(not(feature = "render"), allow(dead_code))]
fn is_frame_name(name: &str, frames: u32) -> bool {
    #[cfg(feature = "render")]
    if let Some(k) = name
        .strip_prefix("frame_")
        .and_then(|r| r.strip_suffix(".png"))
        .and_then(|d| d.parse::<u32>().ok())
    {
        return k < frames && sandbox2d::render::frame_name(k) == name;
    }
    let _ = (name, frames);
    false
}

/// The files `bench --merge` may write into its `--out` folder: the reports and the
/// plots (one per scene).
fn merge_writes(name: &str) -> bool {
    matches!(name, "results.csv" | "results.md" | "stability.md") || name.ends_with(".svg")
}

/// The files `tune --out` writes.
const TUNE_FILES: [&str; 4] = ["tune.md", "tune.json", "pareto.svg", "solver.toml"];

/// The scene file a name loads, when it is a file and not a built-in scene.
fn scene_file(name: &str) -> Option<PathBuf> {
    scene::builtin(name).is_none().then(|| PathBuf::from(name))
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(DEFAULT_LOG_FILTER))
        .init();
    let cli = Cli::parse();
    output::ignore_file_size_signal();
    install_interrupt_handler();
    let timing = matches!(cli.command, Some(Command::Bench(_) | Command::Tune(_)));
    match cli.threads {
        Some(n) if !(1..=sandbox2d::threads::MAX_THREADS).contains(&n) => {
            eprintln!(
                "error: --threads must be 1..={}, got {n}",
                sandbox2d::threads::MAX_THREADS
            );
            return ExitCode::from(2);
        }
        Some(n) => sandbox2d::threads::set_default_threads(n),
        None if timing => {}
        None => sandbox2d::threads::set_default_threads(sandbox2d::threads::available()),
    }
    // (bench and tune time what they are told to: every step on the threads allowed)
    sandbox2d::threads::set_default_adaptive(!timing && !cli.fixed_threads);
    let result = match cli.command {
        None => default_command(),
        Some(Command::Scenes) => list_scenes(),
        Some(Command::Simulate(a)) => simulate(&a),
        #[cfg(feature = "render")]
        Some(Command::Render(a)) => render(&a),
        #[cfg(feature = "render")]
        Some(Command::Run(a)) => run(&a),
        Some(Command::Bench(a)) => bench(&a),
        Some(Command::Tune(a)) => tune(&a),
        Some(Command::BusyLoop) => busy_loop(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", one_line(&f.message));
            ExitCode::from(f.code)
        }
    }
}

fn list_scenes() -> Result<(), Failure> {
    for name in scene::builtin_names() {
        let d = scene::builtin_description(name).unwrap_or_default();
        say!("{name:<16} {d}")?;
    }
    Ok(())
}

/// The plain command opens the window on the default scene (or, without a display,
/// renders it headless into ./out).
#[cfg(feature = "render")]
fn default_command() -> Result<(), Failure> {
    run(&RunArgs {
        scene: DEFAULT_SCENE.into(),
        frames: None,
        screenshot: None,
        no_panel: false,
        compare: Vec::new(),
        solver: SolverFlags::default(),
    })
}

/// Built without rendering, the plain command runs the default scene headless for 10 s
/// and prints its figures.
#[cfg(not(feature = "render"))]
fn default_command() -> Result<(), Failure> {
    say!(
        "sandbox2d: running the built-in scene \"{DEFAULT_SCENE}\" headless for 600 steps (see `sandbox2d --help`)"
    )?;
    simulate(&SimulateArgs {
        scene: DEFAULT_SCENE.into(),
        steps: 600,
        json: false,
        trace: None,
        trace_every: 1,
        events: None,
        save_state: None,
        load_state: None,
        save_run: None,
        keyframes_every: 60,
        run: None,
        from_step: None,
        solver: SolverFlags::default(),
    })
}

/// Refuses solver flags beyond the documented bounds (the rest is checked with the
/// scene's values by the world).
fn check_flags(flags: &SolverFlags) -> Result<(), Failure> {
    let bounded = |flag: &str, v: Option<u32>, max: u32| match v {
        Some(n) if !(1..=max).contains(&n) => Err(Failure::input(format!(
            "--{flag} must be 1..={max}, got {n}"
        ))),
        _ => Ok(()),
    };
    bounded("iterations", flags.iterations, scene::MAX_ITERATIONS)?;
    bounded("substeps", flags.substeps, scene::MAX_SUBSTEPS)
}

/// Loads a scene and builds its world with the command line's solver flags applied,
/// with a progress bar for a build that takes more than a couple of seconds.
fn build(name: &str, flags: &SolverFlags) -> Result<(Scene, World, SolverSettings), Failure> {
    check_flags(flags)?;
    let spinner = progress(None, "{spinner} loading the scene {elapsed}");
    let sc = scene::load(name).map_err(Failure::input);
    spinner.finish_and_clear();
    let sc = sc?;
    let settings = sc.world.solver.merged(flags.overrides()).resolve();
    let fail = |e: sandbox2d::BuildError| Failure::input(format!("{}: {e}", sc.source));
    if let Some((far, ulp)) = sandbox2d::world::far_from_origin(&sc.world) {
        // said once, before the run: the run itself goes ahead
        eprintln!(
            "note: {}: a body starts {far:.3e} m from the scene's origin, where positions step by {ulp:.1e} m (f32); contacts and joints lose precision beyond about {:.0e} m from it (a scene far from 0 is simulated relative to its own centre: its size counts, not its place; docs/stability.md)",
            one_line(&sc.source),
            sandbox2d::world::FAR_FROM_ORIGIN
        );
    }
    // the scene's own [solver] values were checked at load (with their place): what
    // fails here comes from a flag
    settings
        .check()
        .map_err(|e| Failure::input(format!("command-line flags: solver: {e}")))?;
    // World::from_def, body by body, with progress
    let def = &sc.world;
    let mut world = World::new(def.gravity, settings);
    world.drag = def.drag;
    world.origin = def.origin;
    let bar = progress(
        Some(def.bodies.len() as u64),
        "{bar:40} {pos}/{len} bodies built {elapsed}",
    );
    // World::add_body's duplicate-name check scans every body (quadratic for a million
    // bodies): the names are checked here with a set, then the bodies made as add_body
    // makes them.
    let mut names = std::collections::HashSet::with_capacity(def.bodies.len());
    for (i, b) in def.bodies.iter().enumerate() {
        if !names.insert(b.name.as_str()) {
            return Err(fail(sandbox2d::BuildError::DuplicateName(b.name.clone())));
        }
        world.add_made_body(World::make_body(b, def.gravity).map_err(fail)?, b.awake);
        if i % 1024 == 0 {
            bar.set_position(i as u64);
        }
    }
    bar.finish_and_clear();
    for f in &def.forces {
        world.add_force(f).map_err(fail)?;
    }
    for j in &def.joints {
        world.add_joint(j).map_err(fail)?;
    }
    for m in &def.motions {
        world.add_motion(m).map_err(fail)?;
    }
    for s in &def.spawns {
        world.add_spawn(s).map_err(fail)?;
    }
    Ok((sc, world, settings))
}

/// A run that stopped on a non-finite state or an interrupt: one line that names the
/// scene and the step (and, for a blow-up, the body).
fn run_failure(source: &str, e: sim::RunError) -> Failure {
    match e {
        sim::RunError::Interrupted { step } => {
            Failure::interrupted(format!("{source}: interrupted after step {step}"))
        }
        e => Failure::run(format!("{source}: {e}")),
    }
}

fn simulate(a: &SimulateArgs) -> Result<(), Failure> {
    if a.steps == 0 {
        return Err(Failure::input("--steps must be at least 1"));
    }
    if a.trace_every == 0 {
        return Err(Failure::input("--trace-every must be at least 1"));
    }
    if a.keyframes_every == 0 {
        return Err(Failure::input("--keyframes-every must be at least 1"));
    }
    {
        let file = scene_file(&a.scene);
        let mut inputs: Vec<(&str, &Path)> =
            file.iter().map(|f| ("scene file", f.as_path())).collect();
        let mut outputs: Vec<(&str, &Path)> = Vec::new();
        if let Some(t) = &a.trace {
            outputs.push(("--trace", t));
        }
        if let Some(e) = &a.events {
            outputs.push(("--events", e));
        }
        if let Some(p) = &a.save_state {
            outputs.push(("--save-state", p));
        }
        if let Some(p) = &a.save_run {
            outputs.push(("--save-run", p));
        }
        // the run is read before this one starts, so --save-run may name it
        if let Some(p) = &a.run
            && !a
                .save_run
                .as_deref()
                .is_some_and(|q| output::same_file(p, q))
        {
            inputs.push(("--run", p));
        }
        // the state is read before the run, so --save-state may name the same file
        if let Some(p) = &a.load_state
            && !a
                .save_state
                .as_deref()
                .is_some_and(|q| output::same_file(p, q))
        {
            inputs.push(("--load-state", p));
        }
        check_distinct(&outputs, &inputs)?;
    }
    let (sc, mut world, settings) = build(&a.scene, &a.solver)?;
    if let Some(p) = &a.load_state {
        load_state(p, &sc, &mut world, &settings)?;
    }
    if let (Some(p), Some(k)) = (&a.run, a.from_step) {
        let at = load_run(p, &sc, &world)?
            .1
            .world_at(k)
            .map_err(|e| run_file_failure(p, e))?;
        let state = at.snapshot();
        world
            .restore(&state)
            .map_err(|e| Failure::run(format!("{}: {e}", p.display())))?;
        settings_note(&p.display().to_string(), &state.settings, &settings);
        world.settings = settings;
    }
    if a.events.is_some() {
        world.record_events = true;
    }
    // with threads, how dear a hand-off between the cores is just before the run (the
    // world's workers start at its first step, so none is in the way; and before any
    // output file is opened, so none waits on it)
    let round_trip = (world.threads() > 1)
        .then(sandbox2d::threads::core_round_trip_ns)
        .flatten();
    // from here an interrupt stops the run cleanly (before the trace exists, so that no
    // interrupt can leave its temporary file behind)
    GRACEFUL.store(true, Ordering::Relaxed);
    // the trace goes to a temporary file, renamed once the run is complete
    let mut trace_file = match &a.trace {
        Some(p) => Some(AtomicFile::create(p).map_err(Failure::input)?),
        None => None,
    };
    let bar = progress(Some(a.steps), "{bar:40} {pos}/{len} steps {elapsed}");
    let mut events_file = match &a.events {
        Some(p) => {
            let mut f = AtomicFile::create(p).map_err(Failure::input)?;
            writeln!(f, "step,kind,a,b,impulse")
                .map_err(|e| Failure::run(format!("{}: cannot write: {e}", p.display())))?;
            Some(f)
        }
        None => None,
    };
    // created now, so a path that cannot be written is refused before the run
    let mut state_file = match &a.save_state {
        Some(p) => Some(AtomicFile::create(p).map_err(Failure::input)?),
        None => None,
    };
    let mut run_file = match &a.save_run {
        Some(p) => Some(AtomicFile::create(p).map_err(Failure::input)?),
        None => None,
    };
    let mut saved_run = a
        .save_run
        .as_ref()
        .map(|_| sandbox2d::timeline::SavedRun::start(&sc.source, &world, a.keyframes_every));
    let mut event_counts = [0u64; 4];
    let mut events_error: Option<std::io::Error> = None;
    let trace = trace_file.as_mut().map(|f| Trace {
        out: f as &mut dyn Write,
        every: a.trace_every,
    });
    let result = sim::run(&mut world, a.steps, trace, |k, w| {
        if k % 16 == 0 {
            bar.set_position(k);
        }
        if let Some(r) = saved_run.as_mut() {
            r.record(w);
        }
        for e in w.events() {
            event_counts[e.kind as usize] += 1;
            if let (Some(f), None) = (events_file.as_mut(), &events_error)
                && let Err(err) = writeln!(
                    f,
                    "{k},{},{},{},{}",
                    e.kind.name(),
                    sim::csv_field(&w.bodies[e.a].name),
                    sim::csv_field(&w.bodies[e.b].name),
                    e.impulse
                )
            {
                events_error = Some(err);
            }
        }
    });
    bar.finish_and_clear();
    let summary = match result {
        Ok(s) => s,
        Err(sim::RunError::Io(e)) => {
            let path = a.trace.as_deref().unwrap_or(Path::new("trace"));
            return Err(Failure::run(format!(
                "{}: cannot write: {e}",
                path.display()
            )));
        }
        Err(e) => {
            let mut f = run_failure(&sc.source, e);
            if let Some(p) = &a.trace {
                f.message += &format!("; {}: not written (the run did not finish)", p.display());
            }
            return Err(f);
        }
    };
    if let Some(f) = trace_file {
        f.commit().map_err(Failure::run)?;
    }
    if let (Some(e), Some(p)) = (events_error, &a.events) {
        return Err(Failure::run(format!("{}: cannot write: {e}", p.display())));
    }
    if let Some(f) = events_file {
        f.commit().map_err(Failure::run)?;
    }
    if let Some(mut f) = state_file.take() {
        let bytes = world
            .snapshot()
            .to_json()
            .map_err(|e| Failure::run(format!("{}: {e}", f.path().display())))?;
        f.write_all(&bytes).map_err(|e| Failure::run(f.error(e)))?;
        f.commit().map_err(Failure::run)?;
    }
    if let (Some(mut f), Some(r)) = (run_file.take(), saved_run.as_ref()) {
        let bytes = r
            .to_json()
            .map_err(|e| Failure::run(format!("{}: {e}", f.path().display())))?;
        f.write_all(&bytes).map_err(|e| Failure::run(f.error(e)))?;
        f.commit().map_err(Failure::run)?;
    }
    let figures = [
        ("energy at the start", summary.energy_start),
        ("energy at the end", summary.energy_end),
        ("mean residual", summary.residual_mean),
        ("largest residual", summary.residual_max as f64),
        ("largest penetration", summary.penetration_max as f64),
        ("largest joint error", summary.joint_error_max as f64),
    ];
    if let Some((what, v)) = figures.iter().find(|(_, v)| !v.is_finite()) {
        // the energy at the end: the body whose term overflowed (at the start, the
        // scene loader has refused such a body)
        let culprit = match world.energy_not_finite() {
            Some((i, why)) if what.starts_with("energy") => {
                format!(
                    " (body {:?} (#{i}): {why})",
                    one_line(&world.bodies[i].name)
                )
            }
            _ => String::new(),
        };
        return Err(Failure::run(format!(
            "{}: after step {}: the {what} is {v}, not a finite number{culprit}",
            sc.source, summary.steps
        )));
    }
    let (median, mean, p95) = summary.ms_per_step();
    let world_has_no_joints = world.joints().is_empty();
    let hash = format!("{:016x}", world.state_hash());
    if a.json {
        let v = serde_json::json!({
            "scene": sc.name,
            "source": sc.source,
            "solver": {
                "kind": settings.kind.name(),
                "dt": settings.dt,
                "substeps": settings.substeps,
                "iterations": settings.iterations,
                "tolerance": settings.tolerance,
                "warm_start": settings.warm_start,
                "split_impulse": settings.split_impulse,
                "block_solve": settings.block_solve,
                "sleep": settings.sleep,
                "baumgarte": settings.baumgarte,
                "slop": settings.slop,
                "restitution_threshold": settings.restitution_threshold,
                "contact_hertz": settings.contact_hertz,
                "contact_damping_ratio": settings.contact_damping_ratio,
                "max_push_speed": settings.max_push_speed,
                "joint_hertz": settings.joint_hertz,
                "joint_damping_ratio": settings.joint_damping_ratio,
            },
            "steps": summary.steps,
            // threads the steps could use, and whether they did (a small world runs on one)
            // with threads, also the ns a cache line took from one core to another and
            // back just before the run: a virtual machine's cores may share a cache or
            // not, and two threads' figures depend on which
            "threads": {
                "allowed": world.threads(),
                "adaptive": matches!(world.thread_policy(), sandbox2d::Threads::UpTo(_)),
                "steps_on_one": world.thread_use().steps_on_one,
                "steps_on_many": world.thread_use().steps_on_many,
                "switches": world.thread_use().switches,
                "parallel_jobs": world.parallel_jobs(),
                "core_round_trip_ns": round_trip,
            },
            "bodies": world.bodies.len(),
            "ms_per_step": { "median": median, "mean": mean, "p95": p95 },
            "contacts": { "mean": summary.contacts_mean, "max": summary.contacts_max },
            "iterations": { "mean": summary.iterations_mean, "position_mean": summary.position_iterations_mean },
            "residual": { "mean": summary.residual_mean, "max": summary.residual_max },
            "penetration": { "max": summary.penetration_max, "final": summary.penetration_final },
            "energy": { "start": summary.energy_start, "end": summary.energy_end },
            "joint_error": { "max": summary.joint_error_max, "final": summary.joint_error_final },
            "displacement": { "max": summary.displacement_max },
            "stage_ms": {
                "forces": summary.stage_ms[0], "broad_phase": summary.stage_ms[1], "narrow_phase": summary.stage_ms[2],
                "solver": summary.stage_ms[3], "integrate": summary.stage_ms[4],
            },
            "state_hash": hash,
            // counted when recorded (--events, or a scene with a sensor); else null
            "events": world.record_events.then(|| serde_json::json!({
                "begin": event_counts[0], "end": event_counts[1],
                "sensor_begin": event_counts[2], "sensor_end": event_counts[3],
            })),
        });
        say!("{v}")?;
    } else {
        // quoted with escapes: a name cannot put control characters on the terminal
        say!("scene        {:?} ({})", sc.name, one_line(&sc.source))?;
        say!(
            "solver       {} dt={} substeps={} iterations={} tolerance={} warm_start={} split_impulse={} baumgarte={} slop={}",
            settings.kind.name(),
            settings.dt,
            settings.substeps,
            settings.iterations,
            settings.tolerance,
            settings.warm_start,
            settings.split_impulse,
            settings.baumgarte,
            settings.slop
        )?;
        if settings.kind == SolverKind::Soft {
            say!(
                "soft step    contact_hertz={} contact_damping_ratio={} max_push_speed={} joint_hertz={} joint_damping_ratio={}",
                settings.contact_hertz,
                settings.contact_damping_ratio,
                settings.max_push_speed,
                settings.joint_hertz,
                settings.joint_damping_ratio
            )?;
        }
        let used = world.thread_use();
        say!(
            "steps        {} ({} bodies, {} thread{}{})",
            summary.steps,
            world.bodies.len(),
            world.threads(),
            if world.threads() == 1 { "" } else { "s" },
            if used.steps_on_one + used.steps_on_many > 0 {
                format!(
                    " allowed: {} steps on them, {} on one",
                    used.steps_on_many, used.steps_on_one
                )
            } else {
                String::new()
            }
        )?;
        say!("ms/step      median {median:.3}  mean {mean:.3}  p95 {p95:.3}")?;
        say!(
            "contacts     mean {:.1}  max {}",
            summary.contacts_mean,
            summary.contacts_max
        )?;
        say!(
            "iterations   mean {:.2}  (position sweeps {:.2})",
            summary.iterations_mean,
            summary.position_iterations_mean
        )?;
        say!(
            "residual     mean {:.3e}  max {:.3e}",
            summary.residual_mean,
            summary.residual_max
        )?;
        say!(
            "penetration  max {:.5} m  final {:.5} m",
            summary.penetration_max,
            summary.penetration_final
        )?;
        say!(
            "energy       start {:.4} J  end {:.4} J",
            summary.energy_start,
            summary.energy_end
        )?;
        say!(
            "displacement max {:.4} m (the farthest a body ended from its start)",
            summary.displacement_max
        )?;
        if !world_has_no_joints {
            say!(
                "joint error  max {:.6} m  final {:.6} m",
                summary.joint_error_max,
                summary.joint_error_final
            )?;
        }
        say!("state hash   {hash}")?;
    }
    Ok(())
}

/// `simulate --load-state`: reads a saved state, checks that it was saved from this
/// scene, and puts it into `world` (built from the scene). The run keeps its own solver
/// settings (the scene's with this command line's flags); a note says when they differ
/// from the ones the state was saved with, as the run then does not continue the same.
fn load_state(
    path: &Path,
    sc: &Scene,
    world: &mut World,
    settings: &SolverSettings,
) -> Result<(), Failure> {
    let name = one_line(&path.display().to_string());
    let bytes = std::fs::read(path)
        .map_err(|e| Failure::input(format!("{name}: cannot read the state: {e}")))?;
    let bad = |e: sandbox2d::StateError| Failure::input(one_line(&format!("{name}: {e}")));
    let state = WorldState::from_json(&bytes).map_err(bad)?;
    state.check_scene(world, false).map_err(|e| {
        Failure::input(one_line(&format!(
            "{name}: {e} (the scene is {})",
            sc.source
        )))
    })?;
    world.restore(&state).map_err(bad)?;
    settings_note(&name, &state.settings, settings);
    world.settings = *settings;
    Ok(())
}

/// Says on stderr when a saved state or run had other solver settings than the run
/// that goes on from it (it then does not continue bit-identically).
fn settings_note(name: &str, saved: &SolverSettings, now: &SolverSettings) {
    if saved == now {
        return;
    }
    let brief = |s: &SolverSettings| {
        format!(
            "{} dt={} substeps={} iterations={}",
            s.kind.name(),
            s.dt,
            s.substeps,
            s.iterations
        )
    };
    eprintln!(
        "note: {} was saved with other solver settings ({}) than this run's ({}): the run goes on with this run's and will not continue bit-identically",
        one_line(name),
        brief(saved),
        brief(now)
    );
}

/// `--run`: reads a saved run and checks that it was saved from this scene (`world`,
/// built from it). Returns the file's name as messages show it and the run.
fn load_run(
    path: &Path,
    sc: &Scene,
    world: &World,
) -> Result<(String, sandbox2d::timeline::SavedRun), Failure> {
    let name = one_line(&path.display().to_string());
    let bytes = std::fs::read(path)
        .map_err(|e| Failure::input(format!("{name}: cannot read the run: {e}")))?;
    let run = sandbox2d::timeline::SavedRun::from_json(&bytes)
        .map_err(|e| Failure::input(one_line(&format!("{name}: {e}"))))?;
    run.keyframes[0]
        .state
        .check_scene(world, false)
        .map_err(|e| {
            Failure::input(one_line(&format!(
                "{name}: {e} (the scene is {})",
                sc.source
            )))
        })?;
    Ok((name, run))
}

/// A saved run that could not give a step: a step outside it is the input's fault (2),
/// a failed step the run's (1).
fn run_file_failure(path: &Path, e: sandbox2d::timeline::RunFileError) -> Failure {
    let m = one_line(&format!("{}: {e}", path.display()));
    match e {
        sandbox2d::timeline::RunFileError::Step(_) => Failure::run(m),
        _ => Failure::input(m),
    }
}

/// `--from-step K`: the world at step K, of the saved run `run` (stepped again under
/// its own settings) or of the scene run K steps under `flags` (the trunk every pane
/// branches from).
#[cfg(feature = "render")]
fn start_state(
    scene: &str,
    run: Option<&Path>,
    k: u64,
    flags: &SolverFlags,
) -> Result<WorldState, Failure> {
    let (sc, mut world, _) = build(scene, flags)?;
    if let Some(p) = run {
        let (_, saved) = load_run(p, &sc, &world)?;
        let at = saved.world_at(k).map_err(|e| run_file_failure(p, e))?;
        return Ok(at.snapshot());
    }
    for _ in 0..k {
        world
            .step()
            .map_err(|e| Failure::run(format!("{}: {e}", sc.source)))?;
    }
    Ok(world.snapshot())
}

/// The exit code a frame-rendering failure gets: 2 when the input (a size, a path) is
/// at fault, 1 when the run failed.
#[cfg(feature = "render")]
fn frames_failure(e: sandbox2d::render::FramesError) -> Failure {
    use sandbox2d::render::{FramesError, RenderError};
    match &e {
        FramesError::Zero(_)
        | FramesError::OutDir { .. }
        | FramesError::Render(RenderError::InvalidSize { .. }) => Failure::input(e),
        FramesError::Interrupted { written } => {
            let kept = match (written.pngs.first(), written.pngs.last()) {
                (Some(first), Some(last)) => format!(
                    "kept {} complete frame(s), {} .. {}",
                    written.pngs.len(),
                    first.display(),
                    last.display()
                ),
                _ => "kept no frame".to_owned(),
            };
            Failure::interrupted(format!(
                "interrupted after step {}: {kept}; no GIF was written",
                written.steps
            ))
        }
        _ => Failure::run(e),
    }
}

/// Renders `job` of a built world through the scene's camera at `size`.
#[cfg(feature = "render")]
fn render_job(
    sc: &Scene,
    world: &mut World,
    size: [u32; 2],
    job: &sandbox2d::render::FrameJob,
) -> Result<sandbox2d::render::FramesWritten, Failure> {
    let camera = sandbox2d::draw::world::scene_camera(&sc.camera, size, world);
    let mut renderer = sandbox2d::render::Renderer::new_headless().map_err(Failure::run)?;
    let bar = progress(
        Some(job.frames as u64),
        "{bar:40} {pos}/{len} frames {elapsed}",
    );
    GRACEFUL.store(true, Ordering::Relaxed);
    let written = sandbox2d::render::render_frames(world, &camera, &mut renderer, job, |k| {
        bar.set_position(k as u64 + 1);
    });
    bar.finish_and_clear();
    written.map_err(|e| match e {
        // the step error names the body and the step
        sandbox2d::render::FramesError::Step { source, .. } => {
            Failure::run(format!("{}: {source}", sc.source))
        }
        e => frames_failure(e),
    })
}

/// Tells where the frames went: one line.
#[cfg(feature = "render")]
fn print_written(
    w: &sandbox2d::render::FramesWritten,
    out: &std::path::Path,
) -> Result<(), Failure> {
    let name = |p: Option<&PathBuf>| {
        p.and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let gif = w
        .gif
        .as_ref()
        .map(|g| format!(" and {}", g.display()))
        .unwrap_or_default();
    say!(
        "wrote {} frames ({} .. {}) to {}{gif}",
        w.pngs.len(),
        name(w.pngs.first()),
        name(w.pngs.last()),
        out.display()
    )?;
    Ok(())
}

#[cfg(feature = "render")]
fn render(a: &RenderArgs) -> Result<(), Failure> {
    if a.frames == 0 {
        return Err(Failure::input("--frames must be at least 1"));
    }
    if a.every == 0 {
        return Err(Failure::input("--every must be at least 1"));
    }
    if let Some(gif) = &a.gif {
        let mut inputs: Vec<(&str, PathBuf)> = vec![("--out folder", a.out.clone())];
        if let Some(file) = scene_file(&a.scene) {
            inputs.push(("scene file", file));
        }
        if let Some(run) = &a.run {
            inputs.push(("--run file", run.clone()));
        }
        // a frame of this run: frame_NNNN.png in --out, for NNNN < --frames
        if let Some(name) = gif.file_name().and_then(|n| n.to_str())
            && let Some(k) = name
                .strip_prefix("frame_")
                .and_then(|r| r.strip_suffix(".png"))
                .and_then(|d| d.parse::<u32>().ok())
            && k < a.frames
            && sandbox2d::render::frame_name(k) == name
        {
            inputs.push((
                "frame it writes",
                a.out.join(sandbox2d::render::frame_name(k)),
            ));
        }
        let inputs: Vec<(&str, &Path)> = inputs.iter().map(|(w, p)| (*w, p.as_path())).collect();
        check_distinct(&[("--gif", gif)], &inputs)?;
        let folder = match gif.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !folder.is_dir() {
            return Err(Failure::input(format!(
                "{}: cannot create: the folder {} does not exist",
                gif.display(),
                folder.display()
            )));
        }
    }
    // a frame it writes must not be the scene file
    if let Some(file) = scene_file(&a.scene) {
        check_folder_outputs(
            "--out",
            &a.out,
            |n| is_frame_name(n, a.frames),
            &[("scene file", &file)],
        )?;
    }
    let start = match a.from_step {
        Some(k) => Some(start_state(&a.scene, a.run.as_deref(), k, &a.solver)?),
        None => None,
    };
    if let Some(st) = &start {
        println!("from step {} (t = {:.3} s)", st.step_count, st.time);
    }
    if !a.compare.is_empty() {
        return render_compare(a, start.as_ref());
    }
    let (sc, mut world, settings) = build(&a.scene, &a.solver)?;
    if let Some(st) = &start {
        world
            .restore(st)
            .map_err(|e| Failure::run(format!("{}: {e}", sc.source)))?;
        world.settings = settings;
    }
    let job = frame_job(a)?;
    let written = render_job(&sc, &mut world, a.size.unwrap_or(sc.camera.size), &job)?;
    print_written(&written, &a.out)?;
    Ok(())
}

/// `render`'s output folder, created, and the frames, overlays and GIF it asks for.
#[cfg(feature = "render")]
fn frame_job(a: &RenderArgs) -> Result<sandbox2d::render::FrameJob, Failure> {
    std::fs::create_dir_all(&a.out).map_err(|e| {
        Failure::input(format!(
            "{}: cannot create the folder: {e}",
            a.out.display()
        ))
    })?;
    let overlays = sandbox2d::draw::Overlays {
        contacts: a.overlays.contains(&OverlayArg::Contacts),
        aabbs: a.overlays.contains(&OverlayArg::Aabbs),
        velocities: a.overlays.contains(&OverlayArg::Velocities),
        tint: match a.tint {
            None => sandbox2d::draw::world::Tint::Off,
            Some(TintArg::Speed) => sandbox2d::draw::world::Tint::Speed,
            Some(TintArg::Error) => sandbox2d::draw::world::Tint::Error,
        },
        ..sandbox2d::draw::Overlays::NONE
    };
    Ok(sandbox2d::render::FrameJob {
        frames: a.frames,
        every: a.every,
        out_dir: a.out.clone(),
        gif: a.gif.clone(),
        overlays,
    })
}

/// The panes of `--compare`: the scene built once per value, its flags over the
/// command line's, labelled with the value (whitespace tidied).
#[cfg(feature = "render")]
fn compare_panes(
    scene: &str,
    values: &[String],
    base: &SolverFlags,
    start: Option<&WorldState>,
) -> Result<(Scene, Vec<sandbox2d::compare::Pane>), Failure> {
    let flags = parse_compare(values)?;
    let mut panes = Vec::with_capacity(flags.len());
    let mut first = None;
    for (v, f) in values.iter().zip(&flags) {
        let (sc, mut world, settings) = build(scene, &f.over(base))?;
        if let Some(st) = start {
            // the pane goes on from the start's world with its own settings
            world
                .restore(st)
                .map_err(|e| Failure::run(format!("{}: {e}", sc.source)))?;
            world.settings = settings;
        }
        let label = sandbox2d::compare::split_words(v).join(" ");
        let label = if label.is_empty() {
            "(the scene's settings)".to_owned()
        } else {
            label
        };
        panes.push(sandbox2d::compare::Pane::new(label, world));
        first.get_or_insert(sc);
    }
    let sc = first.ok_or_else(|| Failure::input("--compare: no pane"))?;
    Ok((sc, panes))
}

/// `render --compare`: the panes side by side, each `--size`'s width / panes wide.
#[cfg(feature = "render")]
fn render_compare(a: &RenderArgs, start: Option<&WorldState>) -> Result<(), Failure> {
    let (sc, mut panes) = compare_panes(&a.scene, &a.compare, &a.solver, start)?;
    let job = frame_job(a)?;
    let size = a.size.unwrap_or(sc.camera.size);
    let pane_w = sandbox2d::render::compare::pane_width(size[0], panes.len());
    let camera =
        sandbox2d::draw::world::scene_camera(&sc.camera, [pane_w, size[1]], &panes[0].world);
    let mut renderer = sandbox2d::render::Renderer::new_headless().map_err(Failure::run)?;
    let bar = progress(
        Some(job.frames as u64),
        "{bar:40} {pos}/{len} frames {elapsed}",
    );
    GRACEFUL.store(true, Ordering::Relaxed);
    let written = sandbox2d::render::compare::render_compare_frames(
        &mut panes,
        &camera,
        &mut renderer,
        &job,
        |k| bar.set_position(k as u64 + 1),
    );
    bar.finish_and_clear();
    let written = written.map_err(|e| match e {
        e @ sandbox2d::render::FramesError::PaneStep { .. } => {
            Failure::run(format!("{}: {e}", sc.source))
        }
        e => frames_failure(e),
    })?;
    print_written(&written, &a.out)?;
    for p in &panes {
        say!(
            "{:<32} mean {:.3} ms/step",
            p.label,
            p.mean_ms().unwrap_or(0.0)
        )?;
    }
    Ok(())
}

/// Frames the headless fallback of `run` writes when `--frames` is not given.
#[cfg(feature = "render")]
const FALLBACK_FRAMES: u32 = 120;

#[cfg(feature = "render")]
fn run(a: &RunArgs) -> Result<(), Failure> {
    // Refuse a bad scene or flag before any window opens.
    if let (Some(shot), Some(file)) = (&a.screenshot, scene_file(&a.scene)) {
        check_distinct(&[("--screenshot", shot)], &[("scene file", &file)])?;
    }
    let (sc, _, _) = build(&a.scene, &a.solver)?;
    // --compare: each pane's flags over the command line's, checked before any window
    let mut panes = Vec::new();
    if !a.compare.is_empty() {
        let flags = parse_compare(&a.compare)?;
        for (v, f) in a.compare.iter().zip(&flags) {
            let f = f.over(&a.solver);
            build(&a.scene, &f)?;
            let label = sandbox2d::compare::split_words(v).join(" ");
            let label = if label.is_empty() {
                "(the scene's settings)".to_owned()
            } else {
                label
            };
            panes.push((label, f.overrides()));
        }
    }
    #[cfg(feature = "app")]
    {
        use sandbox2d::app::{AppError, AppOptions};
        let opts = AppOptions {
            frames: a.frames,
            screenshot: a.screenshot.clone(),
            show_panel: !a.no_panel,
        };
        for (i, (label, _)) in panes.iter().enumerate() {
            say!("pane {}: {label}", i + 1)?;
        }
        let shown = if panes.is_empty() {
            sandbox2d::app::run(sc.clone(), a.solver.overrides(), opts)
        } else {
            sandbox2d::app::run_compare(sc.clone(), panes.clone(), opts)
        };
        match shown {
            Ok(report) => {
                say!(
                    "sandbox2d: {} frames in {:.2} s: {:.1} fps (frame time median {:.1} ms, p95 {:.1} ms) on {}",
                    report.frames,
                    report.seconds,
                    report.fps(),
                    report.frame_ms_median,
                    report.frame_ms_p95,
                    if report.adapter.is_empty() {
                        "?"
                    } else {
                        &report.adapter
                    }
                )?;
                if let Some(p) = &report.screenshot {
                    say!("screenshot: {}", p.display())?;
                }
                return Ok(());
            }
            Err(AppError::NoDisplay(why)) => {
                say!(
                    "sandbox2d: no display ({why}); rendering {:?} headless into ./out instead",
                    sc.name
                )?;
            }
            Err(AppError::Build(e)) => return Err(Failure::input(e)),
            Err(e) => return Err(Failure::run(e)),
        }
    }
    #[cfg(not(feature = "app"))]
    say!(
        "sandbox2d: built without the window (feature \"app\"); rendering {:?} headless into ./out instead",
        sc.name
    )?;
    run_headless(a, &sc)
}

/// `run` without a display: frames of the scene into ./out (and the last one to
/// `--screenshot`).
#[cfg(feature = "render")]
fn run_headless(a: &RunArgs, sc: &Scene) -> Result<(), Failure> {
    let out = PathBuf::from("out");
    let frames = match a.frames {
        Some(0) => return Err(Failure::input("--frames must be at least 1")),
        Some(n) => u32::try_from(n).map_err(|_| {
            Failure::input(format!("--frames must be at most {}, got {n}", u32::MAX))
        })?,
        None => FALLBACK_FRAMES,
    };
    if let Some(shot) = &a.screenshot {
        let mut inputs: Vec<(&str, PathBuf)> = vec![("output folder", out.clone())];
        if let Some(file) = scene_file(&a.scene) {
            inputs.push(("scene file", file));
        }
        if let Some(name) = shot.file_name().and_then(|n| n.to_str())
            && let Some(k) = name
                .strip_prefix("frame_")
                .and_then(|r| r.strip_suffix(".png"))
                .and_then(|d| d.parse::<u32>().ok())
            && k < frames
            && sandbox2d::render::frame_name(k) == name
        {
            inputs.push((
                "frame it writes",
                out.join(sandbox2d::render::frame_name(k)),
            ));
        }
        let inputs: Vec<(&str, &Path)> = inputs.iter().map(|(w, p)| (*w, p.as_path())).collect();
        check_distinct(&[("--screenshot", shot)], &inputs)?;
    }
    if let Some(file) = scene_file(&a.scene) {
        check_folder_outputs(
            "the headless frames (./out)",
            &out,
            |n| is_frame_name(n, frames),
            &[("scene file", &file)],
        )?;
    }
    let (_, mut world, _) = build(&a.scene, &a.solver)?;
    let job = sandbox2d::render::FrameJob {
        frames,
        every: 1,
        out_dir: out.clone(),
        gif: None,
        overlays: sandbox2d::draw::Overlays::NONE,
    };
    let written = render_job(sc, &mut world, sc.camera.size, &job)?;
    print_written(&written, &out)?;
    if let (Some(shot), Some(last)) = (&a.screenshot, written.pngs.last()) {
        let bytes = std::fs::read(last)
            .map_err(|e| Failure::run(format!("{}: cannot read: {e}", last.display())))?;
        output::write_atomic(shot, &bytes).map_err(Failure::run)?;
        say!("screenshot: {}", shot.display())?;
    }
    Ok(())
}

/// A progress bar on a terminal; hidden when stdout is not one.
fn bench_progress(total: usize) -> indicatif::ProgressBar {
    if !std::io::stdout().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(total as u64);
    b.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

/// Writes a result file in full or not at all.
fn write_file(path: &std::path::Path, text: &str) -> Result<(), Failure> {
    output::write_atomic(path, text.as_bytes()).map_err(Failure::run)
}

/// Creates the results folder and checks that a file can be written in it, before any
/// case runs (rather than after minutes of measuring).
fn writable_dir(dir: &Path) -> Result<(), Failure> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Failure::input(format!("{}: cannot create: {e}", dir.display())))?;
    let probe = dir.join("results.csv");
    // created and dropped uncommitted: the temporary file is removed again
    AtomicFile::create(&probe).map_err(|e| {
        Failure::input(format!(
            "{}: cannot write in this folder: {}",
            dir.display(),
            e.source
        ))
    })?;
    Ok(())
}

fn bench(a: &BenchArgs) -> Result<(), Failure> {
    use sandbox2d::bench::{self, Suite, extremes, shard};
    if !a.merge.is_empty() {
        if let Some(id) = &a.run_id {
            bench::slurm::check_run_id(id).map_err(|e| Failure::input(format!("--run-id: {e}")))?;
        }
        return bench_merge(&a.merge, &a.out, a.run_id.as_deref());
    }
    if a.steps == Some(0) {
        return Err(Failure::input("--steps must be at least 1"));
    }
    if a.repeats == Some(0) {
        return Err(Failure::input("--repeats must be at least 1"));
    }
    if a.jobs == 0 {
        return Err(Failure::input("--jobs must be at least 1"));
    }
    let part = a
        .shard
        .as_deref()
        .map(|s| bench::slurm::resolve(s, env_var))
        .transpose()
        .map_err(Failure::input)?;
    if a.metric.is_some() && !matches!(a.suite, SuiteArg::Quick | SuiteArg::Standard) {
        return Err(Failure::input(
            "--metric trajectory: for the quick and standard suites (the convergence suite measures against the closed forms itself)",
        ));
    }
    if a.metric.is_some() && part.is_some() {
        return Err(Failure::input(
            "--metric trajectory does not shard: each scene's reference is worked out once, in one run",
        ));
    }
    if a.run_id.is_some() && part.is_none() {
        return Err(Failure::input(
            "--run-id names the run of a shard: give it with --shard or --merge",
        ));
    }
    let run = match part {
        Some(_) => bench::slurm::run_id(a.run_id.as_deref(), env_var).map_err(Failure::input)?,
        None => None,
    };
    let suite = match a.suite {
        SuiteArg::Quick => Suite::Quick,
        SuiteArg::Standard => Suite::Standard,
        SuiteArg::Extremes => Suite::Extremes,
        SuiteArg::Scaling => return bench_scaling(a, part.is_some()),
        SuiteArg::Contention => return bench_contention(a, part.is_some()),
        SuiteArg::Convergence => return bench_convergence(a, part.is_some()),
        SuiteArg::Box2d => return bench_box2d(a, part, run),
    };
    let filter = a.filter.clone();
    let key = shard::RunKey {
        suite,
        filter: filter.clone(),
        steps: a.steps,
        repeats: a.repeats,
        run,
    };
    if suite == Suite::Extremes {
        let sweeps = extremes::sweeps(filter.as_deref());
        if sweeps.is_empty() {
            return Err(Failure::input(format!(
                "--filter {:?} matches no sweep",
                filter.unwrap_or_default()
            )));
        }
        writable_dir(&a.out)?;
        let all = extremes::cases(&sweeps);
        let picked: Vec<usize> = match part {
            Some(p) => p.indices(all.len()),
            None => (0..all.len()).collect(),
        };
        let cases: Vec<extremes::ExCase> = picked.iter().map(|&i| all[i]).collect();
        let bar = bench_progress(cases.len());
        let mut done = 0;
        let (results, complete) = bench::run_jobs(
            &cases,
            a.jobs,
            |c| c.run(),
            |i, _| {
                done += 1;
                bar.set_position(done as u64);
                bar.set_message(cases[i].label());
                Ok::<(), Failure>(())
            },
        )?;
        bar.finish_and_clear();
        if !complete {
            return Err(Failure::interrupted("interrupted: nothing was written"));
        }
        let results: Vec<extremes::CaseResult> = results.into_iter().flatten().collect();
        if let Some(p) = part {
            let rows: Vec<_> = picked
                .iter()
                .zip(&cases)
                .zip(&results)
                .map(|((&i, c), r)| (i, c, r))
                .collect();
            let path = a.out.join(p.file_name());
            write_file(&path, &shard::extremes_json(&key, p, all.len(), &rows))?;
            say!(
                "wrote {} (shard {p}: {} of {} cases)",
                path.display(),
                cases.len(),
                all.len()
            )?;
            return Ok(());
        }
        return write_stability(&a.out, &extremes::assemble(&cases, results));
    }
    let opts = bench::Options {
        filter,
        steps: a.steps,
        repeats: a.repeats,
    };
    let mut scenes = opts.scenes(suite);
    if scenes.is_empty() {
        return Err(Failure::input(format!(
            "--filter {:?} matches no scene of the {} suite",
            opts.filter.clone().unwrap_or_default(),
            suite.name()
        )));
    }
    writable_dir(&a.out)?;
    if a.metric.is_some() {
        GRACEFUL.store(true, Ordering::Relaxed);
        let bar = bench_progress(scenes.len());
        bar.set_message("the true motions (references)");
        bench::truth::attach(
            &mut scenes,
            |sc| opts.budget(sc).steps,
            |done, _, name| {
                bar.set_position(done as u64);
                bar.set_message(format!("truth of {name}"));
            },
        );
        bar.finish_and_clear();
        if output::interrupted() {
            return Err(Failure::interrupted("interrupted: nothing was written"));
        }
    }
    let all = bench::cases(&scenes);
    let picked: Vec<usize> = match part {
        Some(p) => p.indices(all.len()),
        None => (0..all.len()).collect(),
    };
    let cases: Vec<bench::Case> = picked.iter().map(|&i| all[i]).collect();
    let total = cases.len();
    let bar = bench_progress(total);
    // Each finished case's row goes at once to a temporary file kept as
    // results.partial.csv (a shard's as results.shard-I-of-N.partial.csv) when the suite
    // stops early: interrupted, failed (a full disk), or interrupted twice; it then
    // holds whole rows only. A complete suite's reports replace it.
    GRACEFUL.store(true, Ordering::Relaxed);
    let partial_path = a.out.join(match part {
        Some(p) => format!("results.shard-{}-of-{}.partial.csv", p.index, p.count),
        None => "results.partial.csv".to_string(),
    });
    let mut partial = output::RowFile::create(&partial_path).map_err(Failure::input)?;
    partial
        .push(&format!("{}\n", bench::report::CSV_COLUMNS.join(",")))
        .map_err(Failure::run)?;
    let run = bench::run_cases(&scenes, &opts, &cases, a.jobs, |done, _, what, row| {
        bar.set_position(done as u64);
        bar.set_message(what.to_string());
        let csv = bench::report::csv(std::slice::from_ref(row));
        let line = csv.split_once('\n').map_or("", |(_, rest)| rest);
        partial.push(line).map_err(Failure::run)
    });
    bar.finish_and_clear();
    // a run that stops early keeps the finished rows and says where
    let kept = |partial: output::RowFile| {
        let rows = partial.rows().saturating_sub(1);
        match partial.keep() {
            Ok(p) => format!(
                "kept the {rows} finished case(s) of {total} in {}",
                p.display()
            ),
            Err(e) => format!("the finished cases were not kept: {e}"),
        }
    };
    let keep = |partial: output::RowFile, mut f: Failure| {
        f.message += &format!("; {}", kept(partial));
        f
    };
    let (rows, complete) = match run {
        Ok(r) => r,
        Err(f) => return Err(keep(partial, f)),
    };
    if !complete {
        let what = if part.is_some() {
            "the shard file was"
        } else {
            "results.csv, results.md and the plots were"
        };
        return Err(Failure::interrupted(format!(
            "interrupted: {}; {what} not written",
            kept(partial)
        )));
    }
    let rows: Vec<bench::Row> = rows.into_iter().flatten().collect();
    if let Some(p) = part {
        let indexed: Vec<(usize, &bench::Row)> = picked.iter().copied().zip(&rows).collect();
        let path = a.out.join(p.file_name());
        if let Err(f) = write_file(&path, &shard::scenes_json(&key, p, all.len(), &indexed)) {
            return Err(keep(partial, f));
        }
        drop(partial);
        // an earlier run's unfinished rows are superseded
        let _ = std::fs::remove_file(&partial_path);
        say!(
            "wrote {} (shard {p}: {} of {} cases)",
            path.display(),
            rows.len(),
            all.len()
        )?;
        return Ok(());
    }
    if let Err(f) = write_reports(&a.out, suite, &scenes, &rows) {
        return Err(keep(partial, f));
    }
    drop(partial);
    // an earlier run's unfinished rows are superseded
    let _ = std::fs::remove_file(&partial_path);
    Ok(())
}

/// `bench --suite scaling`: the pyramid at each size and thread count, one run at a
/// time (its timings are what it reports), then scaling.csv, scaling.md, scaling.svg.
fn bench_scaling(a: &BenchArgs, sharded: bool) -> Result<(), Failure> {
    use sandbox2d::bench::scaling;
    if sharded || a.jobs != 1 {
        return Err(Failure::input(
            "--suite scaling runs one case at a time (it times threads against each other): --jobs and --shard do not apply",
        ));
    }
    let sizes = scaling::sizes(a.filter.as_deref());
    if sizes.is_empty() {
        return Err(Failure::input(format!(
            "--filter {:?} matches no size of the scaling suite (1k, 5k, 20k, 80k)",
            a.filter.clone().unwrap_or_default()
        )));
    }
    writable_dir(&a.out)?;
    let cores = sandbox2d::threads::available();
    let threads = scaling::thread_counts(cores);
    let repeats = a.repeats.unwrap_or(scaling::REPEATS);
    let runs = scaling::runs(&sizes, &threads, repeats);
    let bar = bench_progress(runs.len());
    let mut defs = Vec::new();
    let mut timed = Vec::with_capacity(runs.len());
    for (i, r) in runs.iter().enumerate() {
        if output::interrupted() {
            return Err(Failure::interrupted("interrupted: nothing was written"));
        }
        bar.set_message(r.label(repeats));
        let def = match defs.iter().find(|(b, _)| *b == r.size.base) {
            Some((_, d)) => d,
            None => {
                let d = scaling::scene(r.size.base).map_err(Failure::run)?;
                defs.push((r.size.base, d));
                &defs[defs.len() - 1].1
            }
        };
        let steps = a.steps.unwrap_or(r.size.steps);
        let warmup = scaling::WARMUP_STEPS.min(steps);
        log::debug!("bench: {}", r.label(repeats));
        let t = scaling::run_one(def, r.threads, warmup, steps)
            .map_err(|e| Failure::run(format!("{}: {e}", r.label(repeats))))?;
        timed.push(t);
        bar.set_position(i as u64 + 1);
    }
    bar.finish_and_clear();
    let rows = scaling::assemble(&runs, &timed, &threads);
    let mut command = String::from("sandbox2d bench --suite scaling");
    if let Some(f) = &a.filter {
        command.push_str(&format!(" --filter {f}"));
    }
    if let Some(s) = a.steps {
        command.push_str(&format!(" --steps {s}"));
    }
    if let Some(r) = a.repeats {
        command.push_str(&format!(" --repeats {r}"));
    }
    command.push_str(&format!(" --out {}", a.out.display()));
    let svg = scaling::svg(&rows).map_err(Failure::run)?;
    write_file(&a.out.join("scaling.svg"), &svg)?;
    write_file(&a.out.join("scaling.csv"), &scaling::csv(&rows))?;
    write_file(
        &a.out.join("scaling.md"),
        &scaling::markdown(&rows, repeats, cores, &command),
    )?;
    say!(
        "wrote {}: scaling.csv, scaling.md and scaling.svg ({} rows)",
        a.out.display(),
        rows.len()
    )?;
    Ok(())
}

/// `bench --suite contention`: each scene at one thread and two, idle and beside busy
/// processes the suite starts (every core but one), one run at a time, then
/// contention.csv and contention.md.
fn bench_contention(a: &BenchArgs, sharded: bool) -> Result<(), Failure> {
    use sandbox2d::bench::contention;
    if sharded || a.jobs != 1 {
        return Err(Failure::input(
            "--suite contention runs one case at a time (it times threads against each other): --jobs and --shard do not apply",
        ));
    }
    let scenes = contention::scenes(a.filter.as_deref());
    if scenes.is_empty() {
        return Err(Failure::input(format!(
            "--filter {:?} matches no scene of the contention suite (large_pyramid, many_pyramids)",
            a.filter.clone().unwrap_or_default()
        )));
    }
    writable_dir(&a.out)?;
    let cores = sandbox2d::threads::available();
    let rounds = a.repeats.unwrap_or(contention::ROUNDS);
    let runs = contention::runs(&scenes, rounds);
    let bar = bench_progress(runs.len());
    let mut defs: Vec<(&str, sandbox2d::WorldDef)> = Vec::new();
    let mut timed = Vec::with_capacity(runs.len());
    let mut busy: Option<BusyProcesses> = None;
    for (i, r) in runs.iter().enumerate() {
        if output::interrupted() {
            return Err(Failure::interrupted("interrupted: nothing was written"));
        }
        // the busy processes run exactly while the busy runs do
        if r.busy != busy.is_some() {
            busy = if r.busy {
                Some(BusyProcesses::start(cores.saturating_sub(1).max(1))?)
            } else {
                None
            };
        }
        bar.set_message(r.label(rounds));
        let def = match defs.iter().find(|(n, _)| *n == r.scene.name) {
            Some((_, d)) => d,
            None => {
                let d = contention::scene(r.scene.name).map_err(Failure::run)?;
                defs.push((r.scene.name, d));
                &defs[defs.len() - 1].1
            }
        };
        let steps = a.steps.unwrap_or(r.scene.steps);
        let warmup = contention::WARMUP_STEPS.min(steps);
        log::debug!("bench: {}", r.label(rounds));
        let t = contention::run_one(def, r.mode.policy(cores), warmup, steps)
            .map_err(|e| Failure::run(format!("{}: {e}", r.label(rounds))))?;
        timed.push(t);
        bar.set_position(i as u64 + 1);
    }
    drop(busy);
    bar.finish_and_clear();
    let rows = contention::assemble(&runs, &timed);
    let mut command = String::from("sandbox2d bench --suite contention");
    if let Some(f) = &a.filter {
        command.push_str(&format!(" --filter {f}"));
    }
    if let Some(s) = a.steps {
        command.push_str(&format!(" --steps {s}"));
    }
    if let Some(r) = a.repeats {
        command.push_str(&format!(" --repeats {r}"));
    }
    command.push_str(&format!(" --out {}", a.out.display()));
    write_file(&a.out.join("contention.csv"), &contention::csv(&rows))?;
    let md = contention::markdown(&rows, rounds, cores, &command);
    write_file(&a.out.join("contention.md"), &md)?;
    println!(
        "wrote {}: contention.csv and contention.md ({} rows)",
        a.out.display(),
        rows.len()
    );
    Ok(())
}

/// Processes that spin on a core each (this program's hidden `busy-loop`), killed when
/// dropped.
struct BusyProcesses(Vec<std::process::Child>);

impl BusyProcesses {
    fn start(n: usize) -> Result<BusyProcesses, Failure> {
        let exe = std::env::current_exe().map_err(|e| {
            Failure::run(format!(
                "cannot find this program to start a busy process: {e}"
            ))
        })?;
        let mut started = BusyProcesses(Vec::with_capacity(n));
        for _ in 0..n {
            let child = std::process::Command::new(&exe)
                .arg("busy-loop")
                .stdin(std::process::Stdio::null())
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .spawn()
                .map_err(|e| Failure::run(format!("cannot start a busy process: {e}")))?;
            started.0.push(child);
        }
        Ok(started)
    }
}

impl Drop for BusyProcesses {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// The hidden `busy-loop` command: spins on one core until its parent is gone (the
/// contention suite kills it; this is in case the suite itself was killed).
fn busy_loop() -> Result<(), Failure> {
    #[cfg(unix)]
    let parent = std::os::unix::process::parent_id();
    loop {
        for _ in 0..(1 << 20) {
            std::hint::spin_loop();
        }
        #[cfg(unix)]
        if std::os::unix::process::parent_id() != parent {
            return Ok(());
        }
    }
}

/// `bench --suite convergence`: every solver at halving steps on the closed-form
/// scenes, then convergence.csv, convergence.md and convergence.svg.
fn bench_convergence(a: &BenchArgs, sharded: bool) -> Result<(), Failure> {
    use sandbox2d::bench::convergence;
    if sharded || a.jobs != 1 {
        return Err(Failure::input(
            "--suite convergence runs in seconds on one thread: --jobs and --shard do not apply",
        ));
    }
    let scenes = convergence::scenes(a.filter.as_deref());
    if scenes.is_empty() {
        return Err(Failure::input(format!(
            "--filter {:?} matches no scene of the convergence suite (projectile_drag, pendulum, spring, rolling_disk, sliding_box)",
            a.filter.clone().unwrap_or_default()
        )));
    }
    writable_dir(&a.out)?;
    GRACEFUL.store(true, Ordering::Relaxed);
    let bar = bench_progress(scenes.len() * SolverKind::ALL.len());
    let series = convergence::run_all(&scenes, |done, _, what| {
        bar.set_position(done as u64);
        bar.set_message(what.to_string());
    });
    bar.finish_and_clear();
    let series = match series {
        Ok(s) => s,
        Err(_) if output::interrupted() => {
            return Err(Failure::interrupted("interrupted: nothing was written"));
        }
        Err(e) => return Err(Failure::run(e)),
    };
    let mut command = String::from("sandbox2d bench --suite convergence");
    if let Some(f) = &a.filter {
        command.push_str(&format!(" --filter {f}"));
    }
    command.push_str(&format!(" --out {}", a.out.display()));
    write_file(
        &a.out.join("convergence.svg"),
        &convergence::svg(&series).map_err(Failure::run)?,
    )?;
    write_file(&a.out.join("convergence.csv"), &convergence::csv(&series))?;
    write_file(
        &a.out.join("convergence.md"),
        &convergence::markdown(&series, &command),
    )?;
    println!(
        "wrote {}: convergence.csv, convergence.md and convergence.svg",
        a.out.display()
    );
    for x in &series {
        println!(
            "{:<16} {:<10} order {}",
            x.scene,
            x.kind.name(),
            x.fit.map_or("-".to_string(), |f| format!("{:.2}", f.order))
        );
    }
    Ok(())
}

/// `bench --suite box2d`: each of Box2D's benchmark scenes on 1 and 2 threads, then
/// box2d.csv, box2d.md and box2d.svg (or, with --shard, the shard's file).
fn bench_box2d(
    a: &BenchArgs,
    part: Option<sandbox2d::bench::Shard>,
    run: Option<String>,
) -> Result<(), Failure> {
    use sandbox2d::bench::{self, Suite, box2d, shard};
    let scenes = box2d::scenes(a.filter.as_deref());
    if scenes.is_empty() {
        return Err(Failure::input(format!(
            "--filter {:?} matches no scene of the box2d suite ({})",
            a.filter.clone().unwrap_or_default(),
            box2d::SCENES.map(|s| s.name).join(", ")
        )));
    }
    writable_dir(&a.out)?;
    let all = box2d::cases(&scenes);
    let picked: Vec<usize> = match part {
        Some(p) => p.indices(all.len()),
        None => (0..all.len()).collect(),
    };
    let cases: Vec<box2d::Case> = picked.iter().map(|&i| all[i]).collect();
    let repeats = a.repeats.unwrap_or(1);
    let bar = bench_progress(cases.len());
    if let Some(c) = cases.first() {
        bar.set_message(c.label());
    }
    let mut done = 0;
    let (results, complete) = bench::run_jobs(
        &cases,
        a.jobs,
        |c| box2d::run_case(c, a.steps, repeats),
        |i, r| {
            done += 1;
            bar.set_position(done as u64);
            bar.set_message(cases.get(i + 1).map_or(String::new(), |c| c.label()));
            match r {
                Ok(_) => Ok(()),
                Err(e) => Err(Failure::run(e.clone())),
            }
        },
    )?;
    bar.finish_and_clear();
    if !complete {
        return Err(Failure::interrupted("interrupted: nothing was written"));
    }
    let rows: Vec<box2d::Row> = results.into_iter().flatten().flatten().collect();
    if let Some(p) = part {
        let key = shard::RunKey {
            suite: Suite::Box2d,
            filter: a.filter.clone(),
            steps: a.steps,
            repeats: a.repeats,
            run,
        };
        let indexed: Vec<(usize, &box2d::Row)> = picked.iter().copied().zip(&rows).collect();
        let path = a.out.join(p.file_name());
        write_file(&path, &shard::box2d_json(&key, p, all.len(), &indexed))?;
        println!(
            "wrote {} (shard {p}: {} of {} cases)",
            path.display(),
            rows.len(),
            all.len()
        );
        return Ok(());
    }
    let mut command = String::from("sandbox2d bench --suite box2d");
    if let Some(f) = &a.filter {
        command.push_str(&format!(" --filter {f}"));
    }
    if let Some(s) = a.steps {
        command.push_str(&format!(" --steps {s}"));
    }
    if let Some(r) = a.repeats {
        command.push_str(&format!(" --repeats {r}"));
    }
    if a.jobs != 1 {
        command.push_str(&format!(" --jobs {}", a.jobs));
    }
    command.push_str(&format!(" --out {}", a.out.display()));
    write_box2d(&a.out, &rows, &command)
}

/// Writes the box2d suite's reports into `out`.
fn write_box2d(
    out: &Path,
    rows: &[sandbox2d::bench::box2d::Row],
    command: &str,
) -> Result<(), Failure> {
    use sandbox2d::bench::box2d;
    write_file(
        &out.join("box2d.svg"),
        &box2d::svg(rows).map_err(Failure::run)?,
    )?;
    write_file(&out.join("box2d.csv"), &box2d::csv(rows))?;
    write_file(&out.join("box2d.md"), &box2d::markdown(rows, command))?;
    println!(
        "wrote {}: box2d.csv, box2d.md and box2d.svg ({} rows)",
        out.display(),
        rows.len()
    );
    Ok(())
}

/// Writes stability.md (the extremes suite's report) into `out`.
fn write_stability(
    out: &Path,
    results: &[sandbox2d::bench::extremes::SweepResult],
) -> Result<(), Failure> {
    let path = out.join("stability.md");
    write_file(&path, &sandbox2d::bench::extremes::markdown(results))?;
    say!("wrote {}", path.display())?;
    Ok(())
}

/// Writes a suite's reports into `out`: one plot per scene, results.csv, results.md.
fn write_reports(
    out: &Path,
    suite: sandbox2d::bench::Suite,
    scenes: &[sandbox2d::bench::BenchScene],
    rows: &[sandbox2d::bench::Row],
) -> Result<(), Failure> {
    use sandbox2d::bench;
    let mut plots = Vec::new();
    for sc in scenes {
        if let Some(svg) = bench::plot::svg(sc, rows).map_err(Failure::run)? {
            let name = format!("{}.svg", sc.name);
            write_file(&out.join(&name), &svg)?;
            plots.push(name);
        }
    }
    write_file(&out.join("results.csv"), &bench::report::csv(rows))?;
    write_file(
        &out.join("results.md"),
        &bench::report::markdown(suite, scenes, rows, &plots),
    )?;
    say!(
        "wrote {}: results.csv, results.md and {} plot(s) ({} rows)",
        out.display(),
        plots.len(),
        rows.len()
    )?;
    Ok(())
}

/// The shard files given to `--merge`, `(name, text)` each: the files, and in each
/// folder the files `PREFIX.shard-*.json` (sorted by name, a shard's unfinished
/// `.partial.json` left out). Refused when a file the merge writes into the folder
/// `out` (`writes(name)`) would replace one of them.
fn read_shard_files(
    inputs: &[PathBuf],
    prefix: &str,
    out: Option<&Path>,
    writes: impl Fn(&str) -> bool,
) -> Result<Vec<(String, String)>, Failure> {
    let start = format!("{prefix}.shard-");
    let mut paths = Vec::new();
    for p in inputs {
        if p.is_dir() {
            let entries = std::fs::read_dir(p)
                .map_err(|e| Failure::input(format!("{}: cannot read: {e}", p.display())))?;
            let mut found: Vec<PathBuf> = entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                        n.starts_with(&start)
                            && n.ends_with(".json")
                            && !n.ends_with(".partial.json")
                    })
                })
                .collect();
            if found.is_empty() {
                return Err(Failure::input(format!(
                    "{}: no shard files ({prefix}.shard-I-of-N.json) in this folder",
                    p.display()
                )));
            }
            found.sort();
            paths.extend(found);
        } else {
            paths.push(p.clone());
        }
    }
    // a report or plot it writes must not replace a shard it reads
    let inputs: Vec<(&str, &Path)> = paths.iter().map(|p| ("shard file", p.as_path())).collect();
    if let Some(out) = out {
        check_folder_outputs("--out", out, writes, &inputs)?;
    }
    let mut files = Vec::with_capacity(paths.len());
    for p in &paths {
        let text = std::fs::read_to_string(p)
            .map_err(|e| Failure::input(format!("{}: cannot read: {e}", p.display())))?;
        files.push((p.display().to_string(), text));
    }
    Ok(files)
}

/// `bench --merge`: the shard files (or the shard files in the folders) given, merged
/// into the reports of one unsharded run.
fn bench_merge(inputs: &[PathBuf], out: &Path, run: Option<&str>) -> Result<(), Failure> {
    use sandbox2d::bench::shard::{self, Merged};
    let files = read_shard_files(inputs, "results", Some(out), merge_writes)?;
    let merged = shard::merge(&files, run).map_err(Failure::input)?;
    writable_dir(out)?;
    match merged {
        Merged::Extremes { results } => write_stability(out, &results),
        Merged::Box2d { rows } => write_box2d(
            out,
            &rows,
            &format!("sandbox2d bench --merge ... --out {}", out.display()),
        ),
        Merged::Scenes {
            suite,
            scenes,
            rows,
        } => write_reports(out, suite, &scenes, &rows),
    }
}

/// The most steps `tune` runs a setting for (each of some 40 settings runs them
/// `--rounds` times).
const MAX_TUNE_STEPS: u64 = 1_000_000;

fn tune(a: &TuneArgs) -> Result<(), Failure> {
    use sandbox2d::bench::{shard, slurm, tune};
    if !a.merge.is_empty() {
        return tune_merge(a);
    }
    let (Some(scene_name), Some(budget_ms)) = (a.scene.as_deref(), a.budget_ms) else {
        return Err(Failure::input("give a scene and --budget-ms (or --merge)"));
    };
    if !(budget_ms.is_finite() && budget_ms > 0.0) {
        return Err(Failure::input(format!(
            "--budget-ms must be a positive number of milliseconds, got {budget_ms}"
        )));
    }
    if !(1..=MAX_TUNE_STEPS).contains(&a.steps) {
        return Err(Failure::input(format!(
            "--steps must be 1..={MAX_TUNE_STEPS}, got {}",
            a.steps
        )));
    }
    if !(1..=20).contains(&a.rounds) {
        return Err(Failure::input(format!(
            "--rounds must be 1..=20, got {}",
            a.rounds
        )));
    }
    if a.jobs == 0 {
        return Err(Failure::input("--jobs must be at least 1"));
    }
    let part = a
        .shard
        .as_deref()
        .map(|s| slurm::resolve(s, env_var))
        .transpose()
        .map_err(Failure::input)?;
    let run = match part {
        Some(_) => {
            if a.json || a.write {
                return Err(Failure::input(
                    "--shard writes a shard file for --merge: --json and --write go with the merge",
                ));
            }
            if a.out.is_none() {
                return Err(Failure::input(
                    "--shard needs --out, the folder for tune.shard-I-of-N.json",
                ));
            }
            slurm::run_id(a.run_id.as_deref(), env_var).map_err(Failure::input)?
        }
        None if a.run_id.is_some() => {
            return Err(Failure::input(
                "--run-id names the run of a shard: give it with --shard or --merge",
            ));
        }
        None => None,
    };
    let file = scene_file(scene_name);
    if a.write && file.is_none() {
        return Err(Failure::input(format!(
            "--write: \"{scene_name}\" is a built-in scene, not a file; copy assets/scenes/{scene_name}.toml and tune the copy"
        )));
    }
    let metric = match a.metric {
        MetricArg::Worst => tune::TuneMetric::Worst,
        MetricArg::Penetration => tune::TuneMetric::Penetration,
        MetricArg::Drift => tune::TuneMetric::Drift,
        MetricArg::JointError => tune::TuneMetric::JointError,
        MetricArg::EnergyDrift => tune::TuneMetric::EnergyDrift,
        MetricArg::Residual => tune::TuneMetric::Residual,
        MetricArg::Trajectory => tune::TuneMetric::Trajectory,
    };
    if let (Some(out), Some(f)) = (&a.out, &file) {
        check_folder_outputs(
            "--out",
            out,
            |n| TUNE_FILES.contains(&n),
            &[("scene file", f)],
        )?;
    }
    let sc = scene::load(scene_name).map_err(Failure::input)?;
    if let Some(out) = &a.out {
        writable_dir(out)?;
    }
    let options = tune::TuneOptions {
        budget_ms,
        metric,
        steps: a.steps,
        rounds: a.rounds,
        jobs: a.jobs,
    };
    let bar = progress(
        Some(sandbox2d::bench::settings_grid().len() as u64),
        "{bar:40} {pos}/{len} runs {elapsed} {msg}",
    );
    GRACEFUL.store(true, Ordering::Relaxed);
    let on_run = |done: usize, total: usize, what: &str| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        bar.set_message(what.to_string());
    };
    if let (Some(p), Some(out)) = (part, &a.out) {
        let rows = tune::tune_shard(scene_name, &sc.world, &options, p, on_run);
        bar.finish_and_clear();
        let rows = rows.map_err(|e| tune_failure(&sc, budget_ms, e))?;
        let key = shard::TuneKey {
            scene: scene_name.to_string(),
            digest: tune::scene_digest(&sc.world),
            options,
            run,
        };
        let cases = sandbox2d::bench::settings_grid().len();
        let path = out.join(shard::tune_file_name(p));
        write_file(&path, &shard::tune_json(&key, p, cases, &rows))?;
        println!(
            "wrote {} (shard {p}: {} of {cases} settings)",
            path.display(),
            rows.len()
        );
        return Ok(());
    }
    let result = tune::tune(scene_name, &sc.world, &options, on_run);
    bar.finish_and_clear();
    let report = result.map_err(|e| tune_failure(&sc, budget_ms, e))?;
    tune_output(a, &sc, file.as_deref(), &report)
}

/// A search that ended without a pick, as the command reports it.
fn tune_failure(sc: &Scene, budget_ms: f64, e: sandbox2d::bench::tune::TuneError) -> Failure {
    use sandbox2d::bench::tune::TuneError;
    match e {
        TuneError::Interrupted => {
            Failure::interrupted(format!("{}: interrupted; nothing was written", sc.source))
        }
        e @ TuneError::OverBudget { .. } => {
            Failure::input(format!("{}: {e} (budget {budget_ms} ms/step)", sc.source))
        }
        e @ TuneError::NoTruth(_) => Failure::input(format!("{}: {e}", sc.source)),
        e => Failure::run(format!("{}: {e}", sc.source)),
    }
}

/// `tune --merge`: the shards of one search's coarse pass (files, or folders of
/// `tune.shard-I-of-N.json`), then the fine pass and the pick here.
fn tune_merge(a: &TuneArgs) -> Result<(), Failure> {
    use sandbox2d::bench::{shard, slurm, tune};
    if let Some(id) = &a.run_id {
        slurm::check_run_id(id).map_err(|e| Failure::input(format!("--run-id: {e}")))?;
    }
    let files = read_shard_files(&a.merge, "tune", a.out.as_deref(), |n| {
        TUNE_FILES.contains(&n)
    })?;
    let merged = shard::merge_tune(&files, a.run_id.as_deref()).map_err(Failure::input)?;
    let key = &merged.key;
    let sc = scene::load(&key.scene).map_err(|e| {
        Failure::input(format!(
            "the shards' scene {:?} does not load here: {e}",
            key.scene
        ))
    })?;
    let digest = tune::scene_digest(&sc.world);
    if digest != key.digest {
        return Err(Failure::input(format!(
            "{}: not the scene the shards ran (it changed since: digest {digest}, the shards' {})",
            sc.source, key.digest
        )));
    }
    let file = scene_file(&key.scene);
    if a.write && file.is_none() {
        return Err(Failure::input(format!(
            "--write: \"{}\" is a built-in scene, not a file; copy assets/scenes/{}.toml and tune the copy",
            key.scene, key.scene
        )));
    }
    if let Some(out) = &a.out {
        writable_dir(out)?;
    }
    let bar = progress(None, "{bar:40} {pos}/{len} runs {elapsed} {msg}");
    GRACEFUL.store(true, Ordering::Relaxed);
    let result = tune::tune_merged(
        &key.scene,
        &sc.world,
        &key.options,
        merged.coarse,
        merged.shards,
        |done, total, what| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            bar.set_message(what.to_string());
        },
    );
    bar.finish_and_clear();
    let report = result.map_err(|e| tune_failure(&sc, key.options.budget_ms, e))?;
    tune_output(a, &sc, file.as_deref(), &report)
}

/// Prints a search's report (or its JSON), writes its files into --out, and with
/// --write the pick into the scene file.
fn tune_output(
    a: &TuneArgs,
    sc: &Scene,
    file: Option<&Path>,
    report: &sandbox2d::bench::tune::TuneReport,
) -> Result<(), Failure> {
    use sandbox2d::bench::tune;
    let pick = report.pick.map(|p| report.tried[p].setting);
    if let Some(out) = &a.out {
        write_file(&out.join("tune.md"), &tune::markdown(report))?;
        write_file(
            &out.join("tune.json"),
            &format!("{:#}\n", tune::json(report)),
        )?;
        write_file(
            &out.join("pareto.svg"),
            &tune::svg(report).map_err(Failure::run)?,
        )?;
        if let Some(p) = &pick {
            write_file(&out.join("solver.toml"), &tune::solver_table(p))?;
        }
    }
    if a.json {
        say!("{}", tune::json(report))?;
    } else {
        say_part!("{}", tune::markdown(report))?;
        if let Some(out) = &a.out {
            say!(
                "\nwrote {}: tune.md, tune.json, pareto.svg, solver.toml",
                out.display()
            )?;
        }
    }
    if let (true, Some(path), Some(p)) = (a.write, file, &pick) {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Failure::run(format!("{}: cannot read: {e}", path.display())))?;
        let new = tune::write_setting(&text, p)
            .map_err(|e| Failure::run(format!("{}: {e}", path.display())))?;
        // the edited file must still load, and to the setting it was given
        let check = scene::load_str(&new, &path.display().to_string()).map_err(|e| {
            Failure::run(format!(
                "{}: the edited scene does not load: {e}",
                path.display()
            ))
        })?;
        let got = check.world.solver.resolve();
        let want = p.resolve(&sc.world.solver);
        let same = got.kind == want.kind
            && got.substeps == want.substeps
            && got.iterations == want.iterations
            && (want.kind != SolverKind::Pgs
                || (got.warm_start == want.warm_start
                    && got.split_impulse == want.split_impulse
                    && got.tolerance == want.tolerance));
        if !same {
            return Err(Failure::run(format!(
                "{}: the edited [solver] table does not give {}; the file was left as it was",
                path.display(),
                p.label()
            )));
        }
        write_file(path, &new)?;
        if !a.json {
            say!("wrote the pick ({}) into {}", p.label(), path.display())?;
        }
    }
    Ok(())
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
