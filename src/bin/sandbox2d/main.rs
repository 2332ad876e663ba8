//! The sandbox2d command line: `scenes`, `simulate`, `render`, `run`, `bench`, `tune`,
//! and (with no command) the window on the default scene.
//!
//! This file parses the command line and dispatches; [`args`] holds the arguments,
//! each command has its file (`scenes.rs`, `simulate.rs`, `render.rs`, `run.rs`,
//! `bench/`, `tune.rs`), and what several share is in [`failure`] (errors, exit codes,
//! interrupts), [`load`] (a scene built into a world, saved states and runs),
//! [`paths`] (output paths checked against inputs) and [`shard`] (`--shard` and
//! `--merge`).

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use sandbox2d::output;

#[cfg(feature = "lab")]
use args::{BenchArgs, TuneArgs};
#[cfg(feature = "render")]
use args::{RenderArgs, RunArgs};
use args::{SimulateArgs, SolverFlags};
use failure::{Failure, install_interrupt_handler, one_line};

/// Log levels unless RUST_LOG says otherwise: warnings, minus two harmless ones that
/// would clutter every run (egui's note that it prefers a non-sRGB surface, which we
/// choose on purpose; EGL's report of a DRI2 driver it probes and then does without).
const DEFAULT_LOG_FILTER: &str = "warn,egui_wgpu=error,wgpu_hal::gles::egl=off";

/// `println!` that fails as a run does when stdout cannot be written (a full disk, a
/// closed pipe): one line on stderr and exit 1, never a panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($arg)*).map_err($crate::failure::stdout_failure)
    }};
}

/// `print!`, as [`say!`].
#[cfg(feature = "lab")]
macro_rules! say_part {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($arg)*).map_err($crate::failure::stdout_failure)
    }};
}

mod args;
#[cfg(feature = "lab")]
mod bench;
mod failure;
mod load;
mod paths;
mod progress;
#[cfg(feature = "render")]
mod render;
#[cfg(feature = "render")]
mod run;
mod scenes;
#[cfg(feature = "lab")]
mod shard;
mod simulate;
#[cfg(feature = "lab")]
mod tune;

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

// (parsed once: a large variant costs nothing)
#[allow(clippy::large_enum_variant)]
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
    #[cfg(feature = "lab")]
    Bench(BenchArgs),
    /// Pick the most accurate solver setting that fits a budget in ms per step: runs the
    /// bench's grid on the scene, then a finer pass around each solver's best, and prints the
    /// pick, the cheapest setting nearly as good, and the Pareto front.
    #[cfg(feature = "lab")]
    Tune(TuneArgs),
    /// Spins on one core until its parent is gone (the contention suite's busy process).
    #[cfg(feature = "lab")]
    #[command(hide = true)]
    BusyLoop,
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(DEFAULT_LOG_FILTER))
        .init();
    let cli = Cli::parse();
    output::ignore_file_size_signal();
    install_interrupt_handler();
    #[cfg(feature = "lab")]
    let timing = matches!(cli.command, Some(Command::Bench(_) | Command::Tune(_)));
    #[cfg(not(feature = "lab"))]
    let timing = false;
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
        Some(Command::Scenes) => scenes::list_scenes(),
        Some(Command::Simulate(a)) => simulate::simulate(&a),
        #[cfg(feature = "render")]
        Some(Command::Render(a)) => render::render(&a),
        #[cfg(feature = "render")]
        Some(Command::Run(a)) => run::run(&a),
        #[cfg(feature = "lab")]
        Some(Command::Bench(a)) => bench::bench(&a),
        #[cfg(feature = "lab")]
        Some(Command::Tune(a)) => tune::tune(&a),
        #[cfg(feature = "lab")]
        Some(Command::BusyLoop) => bench::contention::busy_loop(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            if !output::claim_last_word() {
                // a second interrupt is ending the process with its own line
                loop {
                    std::thread::park();
                }
            }
            eprintln!("error: {}", one_line(&f.message));
            ExitCode::from(f.code)
        }
    }
}

/// The plain command opens the window on the default scene (or, without a display,
/// renders it headless into ./out).
#[cfg(feature = "render")]
fn default_command() -> Result<(), Failure> {
    run::run(&RunArgs {
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
    simulate::simulate(&SimulateArgs {
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
