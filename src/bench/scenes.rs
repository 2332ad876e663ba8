//! The bench's scenes: built-in scenes, the joint and mass-ratio scenes of
//! `assets/bench/*.toml`, and the model comparisons, each with what to measure.

use super::{Budget, Suite};
use crate::defs::WorldDef;
use crate::scene;

/// An accuracy measure (smaller is better).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    PenetrationMax,
    PenetrationMean,
    Drift,
    JointError,
    /// |energy drift|
    EnergyDrift,
    Residual,
    /// The RMS distance of the bodies from their true places over the run
    /// (`--metric trajectory`, against [`BenchScene::truth`]).
    Trajectory,
}

impl Metric {
    /// The results.csv column name.
    pub fn name(self) -> &'static str {
        match self {
            Metric::PenetrationMax => "penetration_max",
            Metric::PenetrationMean => "penetration_mean",
            Metric::Drift => "drift",
            Metric::JointError => "joint_error",
            Metric::EnergyDrift => "energy_drift",
            Metric::Residual => "residual",
            Metric::Trajectory => "trajectory_rms",
        }
    }

    /// A label for plot axes.
    pub fn axis_label(self) -> &'static str {
        match self {
            Metric::PenetrationMax => "max penetration (m)",
            Metric::PenetrationMean => "mean penetration (m)",
            Metric::Drift => "drift of the tracked body (m)",
            Metric::JointError => "max joint anchor separation (m)",
            Metric::EnergyDrift => "|energy drift| (relative)",
            Metric::Residual => "residual against converged PGS (relative)",
            Metric::Trajectory => "RMS position error against the true motion (m)",
        }
    }
}

/// Which body's drift a scene measures.
#[derive(Clone, Debug, PartialEq)]
pub enum Track {
    None,
    /// The dynamic body highest at the start (the top of a stack or pyramid).
    Top,
    /// The body of this name.
    Named(String),
}

/// A scene as the bench runs it.
#[derive(Clone, Debug)]
pub struct BenchScene {
    /// Short name: the key in results.csv and the plot's file name.
    pub name: String,
    /// One line: what the scene is and what its error measures.
    pub about: String,
    pub def: WorldDef,
    pub track: Track,
    /// The height from which potential energy is measured (the lowest point a body can reach).
    pub floor_y: f32,
    /// The scene should conserve energy (energy drift is reported).
    pub conservative: bool,
    /// A stack that must stand: the tracked body may move at most this far (m).
    pub standing: Option<f32>,
    /// "Bounded energy": the energy may rise at most this fraction of its scale.
    pub energy_gain: f64,
    /// The error plotted against cost.
    pub primary: Metric,
    /// The measures that decide dominance.
    pub metrics: Vec<Metric>,
    /// Every setting of the grid, or only the solvers' defaults (model comparisons).
    pub full_grid: bool,
    pub budget: Budget,
    /// The true motion runs are compared with (`--metric trajectory`; see
    /// [`super::truth`]), when it was worked out; `None` otherwise.
    pub truth: Option<std::sync::Arc<super::truth::Truth>>,
}

const PENDULUM: &str = include_str!("../../assets/bench/pendulum.toml");
const DOUBLE_PENDULUM: &str = include_str!("../../assets/bench/double_pendulum.toml");
const CHAIN: &str = include_str!("../../assets/bench/chain.toml");
const BALL_AND_CHAIN: &str = include_str!("../../assets/bench/ball_and_chain.toml");
const HEAVY_ON_LIGHT: &str = include_str!("../../assets/bench/heavy_on_light.toml");
const OVERLAP_RECOVERY: &str = include_str!("../../assets/bench/overlap_recovery.toml");

/// Loads an embedded scene; they are checked by a unit test, so failure is a bug.
fn load_text(text: &str, source: &str) -> WorldDef {
    match scene::load_str(text, source) {
        Ok(s) => s.world,
        Err(e) => panic!("embedded bench scene {source}: {e}"),
    }
}

fn load_builtin(name: &str) -> WorldDef {
    match scene::load(name) {
        Ok(s) => s.world,
        Err(e) => panic!("built-in scene {name}: {e}"),
    }
}

/// 200 circles of radius 0.2 m dropped into a 10 m wide pit in two staggered grids
/// (so they tumble and roll), as particles or rigid bodies.
pub fn circles_text(model: &str) -> String {
    let grid = |x: f32, y: f32| {
        format!(
            "[[grid]]\nrows = 10\ncolumns = 10\nspacing = [0.9, 0.9]\norigin = [{x}, {y}]\nshape = {{ circle = 0.2 }}\nmodel = \"{model}\"\n"
        )
    };
    format!(
        r#"name = "circles ({model})"
[world]
gravity = [0.0, -10.0]
[[body]]
name = "ground"
type = "static"
shape = {{ box = [12.0, 1.0] }}
position = [0.0, -0.5]
[[body]]
name = "left"
type = "static"
shape = {{ box = [1.0, 20.0] }}
position = [-5.5, 10.0]
[[body]]
name = "right"
type = "static"
shape = {{ box = [1.0, 20.0] }}
position = [5.5, 10.0]
{}{}"#,
        grid(-4.3, 0.5),
        grid(-3.85, 0.95)
    )
}

/// 400 balls falling side by side (no ground, no contacts), in vacuum or in air.
pub fn free_fall_text(drag: bool) -> String {
    let drag = if drag {
        "[world.drag]\nfluid_density = 1.225\ndrag_coefficient = 0.47\n"
    } else {
        ""
    };
    format!(
        r#"name = "free fall"
[world]
gravity = [0.0, -10.0]
{drag}[[grid]]
rows = 20
columns = 20
spacing = [2.0, 2.0]
shape = {{ circle = 0.1 }}
"#
    )
}

#[allow(clippy::too_many_arguments)]
fn scene(
    name: &str,
    about: &str,
    def: WorldDef,
    track: Track,
    standing: Option<f32>,
    primary: Metric,
    metrics: &[Metric],
    budget: Budget,
) -> BenchScene {
    BenchScene {
        name: name.into(),
        about: about.into(),
        def,
        track,
        floor_y: 0.0,
        conservative: metrics.contains(&Metric::EnergyDrift),
        standing,
        energy_gain: 0.5,
        primary,
        metrics: metrics.to_vec(),
        full_grid: true,
        budget,
        truth: None,
    }
}

const fn budget(steps: u64, repeats: u32, residual_samples: u32) -> Budget {
    Budget {
        steps,
        repeats,
        residual_samples,
        reference_iterations: 1000,
    }
}

use Metric::*;

/// The scenes of the quick suite.
fn quick() -> Vec<BenchScene> {
    let mut v = vec![
        scene(
            "pyramid",
            "the benchmark pyramid, base 20 (210 boxes), 300 steps; error: deepest overlap",
            load_builtin("pyramid"),
            Track::Top,
            Some(0.5),
            PenetrationMax,
            &[PenetrationMax, PenetrationMean, Drift],
            budget(300, 5, 6),
        ),
        scene(
            "stack",
            "15 boxes of 1 m in a column, 300 steps; error: drift of the top box",
            load_builtin("stack"),
            Track::Top,
            Some(0.5),
            Drift,
            &[Drift, PenetrationMax, PenetrationMean],
            budget(300, 3, 6),
        ),
        scene(
            "particles",
            "the MLCP demo's ball pit: 50 particles in a 2 m box, in air, 300 steps; error: deepest overlap",
            load_builtin("particles"),
            Track::None,
            None,
            PenetrationMax,
            &[PenetrationMax, PenetrationMean],
            budget(300, 3, 6),
        ),
        scene(
            "pendulum",
            "a ball on a 2 m distance joint, released horizontal, 600 steps; error: |energy drift|",
            load_text(PENDULUM, "assets/bench/pendulum.toml"),
            Track::None,
            None,
            EnergyDrift,
            &[EnergyDrift, JointError],
            budget(600, 3, 0),
        ),
        scene(
            "chain",
            "20 hinged links hanging from an anchor, released horizontal, 300 steps; error: joint separation",
            load_text(CHAIN, "assets/bench/chain.toml"),
            Track::None,
            None,
            JointError,
            &[JointError, PenetrationMax],
            budget(300, 3, 6),
        ),
    ];
    // Model only what a scene requires: the same scene with less model, solver defaults.
    let model = |name: &str, about: &str, def: WorldDef| BenchScene {
        full_grid: false,
        ..scene(
            name,
            about,
            def,
            Track::None,
            None,
            PenetrationMax,
            &[PenetrationMax],
            budget(300, 5, 0),
        )
    };
    v.push(model(
        "circles_particle",
        "200 circles dropped in a pit as particles (no rotation); compare circles_rigid",
        load_text(&circles_text("particle"), "bench:circles_particle"),
    ));
    v.push(model(
        "circles_rigid",
        "the same 200 circles as rigid bodies",
        load_text(&circles_text("rigid"), "bench:circles_rigid"),
    ));
    v.push(model(
        "fall_vacuum",
        "400 balls in free fall, no contacts, no drag declared; compare fall_drag",
        load_text(&free_fall_text(false), "bench:fall_vacuum"),
    ));
    v.push(model(
        "fall_drag",
        "the same 400 balls in air ([world.drag] declared)",
        load_text(&free_fall_text(true), "bench:fall_drag"),
    ));
    v
}

/// The scenes the standard suite adds.
fn standard_extra() -> Vec<BenchScene> {
    vec![
        scene(
            "large_pyramid",
            "the benchmark pyramid, base 100 (5050 boxes); 300 steps and 1 repeat only (its cost), residual at 2 steps with a 200-sweep reference; error: deepest overlap",
            load_builtin("large_pyramid"),
            Track::Top,
            Some(0.5),
            PenetrationMax,
            &[PenetrationMax, PenetrationMean, Drift],
            Budget {
                steps: 300,
                repeats: 1,
                residual_samples: 2,
                reference_iterations: 200,
            },
        ),
        scene(
            "heavy_on_light",
            "mass ratio 100: a box of density 100 on two boxes of density 1, 300 steps; error: drift of the heavy box",
            load_text(HEAVY_ON_LIGHT, "assets/bench/heavy_on_light.toml"),
            Track::Top,
            Some(0.5),
            Drift,
            &[Drift, PenetrationMax, PenetrationMean],
            budget(300, 3, 6),
        ),
        scene(
            "friction_ramp",
            "five boxes on 25-degree ramps, frictions 0..1, 300 steps; error: creep of box3 (mu 0.6 > tan 25, should stick)",
            load_builtin("friction_ramp"),
            Track::Named("box3".into()),
            None,
            Drift,
            &[Drift, PenetrationMax],
            budget(300, 3, 6),
        ),
        scene(
            "overlap_recovery",
            "five boxes stacked with 0.1 m overlaps, 300 steps; error: mean overlap (how fast it is resolved)",
            load_text(OVERLAP_RECOVERY, "assets/bench/overlap_recovery.toml"),
            Track::None,
            None,
            PenetrationMean,
            &[PenetrationMean, PenetrationMax],
            budget(300, 3, 6),
        ),
        scene(
            "ball_and_chain",
            "10 hinged links with a heavy ball (100x a link), swinging onto the ground, 300 steps; error: joint separation",
            load_text(BALL_AND_CHAIN, "assets/bench/ball_and_chain.toml"),
            Track::None,
            None,
            JointError,
            &[JointError, PenetrationMax],
            budget(300, 3, 6),
        ),
        scene(
            "double_pendulum",
            "two balls on 1 m distance joints, released horizontal, 600 steps; error: |energy drift|",
            load_text(DOUBLE_PENDULUM, "assets/bench/double_pendulum.toml"),
            Track::None,
            None,
            EnergyDrift,
            &[EnergyDrift, JointError],
            budget(600, 3, 0),
        ),
    ]
}

/// The scenes of a suite (the extremes suite has none: it runs sweeps).
pub fn suite(s: Suite) -> Vec<BenchScene> {
    match s {
        Suite::Quick => quick(),
        Suite::Standard => {
            let mut v = quick();
            v.extend(standard_extra());
            v
        }
        Suite::Extremes | Suite::Box2d => Vec::new(),
    }
}

/// Scenes the bench once named otherwise, (former name, name): `--filter` still finds
/// them by the former name. The base-20 pyramid is the built-in `pyramid`.
pub const FORMER_NAMES: &[(&str, &str)] = &[("pyramid20", "pyramid")];

/// A pair of scenes that differ only in how much they model.
#[derive(Clone, Copy, Debug)]
pub struct ModelPair {
    /// The leaner scene.
    pub lean: &'static str,
    /// The fuller scene.
    pub full: &'static str,
    /// What differs.
    pub what: &'static str,
    /// The pipeline stages (indices into [`super::Measured::stage_ms`]: forces, broad,
    /// narrow, solve, integrate) where the extra model's work is done; the other stages
    /// do the same work in both scenes.
    pub stages: &'static [usize],
    /// Why the extra model costs what it costs (or why it may not show).
    pub why: &'static str,
}

/// Pairs of scenes that differ only in how much they model.
pub const MODEL_PAIRS: &[ModelPair] = &[
    ModelPair {
        lean: "circles_particle",
        full: "circles_rigid",
        what: "particles (no rotation) against rigid circles, equal counts",
        stages: &[4],
        why: "a rigid circle adds an angle and an angular velocity to integrate (its contact rows have the shape of a particle's, whose inverse inertia is zero); the rigid circles roll, so the two piles also settle a little differently",
    },
    ModelPair {
        lean: "fall_vacuum",
        full: "fall_drag",
        what: "no drag declared against [world.drag]",
        stages: &[0],
        why: "no ball touches another, so drag's only work is one force per body in the forces stage (the soft step works it out at every substep, so its cost grows with the substeps); a difference in the stages both scenes share is timing noise",
    },
];

/// Box2D's joint grid benchmark layout: n x n circles of radius 0.4 at 1 m spacing
/// (row k at y = k), each hinged to its left and lower neighbours (2 n (n - 1) hinges),
/// 7 static anchors in the middle of the top row, gravity 10. Neighbours are 0.2 m
/// apart, so they never touch (the layout needs no filters). Body `k * n + i` is row k,
/// column i.
pub fn joint_grid(n: usize) -> WorldDef {
    use crate::defs::{BodyDef, BodyType, JointDef, ShapeDef};
    use glam::Vec2;
    let mut def = WorldDef {
        gravity: Some(Vec2::new(0.0, -10.0)),
        ..Default::default()
    };
    for k in 0..n {
        for i in 0..n {
            let anchor = k + 1 == n && i + 3 >= n / 2 && i <= n / 2 + 3;
            def.bodies.push(BodyDef {
                name: format!("b{k}_{i}"),
                body_type: if anchor {
                    BodyType::Static
                } else {
                    BodyType::Dynamic
                },
                shape: ShapeDef::Circle { radius: 0.4 },
                position: Vec2::new(i as f32, k as f32),
                // as in Box2D's layout: the circles never touch one another
                filter: crate::defs::Filter {
                    group: -1,
                    ..Default::default()
                },
                ..Default::default()
            });
        }
    }
    let hinge = JointDef::hinge;
    for k in 0..n {
        for i in 0..n {
            let here = Vec2::new(i as f32, k as f32);
            if i > 0 {
                def.joints
                    .push(hinge(k * n + i - 1, k * n + i, here - Vec2::new(0.5, 0.0)));
            }
            if k > 0 {
                def.joints.push(hinge(
                    (k - 1) * n + i,
                    k * n + i,
                    here - Vec2::new(0.0, 0.5),
                ));
            }
        }
    }
    def
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bench_scene_loads_and_has_a_unique_name() {
        let all = suite(Suite::Standard);
        let mut names: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
        names.sort_unstable();
        let n = names.len();
        names.dedup();
        assert_eq!(names.len(), n);
        for s in &all {
            assert!(!s.def.bodies.is_empty(), "{}", s.name);
        }
        for p in MODEL_PAIRS {
            assert!(all.iter().any(|s| s.name == p.lean) && all.iter().any(|s| s.name == p.full));
        }
    }

    #[test]
    fn the_builtin_joint_grid_is_the_benchmark_layout() {
        let scene = scene::load("joint_grid").unwrap().world;
        let bench = joint_grid(100);
        assert_eq!(scene.bodies.len(), 10_000);
        assert_eq!(scene.joints.len(), 19_800);
        assert_eq!(scene.gravity, bench.gravity);
        for (a, b) in scene.bodies.iter().zip(&bench.bodies) {
            assert_eq!(
                (a.position, a.body_type, &a.shape, a.filter),
                (b.position, b.body_type, &b.shape, b.filter),
                "{} against {}",
                a.name,
                b.name
            );
        }
        for (a, b) in scene.joints.iter().zip(&bench.joints) {
            assert_eq!((a.kind, a.bodies, a.anchor), (b.kind, b.bodies, b.anchor));
        }
    }
}
