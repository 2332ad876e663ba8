//! Progress bars: on stderr for a long load, step or render; on stdout's terminal for
//! the bench's cases.

use std::io::IsTerminal;
use std::time::Duration;

/// A progress bar on stderr that appears only when stderr is a terminal and the work
/// has taken more than two seconds; its elapsed time ticks even while one long step runs.
pub fn progress(len: Option<u64>, template: &str) -> indicatif::ProgressBar {
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

/// A progress bar on a terminal; hidden when stdout is not one.
#[cfg(feature = "lab")]
pub fn bench_progress(total: usize) -> indicatif::ProgressBar {
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
