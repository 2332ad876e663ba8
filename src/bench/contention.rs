//! The contention suite (`bench --suite contention`): what threads are worth when
//! another program holds a core. The large pyramid and many pyramids run on one thread
//! and on two, on a machine as it is (idle) and beside a busy process the suite starts
//! and stops itself (a loop that never sleeps, one per core less one: every core but
//! one is taken). Two threads are run both ways the command line offers: `--threads 2`
//! (the step measures whether the second thread pays and steps on one while it does
//! not: [`Threads::UpTo`]) and `--threads 2 --fixed-threads` (every step on both), and
//! the default (up to every core, [`Threads::UpTo`]). Runs alternate within each round
//! (so noise on a shared machine hits them alike); a run's figure is its mean ms per
//! step (a descheduled thread costs a few long steps, which a median would hide); the
//! report gives each case's median over the rounds and its ratio to one thread in the
//! same conditions. A step's result does not depend on the threads, so every run of a
//! scene must end in the same state hash ("same bits").

use std::time::Instant;

use super::median;
use crate::defs::WorldDef;
use crate::world::{Threads, World};

/// A scene of the suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Scene {
    /// The name `--filter` matches.
    pub name: &'static str,
    /// Timed steps per run (after the warm-up), unless `--steps` says otherwise.
    pub steps: u64,
}

/// The scenes: the large pyramid (the built-in scene) and many pyramids
/// (scenes/many_pyramids.toml).
pub const SCENES: [Scene; 2] = [
    Scene {
        name: "large_pyramid",
        steps: 300,
    },
    Scene {
        name: "many_pyramids",
        steps: 60,
    },
];

/// Untimed steps before each timed run (fewer when `--steps` asks for fewer).
pub const WARMUP_STEPS: u64 = 10;

/// Rounds (each runs every case once), unless `--repeats` says otherwise.
pub const ROUNDS: u32 = 3;

/// The scenes whose name contains `filter` (all without one).
pub fn scenes(filter: Option<&str>) -> Vec<Scene> {
    SCENES
        .into_iter()
        .filter(|s| filter.is_none_or(|f| s.name.contains(f)))
        .collect()
}

/// A scene's world description.
pub fn scene(name: &str) -> Result<WorldDef, String> {
    let text = match name {
        "many_pyramids" => include_str!("../../scenes/many_pyramids.toml"),
        _ => {
            return crate::scene::load(name)
                .map(|s| s.world)
                .map_err(|e| e.to_string());
        }
    };
    crate::scene::load_str(text, "scenes/many_pyramids.toml")
        .map(|s| s.world)
        .map_err(|e| e.to_string())
}

/// How a run's steps use threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// `--threads 1`.
    One,
    /// `--threads 2`: up to two, measured.
    Two,
    /// `--threads 2 --fixed-threads`: every step on both.
    TwoFixed,
    /// No `--threads`: up to every core, measured.
    Default,
}

impl Mode {
    /// The modes in the order a round runs them.
    pub const ALL: [Mode; 4] = [Mode::One, Mode::Two, Mode::TwoFixed, Mode::Default];

    /// The command-line flags of the mode.
    pub fn flags(self) -> &'static str {
        match self {
            Mode::One => "--threads 1",
            Mode::Two => "--threads 2",
            Mode::TwoFixed => "--threads 2 --fixed-threads",
            Mode::Default => "(default)",
        }
    }

    /// The world's thread policy for the mode on a machine of `cores` cores.
    pub fn policy(self, cores: usize) -> Threads {
        match self {
            Mode::One => Threads::Fixed(1),
            Mode::Two => Threads::UpTo(2),
            Mode::TwoFixed => Threads::Fixed(2),
            Mode::Default => Threads::UpTo(cores.max(1)),
        }
    }
}

/// One timed run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    pub scene: Scene,
    /// Beside the busy process.
    pub busy: bool,
    pub mode: Mode,
    pub round: u32,
}

impl Run {
    /// `large_pyramid, busy, --threads 2 (round 1/3)`.
    pub fn label(&self, rounds: u32) -> String {
        format!(
            "{}, {}, {} (round {}/{rounds})",
            self.scene.name,
            if self.busy { "busy" } else { "idle" },
            self.mode.flags(),
            self.round + 1
        )
    }
}

/// Every run in order: scene after scene, idle then busy (so the busy process is
/// started once a scene), and within them round after round of every mode in turn.
pub fn runs(scenes: &[Scene], rounds: u32) -> Vec<Run> {
    let mut v = Vec::new();
    for &scene in scenes {
        for busy in [false, true] {
            for round in 0..rounds.max(1) {
                for mode in Mode::ALL {
                    v.push(Run {
                        scene,
                        busy,
                        mode,
                        round,
                    });
                }
            }
        }
    }
    v
}

/// What one run measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timed {
    /// Mean and median wall time of the timed steps (ms).
    pub mean_ms: f64,
    pub median_ms: f64,
    /// Timed steps run on one thread (by the world's choice, or all of them on one).
    pub steps_on_one: u64,
    pub steps: u64,
    /// [`World::state_hash`] after the last step.
    pub state_hash: u64,
}

/// Builds `def`'s world under `policy`, runs `warmup` steps, then times `steps`.
pub fn run_one(def: &WorldDef, policy: Threads, warmup: u64, steps: u64) -> Result<Timed, String> {
    let mut world = World::from_def(def, def.solver.resolve()).map_err(|e| e.to_string())?;
    world.set_thread_policy(policy);
    for _ in 0..warmup {
        world.step().map_err(|e| e.to_string())?;
    }
    let before = world.thread_use();
    let mut ms = Vec::with_capacity((steps as usize).min(1 << 16));
    for _ in 0..steps {
        let t = Instant::now();
        let r = world.step();
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        r.map_err(|e| e.to_string())?;
    }
    let mean = ms.iter().sum::<f64>() / ms.len().max(1) as f64;
    let used = world.thread_use();
    let on_one = match policy {
        Threads::Fixed(1) => steps,
        Threads::Fixed(_) => 0,
        Threads::UpTo(_) => used.steps_on_one - before.steps_on_one,
    };
    Ok(Timed {
        mean_ms: mean,
        median_ms: median(&mut ms),
        steps_on_one: on_one,
        steps,
        state_hash: world.state_hash(),
    })
}

/// One row of the report: a scene, a load and a mode over every round.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub scene: String,
    pub busy: bool,
    pub mode: Mode,
    pub steps: u64,
    /// Median over the rounds of each run's mean ms per step, and of its median.
    pub mean_ms: f64,
    pub median_ms: f64,
    /// This row's mean over one thread's in the same conditions.
    pub over_one: f64,
    /// The share of the timed steps run on one thread (all rounds).
    pub on_one: f64,
    /// Whether every run of the scene ended in the same state hash.
    pub same_bits: bool,
}

/// The rows of the report, by scene, load (idle first) and mode.
pub fn assemble(runs: &[Run], timed: &[Timed]) -> Vec<Row> {
    let mut rows = Vec::new();
    let mut names: Vec<&str> = Vec::new();
    for r in runs {
        if !names.contains(&r.scene.name) {
            names.push(r.scene.name);
        }
    }
    for name in names {
        let of: Vec<(&Run, &Timed)> = runs
            .iter()
            .zip(timed)
            .filter(|(r, _)| r.scene.name == name)
            .collect();
        let hash0 = of.first().map(|(_, t)| t.state_hash);
        let same = of.iter().all(|(_, t)| Some(t.state_hash) == hash0);
        for busy in [false, true] {
            let start = rows.len();
            for mode in Mode::ALL {
                let mine: Vec<&Timed> = of
                    .iter()
                    .filter(|(r, _)| r.busy == busy && r.mode == mode)
                    .map(|(_, t)| *t)
                    .collect();
                let Some(last) = mine.last() else { continue };
                let mut means: Vec<f64> = mine.iter().map(|t| t.mean_ms).collect();
                let mut medians: Vec<f64> = mine.iter().map(|t| t.median_ms).collect();
                let steps: u64 = mine.iter().map(|t| t.steps).sum();
                let on_one: u64 = mine.iter().map(|t| t.steps_on_one).sum();
                rows.push(Row {
                    scene: name.to_string(),
                    busy,
                    mode,
                    steps: last.steps,
                    mean_ms: median(&mut means),
                    median_ms: median(&mut medians),
                    over_one: f64::NAN,
                    on_one: on_one as f64 / steps.max(1) as f64,
                    same_bits: same,
                });
            }
            let one = rows[start..]
                .iter()
                .find(|r| r.mode == Mode::One)
                .map(|r| r.mean_ms);
            if let Some(one) = one {
                for r in &mut rows[start..] {
                    r.over_one = r.mean_ms / one;
                }
            }
        }
    }
    rows
}

/// The columns of contention.csv.
pub const CSV_COLUMNS: [&str; 9] = [
    "scene",
    "load",
    "threads",
    "steps",
    "mean_ms",
    "median_ms",
    "over_one_thread",
    "steps_on_one",
    "same_bits",
];

/// contention.csv: one row per scene, load and mode.
pub fn csv(rows: &[Row]) -> String {
    let mut s = CSV_COLUMNS.join(",");
    s.push('\n');
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{:.6e},{:.6e},{:.4},{:.4},{}\n",
            r.scene,
            if r.busy { "busy" } else { "idle" },
            r.mode.flags(),
            r.steps,
            r.mean_ms,
            r.median_ms,
            r.over_one,
            r.on_one,
            if r.same_bits { "yes" } else { "no" }
        ));
    }
    s
}

/// contention.md: the table, then per scene the four figures (one and two threads, idle
/// and busy). `command` is the command line that measured it; `cores` the machine's.
pub fn markdown(rows: &[Row], rounds: u32, cores: usize, command: &str) -> String {
    let mut s = String::from("# Contention: threads beside a busy process\n\n");
    s.push_str(&format!(
        "`{command}` on a machine of {cores} core(s). busy: beside a process the suite \
         started that spins on every core but one. ms/step: the median over {rounds} \
         round(s) (the cases alternating) of each run's mean step (and of its median \
         step) after a warm-up of {WARMUP_STEPS} steps; x one thread: the mean over one \
         thread's in the same load; on one: the share of the timed steps the world ran \
         on one thread (`--threads 2` and the default measure whether the second thread \
         pays). \"same bits\": every run of the scene ended in the same state hash.\n\n"
    ));
    s.push_str("| scene | load | threads | steps | mean ms/step | median | x one thread | on one | same bits |\n");
    s.push_str("|---|---|---|---:|---:|---:|---:|---:|---|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.0}% | {} |\n",
            r.scene,
            if r.busy { "busy" } else { "idle" },
            r.mode.flags(),
            r.steps,
            r.mean_ms,
            r.median_ms,
            r.over_one,
            r.on_one * 100.0,
            if r.same_bits { "yes" } else { "no" }
        ));
    }
    s.push_str("\nThe four figures (mean ms/step; `--threads 2` as a user gets it):\n\n");
    let mut names: Vec<&str> = Vec::new();
    for r in rows {
        if !names.contains(&r.scene.as_str()) {
            names.push(&r.scene);
        }
    }
    for name in names {
        let get = |busy: bool, mode: Mode| {
            rows.iter()
                .find(|r| r.scene == name && r.busy == busy && r.mode == mode)
                .map(|r| r.mean_ms)
        };
        let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
        let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) => format!("{:.2}", a / b),
            _ => "-".to_string(),
        };
        let (i1, i2) = (get(false, Mode::One), get(false, Mode::Two));
        let (b1, b2) = (get(true, Mode::One), get(true, Mode::Two));
        s.push_str(&format!(
            "- {name}: idle {} (1 thread) and {} (2), {}x; busy {} and {}, {}x\n",
            f(i1),
            f(i2),
            ratio(i2, i1),
            f(b1),
            f(b2),
            ratio(b2, b1)
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_alternate_the_modes_idle_then_busy_and_the_filter_picks_scenes() {
        assert_eq!(scenes(Some("many")).len(), 1);
        assert!(scenes(Some("tower")).is_empty());
        let r = runs(&scenes(Some("large")), 2);
        assert_eq!(r.len(), 2 * 2 * Mode::ALL.len());
        assert!(r[..8].iter().all(|r| !r.busy) && r[8..].iter().all(|r| r.busy));
        let modes: Vec<Mode> = r[..4].iter().map(|r| r.mode).collect();
        assert_eq!(modes, Mode::ALL);
        assert_eq!(Mode::Default.policy(8), Threads::UpTo(8));
        assert_eq!(Mode::TwoFixed.policy(8), Threads::Fixed(2));
        // both scenes load: the large pyramid's 5050 boxes, many pyramids' 22,000
        assert_eq!(scene("large_pyramid").unwrap().bodies.len(), 5051);
        let many = scene("many_pyramids").unwrap();
        assert_eq!(
            many.bodies
                .iter()
                .filter(|b| b.body_type == crate::defs::BodyType::Dynamic)
                .count(),
            22000
        );
    }

    #[test]
    fn assemble_takes_medians_and_ratios_and_flags_a_hash_that_differs() {
        let runs = runs(&scenes(Some("large")), 3);
        let timed: Vec<Timed> = runs
            .iter()
            .map(|r| {
                let base = if r.busy { 2.0 } else { 1.0 };
                let ms = match r.mode {
                    Mode::One => base,
                    _ => base * if r.busy { 1.05 } else { 0.6 },
                } + r.round as f64 * 0.01;
                Timed {
                    mean_ms: ms,
                    median_ms: ms * 0.9,
                    steps_on_one: if r.busy { 9 } else { 1 },
                    steps: 10,
                    state_hash: 7,
                }
            })
            .collect();
        let rows = assemble(&runs, &timed);
        assert_eq!(rows.len(), 8);
        let two_idle = rows
            .iter()
            .find(|r| !r.busy && r.mode == Mode::Two)
            .unwrap();
        assert!(
            (two_idle.over_one - 0.6).abs() < 0.01,
            "{}",
            two_idle.over_one
        );
        assert!((two_idle.mean_ms - 0.61).abs() < 1e-9, "the median round");
        assert!(rows.iter().all(|r| r.same_bits));
        let md = markdown(&rows, 3, 2, "sandbox2d bench --suite contention");
        assert!(md.contains("busy 2.010 and 2.110, 1.05x"), "{md}");
        let mut odd = timed.clone();
        odd[5].state_hash = 8;
        assert!(assemble(&runs, &odd).iter().all(|r| !r.same_bits));
        assert_eq!(csv(&rows).lines().count(), 9);
    }
}
