//! The scaling suite (`bench --suite scaling`): what a step of the benchmark pyramid
//! costs as it grows from about 1k to 80k boxes, on 1 and 2 threads (and every core
//! where a machine has more than 2).
//!
//! Each size is the `[[pyramid]]` of `assets/scenes/large_pyramid.toml` at another base,
//! boxes of 1 m on a static ground wider than the base, under that file's own `[solver]`
//! table (the soft step, 4 substeps of 1 sweep, contacts of 60 Hz, slop 1 mm, no
//! sleeping). For each size and thread count, [`run_one`] builds the world, sets its
//! threads ([`World::set_threads`]), runs a warm-up, then times each step of the run and
//! keeps the median; repeats alternate the thread counts (1, 2, 1, 2, ...) so noise on a
//! shared machine hits them alike. A step's result does not depend on the thread count,
//! so the state hash after the last step must be the same for every count of a size:
//! the report checks it ("same bits").

use std::time::Instant;

use plotters::prelude::*;

use super::median;
use crate::defs::WorldDef;
use crate::world::World;

/// One size of the suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size {
    /// The label `--filter` matches: `1k`, `5k`, `20k`, `80k`.
    pub label: &'static str,
    /// The pyramid's base: it has base (base + 1) / 2 boxes.
    pub base: u32,
    /// Timed steps per run (after the warm-up), unless `--steps` says otherwise.
    pub steps: u64,
}

impl Size {
    /// The boxes of the pyramid.
    pub fn boxes(&self) -> u64 {
        self.base as u64 * (self.base as u64 + 1) / 2
    }
}

/// The sizes, smallest first: bases 45, 100, 200 and 400 (1035, 5050, 20100 and 80200
/// boxes). The step counts keep the whole suite within a few minutes on two cores.
pub const SIZES: [Size; 4] = [
    Size {
        label: "1k",
        base: 45,
        steps: 200,
    },
    Size {
        label: "5k",
        base: 100,
        steps: 100,
    },
    Size {
        label: "20k",
        base: 200,
        steps: 50,
    },
    Size {
        label: "80k",
        base: 400,
        steps: 20,
    },
];

/// Untimed steps before each timed run (fewer when `--steps` asks for fewer).
pub const WARMUP_STEPS: u64 = 10;

/// Timed runs of each size and thread count, unless `--repeats` says otherwise.
pub const REPEATS: u32 = 3;

/// The scene text of a pyramid of base `base`: large_pyramid.toml's world and
/// `[solver]` table, a static ground of half-extents (base + 10, 1) whose top is y = 0,
/// and the pyramid on it.
pub fn scene_text(base: u32) -> String {
    format!(
        r#"name = "pyramid {base}"
[world]
gravity = [0.0, -10.0]
[solver]
dt = 0.016666667
kind = "soft"
substeps = 4
iterations = 1
slop = 0.001
sleep = false
[[body]]
name = "ground"
type = "static"
shape = {{ box = [{w}.0, 2.0] }}
position = [0.0, -1.0]
friction = 0.6
restitution = 0.0
[[pyramid]]
base = {base}
box = [1.0, 1.0]
origin = [0.0, 0.0]
density = 1.0
friction = 0.6
restitution = 0.0
"#,
        w = 2 * (base + 10)
    )
}

/// The scene of a pyramid of base `base` (see [`scene_text`]).
pub fn scene(base: u32) -> Result<WorldDef, String> {
    crate::scene::load_str(&scene_text(base), &format!("scaling pyramid {base}"))
        .map(|s| s.world)
        .map_err(|e| e.to_string())
}

/// The thread counts measured on a machine of `cores` cores: 1 and 2, and `cores` when
/// it is above 2.
pub fn thread_counts(cores: usize) -> Vec<usize> {
    let mut v = vec![1, 2];
    if cores > 2 {
        v.push(cores);
    }
    v
}

/// The sizes whose label contains `filter` (all without one).
pub fn sizes(filter: Option<&str>) -> Vec<Size> {
    SIZES
        .into_iter()
        .filter(|s| filter.is_none_or(|f| s.label.contains(f)))
        .collect()
}

/// One timed run: a size at a thread count, in repeat `repeat`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    pub size: Size,
    pub threads: usize,
    pub repeat: u32,
}

impl Run {
    /// `5k, 2 threads (repeat 1/3)`.
    pub fn label(&self, repeats: u32) -> String {
        format!(
            "{}, {} thread{} (repeat {}/{repeats})",
            self.size.label,
            self.threads,
            if self.threads == 1 { "" } else { "s" },
            self.repeat + 1
        )
    }
}

/// Every run in order: size after size, and within a size repeat after repeat, each
/// repeat running every thread count in turn (1, 2, 1, 2, ...).
pub fn runs(sizes: &[Size], threads: &[usize], repeats: u32) -> Vec<Run> {
    let mut v = Vec::new();
    for &size in sizes {
        for repeat in 0..repeats.max(1) {
            for &t in threads {
                v.push(Run {
                    size,
                    threads: t,
                    repeat,
                });
            }
        }
    }
    v
}

/// What one run measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timed {
    /// Median wall time of the timed steps (ms).
    pub ms_per_step: f64,
    /// Mean number of contacts (touching pairs, [`World::contacts`]) over the timed steps.
    pub contacts: f64,
    /// [`World::state_hash`] after the last step.
    pub state_hash: u64,
    /// Dynamic bodies.
    pub bodies: u64,
    /// Timed steps.
    pub steps: u64,
}

/// Builds `def`'s world on `threads` threads, runs `warmup` steps, then times `steps`.
pub fn run_one(def: &WorldDef, threads: usize, warmup: u64, steps: u64) -> Result<Timed, String> {
    let mut world = World::from_def(def, def.solver.resolve()).map_err(|e| e.to_string())?;
    world.set_threads(threads);
    for _ in 0..warmup {
        world.step().map_err(|e| e.to_string())?;
    }
    let mut ms = Vec::with_capacity((steps as usize).min(1 << 16));
    let mut contacts = 0.0f64;
    for _ in 0..steps {
        let t = Instant::now();
        let r = world.step();
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        r.map_err(|e| e.to_string())?;
        contacts += world.contacts().len() as f64;
    }
    Ok(Timed {
        ms_per_step: median(&mut ms),
        contacts: contacts / steps.max(1) as f64,
        state_hash: world.state_hash(),
        bodies: world.bodies.iter().filter(|b| b.is_dynamic()).count() as u64,
        steps,
    })
}

/// One row of the report: a size at a thread count, over every repeat.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub label: String,
    pub bodies: u64,
    pub threads: usize,
    pub steps: u64,
    /// Median over repeats of each run's median ms per step.
    pub ms_per_step: f64,
    pub contacts: f64,
    /// ms_per_step / contacts, in microseconds.
    pub us_per_contact: f64,
    /// The 1-thread row's ms_per_step over this one's (NaN without a 1-thread row).
    pub speedup: f64,
    /// The state hash after the last step (the last repeat's).
    pub state_hash: u64,
    /// Whether every repeat of every thread count of this size ended in this hash.
    pub same_bits: bool,
}

/// The rows of the report from the runs and what each measured, by size then thread
/// count (in the order given).
pub fn assemble(runs: &[Run], timed: &[Timed], threads: &[usize]) -> Vec<Row> {
    let mut rows = Vec::new();
    let mut labels: Vec<Size> = Vec::new();
    for r in runs {
        if !labels.contains(&r.size) {
            labels.push(r.size);
        }
    }
    for size in labels {
        let of_size: Vec<(&Run, &Timed)> = runs
            .iter()
            .zip(timed)
            .filter(|(r, _)| r.size == size)
            .collect();
        let hash0 = of_size.first().map(|(_, t)| t.state_hash);
        let same = of_size.iter().all(|(_, t)| Some(t.state_hash) == hash0);
        let start = rows.len();
        for &n in threads {
            let mine: Vec<&Timed> = of_size
                .iter()
                .filter(|(r, _)| r.threads == n)
                .map(|(_, t)| *t)
                .collect();
            let Some(last) = mine.last() else { continue };
            let mut ms: Vec<f64> = mine.iter().map(|t| t.ms_per_step).collect();
            let ms = median(&mut ms);
            rows.push(Row {
                label: size.label.to_string(),
                bodies: last.bodies,
                threads: n,
                steps: last.steps,
                ms_per_step: ms,
                contacts: last.contacts,
                us_per_contact: if last.contacts > 0.0 {
                    ms * 1e3 / last.contacts
                } else {
                    f64::NAN
                },
                speedup: f64::NAN,
                state_hash: last.state_hash,
                same_bits: same,
            });
        }
        let one = rows[start..]
            .iter()
            .find(|r| r.threads == 1)
            .map(|r| r.ms_per_step);
        if let Some(one) = one {
            for r in &mut rows[start..] {
                r.speedup = one / r.ms_per_step;
            }
        }
    }
    rows
}

/// The columns of scaling.csv.
pub const CSV_COLUMNS: [&str; 10] = [
    "size",
    "bodies",
    "threads",
    "steps",
    "ms_per_step",
    "contacts",
    "us_per_contact",
    "speedup",
    "state_hash",
    "same_bits",
];

/// scaling.csv: one row per size and thread count.
pub fn csv(rows: &[Row]) -> String {
    let mut s = CSV_COLUMNS.join(",");
    s.push('\n');
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{:.6e},{:.1},{:.6e},{:.4},{:016x},{}\n",
            r.label,
            r.bodies,
            r.threads,
            r.steps,
            r.ms_per_step,
            r.contacts,
            r.us_per_contact,
            r.speedup,
            r.state_hash,
            if r.same_bits { "yes" } else { "no" }
        ));
    }
    s
}

/// scaling.md: the table, then per size the ratio of 2 threads' time to 1 thread's.
/// `command` is the command line that measured it; `cores` the machine's cores.
pub fn markdown(rows: &[Row], repeats: u32, cores: usize, command: &str) -> String {
    let mut s = String::from("# Scaling: the benchmark pyramid from 1k to 80k boxes\n\n");
    s.push_str(&format!(
        "`{command}` on a machine of {cores} core(s). Each size is large_pyramid.toml's \
         pyramid at another base, under its [solver] table (the soft step, 4 substeps x 1 \
         sweep, the default contact springs (60 Hz at 4 substeps, damping ratio 10), slop 1 mm, no sleeping). ms/step is the median over {repeats} \
         repeat(s) (thread counts alternating) of each run's median step after a \
         warm-up of {WARMUP_STEPS} steps (or of the timed steps' count, if fewer); \
         contacts: the mean number of touching pairs (manifolds) per step; us/contact: \
         ms/step over it; speedup: 1 thread's ms/step over this one's. \"same bits\": \
         every run of the size ended in the same state hash, whatever its thread count.\n\n"
    ));
    s.push_str(
        "| size | bodies | threads | steps | ms/step | contacts | us/contact | speedup | state hash | same bits |\n",
    );
    s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---|---|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.3} | {:.0} | {:.4} | {:.2}x | `{:016x}` | {} |\n",
            r.label,
            r.bodies,
            r.threads,
            r.steps,
            r.ms_per_step,
            r.contacts,
            r.us_per_contact,
            r.speedup,
            r.state_hash,
            if r.same_bits { "yes" } else { "no" }
        ));
    }
    s.push_str("\n2 threads' time over 1 thread's (below 1: two threads are faster):\n\n");
    let mut labels: Vec<&str> = Vec::new();
    for r in rows {
        if !labels.contains(&r.label.as_str()) {
            labels.push(&r.label);
        }
    }
    for l in labels {
        let ms = |n: usize| {
            rows.iter()
                .find(|r| r.label == l && r.threads == n)
                .map(|r| r.ms_per_step)
        };
        if let (Some(one), Some(two)) = (ms(1), ms(2)) {
            s.push_str(&format!("- {l}: {:.2}\n", two / one));
        }
    }
    s.push_str("\n![ms per step against bodies](scaling.svg)\n");
    s
}

/// A thread count's colour.
fn color(i: usize) -> RGBColor {
    [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
    ][i % 4]
}

/// scaling.svg: ms per step against bodies, log-log, one line per thread count.
pub fn svg(rows: &[Row]) -> Result<String, String> {
    let mut threads: Vec<usize> = rows.iter().map(|r| r.threads).collect();
    threads.sort_unstable();
    threads.dedup();
    let pts = |n: usize| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.threads == n && r.ms_per_step > 0.0 && r.ms_per_step.is_finite())
            .map(|r| (r.bodies as f64, r.ms_per_step))
            .collect()
    };
    let all: Vec<(f64, f64)> = threads.iter().flat_map(|&n| pts(n)).collect();
    let (x0, x1) = all.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.0), hi.max(p.0))
    });
    let (y0, y1) = all.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.1), hi.max(p.1))
    });
    let (x0, x1) = if all.is_empty() {
        (100.0, 1e5)
    } else {
        ((x0 / 1.5).max(1.0), (x1 * 1.5).max(x0 * 10.0))
    };
    let (y0, y1) = if all.is_empty() {
        (1e-3, 1.0)
    } else {
        ((y0 / 1.5).max(1e-6), (y1 * 1.5).max(y0 * 10.0))
    };
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (820, 560)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Scaling: the benchmark pyramid, ms per step against bodies",
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("dynamic bodies")
            .y_desc("ms per step (median)")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| super::plot::short(*v))
            .draw()
            .map_err(|x| e(&x))?;
        for (i, &n) in threads.iter().enumerate() {
            let c = color(i);
            let p = pts(n);
            chart
                .draw_series(LineSeries::new(p.iter().copied(), c))
                .map_err(|x| e(&x))?
                .label(format!("{n} thread{}", if n == 1 { "" } else { "s" }))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
            chart
                .draw_series(p.iter().map(|&q| Circle::new(q, 3, c.filled())))
                .map_err(|x| e(&x))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sizes_are_the_pyramids_of_the_brief_under_large_pyramids_solver() {
        let boxes: Vec<u64> = SIZES.iter().map(Size::boxes).collect();
        assert_eq!(boxes, [1035, 5050, 20100, 80200]);
        let large = crate::scene::load("large_pyramid").unwrap().world;
        let mine = scene(100).unwrap();
        assert_eq!(
            mine.solver, large.solver,
            "large_pyramid.toml's own [solver]"
        );
        assert_eq!(mine.gravity, large.gravity);
        assert_eq!(mine.bodies.len(), large.bodies.len());
        // the boxes stand where large_pyramid's do
        assert_eq!(mine.bodies[1..], large.bodies[1..]);
        let small = scene(45).unwrap();
        assert_eq!(small.bodies.len(), 1 + 1035);
    }

    #[test]
    fn runs_alternate_thread_counts_and_the_filter_picks_sizes_by_label() {
        assert_eq!(thread_counts(2), vec![1, 2]);
        assert_eq!(thread_counts(1), vec![1, 2]);
        assert_eq!(thread_counts(8), vec![1, 2, 8]);
        let s = sizes(Some("5k"));
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].base, 100);
        assert!(sizes(Some("3k")).is_empty());
        assert_eq!(sizes(None).len(), 4);
        let r = runs(&sizes(Some("1k")), &[1, 2], 2);
        let order: Vec<(usize, u32)> = r.iter().map(|r| (r.threads, r.repeat)).collect();
        assert_eq!(order, [(1, 0), (2, 0), (1, 1), (2, 1)]);
    }

    #[test]
    fn assemble_takes_medians_and_speedups_and_flags_a_hash_that_differs() {
        let size = SIZES[0];
        let runs = runs(&[size], &[1, 2], 3);
        let t = |ms: f64, hash: u64| Timed {
            ms_per_step: ms,
            contacts: 100.0,
            state_hash: hash,
            bodies: 1035,
            steps: 5,
        };
        let timed = [
            t(4.0, 7),
            t(2.0, 7),
            t(9.0, 7),
            t(3.0, 7),
            t(5.0, 7),
            t(1.0, 7),
        ];
        let rows = assemble(&runs, &timed, &[1, 2]);
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].threads, rows[0].ms_per_step), (1, 5.0));
        assert_eq!((rows[1].threads, rows[1].ms_per_step), (2, 2.0));
        assert_eq!(rows[1].speedup, 2.5);
        assert_eq!(rows[0].us_per_contact, 50.0);
        assert!(rows.iter().all(|r| r.same_bits));
        let mut odd = timed;
        odd[3].state_hash = 8;
        let rows = assemble(&runs, &odd, &[1, 2]);
        assert!(rows.iter().all(|r| !r.same_bits));
        let md = markdown(&rows, 3, 2, "sandbox2d bench --suite scaling");
        assert!(md.contains("| no |") && md.contains("- 1k: 0.40"), "{md}");
        let c = csv(&rows);
        assert_eq!(c.lines().count(), 3);
        assert!(c.lines().nth(1).unwrap().starts_with("1k,1035,1,5,"), "{c}");
        let svg = svg(&rows).unwrap();
        assert!(svg.contains("<svg") && svg.contains("2 threads"), "{svg}");
    }
}
