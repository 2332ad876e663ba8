//! `sandbox2d simulate`: a scene run headless; its figures printed (or one JSON
//! object), with the trace, events, saved state and saved run it asks for.

use std::io::Write;
use std::path::Path;

use serde::Serialize;

use sandbox2d::output::{self, AtomicFile};
use sandbox2d::sim::{self, Trace};
use sandbox2d::{SolverKind, SolverSettings};

use crate::args::SimulateArgs;
use crate::failure::{self, Failure, one_line, run_failure};
use crate::load::{build, load_run, load_state, run_file_failure, settings_note};
use crate::paths::{check_distinct, scene_file};
use crate::progress::progress;

// `simulate --json`. The keys stand in the order the object has always had them, by
// name (as a JSON map sorts them), so each struct's fields are declared by name; f32
// figures are printed as the f64 they widen to, as they always were.

/// The run's figures.
#[derive(Serialize)]
struct Figures<'a> {
    bodies: usize,
    contacts: MaxMean<usize>,
    displacement: Max,
    energy: EndStart,
    events: Option<EventCounts>,
    iterations: Iterations,
    joint_error: FinalMax,
    ms_per_step: Timing,
    penetration: FinalMax,
    residual: MaxMean<f64>,
    scene: &'a str,
    solver: Solver,
    source: &'a str,
    stage_ms: StageMs,
    state_hash: &'a str,
    steps: u64,
    /// Threads the steps could use, and whether they did (a small world runs on one);
    /// with threads, also the ns a cache line took from one core to another and back
    /// just before the run: a virtual machine's cores may share a cache or not, and two
    /// threads' figures depend on which.
    threads: ThreadFigures,
}

#[derive(Serialize)]
struct MaxMean<T> {
    max: T,
    mean: f64,
}

#[derive(Serialize)]
struct Max {
    max: f64,
}

#[derive(Serialize)]
struct EndStart {
    end: f64,
    start: f64,
}

/// Contact and sensor events counted over the run.
#[derive(Serialize)]
struct EventCounts {
    begin: u64,
    end: u64,
    sensor_begin: u64,
    sensor_end: u64,
}

#[derive(Serialize)]
struct Iterations {
    mean: f64,
    position_mean: f64,
}

/// The largest over the run and the one after its last step.
#[derive(Serialize)]
struct FinalMax {
    #[serde(rename = "final")]
    last: f64,
    max: f64,
}

/// Milliseconds per step.
#[derive(Serialize)]
struct Timing {
    mean: f64,
    median: f64,
    p95: f64,
}

/// Mean milliseconds per step in each stage.
#[derive(Serialize)]
struct StageMs {
    broad_phase: f64,
    forces: f64,
    integrate: f64,
    narrow_phase: f64,
    solver: f64,
}

#[derive(Serialize)]
struct ThreadFigures {
    adaptive: bool,
    allowed: usize,
    core_round_trip_ns: Option<f64>,
    parallel_jobs: u64,
    steps_on_many: u64,
    steps_on_one: u64,
    switches: u32,
}

/// The solver settings the run used.
#[derive(Serialize)]
struct Solver {
    baumgarte: f64,
    block_solve: bool,
    contact_damping_ratio: f64,
    contact_hertz: f64,
    dt: f64,
    iterations: u32,
    joint_damping_ratio: f64,
    joint_hertz: f64,
    kind: &'static str,
    max_push_speed: f64,
    restitution_threshold: f64,
    sleep: bool,
    slop: f64,
    split_impulse: bool,
    substeps: u32,
    tolerance: f64,
    warm_start: bool,
}

impl Solver {
    fn of(s: &SolverSettings) -> Solver {
        Solver {
            baumgarte: s.baumgarte.into(),
            block_solve: s.block_solve,
            contact_damping_ratio: s.contact_damping_ratio.into(),
            contact_hertz: s.contact_hertz.into(),
            dt: s.dt.into(),
            iterations: s.iterations,
            joint_damping_ratio: s.joint_damping_ratio.into(),
            joint_hertz: s.joint_hertz.into(),
            kind: s.kind.name(),
            max_push_speed: s.max_push_speed.into(),
            restitution_threshold: s.restitution_threshold.into(),
            sleep: s.sleep,
            slop: s.slop.into(),
            split_impulse: s.split_impulse,
            substeps: s.substeps,
            tolerance: s.tolerance.into(),
            warm_start: s.warm_start,
        }
    }
}

pub fn simulate(a: &SimulateArgs) -> Result<(), Failure> {
    if a.steps == 0 {
        return Err(Failure::input("--steps must be at least 1"));
    }
    if a.trace_every == 0 {
        return Err(Failure::input("--trace-every must be at least 1"));
    }
    if a.keyframes_every == 0 {
        return Err(Failure::input("--keyframes-every must be at least 1"));
    }
    {
        let file = scene_file(&a.scene);
        let mut inputs: Vec<(&str, &Path)> =
            file.iter().map(|f| ("scene file", f.as_path())).collect();
        let outputs: Vec<(&str, &Path)> = [
            ("--trace", &a.trace),
            ("--events", &a.events),
            ("--save-state", &a.save_state),
            ("--save-run", &a.save_run),
        ]
        .into_iter()
        .filter_map(|(what, p)| Some((what, p.as_deref()?)))
        .collect();
        // the run and the state are read before the run starts, so --save-run may name
        // the run and --save-state the state
        for (what, read, written) in [
            ("--run", &a.run, &a.save_run),
            ("--load-state", &a.load_state, &a.save_state),
        ] {
            if let Some(p) = read
                && !written.as_deref().is_some_and(|q| output::same_file(p, q))
            {
                inputs.push((what, p));
            }
        }
        check_distinct(&outputs, &inputs)?;
    }
    let (sc, mut world, settings) = build(&a.scene, &a.solver)?;
    if let Some(p) = &a.load_state {
        load_state(p, &sc, &mut world, &settings)?;
    }
    if let (Some(p), Some(k)) = (&a.run, a.from_step) {
        let at = load_run(p, &sc, &world)?
            .1
            .world_at(k)
            .map_err(|e| run_file_failure(p, e))?;
        let state = at.snapshot();
        world
            .restore(&state)
            .map_err(|e| Failure::run(format!("{}: {e}", p.display())))?;
        settings_note(&p.display().to_string(), &state.settings, &settings);
        world.settings = settings;
    }
    if a.events.is_some() {
        world.record_events = true;
    }
    // with threads, how dear a hand-off between the cores is just before the run (the
    // world's workers start at its first step, so none is in the way; and before any
    // output file is opened, so none waits on it)
    let round_trip = (world.threads() > 1)
        .then(sandbox2d::threads::core_round_trip_ns)
        .flatten();
    // from here an interrupt stops the run cleanly (before the trace exists, so that no
    // interrupt can leave its temporary file behind)
    failure::graceful();
    // the trace goes to a temporary file, renamed once the run is complete
    let mut trace_file = match &a.trace {
        Some(p) => Some(AtomicFile::create(p).map_err(Failure::input)?),
        None => None,
    };
    let bar = progress(Some(a.steps), "{bar:40} {pos}/{len} steps {elapsed}");
    let mut events_file = match &a.events {
        Some(p) => {
            let mut f = AtomicFile::create(p).map_err(Failure::input)?;
            writeln!(f, "step,kind,a,b,impulse")
                .map_err(|e| Failure::run(format!("{}: cannot write: {e}", p.display())))?;
            Some(f)
        }
        None => None,
    };
    // created now, so a path that cannot be written is refused before the run
    let mut state_file = match &a.save_state {
        Some(p) => Some(AtomicFile::create(p).map_err(Failure::input)?),
        None => None,
    };
    let mut run_file = match &a.save_run {
        Some(p) => Some(AtomicFile::create(p).map_err(Failure::input)?),
        None => None,
    };
    let mut saved_run = a
        .save_run
        .as_ref()
        .map(|_| sandbox2d::timeline::SavedRun::start(&sc.source, &world, a.keyframes_every));
    let mut event_counts = [0u64; 4];
    let mut events_error: Option<std::io::Error> = None;
    let trace = trace_file.as_mut().map(|f| Trace {
        out: f as &mut dyn Write,
        every: a.trace_every,
    });
    let result = sim::run(&mut world, a.steps, trace, |k, w| {
        if k % 16 == 0 {
            bar.set_position(k);
        }
        if let Some(r) = saved_run.as_mut() {
            r.record(w);
        }
        for e in w.events() {
            event_counts[e.kind as usize] += 1;
            // the step's own events: their bodies are there until a removal
            let name = |key| w.body(key).map_or("", |b| b.name.as_str());
            if let (Some(f), None) = (events_file.as_mut(), &events_error)
                && let Err(err) = writeln!(
                    f,
                    "{k},{},{},{},{}",
                    e.kind.name(),
                    sim::csv_field(name(e.a)),
                    sim::csv_field(name(e.b)),
                    e.impulse
                )
            {
                events_error = Some(err);
            }
        }
    });
    bar.finish_and_clear();
    let summary = match result {
        Ok(s) => s,
        Err(sim::RunError::Io(e)) => {
            let path = a.trace.as_deref().unwrap_or(Path::new("trace"));
            return Err(Failure::run(format!(
                "{}: cannot write: {e}",
                path.display()
            )));
        }
        Err(e) => {
            let mut f = run_failure(&sc.source, e);
            if let Some(p) = &a.trace {
                f.message += &format!("; {}: not written (the run did not finish)", p.display());
            }
            return Err(f);
        }
    };
    if let Some(f) = trace_file {
        f.commit().map_err(Failure::run)?;
    }
    if let (Some(e), Some(p)) = (events_error, &a.events) {
        return Err(Failure::run(format!("{}: cannot write: {e}", p.display())));
    }
    if let Some(f) = events_file {
        f.commit().map_err(Failure::run)?;
    }
    if let Some(mut f) = state_file.take() {
        let bytes = world
            .snapshot()
            .to_json()
            .map_err(|e| Failure::run(format!("{}: {e}", f.path().display())))?;
        f.write_all(&bytes).map_err(|e| Failure::run(f.error(e)))?;
        f.commit().map_err(Failure::run)?;
    }
    if let (Some(mut f), Some(r)) = (run_file.take(), saved_run.as_ref()) {
        let bytes = r
            .to_json()
            .map_err(|e| Failure::run(format!("{}: {e}", f.path().display())))?;
        f.write_all(&bytes).map_err(|e| Failure::run(f.error(e)))?;
        f.commit().map_err(Failure::run)?;
    }
    let figures = [
        ("energy at the start", summary.energy_start),
        ("energy at the end", summary.energy_end),
        ("mean residual", summary.residual_mean),
        ("largest residual", summary.residual_max as f64),
        ("largest penetration", summary.penetration_max as f64),
        ("largest joint error", summary.joint_error_max as f64),
    ];
    if let Some((what, v)) = figures.iter().find(|(_, v)| !v.is_finite()) {
        // the energy at the end: the body whose term overflowed (at the start, the
        // scene loader has refused such a body)
        let culprit = match world.energy_not_finite() {
            Some((key, why)) if what.starts_with("energy") => {
                // #n: its place in creation order (the scene file's order)
                let (i, (_, b)) = world
                    .bodies()
                    .enumerate()
                    .find(|(_, (k, _))| *k == key)
                    .expect("the key energy_not_finite gives names a body");
                format!(" (body {:?} (#{i}): {why})", one_line(&b.name))
            }
            _ => String::new(),
        };
        return Err(Failure::run(format!(
            "{}: after step {}: the {what} is {v}, not a finite number{culprit}",
            sc.source, summary.steps
        )));
    }
    let (median, mean, p95) = summary.ms_per_step();
    let world_has_no_joints = world.joint_count() == 0;
    let hash = format!("{:016x}", world.state_hash());
    if a.json {
        let used = world.thread_use();
        let figures = Figures {
            bodies: world.body_count(),
            contacts: MaxMean {
                max: summary.contacts_max,
                mean: summary.contacts_mean,
            },
            displacement: Max {
                max: summary.displacement_max.into(),
            },
            energy: EndStart {
                end: summary.energy_end,
                start: summary.energy_start,
            },
            // counted when recorded (--events, or a scene with a sensor); else null
            events: world.record_events.then_some(EventCounts {
                begin: event_counts[0],
                end: event_counts[1],
                sensor_begin: event_counts[2],
                sensor_end: event_counts[3],
            }),
            iterations: Iterations {
                mean: summary.iterations_mean,
                position_mean: summary.position_iterations_mean,
            },
            joint_error: FinalMax {
                last: summary.joint_error_final.into(),
                max: summary.joint_error_max.into(),
            },
            ms_per_step: Timing { mean, median, p95 },
            penetration: FinalMax {
                last: summary.penetration_final.into(),
                max: summary.penetration_max.into(),
            },
            residual: MaxMean {
                max: summary.residual_max.into(),
                mean: summary.residual_mean,
            },
            scene: &sc.name,
            solver: Solver::of(&settings),
            source: &sc.source,
            stage_ms: StageMs {
                broad_phase: summary.stage_ms[1],
                forces: summary.stage_ms[0],
                integrate: summary.stage_ms[4],
                narrow_phase: summary.stage_ms[2],
                solver: summary.stage_ms[3],
            },
            state_hash: &hash,
            steps: summary.steps,
            threads: ThreadFigures {
                adaptive: matches!(world.thread_policy(), sandbox2d::Threads::UpTo(_)),
                allowed: world.threads(),
                core_round_trip_ns: round_trip,
                parallel_jobs: world.parallel_jobs(),
                steps_on_many: used.steps_on_many,
                steps_on_one: used.steps_on_one,
                switches: used.switches,
            },
        };
        let text = serde_json::to_string(&figures)
            .map_err(|e| Failure::run(format!("the figures as JSON: {e}")))?;
        say!("{text}")?;
    } else {
        // quoted with escapes: a name cannot put control characters on the terminal
        say!("scene        {:?} ({})", sc.name, one_line(&sc.source))?;
        say!(
            "solver       {} dt={} substeps={} iterations={} tolerance={} warm_start={} split_impulse={} baumgarte={} slop={}",
            settings.kind.name(),
            settings.dt,
            settings.substeps,
            settings.iterations,
            settings.tolerance,
            settings.warm_start,
            settings.split_impulse,
            settings.baumgarte,
            settings.slop
        )?;
        if settings.kind == SolverKind::Soft {
            say!(
                "soft step    contact_hertz={} contact_damping_ratio={} max_push_speed={} joint_hertz={} joint_damping_ratio={}",
                settings.contact_hertz,
                settings.contact_damping_ratio,
                settings.max_push_speed,
                settings.joint_hertz,
                settings.joint_damping_ratio
            )?;
        }
        let used = world.thread_use();
        say!(
            "steps        {} ({} bodies, {} thread{}{})",
            summary.steps,
            world.body_count(),
            world.threads(),
            if world.threads() == 1 { "" } else { "s" },
            if used.steps_on_one + used.steps_on_many > 0 {
                format!(
                    " allowed: {} steps on them, {} on one",
                    used.steps_on_many, used.steps_on_one
                )
            } else {
                String::new()
            }
        )?;
        say!("ms/step      median {median:.3}  mean {mean:.3}  p95 {p95:.3}")?;
        say!(
            "contacts     mean {:.1}  max {}",
            summary.contacts_mean,
            summary.contacts_max
        )?;
        say!(
            "iterations   mean {:.2}  (position sweeps {:.2})",
            summary.iterations_mean,
            summary.position_iterations_mean
        )?;
        say!(
            "residual     mean {:.3e}  max {:.3e}",
            summary.residual_mean,
            summary.residual_max
        )?;
        say!(
            "penetration  max {:.5} m  final {:.5} m",
            summary.penetration_max,
            summary.penetration_final
        )?;
        say!(
            "energy       start {:.4} J  end {:.4} J",
            summary.energy_start,
            summary.energy_end
        )?;
        say!(
            "displacement max {:.4} m (the farthest a body ended from its start)",
            summary.displacement_max
        )?;
        if !world_has_no_joints {
            say!(
                "joint error  max {:.6} m  final {:.6} m",
                summary.joint_error_max,
                summary.joint_error_final
            )?;
        }
        say!("state hash   {hash}")?;
    }
    Ok(())
}
