//! Joints under both solvers, against closed forms and bounds.

use glam::Vec2;
use sandbox2d::scene::load_str;
use sandbox2d::{SolverKind, SolverSettings, World};

fn world(toml: &str, kind: SolverKind) -> World {
    let sc = load_str(toml, "test.toml").expect("scene parses");
    let s = sc.world.solver.merged(Default::default());
    let mut settings = sandbox2d::SolverOverrides { kind: Some(kind), ..s }.resolve();
    settings.kind = kind;
    World::from_def(&sc.world, settings).expect("builds")
}

/// A uniform disc of radius r, mass m, on a hinge at distance L above its centre.
fn pendulum_scene(theta0: f32, joint: &str) -> String {
    let (l, r) = (1.0f32, 0.1f32);
    let (x, y) = (l * theta0.sin(), 2.0 - l * theta0.cos());
    format!(
        r#"name = "pendulum"
[world]
gravity = [0.0, -9.81]
[[body]]
name = "pivot"
type = "static"
shape = {{ circle = 0.05 }}
position = [0.0, 2.0]
[[body]]
name = "bob"
shape = {{ circle = {r} }}
position = [{x}, {y}]
angle = {theta0}
density = 100.0
[[joint]]
type = "{joint}"
bodies = ["pivot", "bob"]
{anchor}
"#,
        anchor = if joint == "hinge" {
            "anchor = [0.0, 2.0]".to_string()
        } else {
            format!("anchors = [[0.0, 2.0], [{x}, {y}]]")
        }
    )
}

/// Angle of the bob from straight down, about the pivot.
fn swing(w: &World) -> f32 {
    let d = w.bodies[1].position - Vec2::new(0.0, 2.0);
    d.x.atan2(-d.y)
}

/// Period from the times of upward zero crossings (linear interpolation).
fn measure_period(w: &mut World, seconds: f32) -> f32 {
    let dt = w.settings.dt;
    let mut crossings = Vec::new();
    let mut prev = swing(w);
    let steps = (seconds / dt) as usize;
    for k in 1..=steps {
        w.step().unwrap();
        let now = swing(w);
        if prev < 0.0 && now >= 0.0 {
            let frac = prev / (prev - now);
            crossings.push((k as f32 - 1.0 + frac) * dt);
        }
        prev = now;
    }
    assert!(crossings.len() >= 3, "too few periods: {crossings:?}");
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f32
}

fn pendulum_period_closed_form() -> f32 {
    // T = 2 pi sqrt((I + m L^2) / (m g L)), I = m r^2 / 2
    let (l, r, g) = (1.0f32, 0.1f32, 9.81f32);
    let i_over_m = 0.5 * r * r;
    std::f32::consts::TAU * ((i_over_m + l * l) / (g * l)).sqrt()
}

#[test]
fn pendulum_period_matches_closed_form() {
    let t = pendulum_period_closed_form();
    for (kind, tol) in [(SolverKind::Xpbd, 0.005), (SolverKind::Pgs, 0.02)] {
        let mut w = world(&pendulum_scene(0.05, "hinge"), kind);
        let p = measure_period(&mut w, 12.0);
        let err = (p - t).abs() / t;
        eprintln!("{kind:?}: period {p:.5} s vs {t:.5} s, error {:.3}%", err * 100.0);
        assert!(err < tol, "{kind:?}: period {p} vs {t}");
    }
}

#[test]
fn pendulum_keeps_its_amplitude() {
    for kind in [SolverKind::Xpbd, SolverKind::Pgs] {
        let mut w = world(&pendulum_scene(0.5, "distance"), kind);
        let steps = (20.0 / w.settings.dt) as usize;
        let (mut first, mut last) = (0.0f32, 0.0f32);
        let period_steps = (pendulum_period_closed_form() / w.settings.dt) as usize;
        for k in 0..steps {
            w.step().unwrap();
            let a = swing(&w).abs();
            if k < period_steps {
                first = first.max(a);
            }
            if k >= steps - period_steps {
                last = last.max(a);
            }
        }
        eprintln!("{kind:?}: amplitude {first:.5} -> {last:.5} ({:.2}%)", 100.0 * last / first);
        if kind == SolverKind::Xpbd {
            assert!(last >= 0.99 * first, "XPBD lost amplitude: {first} -> {last}");
        }
    }
}
