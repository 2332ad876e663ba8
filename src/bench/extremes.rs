//! Numerical stability at the extremes: sweep one thing at a time and find where each
//! setting stops being stable or accurate.
//!
//! Each [`Sweep`] has values ordered from easy to hard, a scene built for each value,
//! and a check against a closed form or a bound ([`check`]). `stability.md` lists, per
//! sweep and setting, the last value of the leading run that held and how the next
//! one failed; `tests/extremes.rs` re-checks those claims from `docs/stability.md`.

use std::fmt::Write as _;

use super::{Setting, joint_error};
use crate::defs::{SolverKind, WorldDef};
use crate::math::Vec2;
use crate::scene;
use crate::world::World;

/// Allowed overlap before a run counts as inaccurate (m): ten slops.
pub const MAX_PENETRATION: f32 = 0.05;
/// The PGS slop (m): a resting contact may sit this deep.
const SLOP: f32 = 0.005;
/// A value holds only when every measure clears its bound by this fraction, and fails
/// only when one exceeds its bound by as much; within it either way the case is
/// [`CaseResult::Marginal`]: a verdict a small change of arithmetic could flip.
pub const MARGIN: f64 = 0.1;

/// Where a measure stands against its bound: clear (<= (1 - MARGIN) bound), beyond
/// (> (1 + MARGIN) bound, or NaN), or marginal between.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Standing {
    Clear,
    Marginal,
    Beyond,
}

fn standing_of(measured: f64, bound: f64) -> Standing {
    if measured <= (1.0 - MARGIN) * bound {
        Standing::Clear
    } else if measured <= (1.0 + MARGIN) * bound {
        Standing::Marginal
    } else {
        Standing::Beyond
    }
}

/// The message of a marginal measure.
fn marginal(what: &str, measured: f64, bound: f64) -> CaseResult {
    CaseResult::Marginal(format!(
        "marginal: {what} {measured:.3} m within {:.0}% of its bound {bound:.3} m",
        MARGIN * 100.0
    ))
}

/// Grades an error against its bound: `Err` with `failed()` beyond it, a marginal
/// result naming `what()` within the margin, `Ok` when clear.
fn grade(
    measured: f64,
    bound: f64,
    failed: impl FnOnce() -> String,
    what: impl FnOnce() -> String,
) -> Result<(), CaseResult> {
    match standing_of(measured, bound) {
        Standing::Beyond => Err(CaseResult::Failed(failed())),
        Standing::Marginal => Err(marginal(&what(), measured, bound)),
        Standing::Clear => Ok(()),
    }
}

/// One thing swept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sweep {
    MassRatio,
    MassRatioChain,
    TimeStep,
    Tunneling,
    StackHeight,
    Distance,
    Span,
    Iterations,
    Friction,
    Restitution,
}

impl Sweep {
    pub const ALL: [Sweep; 10] = [
        Sweep::MassRatio,
        Sweep::MassRatioChain,
        Sweep::TimeStep,
        Sweep::Tunneling,
        Sweep::StackHeight,
        Sweep::Distance,
        Sweep::Span,
        Sweep::Iterations,
        Sweep::Friction,
        Sweep::Restitution,
    ];

    /// The name in stability.md's first column.
    pub fn name(self) -> &'static str {
        match self {
            Sweep::MassRatio => "mass_ratio",
            Sweep::MassRatioChain => "mass_ratio_chain",
            Sweep::TimeStep => "time_step",
            Sweep::Tunneling => "tunneling",
            Sweep::StackHeight => "stack_height",
            Sweep::Distance => "distance",
            Sweep::Span => "span",
            Sweep::Iterations => "iterations",
            Sweep::Friction => "friction",
            Sweep::Restitution => "restitution",
        }
    }

    pub fn from_name(s: &str) -> Option<Sweep> {
        Sweep::ALL.into_iter().find(|w| w.name() == s)
    }

    /// What is swept, on what scene, and what counts as holding.
    pub fn about(self) -> &'static str {
        match self {
            Sweep::MassRatio => {
                "a box of density r on two 1 m boxes of density 1, 3 s: holds while the heavy box moves < 0.1 m and overlap < 0.05 m"
            }
            Sweep::MassRatioChain => {
                "a ball of r times a link's mass at the end of 5 hinged links, released horizontal, 3 s: holds while finite and joint separation < 0.05 m"
            }
            Sweep::TimeStep => {
                "a stack of 10 boxes for 3 s at time step dt: holds while the top box moves < 0.15 m and overlap < 0.05 m"
            }
            Sweep::Tunneling => {
                "a ball of radius 0.05 m at speed v against a static wall 0.02 m thick, no gravity, dt 1/60: holds while the ball stays on its side"
            }
            Sweep::StackHeight => {
                "a stack of n boxes of 1 m for 4 s: holds while the top box moves < 0.1 m + n slops and overlap < 0.05 m"
            }
            Sweep::Distance => {
                "a stack of 5 boxes moved by (d, d) from the origin, 3 s: holds while the top moves < 0.125 m, overlap < 0.05 m and every box ends slower than 0.05 m/s. Beyond 1e3 m the scene is simulated relative to its own centre (whole metres, `WorldDef::origin`), so from 1e4 m on its numbers are those at 0"
            }
            Sweep::Span => {
                "the stack of `distance` at 0 and a static 1 m box at (2d, 2d - 10): beyond 1e3 m the scene's centre is about (d, d), so the stack works in f32 about (d, d) from it, 3 s, same bounds as `distance`. What limits a scene is its size, not its place"
            }
            Sweep::Iterations => {
                "the pyramid of base 20 for 5 s at n iterations (PGS: sweeps per step, tolerance 1e-4; XPBD: iterations per substep, 20 substeps): holds while the top box moves < 0.2 m and overlap < 0.05 m"
            }
            Sweep::Friction => {
                "a 0.5 m box on a 25-degree ramp of friction mu, 1 s: holds while its slide is within 0.02 m + 5% of the closed form (g (sin 25 - mu cos 25) for mu < tan 25, else 0)"
            }
            Sweep::Restitution => {
                "a ball dropped 2 m onto a pad, both of restitution e: holds while the first bounce peaks within 0.1 m of e^2 x 2 m"
            }
        }
    }

    /// The values, from easy to hard (the order "holds through" counts in).
    pub fn values(self) -> Vec<f64> {
        match self {
            Sweep::MassRatio | Sweep::MassRatioChain => vec![1.0, 10.0, 100.0, 1e3, 1e4],
            // steps per second: dt = 1/value
            Sweep::TimeStep => vec![1000.0, 480.0, 240.0, 120.0, 60.0, 30.0, 15.0],
            Sweep::Tunneling => vec![1.0, 3.0, 10.0, 30.0, 100.0, 300.0],
            Sweep::StackHeight => vec![5.0, 10.0, 20.0, 30.0, 40.0, 50.0],
            Sweep::Distance => vec![0.0, 1e2, 1e3, 1e4, 3e4, 1e5, 1e6, 1e7],
            Sweep::Span => vec![0.0, 1e2, 1e3, 1e4, 3e4, 1e5],
            Sweep::Iterations => vec![1000.0, 300.0, 100.0, 30.0, 10.0, 5.0, 3.0, 2.0, 1.0],
            Sweep::Friction => vec![0.0, 0.2, 0.4, 0.45, 0.5, 0.6, 1.0, 2.0],
            Sweep::Restitution => vec![0.0, 0.25, 0.5, 0.75, 0.9, 1.0],
        }
    }

    /// A value as the tables write it.
    pub fn format_value(self, v: f64) -> String {
        match self {
            Sweep::TimeStep => format!("1/{v} s"),
            Sweep::Tunneling => format!("{v} m/s"),
            Sweep::Distance | Sweep::Span => format!("{v:e} m"),
            Sweep::MassRatio | Sweep::MassRatioChain => format!("{v:e}"),
            _ => format!("{v}"),
        }
    }

    /// The value a table cell names.
    pub fn parse_value(self, s: &str) -> Option<f64> {
        self.values()
            .into_iter()
            .find(|&v| self.format_value(v) == s.trim())
    }
}

/// A setting of the extremes sweeps, with its short name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExSetting {
    pub label: &'static str,
    pub setting: Setting,
}

fn pgs(iterations: u32, split_impulse: bool) -> Setting {
    Setting {
        iterations,
        split_impulse,
        ..Setting::defaults(SolverKind::Pgs)
    }
}

fn soft(substeps: u32) -> Setting {
    Setting {
        substeps,
        ..Setting::defaults(SolverKind::Soft)
    }
}

fn xpbd(substeps: u32) -> Setting {
    Setting {
        substeps,
        ..Setting::defaults(SolverKind::Xpbd)
    }
}

/// The settings a sweep runs. PGS rows use the defaults (tolerance 1e-4, warm start,
/// split impulse) but for what the label says; for the iterations sweep the value sets
/// the iterations.
pub fn settings(sweep: Sweep) -> Vec<ExSetting> {
    if sweep == Sweep::Iterations {
        return vec![
            ExSetting {
                label: "Soft step",
                setting: soft(4),
            },
            ExSetting {
                label: "PGS",
                setting: pgs(10, true),
            },
            ExSetting {
                label: "PGS no warm start",
                setting: Setting {
                    warm_start: false,
                    ..pgs(10, true)
                },
            },
            ExSetting {
                label: "XPBD 20 substeps",
                setting: xpbd(20),
            },
        ];
    }
    vec![
        ExSetting {
            label: "Soft 4",
            setting: soft(4),
        },
        ExSetting {
            label: "Soft 8",
            setting: soft(8),
        },
        ExSetting {
            label: "PGS 4",
            setting: pgs(4, true),
        },
        ExSetting {
            label: "PGS 10",
            setting: pgs(10, true),
        },
        ExSetting {
            label: "PGS 32",
            setting: pgs(32, true),
        },
        ExSetting {
            label: "PGS 10 no split",
            setting: pgs(10, false),
        },
        ExSetting {
            label: "XPBD 4",
            setting: xpbd(4),
        },
        ExSetting {
            label: "XPBD 20",
            setting: xpbd(20),
        },
    ]
}

/// How one case came out.
#[derive(Clone, Debug, PartialEq)]
pub enum CaseResult {
    /// Stable and accurate, every measure clear of its bound by [`MARGIN`]; what was
    /// measured.
    Held(String),
    /// Within [`MARGIN`] of a bound (either side), none beyond: neither a hold nor a
    /// failure can be claimed. Starts "marginal:".
    Marginal(String),
    /// Why not: starts "unstable:", "inaccurate:" or "tunnelled:".
    Failed(String),
}

impl CaseResult {
    pub fn held(&self) -> bool {
        matches!(self, CaseResult::Held(_))
    }

    /// The kind of a result that did not hold: the word before the first ':' of its
    /// reason ("unstable", "inaccurate", "tunnelled", "marginal"); `None` when it held.
    pub fn kind(&self) -> Option<&str> {
        match self {
            CaseResult::Held(_) => None,
            CaseResult::Marginal(why) | CaseResult::Failed(why) => why.split(':').next(),
        }
    }
}

fn load(text: &str, what: &str) -> WorldDef {
    match scene::load_str(text, what) {
        Ok(s) => s.world,
        Err(e) => panic!("extremes scene {what}: {e}"),
    }
}

fn stack_text(count: u32, offset: f64) -> String {
    format!(
        r#"name = "stack"
[world]
gravity = [0.0, -10.0]
[[body]]
name = "ground"
type = "static"
shape = {{ box = [40.0, 1.0] }}
position = [{o}, {g}]
[[stack]]
count = {count}
origin = [{o}, {o}]
"#,
        o = offset,
        g = offset - 0.5
    )
}

/// The scene of one case.
pub fn world_def(sweep: Sweep, value: f64) -> WorldDef {
    match sweep {
        Sweep::MassRatio => load(
            &format!(
                r#"name = "heavy on light"
[world]
gravity = [0.0, -10.0]
[[body]]
name = "ground"
type = "static"
shape = {{ box = [40.0, 1.0] }}
position = [0.0, -0.5]
[[stack]]
count = 2
[[body]]
name = "heavy"
shape = {{ box = [1.0, 1.0] }}
position = [0.0, 2.5]
density = {value}
"#
            ),
            "extremes:mass_ratio",
        ),
        Sweep::MassRatioChain => {
            // a link of 0.5 x 0.1 at density 1 weighs 0.05 kg; the ball (r 0.25) weighs value x that
            let density = value * 0.05 / (std::f64::consts::PI * 0.25 * 0.25);
            load(
                &format!(
                    r#"name = "heavy ball on a chain"
[world]
gravity = [0.0, -10.0]
[[chain]]
links = 5
link = [0.5, 0.1]
anchor = [0.0, 5.0]
end = {{ shape = {{ circle = 0.25 }}, density = {density} }}
"#
                ),
                "extremes:mass_ratio_chain",
            )
        }
        Sweep::TimeStep => {
            let mut d = load(&stack_text(10, 0.0), "extremes:time_step");
            d.solver.dt = Some((1.0 / value) as f32);
            d
        }
        Sweep::Tunneling => load(
            &format!(
                r#"name = "tunneling"
[[body]]
name = "wall"
type = "static"
shape = {{ box = [0.02, 1.0] }}
position = [0.0, 0.0]
[[body]]
name = "ball"
shape = {{ circle = 0.05 }}
position = [-1.0, 0.0]
velocity = [{value}, 0.0]
"#
            ),
            "extremes:tunneling",
        ),
        Sweep::StackHeight => load(&stack_text(value as u32, 0.0), "extremes:stack_height"),
        Sweep::Distance => load(&stack_text(5, value), "extremes:distance"),
        Sweep::Span => load(
            &format!(
                "{}[[body]]\nname = \"marker\"\ntype = \"static\"\nshape = {{ box = [1.0, 1.0] }}\nposition = [{m}, {n}]\n",
                stack_text(5, 0.0),
                m = 2.0 * value,
                n = 2.0 * value - 10.0
            ),
            "extremes:span",
        ),
        Sweep::Iterations => match scene::load("pyramid") {
            Ok(s) => s.world,
            Err(e) => panic!("built-in pyramid: {e}"),
        },
        Sweep::Friction => {
            let (c, s) = (RAMP_ANGLE.cos(), RAMP_ANGLE.sin());
            // the box sits on the ramp's top face, 2.5 m up-slope of its centre
            let (bx, by) = (2.5 * c - 0.5 * s, 2.0 + 2.5 * s + 0.5 * c);
            load(
                &format!(
                    r#"name = "ramp"
[world]
gravity = [0.0, -10.0]
[[body]]
name = "ramp"
type = "static"
shape = {{ box = [8.0, 0.5] }}
position = [0.0, 2.0]
angle = {RAMP_ANGLE}
friction = {value}
[[body]]
name = "box"
shape = {{ box = [0.5, 0.5] }}
position = [{bx}, {by}]
angle = {RAMP_ANGLE}
friction = {value}
"#
                ),
                "extremes:friction",
            )
        }
        Sweep::Restitution => load(
            &format!(
                r#"name = "bounce"
[world]
gravity = [0.0, -10.0]
[[body]]
name = "pad"
type = "static"
shape = {{ box = [2.0, 0.5] }}
position = [0.0, -0.25]
restitution = {value}
[[body]]
name = "ball"
shape = {{ circle = 0.25 }}
position = [0.0, {y}]
restitution = {value}
"#,
                y = 0.25 + DROP
            ),
            "extremes:restitution",
        ),
    }
}

/// The ramp's tilt (rad): 25 degrees.
const RAMP_ANGLE: f64 = 0.436_332_312_998_582_4;
/// The restitution drop height (m).
const DROP: f64 = 2.0;

/// Steps a world, calling `each(world, k)` after step k (from 1); stops at the first
/// `Err` it returns. A non-finite state becomes a failed result.
fn drive(
    world: &mut World,
    steps: u64,
    mut each: impl FnMut(&World, u64) -> Result<(), String>,
) -> Result<(), CaseResult> {
    for k in 1..=steps {
        match world.step() {
            Ok(()) => {}
            Err(e) => {
                return Err(CaseResult::Failed(format!(
                    "unstable: non-finite at step {k}: {e}"
                )));
            }
        }
        each(world, k).map_err(CaseResult::Failed)?;
    }
    Ok(())
}

fn top_index(world: &World) -> usize {
    super::tracked_body(world, &super::Track::Top).unwrap_or(0)
}

/// Runs one case: the sweep's scene at `value` with `setting`, checked against its bound.
pub fn check(sweep: Sweep, value: f64, setting: &Setting) -> CaseResult {
    let mut setting = *setting;
    if sweep == Sweep::Iterations {
        setting.iterations = value as u32;
    }
    let def = world_def(sweep, value);
    let mut world = match World::from_def(&def, setting.resolve(&def.solver)) {
        Ok(w) => w,
        Err(e) => return CaseResult::Failed(format!("build: {e}")),
    };
    match run_case(sweep, value, &mut world) {
        Ok(detail) => CaseResult::Held(detail),
        Err(r) => r,
    }
}

/// Steps for `seconds` of simulated time.
fn steps_for(world: &World, seconds: f64) -> u64 {
    (seconds / world.settings.dt as f64).round() as u64
}

/// A stack-like run: the top body may move at most `tol` (m) (else it fell: unstable),
/// and overlap stays below [`MAX_PENETRATION`] (else inaccurate), each by [`MARGIN`]
/// (else marginal); returns (top movement, deepest overlap).
fn standing(world: &mut World, seconds: f64, tol: f32) -> Result<(f32, f32), CaseResult> {
    let top = top_index(world);
    let p0 = world.bodies[top].position;
    let mut deepest = 0.0f32;
    let mut first_deep: Option<u64> = None;
    let steps = steps_for(world, seconds);
    drive(world, steps, |w, k| {
        let pen = w.stats().penetration;
        deepest = deepest.max(pen);
        if standing_of(pen as f64, MAX_PENETRATION as f64) == Standing::Beyond
            && first_deep.is_none()
        {
            first_deep = Some(k);
        }
        Ok(())
    })?;
    let moved = (world.bodies[top].position - p0).length();
    let top_standing = standing_of(moved as f64, tol as f64);
    if top_standing == Standing::Beyond {
        return Err(CaseResult::Failed(format!(
            "unstable: top body moved {moved:.3} m (> {tol:.3} m)"
        )));
    }
    if let Some(k) = first_deep {
        return Err(CaseResult::Failed(format!(
            "inaccurate: overlap {deepest:.3} m > {MAX_PENETRATION} m (from step {k}), top moved {moved:.3} m"
        )));
    }
    if top_standing == Standing::Marginal {
        return Err(marginal("top body moved", moved as f64, tol as f64));
    }
    if standing_of(deepest as f64, MAX_PENETRATION as f64) == Standing::Marginal {
        return Err(marginal("overlap", deepest as f64, MAX_PENETRATION as f64));
    }
    Ok((moved, deepest))
}

fn run_case(sweep: Sweep, value: f64, world: &mut World) -> Result<String, CaseResult> {
    match sweep {
        Sweep::MassRatio => {
            let (moved, pen) = standing(world, 3.0, 0.1)?;
            Ok(format!("heavy box moved {moved:.4} m, overlap {pen:.4} m"))
        }
        Sweep::MassRatioChain => {
            let steps = steps_for(world, 3.0);
            let mut worst: Option<f32> = None;
            drive(world, steps, |w, k| {
                if let Some(e) = joint_error(w) {
                    worst = Some(worst.unwrap_or(0.0).max(e));
                    if standing_of(e as f64, 0.05) == Standing::Beyond {
                        return Err(format!(
                            "inaccurate: joint separation {e:.3} m > 0.05 m at step {k}"
                        ));
                    }
                }
                Ok(())
            })?;
            match worst {
                Some(e) if standing_of(e as f64, 0.05) == Standing::Marginal => {
                    Err(marginal("joint separation", e as f64, 0.05))
                }
                Some(e) => Ok(format!("joint separation {e:.4} m")),
                None => Ok("finite (joint error not measured in this build)".into()),
            }
        }
        Sweep::TimeStep => {
            let (moved, pen) = standing(world, 3.0, 0.15)?;
            Ok(format!("top moved {moved:.4} m, overlap {pen:.4} m"))
        }
        Sweep::StackHeight => {
            let (moved, pen) = standing(world, 4.0, 0.1 + value as f32 * SLOP)?;
            Ok(format!("top moved {moved:.4} m, overlap {pen:.4} m"))
        }
        Sweep::Iterations => {
            let (moved, pen) = standing(world, 5.0, 0.2)?;
            Ok(format!("top moved {moved:.4} m, overlap {pen:.4} m"))
        }
        Sweep::Distance | Sweep::Span => {
            let (moved, pen) = standing(world, 3.0, 0.1 + 5.0 * SLOP)?;
            let fastest = world
                .bodies
                .iter()
                .map(|b| b.velocity.length())
                .fold(0.0f32, f32::max);
            match standing_of(fastest as f64, 0.05) {
                Standing::Beyond => {
                    return Err(CaseResult::Failed(format!(
                        "unstable: not at rest, a box ends at {fastest:.3} m/s"
                    )));
                }
                Standing::Marginal => {
                    return Err(CaseResult::Marginal(format!(
                        "marginal: a box ends at {fastest:.3} m/s, within {:.0}% of the 0.05 m/s bound",
                        MARGIN * 100.0
                    )));
                }
                Standing::Clear => {}
            }
            Ok(format!(
                "top moved {moved:.4} m, overlap {pen:.4} m, fastest {fastest:.4} m/s"
            ))
        }
        Sweep::Tunneling => {
            let ball = world.body_index("ball").unwrap_or(1);
            let steps = steps_for(world, 1.0 / value + 0.5);
            let face = -0.01f32;
            // the centre stops a radius (0.05 m) short of the face; it holds while it
            // stays short of the face by more than MARGIN of a radius
            let radius = 0.05f64;
            let mut furthest = f32::NEG_INFINITY;
            drive(world, steps, |w, k| {
                let x = w.bodies[ball].position.x;
                furthest = furthest.max(x);
                if x > face {
                    return Err(format!(
                        "tunnelled: its centre passed the wall's face at step {k} (x = {x:.3} m)"
                    ));
                }
                Ok(())
            })?;
            if ((face - furthest) as f64) < MARGIN * radius {
                return Err(CaseResult::Marginal(format!(
                    "marginal: its centre came to {furthest:.4} m, within {:.0}% of a radius of the face",
                    MARGIN * 100.0
                )));
            }
            Ok(format!(
                "stopped at x = {:.4} m (face at -0.01)",
                world.bodies[ball].position.x
            ))
        }
        Sweep::Friction => {
            let bx = world.body_index("box").unwrap_or(1);
            let p0 = world.bodies[bx].position;
            let steps = steps_for(world, 1.0);
            drive(world, steps, |_, _| Ok(()))?;
            let down = Vec2::new(-(RAMP_ANGLE.cos() as f32), -(RAMP_ANGLE.sin() as f32));
            let slid = (world.bodies[bx].position - p0).dot(down) as f64;
            // semi-implicit Euler from rest: s_n = a h^2 n (n + 1) / 2,
            // a = g (sin theta - mu cos theta) when mu < tan theta, else 0
            let g = 10.0f64;
            let a = (g * (RAMP_ANGLE.sin() - value * RAMP_ANGLE.cos())).max(0.0);
            let h = world.settings.dt as f64;
            let n = steps as f64;
            let exact = a * h * h * n * (n + 1.0) / 2.0;
            let tol = 0.02 + 0.05 * exact;
            grade(
                (slid - exact).abs(),
                tol,
                || {
                    format!(
                        "inaccurate: slid {slid:.3} m, closed form {exact:.3} m (tolerance {tol:.3} m)"
                    )
                },
                || format!("slid {slid:.3} m, closed form {exact:.3} m: error"),
            )?;
            Ok(format!("slid {slid:.4} m, closed form {exact:.4} m"))
        }
        Sweep::Restitution => {
            let ball = world.body_index("ball").unwrap_or(1);
            let steps = steps_for(world, 2.5);
            // phase 0: falling, 1: rising after the first bounce, 2: past its apex
            let (mut phase, mut peak) = (0u8, 0.0f64);
            drive(world, steps, |w, _| {
                let b = &w.bodies[ball];
                let y = b.position.y as f64 - 0.25;
                match phase {
                    0 if b.velocity.y > 0.0 => (phase, peak) = (1, y),
                    1 if b.velocity.y > 0.0 => peak = peak.max(y),
                    1 => phase = 2,
                    _ => {}
                }
                Ok(())
            })?;
            let expect = value * value * DROP;
            grade(
                (peak - expect).abs(),
                0.1,
                || format!("inaccurate: bounced to {peak:.3} m, e^2 h = {expect:.3} m"),
                || format!("bounced to {peak:.3} m, e^2 h = {expect:.3} m: error"),
            )?;
            Ok(format!("bounced to {peak:.4} m, e^2 h = {expect:.4} m"))
        }
    }
}

/// The results of one sweep and setting, in value order.
#[derive(Clone, Debug)]
pub struct SweepResult {
    pub sweep: Sweep,
    pub setting: ExSetting,
    pub cases: Vec<(f64, CaseResult)>,
}

impl SweepResult {
    /// (holds through, first failure or marginal value with its reason) along the
    /// values, easy to hard. `None` for holds-through when the first value does not
    /// hold; `None` for the failure when every value held.
    pub fn headline(&self) -> (Option<f64>, Option<(f64, String)>) {
        let mut last = None;
        for (v, r) in &self.cases {
            match r {
                CaseResult::Held(_) => last = Some(*v),
                CaseResult::Failed(why) | CaseResult::Marginal(why) => {
                    return (last, Some((*v, why.clone())));
                }
            }
        }
        (last, None)
    }
}

/// One case of the extremes suite: a sweep's scene at one value with one setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExCase {
    pub sweep: Sweep,
    pub setting: ExSetting,
    pub value: f64,
}

impl ExCase {
    /// `sweep / setting / value`, as the progress bar shows it.
    pub fn label(&self) -> String {
        format!(
            "{} / {} / {}",
            self.sweep.name(),
            self.setting.label,
            self.sweep.format_value(self.value)
        )
    }

    /// Runs the case ([`check`]).
    pub fn run(&self) -> CaseResult {
        let r = check(self.sweep, self.value, &self.setting.setting);
        log::debug!("extremes: {}: {r:?}", self.label());
        r
    }
}

/// The sweeps whose name contains `filter` (all without one), in table order.
pub fn sweeps(filter: Option<&str>) -> Vec<Sweep> {
    Sweep::ALL
        .into_iter()
        .filter(|s| filter.is_none_or(|f| s.name().contains(f)))
        .collect()
}

/// Every case of the sweeps, in run order: by sweep, then setting, then value.
pub fn cases(sweeps: &[Sweep]) -> Vec<ExCase> {
    let mut out = Vec::new();
    for &sweep in sweeps {
        for setting in settings(sweep) {
            for value in sweep.values() {
                out.push(ExCase {
                    sweep,
                    setting,
                    value,
                });
            }
        }
    }
    out
}

/// Groups the results of `cases` (in the order [`cases`] gives, one result each) into
/// one [`SweepResult`] per sweep and setting.
pub fn assemble(cases: &[ExCase], results: Vec<CaseResult>) -> Vec<SweepResult> {
    let mut out: Vec<SweepResult> = Vec::new();
    for (c, r) in cases.iter().zip(results) {
        match out.last_mut() {
            Some(last) if last.sweep == c.sweep && last.setting == c.setting => {
                last.cases.push((c.value, r));
            }
            _ => out.push(SweepResult {
                sweep: c.sweep,
                setting: c.setting,
                cases: vec![(c.value, r)],
            }),
        }
    }
    out
}

/// Runs every sweep at every setting; `progress(done, total, what)` after each case.
pub fn run_all(sweeps: &[Sweep], mut progress: impl FnMut(usize, usize, &str)) -> Vec<SweepResult> {
    let cases = cases(sweeps);
    let total = cases.len();
    let mut results = Vec::with_capacity(total);
    for (i, c) in cases.iter().enumerate() {
        results.push(c.run());
        progress(i + 1, total, &c.label());
    }
    assemble(&cases, results)
}

/// The header of the summary table (tests/extremes.rs reads the rows under it).
pub const TABLE_HEADER: &str = "| sweep | setting | holds through | fails at | how it failed |";

/// stability.md: the summary table, then every case per sweep.
pub fn markdown(results: &[SweepResult]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Stability at the extremes\n\nWritten by `sandbox2d bench --suite extremes`. Each sweep changes one thing, \
         from easy to hard; \"holds through\" is the last value of the leading run that held \
         (stable, and every measure within 90% of its bound), \"fails at\" the next value and how it \
         failed: \"unstable\" or \"inaccurate\" past 110% of a bound, \"marginal\" within 10% \
         of one either way (a verdict any change of arithmetic could flip, so neither is claimed). \
         PGS settings are the defaults (tolerance 1e-4, warm start, split impulse, dt 1/60, slop \
         0.005 m, beta 0.2) but for the sweeps they name; \"no split\" is Baumgarte in the \
         velocity rows. `tests/extremes.rs` \
         re-checks every claim of the table below.\n"
    );
    let _ = writeln!(s, "{TABLE_HEADER}\n|---|---|---|---|---|");
    for r in results {
        let sw = r.sweep;
        let (held, fail) = r.headline();
        let held = held.map_or("none".to_string(), |v| sw.format_value(v));
        let (at, how) = match fail {
            Some((v, why)) => (sw.format_value(v), why),
            None => ("-".to_string(), "held at every value".to_string()),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            sw.name(),
            r.setting.label,
            held,
            at,
            how.replace('|', "/")
        );
    }
    let _ = writeln!(s);
    for sw in Sweep::ALL {
        let rs: Vec<&SweepResult> = results.iter().filter(|r| r.sweep == sw).collect();
        if rs.is_empty() {
            continue;
        }
        let _ = writeln!(s, "## {}\n\n{}.\n", sw.name(), sw.about());
        let _ = write!(s, "| value |");
        for r in &rs {
            let _ = write!(s, " {} |", r.setting.label);
        }
        let _ = writeln!(s);
        let _ = writeln!(s, "|---|{}", "---|".repeat(rs.len()));
        for (i, v) in sw.values().into_iter().enumerate() {
            let _ = write!(s, "| {} |", sw.format_value(v));
            for r in &rs {
                let cell = match r.cases.get(i).map(|c| &c.1) {
                    Some(CaseResult::Held(d)) => format!("held: {d}"),
                    Some(CaseResult::Marginal(d)) => d.clone(),
                    Some(CaseResult::Failed(d)) => format!("**failed**: {d}"),
                    None => String::new(),
                };
                let _ = write!(s, " {} |", cell.replace('|', "/"));
            }
            let _ = writeln!(s);
        }
        let _ = writeln!(s);
    }
    s
}

/// One claim of the summary table: (sweep, setting label, holds through, fails at, how).
#[derive(Clone, Debug, PartialEq)]
pub struct Claim {
    pub sweep: Sweep,
    pub setting: ExSetting,
    pub holds_through: Option<f64>,
    pub fails_at: Option<f64>,
    /// How it failed ("unstable: ...", "marginal: ..."), or "held at every value".
    pub how: String,
}

/// Reads the claims of a stability.md summary table.
pub fn parse_claims(text: &str) -> Result<Vec<Claim>, String> {
    let mut lines = text.lines().skip_while(|l| l.trim() != TABLE_HEADER);
    if lines.next().is_none() {
        return Err("no summary table".into());
    }
    let mut out = Vec::new();
    for line in lines.skip(1) {
        let line = line.trim();
        if !line.starts_with('|') {
            break;
        }
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        if cells.len() < 5 {
            return Err(format!("short row: {line}"));
        }
        let sweep = Sweep::from_name(cells[0]).ok_or_else(|| format!("unknown sweep: {line}"))?;
        let setting = settings(sweep)
            .into_iter()
            .find(|s| s.label == cells[1])
            .ok_or_else(|| format!("unknown setting: {line}"))?;
        let value = |c: &str| -> Result<Option<f64>, String> {
            match c {
                "none" | "-" => Ok(None),
                _ => sweep
                    .parse_value(c)
                    .map(Some)
                    .ok_or_else(|| format!("bad value {c:?}: {line}")),
            }
        };
        out.push(Claim {
            sweep,
            setting,
            holds_through: value(cells[2])?,
            fails_at: value(cells[3])?,
            how: cells[4].to_string(),
        });
    }
    Ok(out)
}

/// One cell of a per-value table: its verdict, as [`CaseResult::kind`] names it
/// (`None`: held), and its text.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub value: f64,
    pub label: String,
    pub kind: Option<String>,
    pub text: String,
}

/// Reads the per-value table of `sweep` from a stability.md: every cell, row by row.
pub fn parse_table(text: &str, sweep: Sweep) -> Result<Vec<Cell>, String> {
    let heading = format!("## {}", sweep.name());
    let mut lines = text
        .lines()
        .skip_while(|l| l.trim() != heading)
        .skip(1)
        .skip_while(|l| !l.trim_start().starts_with("| value |"));
    let header = lines
        .next()
        .ok_or_else(|| format!("no table under {heading}"))?;
    let labels: Vec<&str> = header
        .trim()
        .trim_matches('|')
        .split('|')
        .map(str::trim)
        .skip(1)
        .collect();
    let mut out = Vec::new();
    for line in lines.skip(1) {
        let line = line.trim();
        if !line.starts_with('|') {
            break;
        }
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        let value = sweep
            .parse_value(cells[0])
            .ok_or_else(|| format!("bad value: {line}"))?;
        if cells.len() != labels.len() + 1 {
            return Err(format!("row of {} cells: {line}", cells.len()));
        }
        for (label, cell) in labels.iter().zip(&cells[1..]) {
            let kind = if cell.starts_with("held: ") {
                None
            } else if let Some(rest) = cell.strip_prefix("**failed**: ") {
                Some(rest.split(':').next().unwrap_or("").to_string())
            } else if cell.starts_with("marginal: ") {
                Some("marginal".to_string())
            } else {
                return Err(format!("cell without a verdict: {cell}"));
            };
            out.push(Cell {
                value,
                label: label.to_string(),
                kind,
                text: cell.to_string(),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_value_formats_and_parses_back() {
        for sw in Sweep::ALL {
            assert_eq!(Sweep::from_name(sw.name()), Some(sw));
            for v in sw.values() {
                assert_eq!(sw.parse_value(&sw.format_value(v)), Some(v), "{sw:?} {v}");
            }
        }
    }

    #[test]
    fn the_headline_is_the_leading_run_of_holds_and_the_next_failure() {
        let r = SweepResult {
            sweep: Sweep::StackHeight,
            setting: settings(Sweep::StackHeight)[0],
            cases: vec![
                (5.0, CaseResult::Held("a".into())),
                (10.0, CaseResult::Held("b".into())),
                (20.0, CaseResult::Failed("fell".into())),
                (30.0, CaseResult::Held("c".into())),
            ],
        };
        assert_eq!(r.headline(), (Some(10.0), Some((20.0, "fell".into()))));
        let md = markdown(std::slice::from_ref(&r));
        let claims = parse_claims(&md).unwrap();
        assert_eq!(claims.len(), 1);
        assert_eq!(claims[0].holds_through, Some(10.0));
        assert_eq!(claims[0].fails_at, Some(20.0));
        assert_eq!(claims[0].how, "fell");
    }

    #[test]
    fn a_measure_within_the_margin_of_its_bound_is_marginal() {
        // the knife edges stability.md claimed before margins: 0.103 m against 0.100 m,
        // 0.050 against 0.05
        assert_eq!(standing_of(0.103, 0.1), Standing::Marginal);
        assert_eq!(standing_of(0.050, 0.05), Standing::Marginal);
        assert_eq!(standing_of(0.0459, 0.05), Standing::Marginal);
        assert_eq!(standing_of(0.0449, 0.05), Standing::Clear);
        assert_eq!(standing_of(0.111, 0.1), Standing::Beyond);
        assert_eq!(standing_of(f64::NAN, 0.1), Standing::Beyond);
        // a marginal value ends the leading run, and the tables name it
        let r = SweepResult {
            sweep: Sweep::MassRatio,
            setting: settings(Sweep::MassRatio)[0],
            cases: vec![
                (1.0, CaseResult::Held("a".into())),
                (10.0, marginal("top body moved", 0.103, 0.1)),
                (100.0, CaseResult::Held("b".into())),
                (1e3, CaseResult::Failed("unstable: fell".into())),
                (1e4, CaseResult::Failed("inaccurate: deep".into())),
            ],
        };
        let (held, fail) = r.headline();
        assert_eq!(held, Some(1.0));
        let (at, why) = fail.unwrap();
        assert_eq!(at, 10.0);
        assert!(why.starts_with("marginal: "), "{why}");
        let md = markdown(std::slice::from_ref(&r));
        let cells = parse_table(&md, Sweep::MassRatio).unwrap();
        let kinds: Vec<Option<&str>> = cells.iter().map(|c| c.kind.as_deref()).collect();
        assert_eq!(
            kinds,
            [
                None,
                Some("marginal"),
                None,
                Some("unstable"),
                Some("inaccurate")
            ]
        );
        assert_eq!(r.cases[1].1.kind(), Some("marginal"));
        assert_eq!(
            CaseResult::Failed("unstable: fell".into()).kind(),
            Some("unstable")
        );
    }
}
