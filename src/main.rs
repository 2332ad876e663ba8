//! The sandbox2d command line: `scenes`, `simulate`, and (with no command) the default
//! scene.

use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use sandbox2d::scene::{self, Scene};
use sandbox2d::sim::{self, Trace};
use sandbox2d::{SolverKind, SolverOverrides, SolverSettings, World};

/// The scene the plain `sandbox2d` command shows.
const DEFAULT_SCENE: &str = "pyramid";

#[derive(Parser)]
#[command(
    name = "sandbox2d",
    version,
    about = "A 2D physics sandbox: PGS and XPBD solvers, measured for speed and accuracy."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// List the built-in scenes, one line each.
    Scenes,
    /// Run a scene headless and print its figures.
    Simulate(SimulateArgs),
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
    Pgs,
    Xpbd,
}

/// Flags that override the scene's `[solver]` table.
#[derive(Args, Clone, Default)]
struct SolverFlags {
    /// Solver: pgs or xpbd. Settings the scene does not give take this solver's defaults.
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
    /// Baumgarte factor beta in [0, 1].
    #[arg(long)]
    baumgarte: Option<f32>,
    /// Allowed penetration (m).
    #[arg(long)]
    slop: Option<f32>,
    /// Soft step (one collide per step, substeps reuse its manifolds, soft contacts).
    #[arg(long, value_enum)]
    soft_step: Option<OnOff>,
    /// Soft step: contact spring frequency (Hz).
    #[arg(long)]
    contact_hertz: Option<f32>,
    /// Soft step: contact spring damping ratio.
    #[arg(long)]
    contact_damping_ratio: Option<f32>,
    /// Soft step: fastest push-out of overlap (m/s).
    #[arg(long)]
    max_push_speed: Option<f32>,
}

impl SolverFlags {
    fn overrides(&self) -> SolverOverrides {
        SolverOverrides {
            kind: self.solver.map(|s| match s {
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
            restitution_threshold: None,
            soft_step: self.soft_step.map(Into::into),
            contact_hertz: self.contact_hertz,
            contact_damping_ratio: self.contact_damping_ratio,
            max_push_speed: self.max_push_speed,
        }
    }
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
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        None => default_command(),
        Some(Command::Scenes) => list_scenes(),
        Some(Command::Simulate(a)) => simulate(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

fn list_scenes() -> Result<(), Failure> {
    for name in scene::builtin_names() {
        let d = scene::builtin_description(name).unwrap_or_default();
        println!("{name:<16} {d}");
    }
    Ok(())
}

/// Without a window yet, the plain command runs the default scene headless for 10 s
/// and prints its figures.
fn default_command() -> Result<(), Failure> {
    println!(
        "sandbox2d: running the built-in scene \"{DEFAULT_SCENE}\" headless for 600 steps (see `sandbox2d --help`)"
    );
    simulate(&SimulateArgs {
        scene: DEFAULT_SCENE.into(),
        steps: 600,
        json: false,
        trace: None,
        trace_every: 1,
        solver: SolverFlags::default(),
    })
}

/// Loads a scene and builds its world with the command line's solver flags applied.
fn build(name: &str, flags: &SolverFlags) -> Result<(Scene, World, SolverSettings), Failure> {
    let sc = scene::load(name).map_err(Failure::input)?;
    let settings = sc.world.solver.merged(flags.overrides()).resolve();
    let world = World::from_def(&sc.world, settings)
        .map_err(|e| Failure::input(format!("{}: {e}", sc.source)))?;
    Ok((sc, world, settings))
}

fn simulate(a: &SimulateArgs) -> Result<(), Failure> {
    if a.trace_every == 0 {
        return Err(Failure::input("--trace-every must be at least 1"));
    }
    let (sc, mut world, settings) = build(&a.scene, &a.solver)?;
    let mut trace_file = match &a.trace {
        Some(p) => Some(BufWriter::new(std::fs::File::create(p).map_err(|e| {
            Failure::input(format!("{}: cannot create: {e}", p.display()))
        })?)),
        None => None,
    };
    let bar = if std::io::stderr().is_terminal() && a.steps >= 200 {
        let b = indicatif::ProgressBar::new(a.steps);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} steps {elapsed}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(b)
    } else {
        None
    };
    let trace = trace_file.as_mut().map(|f| Trace {
        out: f as &mut dyn Write,
        every: a.trace_every,
    });
    let summary = sim::run(&mut world, a.steps, trace, |k| {
        if let Some(b) = &bar {
            if k % 16 == 0 {
                b.set_position(k);
            }
        }
    })
    .map_err(Failure::run)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if let Some(mut f) = trace_file {
        f.flush().map_err(Failure::run)?;
    }
    let (median, mean, p95) = summary.ms_per_step();
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
                "baumgarte": settings.baumgarte,
                "slop": settings.slop,
                "restitution_threshold": settings.restitution_threshold,
                "soft_step": settings.soft_step,
                "contact_hertz": settings.contact_hertz,
                "contact_damping_ratio": settings.contact_damping_ratio,
                "max_push_speed": settings.max_push_speed,
            },
            "steps": summary.steps,
            "bodies": world.bodies.len(),
            "ms_per_step": { "median": median, "mean": mean, "p95": p95 },
            "contacts": { "mean": summary.contacts_mean, "max": summary.contacts_max },
            "iterations": { "mean": summary.iterations_mean, "position_mean": summary.position_iterations_mean },
            "residual": { "mean": summary.residual_mean, "max": summary.residual_max },
            "penetration": { "max": summary.penetration_max, "final": summary.penetration_final },
            "energy": { "start": summary.energy_start, "end": summary.energy_end },
            "stage_ms": {
                "forces": summary.stage_ms[0], "broad_phase": summary.stage_ms[1], "narrow_phase": summary.stage_ms[2],
                "solver": summary.stage_ms[3], "integrate": summary.stage_ms[4],
            },
            "state_hash": hash,
        });
        println!("{v}");
    } else {
        println!("scene        {} ({})", sc.name, sc.source);
        println!(
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
        );
        if settings.soft_step {
            println!(
                "soft step    contact_hertz={} contact_damping_ratio={} max_push_speed={}",
                settings.contact_hertz, settings.contact_damping_ratio, settings.max_push_speed
            );
        }
        println!(
            "steps        {} ({} bodies)",
            summary.steps,
            world.bodies.len()
        );
        println!("ms/step      median {median:.3}  mean {mean:.3}  p95 {p95:.3}");
        println!(
            "contacts     mean {:.1}  max {}",
            summary.contacts_mean, summary.contacts_max
        );
        println!(
            "iterations   mean {:.2}  (position sweeps {:.2})",
            summary.iterations_mean, summary.position_iterations_mean
        );
        println!(
            "residual     mean {:.3e}  max {:.3e}",
            summary.residual_mean, summary.residual_max
        );
        println!(
            "penetration  max {:.5} m  final {:.5} m",
            summary.penetration_max, summary.penetration_final
        );
        println!(
            "energy       start {:.4} J  end {:.4} J",
            summary.energy_start, summary.energy_end
        );
        println!("state hash   {hash}");
    }
    Ok(())
}
