//! The bench's measures: monotone trade-offs, the residual, n/a rows, energy.

use glam::Vec2;
use sandbox2d::bench::{self, Budget, Outcome, Setting, Suite};
use sandbox2d::{BodyDef, BodyType, ShapeDef, SolverSettings, World};

fn scene(name: &str) -> bench::BenchScene {
    bench::scenes::suite(Suite::Standard)
        .into_iter()
        .find(|s| s.name == name)
        .expect("bench scene")
}

fn measured(o: Outcome) -> bench::Measured {
    match o {
        Outcome::Ran(m) => m,
        other => panic!("did not run: {other:?}"),
    }
}

const NO_RESIDUAL: Budget = Budget {
    steps: 300,
    repeats: 1,
    residual_samples: 0,
    reference_iterations: 0,
};

#[test]
fn more_pgs_iterations_never_deepen_the_base_20_pyramids_penetration() {
    let sc = scene("pyramid20");
    for (warm, split) in [(true, true), (false, false)] {
        let mut last: Option<(u32, f64)> = None;
        for n in bench::GRID_COUNTS {
            let m = measured(bench::run_case(
                &sc,
                &Setting::pgs(n, warm, split),
                &NO_RESIDUAL,
            ));
            if let Some((k, p)) = last {
                assert!(
                    m.penetration_max <= p,
                    "warm {warm} split {split}: {n} sweeps overlap {} m, deeper than {k} sweeps' {p} m",
                    m.penetration_max
                );
            }
            last = Some((n, m.penetration_max));
        }
        // and the deepest overlap at 32 sweeps is a few slops at most
        assert!(last.unwrap().1 < 4.0 * 0.005, "{last:?}");
    }
}

#[test]
fn more_xpbd_substeps_never_worsen_the_pendulums_energy_drift() {
    let sc = scene("pendulum");
    let budget = Budget {
        steps: 600,
        ..NO_RESIDUAL
    };
    let mut last: Option<(u32, f64)> = None;
    for n in bench::GRID_COUNTS {
        let m = measured(bench::run_case(&sc, &Setting::xpbd(n), &budget));
        let drift = m.energy_drift.abs();
        assert!(drift.is_finite());
        if let Some((k, d)) = last {
            assert!(
                drift <= d,
                "{n} substeps drift {drift}, worse than {k} substeps' {d}"
            );
        }
        last = Some((n, drift));
    }
    // 32 substeps of 1/1920 s: the pendulum keeps its energy within 1%
    assert!(last.unwrap().1 < 0.01, "{last:?}");
}

#[test]
fn the_residual_falls_with_sweeps_and_vanishes_for_the_reference_itself() {
    let sc = scene("pyramid20");
    let budget = Budget {
        steps: 60,
        repeats: 1,
        residual_samples: 3,
        reference_iterations: 200,
    };
    let one = measured(bench::run_case(&sc, &Setting::pgs(1, true, true), &budget));
    let many = measured(bench::run_case(&sc, &Setting::pgs(32, true, true), &budget));
    assert!(one.residual > 0.1, "{}", one.residual);
    assert!(
        many.residual < one.residual / 10.0,
        "{} vs {}",
        many.residual,
        one.residual
    );
    // the reference setting against itself: the same sweeps from the same state
    let same = measured(bench::run_case(
        &sc,
        &Setting::pgs(200, true, true),
        &budget,
    ));
    assert!(same.residual < 1e-6, "{}", same.residual);
}

#[test]
fn a_resting_box_s_converged_lambdas_carry_its_weight() {
    // sum of normal lambdas (impulses) per step = m g dt for a box at rest
    let mut s = SolverSettings::pgs();
    s.iterations = 200;
    s.tolerance = 0.0;
    s.sleep = false;
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), s);
    w.add_body(&BodyDef {
        name: "ground".into(),
        body_type: BodyType::Static,
        shape: ShapeDef::Box {
            width: 10.0,
            height: 1.0,
        },
        position: Vec2::new(0.0, -0.5),
        ..Default::default()
    })
    .unwrap();
    w.add_body(&BodyDef {
        name: "box".into(),
        shape: ShapeDef::Box {
            width: 1.0,
            height: 1.0,
        },
        density: 2.0,
        position: Vec2::new(0.0, 0.5),
        ..Default::default()
    })
    .unwrap();
    for _ in 0..60 {
        w.step().unwrap();
    }
    let mut lam = Vec::new();
    w.contact_lambdas(&mut lam);
    assert_eq!(lam.len(), 4, "two points, normal and friction each");
    let normal: f32 = lam.iter().step_by(2).sum();
    let weight_impulse = 2.0 * 10.0 / 60.0;
    assert!(
        (normal - weight_impulse).abs() < 1e-3 * weight_impulse,
        "{normal} vs {weight_impulse}"
    );
    // and a clone steps to the same state, bit for bit
    let mut c = w.clone();
    w.step().unwrap();
    c.step().unwrap();
    assert_eq!(w.state_hash(), c.state_hash());
}

#[test]
fn both_solvers_run_stacks_and_joints_and_a_build_failure_is_na() {
    let sc = scene("pyramid20");
    let budget = Budget {
        steps: 5,
        ..NO_RESIDUAL
    };
    // XPBD on the pyramid: 5 steps from rest, stable, no box deeper than the suite's
    // overlap bound, and the tracked top box moved no further than a free fall of 5
    // steps (1/2 g t^2 = 0.035 m).
    let xpbd = measured(bench::run_case(&sc, &Setting::xpbd(4), &budget));
    assert_eq!(xpbd.steps, 5);
    assert!(xpbd.verdict.is_stable(), "{xpbd:?}");
    assert!(
        (0.0..0.05).contains(&xpbd.penetration_max),
        "{}",
        xpbd.penetration_max
    );
    let t = 5.0 / 60.0;
    assert!(xpbd.drift <= 0.5 * 10.0 * t * t, "{}", xpbd.drift);
    // PGS on the distance-joint pendulum: the joint holds and the energy is kept
    let pendulum = scene("pendulum");
    let row = measured(bench::run_case(
        &pendulum,
        &Setting::pgs(4, true, true),
        &budget,
    ));
    assert_eq!(row.steps, 5);
    assert!(row.verdict.is_stable(), "{row:?}");
    assert!(row.joint_error < 0.01, "{}", row.joint_error);
    assert!(row.energy_drift.abs() < 0.01, "{}", row.energy_drift);
    let csv = bench::report::csv(&[bench::Row {
        scene: "pendulum".into(),
        setting: Setting::xpbd(4),
        outcome: Outcome::Failed("no such body".into()),
    }]);
    assert!(csv.lines().nth(1).unwrap().contains(",n/a (build failed),"));
}

#[test]
fn energy_is_kinetic_plus_potential_above_the_floor() {
    // E = m g h + 1/2 m v^2 for a ball of mass m at height h moving at v
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::pgs());
    let b = w
        .add_body(&BodyDef {
            name: "ball".into(),
            shape: ShapeDef::Circle { radius: 0.5 },
            mass: Some(3.0),
            position: Vec2::new(7.0, 2.5),
            velocity: Vec2::new(3.0, -4.0),
            ..Default::default()
        })
        .unwrap();
    let e = bench::energy_about(&w, 0.5);
    assert!(
        (e - (3.0 * 10.0 * 2.0 + 0.5 * 3.0 * 25.0)).abs() < 1e-9,
        "{e}"
    );
    // semi-implicit Euler in free fall: v' = v + g h, x' = x + h v' changes the energy
    // by exactly -1/2 m |g|^2 h^2 a step
    let e0 = bench::energy_about(&w, 0.0);
    for _ in 0..30 {
        w.step().unwrap();
    }
    let e1 = bench::energy_about(&w, 0.0);
    let expect = -30.0 * 0.5 * 3.0 * 100.0 / (60.0 * 60.0);
    assert!((e1 - e0 - expect).abs() < 1e-3, "{} vs {expect}", e1 - e0);
    assert!(w.bodies[b].position.y < 2.5);
}
