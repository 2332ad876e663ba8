//! `sandbox2d render`: a scene's frames headless into PNGs (and a GIF), or with
//! --compare the panes side by side.

use std::path::{Path, PathBuf};

use sandbox2d::World;
use sandbox2d::WorldState;
use sandbox2d::scene::Scene;

use crate::args::{OverlayArg, RenderArgs, SolverFlags, TintArg, pane_label, parse_compare};
use crate::failure::{self, Failure};
use crate::load::{build, start_state};
use crate::paths::{
    check_distinct, check_folder_outputs, frame_it_writes, is_frame_name, scene_file,
};
use crate::progress::progress;

/// The exit code a frame-rendering failure gets: 2 when the input (a size, a path) is
/// at fault, 1 when the run failed.
pub fn frames_failure(e: sandbox2d::render::FramesError) -> Failure {
    use sandbox2d::render::{FramesError, RenderError};
    match &e {
        FramesError::Zero(_)
        | FramesError::OutDir { .. }
        | FramesError::Render(RenderError::InvalidSize { .. }) => Failure::input(e),
        FramesError::Interrupted { written } => {
            let kept = match (written.pngs.first(), written.pngs.last()) {
                (Some(first), Some(last)) => format!(
                    "kept {} complete frame(s), {} .. {}",
                    written.pngs.len(),
                    first.display(),
                    last.display()
                ),
                _ => "kept no frame".to_owned(),
            };
            Failure::interrupted(format!(
                "interrupted after step {}: {kept}; no GIF was written",
                written.steps
            ))
        }
        _ => Failure::run(e),
    }
}

/// Renders `job` of a built world through the scene's camera at `size`.
pub fn render_job(
    sc: &Scene,
    world: &mut World,
    size: [u32; 2],
    job: &sandbox2d::render::FrameJob,
) -> Result<sandbox2d::render::FramesWritten, Failure> {
    let camera = sandbox2d::draw::world::scene_camera(&sc.camera, size, world);
    let mut renderer = sandbox2d::render::Renderer::new_headless().map_err(Failure::run)?;
    let bar = progress(
        Some(job.frames as u64),
        "{bar:40} {pos}/{len} frames {elapsed}",
    );
    failure::graceful();
    let written = sandbox2d::render::render_frames(world, &camera, &mut renderer, job, |k| {
        bar.set_position(k as u64 + 1);
    });
    bar.finish_and_clear();
    written.map_err(|e| match e {
        // the step error names the body and the step
        sandbox2d::render::FramesError::Step { source, .. } => {
            Failure::run(format!("{}: {source}", sc.source))
        }
        e => frames_failure(e),
    })
}

/// Tells where the frames went: one line.
pub fn print_written(
    w: &sandbox2d::render::FramesWritten,
    out: &std::path::Path,
) -> Result<(), Failure> {
    let name = |p: Option<&PathBuf>| {
        p.and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let gif = w
        .gif
        .as_ref()
        .map(|g| format!(" and {}", g.display()))
        .unwrap_or_default();
    say!(
        "wrote {} frames ({} .. {}) to {}{gif}",
        w.pngs.len(),
        name(w.pngs.first()),
        name(w.pngs.last()),
        out.display()
    )?;
    Ok(())
}

pub fn render(a: &RenderArgs) -> Result<(), Failure> {
    if a.frames == 0 {
        return Err(Failure::input("--frames must be at least 1"));
    }
    if a.every == 0 {
        return Err(Failure::input("--every must be at least 1"));
    }
    if let Some(gif) = &a.gif {
        let mut inputs: Vec<(&str, PathBuf)> = vec![("--out folder", a.out.clone())];
        if let Some(file) = scene_file(&a.scene) {
            inputs.push(("scene file", file));
        }
        if let Some(run) = &a.run {
            inputs.push(("--run file", run.clone()));
        }
        // a frame of this run: frame_NNNN.png in --out, for NNNN < --frames
        if let Some(frame) = frame_it_writes(gif, &a.out, a.frames) {
            inputs.push(("frame it writes", frame));
        }
        let inputs: Vec<(&str, &Path)> = inputs.iter().map(|(w, p)| (*w, p.as_path())).collect();
        check_distinct(&[("--gif", gif)], &inputs)?;
        let folder = match gif.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !folder.is_dir() {
            return Err(Failure::input(format!(
                "{}: cannot create: the folder {} does not exist",
                gif.display(),
                folder.display()
            )));
        }
    }
    // a frame it writes must not be the scene file
    if let Some(file) = scene_file(&a.scene) {
        check_folder_outputs(
            "--out",
            &a.out,
            |n| is_frame_name(n, a.frames),
            &[("scene file", &file)],
        )?;
    }
    let start = match a.from_step {
        Some(k) => Some(start_state(&a.scene, a.run.as_deref(), k, &a.solver)?),
        None => None,
    };
    if let Some(st) = &start {
        say!("from step {} (t = {:.3} s)", st.step_count, st.time)?;
    }
    if !a.compare.is_empty() {
        return render_compare(a, start.as_ref());
    }
    let (sc, mut world, settings) = build(&a.scene, &a.solver)?;
    if let Some(st) = &start {
        world
            .restore(st)
            .map_err(|e| Failure::run(format!("{}: {e}", sc.source)))?;
        world.settings = settings;
    }
    let job = frame_job(a)?;
    let written = render_job(&sc, &mut world, a.size.unwrap_or(sc.camera.size), &job)?;
    print_written(&written, &a.out)?;
    Ok(())
}

/// `render`'s output folder, created, and the frames, overlays and GIF it asks for.
fn frame_job(a: &RenderArgs) -> Result<sandbox2d::render::FrameJob, Failure> {
    std::fs::create_dir_all(&a.out).map_err(|e| {
        Failure::input(format!(
            "{}: cannot create the folder: {e}",
            a.out.display()
        ))
    })?;
    let overlays = sandbox2d::draw::Overlays {
        contacts: a.overlays.contains(&OverlayArg::Contacts),
        aabbs: a.overlays.contains(&OverlayArg::Aabbs),
        velocities: a.overlays.contains(&OverlayArg::Velocities),
        tint: match a.tint {
            None => sandbox2d::draw::world::Tint::Off,
            Some(TintArg::Speed) => sandbox2d::draw::world::Tint::Speed,
            Some(TintArg::Error) => sandbox2d::draw::world::Tint::Error,
        },
        ..sandbox2d::draw::Overlays::NONE
    };
    Ok(sandbox2d::render::FrameJob {
        frames: a.frames,
        every: a.every,
        out_dir: a.out.clone(),
        gif: a.gif.clone(),
        overlays,
    })
}

/// The panes of `--compare`: the scene built once per value, its flags over the
/// command line's, labelled with the value (whitespace tidied).
pub fn compare_panes(
    scene: &str,
    values: &[String],
    base: &SolverFlags,
    start: Option<&WorldState>,
) -> Result<(Scene, Vec<sandbox2d::compare::Pane>), Failure> {
    let flags = parse_compare(values)?;
    let mut panes = Vec::with_capacity(flags.len());
    let mut first = None;
    for (v, f) in values.iter().zip(&flags) {
        let (sc, mut world, settings) = build(scene, &f.over(base))?;
        if let Some(st) = start {
            // the pane goes on from the start's world with its own settings
            world
                .restore(st)
                .map_err(|e| Failure::run(format!("{}: {e}", sc.source)))?;
            world.settings = settings;
        }
        panes.push(sandbox2d::compare::Pane::new(pane_label(v), world));
        first.get_or_insert(sc);
    }
    let sc = first.ok_or_else(|| Failure::input("--compare: no pane"))?;
    Ok((sc, panes))
}

/// `render --compare`: the panes side by side, each `--size`'s width / panes wide.
fn render_compare(a: &RenderArgs, start: Option<&WorldState>) -> Result<(), Failure> {
    let (sc, mut panes) = compare_panes(&a.scene, &a.compare, &a.solver, start)?;
    let job = frame_job(a)?;
    let size = a.size.unwrap_or(sc.camera.size);
    let pane_w = sandbox2d::render::compare::pane_width(size[0], panes.len());
    let camera =
        sandbox2d::draw::world::scene_camera(&sc.camera, [pane_w, size[1]], &panes[0].world);
    let mut renderer = sandbox2d::render::Renderer::new_headless().map_err(Failure::run)?;
    let bar = progress(
        Some(job.frames as u64),
        "{bar:40} {pos}/{len} frames {elapsed}",
    );
    failure::graceful();
    let written = sandbox2d::render::compare::render_compare_frames(
        &mut panes,
        &camera,
        &mut renderer,
        &job,
        |k| bar.set_position(k as u64 + 1),
    );
    bar.finish_and_clear();
    let written = written.map_err(|e| match e {
        e @ sandbox2d::render::FramesError::PaneStep { .. } => {
            Failure::run(format!("{}: {e}", sc.source))
        }
        e => frames_failure(e),
    })?;
    print_written(&written, &a.out)?;
    for p in &panes {
        say!(
            "{:<32} mean {:.3} ms/step",
            p.label,
            p.mean_ms().unwrap_or(0.0)
        )?;
    }
    Ok(())
}
