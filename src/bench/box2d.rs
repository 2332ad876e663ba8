//! `bench --suite box2d`: Box2D v3's own benchmark set (its `benchmark/main.c` and
//! `shared/benchmarks.c`) as scene files (`scenes/box2d/*.toml`, embedded here), each
//! run at Box2D's step count on 1 and 2 threads: ms per step (median and mean of the
//! steps after the first, which Box2D's harness leaves out too), contacts, and an
//! accuracy figure that fits the scene, with the bodies that left it. Reports:
//! box2d.csv, box2d.md and box2d.svg (ms per step per scene and thread count).

use std::time::Instant;

use plotters::prelude::*;

use super::median;
use crate::World;
use crate::defs::WorldDef;

/// What a scene's accuracy figure measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Figure {
    /// The deepest contact overlap over the run (m).
    Overlap,
    /// The largest joint anchor separation over the run (m).
    Stretch,
    /// How far the top box of each pyramid sank by the run's end, the most of them (m).
    TopSink,
    /// Dynamic bodies outside their container at the end (count).
    Escaped,
}

impl Figure {
    /// The column's name.
    pub fn name(self) -> &'static str {
        match self {
            Figure::Overlap => "deepest overlap (m)",
            Figure::Stretch => "largest joint stretch (m)",
            Figure::TopSink => "top box sank (m)",
            Figure::Escaped => "bodies out of the container",
        }
    }

    /// A short key for the CSV.
    pub fn key(self) -> &'static str {
        match self {
            Figure::Overlap => "overlap_m",
            Figure::Stretch => "stretch_m",
            Figure::TopSink => "top_sink_m",
            Figure::Escaped => "escaped",
        }
    }
}

/// Where a scene's bodies belong: a body outside counts as lost (through the ground,
/// out of a drum).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Arena {
    /// No floor or container (zero gravity, or a hanging grid): nothing is lost.
    Open,
    /// Above y (m): the floor's top, a catcher.
    Above(f32),
    /// Above its own floor: y = step x the number in its name after `prefix` / `per`
    /// (Box2D's many pyramids: row = pyramid / 20; rain: the floor of its humans table).
    AboveOwnFloor {
        prefix: &'static str,
        per: u32,
        step: f32,
    },
    /// Within `radius` of the named body's centre (a drum) or of a point.
    Within {
        body: Option<&'static str>,
        center: [f32; 2],
        radius: f32,
    },
    /// Within the named body's square of half-size `half` (its frame: a turning box).
    InsideSquare { body: &'static str, half: f32 },
}

/// One of Box2D's benchmarks as a scene.
#[derive(Clone, Copy, Debug)]
pub struct Box2dScene {
    /// Box2D's name (`-b=NAME`).
    pub name: &'static str,
    /// Box2D's step count.
    pub steps: u64,
    /// The scene file's text (scenes/box2d/NAME.toml).
    pub text: &'static str,
    pub figure: Figure,
    pub arena: Arena,
}

impl Box2dScene {
    /// The scene as a world description.
    pub fn def(&self) -> Result<WorldDef, String> {
        crate::scene::load_str(self.text, &format!("scenes/box2d/{}.toml", self.name))
            .map(|s| s.world)
            .map_err(|e| e.to_string())
    }
}

/// The ten scenes, in Box2D's order.
pub const SCENES: [Box2dScene; 10] = [
    Box2dScene {
        name: "compounds",
        steps: 500,
        text: include_str!("../../scenes/box2d/compounds.toml"),
        figure: Figure::Overlap,
        arena: Arena::Above(-80.0),
    },
    Box2dScene {
        name: "joint_grid",
        steps: 500,
        text: include_str!("../../scenes/box2d/joint_grid.toml"),
        figure: Figure::Stretch,
        arena: Arena::Open,
    },
    Box2dScene {
        name: "junkyard",
        steps: 800,
        text: include_str!("../../scenes/box2d/junkyard.toml"),
        figure: Figure::Overlap,
        arena: Arena::Above(0.5),
    },
    Box2dScene {
        name: "large_pyramid",
        steps: 500,
        text: include_str!("../../scenes/box2d/large_pyramid.toml"),
        figure: Figure::TopSink,
        arena: Arena::Above(0.0),
    },
    Box2dScene {
        name: "many_pyramids",
        steps: 200,
        text: include_str!("../../scenes/box2d/many_pyramids.toml"),
        figure: Figure::TopSink,
        arena: Arena::AboveOwnFloor {
            prefix: "pyramid",
            per: 20,
            step: 11.0,
        },
    },
    Box2dScene {
        name: "rain",
        steps: 1000,
        text: include_str!("../../scenes/box2d/rain.toml"),
        figure: Figure::Stretch,
        arena: Arena::AboveOwnFloor {
            prefix: "spawn0/humans",
            per: 1,
            step: 45.0,
        },
    },
    Box2dScene {
        name: "smash",
        steps: 300,
        text: include_str!("../../scenes/box2d/smash.toml"),
        figure: Figure::Overlap,
        arena: Arena::Open,
    },
    Box2dScene {
        name: "spinner",
        steps: 500,
        text: include_str!("../../scenes/box2d/spinner.toml"),
        figure: Figure::Escaped,
        arena: Arena::Within {
            body: None,
            center: [0.0, 32.0],
            radius: 40.0,
        },
    },
    Box2dScene {
        name: "tumbler",
        steps: 750,
        text: include_str!("../../scenes/box2d/tumbler.toml"),
        figure: Figure::Escaped,
        arena: Arena::InsideSquare {
            body: "tumbler",
            half: 10.0,
        },
    },
    Box2dScene {
        name: "washer",
        steps: 500,
        text: include_str!("../../scenes/box2d/washer.toml"),
        figure: Figure::Escaped,
        arena: Arena::Within {
            body: Some("drum"),
            center: [0.0, 0.0],
            radius: 18.0,
        },
    },
];

/// The scenes whose name contains `filter` (all without one).
pub fn scenes(filter: Option<&str>) -> Vec<Box2dScene> {
    SCENES
        .iter()
        .filter(|s| filter.is_none_or(|f| s.name.contains(f)))
        .copied()
        .collect()
}

/// The thread counts every scene runs at.
pub const THREADS: [usize; 2] = [1, 2];

/// One run to make: a scene at a thread count.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    pub scene: Box2dScene,
    pub threads: usize,
}

impl Case {
    /// What the progress bar shows.
    pub fn label(&self) -> String {
        format!(
            "{} ({} thread{})",
            self.scene.name,
            self.threads,
            if self.threads == 1 { "" } else { "s" }
        )
    }
}

/// Every scene at every thread count, scene by scene.
pub fn cases(scenes: &[Box2dScene]) -> Vec<Case> {
    scenes
        .iter()
        .flat_map(|&scene| THREADS.iter().map(move |&threads| Case { scene, threads }))
        .collect()
}

/// What a case measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub scene: String,
    pub threads: usize,
    /// Steps run (the first is not timed).
    pub steps: u64,
    /// Runs of the scene (`--repeats`).
    pub repeats: u32,
    /// Median over the runs of each run's median step time (ms).
    pub ms_median: f64,
    /// Median over the runs of each run's mean step time (ms).
    pub ms_mean: f64,
    /// Time per stage, mean of the timed steps (ms): forces, broad phase, narrow phase,
    /// solver, integration (the first run's).
    pub stage_ms: [f64; 5],
    /// Contact manifolds: the mean over the timed steps, and at the end.
    pub contacts_mean: f64,
    pub contacts_end: u64,
    /// Bodies at the end (dynamic ones).
    pub bodies: u64,
    /// The scene's accuracy figure ([`Figure`]).
    pub figure: Figure,
    pub accuracy: f64,
    /// Dynamic bodies outside the scene's arena at the end.
    pub lost: u64,
    /// The state hash at the end (every run's; they must agree).
    pub state_hash: u64,
}

/// The top box of each `[[pyramid]]` table (its last body, `pyramidK_{n-1}`) and where
/// it starts.
fn apexes(world: &World) -> Vec<(usize, f32)> {
    let mut last: Vec<(u32, usize, usize)> = Vec::new();
    for (i, b) in world.bodies.iter().enumerate() {
        let Some(rest) = b.name.strip_prefix("pyramid") else {
            continue;
        };
        let Some((p, k)) = rest.split_once('_') else {
            continue;
        };
        let (Ok(p), Ok(k)) = (p.parse::<u32>(), k.parse::<usize>()) else {
            continue;
        };
        match last.iter_mut().find(|(q, _, _)| *q == p) {
            Some(e) if k > e.1 => (e.1, e.2) = (k, i),
            Some(_) => {}
            None => last.push((p, k, i)),
        }
    }
    last.iter()
        .map(|&(_, _, i)| (i, world.bodies[i].position.y))
        .collect()
}

/// The number in a body's name right after `prefix` (`pyramid12_3` -> 12).
fn number_after(name: &str, prefix: &str) -> Option<u32> {
    let rest = name.strip_prefix(prefix)?;
    let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
    digits.parse().ok()
}

/// Dynamic bodies outside the arena.
pub fn lost(world: &World, arena: Arena) -> u64 {
    let body = |name: &str| world.body_index(name).map(|i| world.bodies[i].transform());
    let outside: Box<dyn Fn(&crate::body::Body) -> bool> = match arena {
        Arena::Open => return 0,
        Arena::Above(y) => Box::new(move |b| b.position.y < y),
        Arena::AboveOwnFloor { prefix, per, step } => Box::new(move |b| {
            number_after(&b.name, prefix)
                .is_some_and(|n| b.position.y < step * (n / per.max(1)) as f32)
        }),
        Arena::Within {
            body: name,
            center,
            radius,
        } => {
            let c = match name {
                Some(n) => match body(n) {
                    Some(xf) => xf.p,
                    None => return 0,
                },
                None => crate::math::Vec2::from(center),
            };
            Box::new(move |b| b.position.distance(c) > radius)
        }
        Arena::InsideSquare { body: name, half } => {
            let Some(xf) = body(name) else {
                return 0;
            };
            Box::new(move |b| {
                let p = xf.q.inv_rotate(b.position - xf.p);
                p.x.abs() > half || p.y.abs() > half
            })
        }
    };
    world
        .bodies
        .iter()
        .filter(|b| b.is_dynamic() && outside(b))
        .count() as u64
}

/// Runs one case `repeats` times; `steps` overrides the scene's count.
pub fn run_case(case: &Case, steps: Option<u64>, repeats: u32) -> Result<Row, String> {
    let sc = case.scene;
    let def = sc.def()?;
    let steps = steps.unwrap_or(sc.steps).max(2);
    let (mut medians, mut means) = (Vec::new(), Vec::new());
    let mut first: Option<Row> = None;
    for run in 0..repeats.max(1) {
        if crate::output::interrupted() {
            return Err("interrupted".into());
        }
        let mut world = World::from_def(&def, def.solver.resolve()).map_err(|e| e.to_string())?;
        world.set_threads(case.threads);
        let tops = apexes(&world);
        let mut ms = Vec::with_capacity(steps as usize);
        let (mut stage, mut contacts) = ([0.0f64; 5], 0.0f64);
        let mut accuracy = 0.0f64;
        for n in 0..steps {
            let t = Instant::now();
            let r = world.step();
            let elapsed = t.elapsed().as_secs_f64() * 1e3;
            r.map_err(|e| format!("{}: {e}", case.label()))?;
            if n > 0 {
                // Box2D's harness times the steps after the first, which builds the
                // contact cache
                ms.push(elapsed);
                let s = world.stats();
                for (acc, x) in stage.iter_mut().zip([
                    s.ms_forces,
                    s.ms_broad,
                    s.ms_narrow,
                    s.ms_solve,
                    s.ms_integrate,
                ]) {
                    *acc += x as f64;
                }
                contacts += world.contacts().len() as f64;
            }
            // measured outside the timed step
            if run == 0 {
                match sc.figure {
                    Figure::Overlap => accuracy = accuracy.max(world.stats().penetration as f64),
                    Figure::Stretch => accuracy = accuracy.max(world.joint_error() as f64),
                    Figure::TopSink | Figure::Escaped => {}
                }
            }
        }
        let timed = ms.len() as f64;
        means.push(ms.iter().sum::<f64>() / timed);
        medians.push(median(&mut ms));
        let hash = world.state_hash();
        match &first {
            Some(f) if f.state_hash != hash => {
                return Err(format!(
                    "{}: run {} ended in state hash {hash:016x}, the first in {:016x}: not deterministic",
                    case.label(),
                    run + 1,
                    f.state_hash
                ));
            }
            Some(_) => {}
            None => {
                let lost = lost(&world, sc.arena);
                match sc.figure {
                    Figure::TopSink => {
                        accuracy = tops
                            .iter()
                            .map(|&(i, y0)| (y0 - world.bodies[i].position.y) as f64)
                            .fold(f64::NEG_INFINITY, f64::max);
                    }
                    Figure::Escaped => accuracy = lost as f64,
                    _ => {}
                }
                first = Some(Row {
                    scene: sc.name.to_string(),
                    threads: case.threads,
                    steps,
                    repeats,
                    ms_median: 0.0,
                    ms_mean: 0.0,
                    stage_ms: stage.map(|x| x / timed),
                    contacts_mean: contacts / timed,
                    contacts_end: world.contacts().len() as u64,
                    bodies: world.bodies.iter().filter(|b| b.is_dynamic()).count() as u64,
                    figure: sc.figure,
                    accuracy,
                    lost,
                    state_hash: hash,
                });
            }
        }
    }
    let mut row = first.expect("at least one run");
    row.ms_median = median(&mut medians);
    row.ms_mean = median(&mut means);
    Ok(row)
}

/// The CSV's columns.
pub const CSV_COLUMNS: [&str; 17] = [
    "scene",
    "threads",
    "steps",
    "repeats",
    "ms_median",
    "ms_mean",
    "forces_ms",
    "broad_ms",
    "narrow_ms",
    "solve_ms",
    "integrate_ms",
    "contacts_mean",
    "contacts_end",
    "bodies",
    "figure",
    "accuracy",
    "lost",
];

/// box2d.csv: one row per scene and thread count (numbers in full, `{:e}`), then the
/// state hash.
pub fn csv(rows: &[Row]) -> String {
    let mut s = CSV_COLUMNS.join(",");
    s.push_str(",state_hash\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{},{},{},{:e},{},{:016x}\n",
            r.scene,
            r.threads,
            r.steps,
            r.repeats,
            r.ms_median,
            r.ms_mean,
            r.stage_ms[0],
            r.stage_ms[1],
            r.stage_ms[2],
            r.stage_ms[3],
            r.stage_ms[4],
            r.contacts_mean,
            r.contacts_end,
            r.bodies,
            r.figure.key(),
            r.accuracy,
            r.lost,
            r.state_hash
        ));
    }
    s
}

/// An accuracy figure as the table writes it.
fn figure_text(f: Figure, x: f64) -> String {
    match f {
        Figure::Escaped => format!("{x:.0}"),
        _ => format!("{x:.4}"),
    }
}

/// box2d.md: the table, and per scene 2 threads' time over 1 thread's. `command` is
/// the command line that measured it.
pub fn markdown(rows: &[Row], command: &str) -> String {
    let mut s = String::from("# Box2D's benchmark set\n\n");
    s.push_str(&format!(
        "`{command}`. Each scene is scenes/box2d/NAME.toml, a port of Box2D v3's benchmark \
         of that name, run for Box2D's step count under the scene's own [solver] table. \
         ms/step: the median and the mean of the steps after the first (Box2D's harness \
         leaves the first out too), the median over the repeats; stages: the mean time \
         of each stage (forces, broad phase, narrow phase, solver, integration); \
         contacts: manifolds, the mean over the steps and at the end; lost: dynamic \
         bodies outside the scene (through its floor, out of its drum) at the end.\n\n"
    ));
    s.push_str(
        "| scene | threads | steps | ms/step median | mean | forces / broad / narrow / solve / integrate (ms) | contacts (mean, end) | bodies | accuracy | lost | state hash |\n",
    );
    s.push_str("|---|---:|---:|---:|---:|---|---:|---:|---|---:|---|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.3} | {:.3} / {:.3} / {:.3} / {:.3} / {:.3} | {:.0}, {} | {} | {}: {} | {} | `{:016x}` |\n",
            r.scene,
            r.threads,
            r.steps,
            r.ms_median,
            r.ms_mean,
            r.stage_ms[0],
            r.stage_ms[1],
            r.stage_ms[2],
            r.stage_ms[3],
            r.stage_ms[4],
            r.contacts_mean,
            r.contacts_end,
            r.bodies,
            r.figure.name(),
            figure_text(r.figure, r.accuracy),
            r.lost,
            r.state_hash
        ));
    }
    let mut names: Vec<&str> = Vec::new();
    for r in rows {
        if !names.contains(&r.scene.as_str()) {
            names.push(&r.scene);
        }
    }
    let pairs: Vec<(&str, f64, f64)> = names
        .iter()
        .filter_map(|&n| {
            let ms = |t: usize| {
                rows.iter()
                    .find(|r| r.scene == n && r.threads == t)
                    .map(|r| r.ms_mean)
            };
            Some((n, ms(1)?, ms(2)?))
        })
        .collect();
    if !pairs.is_empty() {
        s.push_str("\n2 threads' mean time over 1 thread's (below 1: two threads are faster):\n\n");
        for (n, one, two) in pairs {
            s.push_str(&format!("- {n}: {:.2}\n", two / one));
        }
    }
    s.push_str("\n![ms per step, per scene and thread count](box2d.svg)\n");
    s
}

/// box2d.svg: ms per step (mean) per scene, one bar per thread count, log scale.
pub fn svg(rows: &[Row]) -> Result<String, String> {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        if !names.contains(&r.scene) {
            names.push(r.scene.clone());
        }
    }
    let mut threads: Vec<usize> = rows.iter().map(|r| r.threads).collect();
    threads.sort_unstable();
    threads.dedup();
    let ok = |x: f64| x.is_finite() && x > 0.0;
    let (lo, hi) = rows
        .iter()
        .map(|r| r.ms_mean)
        .filter(|&x| ok(x))
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
    let (y0, y1) = if hi > 0.0 {
        ((lo / 2.0).max(1e-4), hi * 2.0)
    } else {
        (1e-2, 10.0)
    };
    let n = names.len().max(1) as f64;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (900, 520)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Box2D's benchmark set: ms per step (mean)",
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(60)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..n, (y0..y1).log_scale())
            .map_err(|x| e(&x))?;
        let label_names = names.clone();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(names.len() * 2 + 1)
            .x_label_formatter(&move |v| {
                let i = (*v - 0.5).round();
                if (v - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
                    label_names.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_desc("ms per step")
            .y_label_formatter(&|v| super::plot::short(*v))
            .draw()
            .map_err(|x| e(&x))?;
        let width = 0.8 / threads.len().max(1) as f64;
        for (k, &t) in threads.iter().enumerate() {
            let c = [
                RGBColor(31, 119, 180),
                RGBColor(214, 39, 40),
                RGBColor(44, 160, 44),
            ][k % 3];
            let bars: Vec<_> = rows
                .iter()
                .filter(|r| r.threads == t && ok(r.ms_mean))
                .filter_map(|r| {
                    let i = names.iter().position(|n| *n == r.scene)? as f64;
                    let x0 = i + 0.1 + k as f64 * width;
                    Some(Rectangle::new(
                        [(x0, y0), (x0 + width * 0.9, r.ms_mean)],
                        c.filled(),
                    ))
                })
                .collect();
            chart
                .draw_series(bars)
                .map_err(|x| e(&x))?
                .label(format!("{t} thread{}", if t == 1 { "" } else { "s" }))
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
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
    fn every_scene_loads_and_the_filter_picks_by_name() {
        for sc in SCENES {
            let def = sc.def().unwrap_or_else(|e| panic!("{e}"));
            assert!(
                !def.bodies.is_empty() || !def.spawns.is_empty(),
                "{}",
                sc.name
            );
        }
        let picked = scenes(Some("pyramid"));
        let names: Vec<&str> = picked.iter().map(|s| s.name).collect();
        assert_eq!(names, ["large_pyramid", "many_pyramids"]);
        assert_eq!(cases(&picked).len(), 4, "two thread counts each");
    }

    #[test]
    fn the_median_of_an_even_count_is_the_mean_of_the_middle_two() {
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut [5.0, 1.0, 3.0]), 3.0);
    }

    #[test]
    fn a_name_gives_its_floor() {
        assert_eq!(number_after("pyramid37_4", "pyramid"), Some(37));
        assert_eq!(
            number_after("spawn0/humans3_2_hip#17", "spawn0/humans"),
            Some(3)
        );
        assert_eq!(number_after("ground", "pyramid"), None);
    }
}
