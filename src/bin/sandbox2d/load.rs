//! A scene loaded and built into a world under the command line's solver flags, and
//! the saved states and runs a command starts from.

use std::path::Path;

use sandbox2d::scene::{self, Scene};
use sandbox2d::{SolverSettings, World, WorldState};

use crate::args::{SolverFlags, check_flags};
use crate::failure::{Failure, one_line};
use crate::progress::progress;

/// Loads a scene and builds its world with the command line's solver flags applied,
/// with a progress bar for a build that takes more than a couple of seconds.
pub fn build(name: &str, flags: &SolverFlags) -> Result<(Scene, World, SolverSettings), Failure> {
    check_flags(flags)?;
    let spinner = progress(None, "{spinner} loading the scene {elapsed}");
    let sc = scene::load(name).map_err(Failure::input);
    spinner.finish_and_clear();
    let sc = sc?;
    let settings = sc.world.solver.merged(flags.overrides()).resolve();
    let fail = |e: sandbox2d::BuildError| Failure::input(format!("{}: {e}", sc.source));
    if let Some((far, ulp)) = sandbox2d::world::far_from_origin(&sc.world) {
        // said once, before the run: the run itself goes ahead
        eprintln!(
            "note: {}: a body starts {far:.3e} m from the scene's origin, where positions step by {ulp:.1e} m (f32); contacts and joints lose precision beyond about {:.0e} m from it (a scene far from 0 is simulated relative to its own centre: its size counts, not its place; docs/stability.md)",
            one_line(&sc.source),
            sandbox2d::world::FAR_FROM_ORIGIN
        );
    }
    // the scene's own [solver] values were checked at load (with their place): what
    // fails here comes from a flag
    settings
        .check()
        .map_err(|e| Failure::input(format!("command-line flags: solver: {e}")))?;
    // World::from_def, body by body, with progress
    let def = &sc.world;
    let mut world = World::new(def.gravity, settings);
    world.drag = def.drag;
    world.origin = def.origin;
    let bar = progress(
        Some(def.bodies.len() as u64),
        "{bar:40} {pos}/{len} bodies built {elapsed}",
    );
    // World::add_body's duplicate-name check scans every body (quadratic for a million
    // bodies): the names are checked here with a set, then the bodies made as add_body
    // makes them.
    let mut names = std::collections::HashSet::with_capacity(def.bodies.len());
    for (i, b) in def.bodies.iter().enumerate() {
        if !names.insert(b.name.as_str()) {
            return Err(fail(sandbox2d::BuildError::DuplicateName(b.name.clone())));
        }
        world.add_made_body(World::make_body(b, def.gravity).map_err(fail)?, b.awake);
        if i % 1024 == 0 {
            bar.set_position(i as u64);
        }
    }
    bar.finish_and_clear();
    for f in &def.forces {
        world.add_force(f).map_err(fail)?;
    }
    for j in &def.joints {
        world.add_joint(j).map_err(fail)?;
    }
    for m in &def.motions {
        world.add_motion(m).map_err(fail)?;
    }
    for s in &def.spawns {
        world.add_spawn(s).map_err(fail)?;
    }
    Ok((sc, world, settings))
}

/// `simulate --load-state`: reads a saved state, checks that it was saved from this
/// scene, and puts it into `world` (built from the scene). The run keeps its own solver
/// settings (the scene's with this command line's flags); a note says when they differ
/// from the ones the state was saved with, as the run then does not continue the same.
pub fn load_state(
    path: &Path,
    sc: &Scene,
    world: &mut World,
    settings: &SolverSettings,
) -> Result<(), Failure> {
    let name = one_line(&path.display().to_string());
    let bytes = std::fs::read(path)
        .map_err(|e| Failure::input(format!("{name}: cannot read the state: {e}")))?;
    let bad = |e: sandbox2d::StateError| Failure::input(one_line(&format!("{name}: {e}")));
    let state = WorldState::from_json(&bytes).map_err(bad)?;
    state.check_scene(world, false).map_err(|e| {
        Failure::input(one_line(&format!(
            "{name}: {e} (the scene is {})",
            sc.source
        )))
    })?;
    world.restore(&state).map_err(bad)?;
    settings_note(&name, &state.settings, settings);
    world.settings = *settings;
    Ok(())
}

/// Says on stderr when a saved state or run had other solver settings than the run
/// that goes on from it (it then does not continue bit-identically).
pub fn settings_note(name: &str, saved: &SolverSettings, now: &SolverSettings) {
    if saved == now {
        return;
    }
    let brief = |s: &SolverSettings| {
        format!(
            "{} dt={} substeps={} iterations={}",
            s.kind.name(),
            s.dt,
            s.substeps,
            s.iterations
        )
    };
    eprintln!(
        "note: {} was saved with other solver settings ({}) than this run's ({}): the run goes on with this run's and will not continue bit-identically",
        one_line(name),
        brief(saved),
        brief(now)
    );
}

/// `--run`: reads a saved run and checks that it was saved from this scene (`world`,
/// built from it). Returns the file's name as messages show it and the run.
pub fn load_run(
    path: &Path,
    sc: &Scene,
    world: &World,
) -> Result<(String, sandbox2d::timeline::SavedRun), Failure> {
    let name = one_line(&path.display().to_string());
    let bytes = std::fs::read(path)
        .map_err(|e| Failure::input(format!("{name}: cannot read the run: {e}")))?;
    let run = sandbox2d::timeline::SavedRun::from_json(&bytes)
        .map_err(|e| Failure::input(one_line(&format!("{name}: {e}"))))?;
    run.keyframes[0]
        .state
        .check_scene(world, false)
        .map_err(|e| {
            Failure::input(one_line(&format!(
                "{name}: {e} (the scene is {})",
                sc.source
            )))
        })?;
    Ok((name, run))
}

/// A saved run that could not give a step: a step outside it is the input's fault (2),
/// a failed step the run's (1).
pub fn run_file_failure(path: &Path, e: sandbox2d::timeline::RunFileError) -> Failure {
    let m = one_line(&format!("{}: {e}", path.display()));
    match e {
        sandbox2d::timeline::RunFileError::Step(_) => Failure::run(m),
        _ => Failure::input(m),
    }
}

/// `--from-step K`: the world at step K, of the saved run `run` (stepped again under
/// its own settings) or of the scene run K steps under `flags` (the trunk every pane
/// branches from).
#[cfg(feature = "render")]
pub fn start_state(
    scene: &str,
    run: Option<&Path>,
    k: u64,
    flags: &SolverFlags,
) -> Result<WorldState, Failure> {
    let (sc, mut world, _) = build(scene, flags)?;
    if let Some(p) = run {
        let (_, saved) = load_run(p, &sc, &world)?;
        let at = saved.world_at(k).map_err(|e| run_file_failure(p, e))?;
        return Ok(at.snapshot());
    }
    for _ in 0..k {
        world
            .step()
            .map_err(|e| Failure::run(format!("{}: {e}", sc.source)))?;
    }
    Ok(world.snapshot())
}
