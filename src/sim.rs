//! Running a world for a number of steps and summarising what it cost and how right it
//! was: the figures `simulate --json` prints and the bench records.

use std::io::Write;
use std::time::Instant;

use crate::world::{StepError, World};

/// Figures of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunSummary {
    pub steps: u64,
    /// Wall time per step (ms): one entry per step for runs of up to
    /// [`MAX_STEP_SAMPLES`] steps; beyond that an even sample of them (every 2nd, 4th,
    /// ... step), so a long run's memory stays bounded.
    pub step_ms: Vec<f64>,
    pub contacts_mean: f64,
    pub contacts_max: usize,
    pub iterations_mean: f64,
    /// Split-impulse (position) sweeps per step, mean.
    pub position_iterations_mean: f64,
    pub residual_mean: f64,
    pub residual_max: f32,
    pub penetration_max: f32,
    pub penetration_mean: f64,
    pub penetration_final: f32,
    pub energy_start: f64,
    pub energy_end: f64,
    /// Largest joint anchor separation over the run, and at the end (m).
    pub joint_error_max: f32,
    pub joint_error_final: f32,
    /// The farthest any dynamic body ended from where it started (m): how far a stack
    /// or a pile moved.
    pub displacement_max: f32,
    /// Mean time per stage (ms): forces, broad phase, narrow phase, solver, integration.
    pub stage_ms: [f64; 5],
}

impl RunSummary {
    /// The median, mean and 95th percentile of the step times (ms).
    pub fn ms_per_step(&self) -> (f64, f64, f64) {
        if self.step_ms.is_empty() {
            return (0.0, 0.0, 0.0);
        }
        let mut v = self.step_ms.clone();
        v.sort_by(f64::total_cmp);
        let pick = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        (
            pick(0.5),
            v.iter().sum::<f64>() / v.len() as f64,
            pick(0.95),
        )
    }
}

/// The most step times a [`RunSummary`] keeps (8 MiB).
pub const MAX_STEP_SAMPLES: usize = 1 << 20;

/// Where and how often to write the trace CSV.
pub struct Trace<'a> {
    pub out: &'a mut dyn Write,
    /// Write every K-th step (and the initial state, step 0).
    pub every: u64,
}

/// A CSV field: quoted (with doubled quotes) when it holds a comma, a quote or a newline.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Writes the CSV header `step,t,id,name,x,y,angle,vx,vy,omega`.
pub fn write_trace_header(out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(out, "step,t,id,name,x,y,angle,vx,vy,omega")
}

/// Writes one row per body of the world's current state.
pub fn write_trace_rows(out: &mut dyn Write, world: &World) -> std::io::Result<()> {
    let step = world.step_count();
    let t = world.time();
    let shifted = world.origin != glam::DVec2::ZERO;
    for (i, b) in world.bodies.iter().enumerate() {
        write!(out, "{step},{t},{i},{},", csv_field(&b.name))?;
        // positions in the file's coordinates: the world's origin added back in f64
        // (an f32 is printed as itself when there is none)
        if shifted {
            let p = world.world_position_index(i);
            write!(out, "{},{}", p.x, p.y)?;
        } else {
            write!(out, "{},{}", b.position.x, b.position.y)?;
        }
        writeln!(
            out,
            ",{},{},{},{}",
            b.angle, b.velocity.x, b.velocity.y, b.angular_velocity
        )?;
    }
    Ok(())
}

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Step(#[from] StepError),
    #[error("writing the trace: {0}")]
    Io(#[from] std::io::Error),
    /// An interrupt ([`crate::output::interrupted`]) stopped the run after `step` steps.
    #[error("interrupted after step {step}")]
    Interrupted { step: u64 },
}

/// Steps `world` `steps` times, timing each step, and sums up the figures;
/// `on_step(k, world)` after step k.
pub fn run(
    world: &mut World,
    steps: u64,
    mut trace: Option<Trace<'_>>,
    mut on_step: impl FnMut(u64, &World),
) -> Result<RunSummary, RunError> {
    let mut s = RunSummary {
        energy_start: world.energy(),
        // grown as the run goes: `steps` is the user's count, not a promise
        step_ms: Vec::new(),
        ..Default::default()
    };
    if let Some(tr) = trace.as_mut() {
        write_trace_header(tr.out)?;
        write_trace_rows(tr.out, world)?;
    }
    let start: Vec<(bool, crate::math::Vec2)> = world
        .bodies
        .iter()
        .map(|b| (b.is_dynamic(), b.position))
        .collect();
    let (mut contacts, mut iters, mut res, mut pen, mut pos_iters) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    // keep every `stride`-th step time; halve the samples when they reach the cap
    let mut stride: u64 = 1;
    for k in 1..=steps {
        if crate::output::interrupted() {
            return Err(RunError::Interrupted { step: k - 1 });
        }
        let t = Instant::now();
        world.step()?;
        if k % stride == 0 {
            s.step_ms.push(t.elapsed().as_secs_f64() * 1e3);
            if s.step_ms.len() >= MAX_STEP_SAMPLES {
                let mut i = 0;
                s.step_ms.retain(|_| {
                    i += 1;
                    i % 2 == 0
                });
                stride *= 2;
            }
        }
        let st = *world.stats();
        contacts += st.contacts as f64;
        s.contacts_max = s.contacts_max.max(st.contacts);
        iters += st.iterations as f64;
        pos_iters += st.position_iterations as f64;
        res += st.residual as f64;
        s.residual_max = s.residual_max.max(st.residual);
        pen += st.penetration as f64;
        s.penetration_max = s.penetration_max.max(st.penetration);
        s.penetration_final = st.penetration;
        s.joint_error_final = world.joint_error();
        s.joint_error_max = s.joint_error_max.max(s.joint_error_final);
        for (acc, v) in s.stage_ms.iter_mut().zip([
            st.ms_forces,
            st.ms_broad,
            st.ms_narrow,
            st.ms_solve,
            st.ms_integrate,
        ]) {
            *acc += v as f64;
        }
        if let Some(tr) = trace.as_mut()
            && k % tr.every.max(1) == 0
        {
            write_trace_rows(tr.out, world)?;
        }
        on_step(k, world);
    }
    let n = steps.max(1) as f64;
    s.steps = steps;
    s.contacts_mean = contacts / n;
    s.iterations_mean = iters / n;
    s.position_iterations_mean = pos_iters / n;
    s.residual_mean = res / n;
    s.penetration_mean = pen / n;
    s.energy_end = world.energy();
    s.displacement_max = world
        .bodies
        .iter()
        .zip(&start)
        .filter(|(_, (dynamic, _))| *dynamic)
        .map(|(b, (_, p))| b.position.distance(*p))
        .fold(0.0, f32::max);
    for v in &mut s.stage_ms {
        *v /= n;
    }
    Ok(s)
}
