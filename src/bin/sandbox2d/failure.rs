//! How a command fails: the message and exit code of a [`Failure`], the interrupt
//! handler and the flag a command sets once it stops cleanly on an interrupt.

use std::sync::atomic::{AtomicBool, Ordering};

use sandbox2d::output;
use sandbox2d::scene;
use sandbox2d::sim;

/// A write to stdout that failed.
pub fn stdout_failure(e: std::io::Error) -> Failure {
    Failure::run(format!("stdout: cannot write: {e}"))
}

/// A failure and the exit code it gets: 2 for bad input, 1 for a run that failed.
pub struct Failure {
    pub code: u8,
    pub message: String,
}

impl Failure {
    pub fn input(message: impl std::fmt::Display) -> Failure {
        Failure {
            code: 2,
            message: message.to_string(),
        }
    }
    pub fn run(message: impl std::fmt::Display) -> Failure {
        Failure {
            code: 1,
            message: message.to_string(),
        }
    }
    /// Stopped by SIGINT or SIGTERM: exit 130, as a shell reports a Ctrl-C.
    pub fn interrupted(message: impl std::fmt::Display) -> Failure {
        Failure {
            code: 130,
            message: message.to_string(),
        }
    }
    /// A command interrupted before it wrote anything.
    #[cfg(feature = "lab")]
    pub fn nothing_written() -> Failure {
        Failure::interrupted("interrupted: nothing was written")
    }
}

/// Set by a command that stops cleanly on an interrupt (it checks
/// [`output::interrupted`] and removes what is incomplete); otherwise an interrupt ends
/// the process at once, as it would without a handler.
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// From here an interrupt asks the command to stop cleanly (see [`GRACEFUL`]).
pub fn graceful() {
    GRACEFUL.store(true, Ordering::Relaxed);
}

/// SIGINT / SIGTERM: the first asks a graceful command to stop; a second, or any while
/// no graceful command runs, exits at once with 130.
pub fn install_interrupt_handler() {
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
pub fn one_line(s: &str) -> String {
    scene::escape_controls(s)
}

/// A run that stopped on a non-finite state or an interrupt: one line that names the
/// scene and the step (and, for a blow-up, the body).
pub fn run_failure(source: &str, e: sim::RunError) -> Failure {
    match e {
        sim::RunError::Interrupted { step } => {
            Failure::interrupted(format!("{source}: interrupted after step {step}"))
        }
        e => Failure::run(format!("{source}: {e}")),
    }
}
