//! `bench --suite contention`: each scene at one thread and two, idle and beside busy
//! processes the suite starts; and the hidden `busy-loop` command those processes run.

use sandbox2d::bench::contention;

use crate::args::BenchArgs;
use crate::failure::Failure;
use crate::paths::write_file;

/// What --filter picks among, for the message when it picks nothing.
const PICKS: &str = "scene of the contention suite (large_pyramid, many_pyramids)";

/// Each scene at one thread and two, idle and beside busy processes the suite starts
/// (every core but one), one run at a time, then contention.csv and contention.md.
pub fn bench_contention(a: &BenchArgs, sharded: bool) -> Result<(), Failure> {
    super::one_case_at_a_time(a, sharded, "contention", super::TIMES_THREADS)?;
    let scenes = super::filtered(a, contention::scenes(a.filter.as_deref()), PICKS)?;
    let cores = sandbox2d::threads::available();
    let rounds = a.repeats.unwrap_or(contention::ROUNDS);
    let runs = contention::runs(&scenes, rounds);
    let mut defs: Vec<(&str, sandbox2d::WorldDef)> = Vec::new();
    let mut busy: Option<BusyProcesses> = None;
    let timed = super::one_at_a_time(
        &runs,
        |r| r.label(rounds),
        |r| {
            // the busy processes run exactly while the busy runs do
            if r.busy != busy.is_some() {
                busy = if r.busy {
                    Some(BusyProcesses::start(cores.saturating_sub(1).max(1))?)
                } else {
                    None
                };
            }
            let def = super::made_once(&mut defs, r.scene.name, || {
                contention::scene(r.scene.name).map_err(Failure::run)
            })?;
            let steps = a.steps.unwrap_or(r.scene.steps);
            let warmup = contention::WARMUP_STEPS.min(steps);
            contention::run_one(def, r.mode.policy(cores), warmup, steps)
                .map_err(|e| Failure::run(format!("{}: {e}", r.label(rounds))))
        },
    )?;
    drop(busy);
    let rows = contention::assemble(&runs, &timed);
    let command = super::suite_command(a, "contention", true);
    write_file(&a.out.join("contention.csv"), &contention::csv(&rows))?;
    let md = contention::markdown(&rows, rounds, cores, &command);
    write_file(&a.out.join("contention.md"), &md)?;
    say!(
        "wrote {}: contention.csv and contention.md ({} rows)",
        a.out.display(),
        rows.len()
    )?;
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
pub fn busy_loop() -> Result<(), Failure> {
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
