//! Accuracy against the true motion: the convergence suite's orders checked against
//! theory, and the trajectory error (`--metric trajectory`) checked against the closed
//! forms.

use sandbox2d::SolverKind;
use sandbox2d::bench::convergence;

mod common;
use common::cli::{sandbox2d, tmp};

/// The fitted order of `kind` on the convergence suite's `scene`.
fn order(scene: &str, kind: SolverKind) -> convergence::Series {
    let sc = convergence::scenes(Some(scene)).remove(0);
    convergence::run(&sc, kind).unwrap()
}

/// Semi-implicit Euler (every solver's integrator: v += h (g + F/m), x += h v, with the
/// drag taken implicitly) is first order: the error of the projectile halves with dt.
/// The bound 0.25 tells order 1 from 2 (and from 1/2).
#[test]
fn semi_implicit_euler_is_first_order_on_the_projectile() {
    for kind in SolverKind::ALL {
        let s = order("projectile_drag", kind);
        let f = s
            .fit
            .unwrap_or_else(|| panic!("{kind:?}: no fit: {:?}", s.levels));
        assert!(f.used >= 3, "{kind:?}: {f:?}");
        assert!(
            (f.order - 1.0).abs() < 0.25,
            "{kind:?}: order {f:?} {:?}",
            s.levels
        );
        // and level by level while the error is the method's: halving dt halves it
        for (w, p) in s
            .levels
            .windows(2)
            .zip(convergence::local_orders(&s.levels))
        {
            if p.is_finite() {
                let ratio = w[0].error / w[1].error;
                assert!(
                    (1.7..2.3).contains(&ratio),
                    "{kind:?}: {ratio} at dt {}",
                    w[1].dt
                );
            }
        }
    }
    // one substep of PGS is the plain step: without drag its error would be g t h / 2
    // exactly; with the drag's e^(-t/2) the worst error over 2 s at h = 1/15 s is
    // close to that bound (10 x 2 / 15 / 2 = 0.67 m) times the drag's slowing
    let s = order("projectile_drag", SolverKind::Pgs);
    let e0 = s.levels[0].error;
    assert!((0.1..0.67).contains(&e0), "{e0}");
}

/// The pendulum released horizontal, against its exact motion (Jacobi's sn): the
/// constrained step is first order too under each solver.
#[test]
fn the_pendulum_is_first_order_under_every_solver() {
    for kind in SolverKind::ALL {
        let s = order("pendulum", kind);
        let f = s
            .fit
            .unwrap_or_else(|| panic!("{kind:?}: no fit: {:?}", s.levels));
        assert!(f.used >= 3, "{kind:?}: {f:?}");
        assert!(
            (f.order - 1.0).abs() < 0.25,
            "{kind:?}: order {f:?} {:?}",
            s.levels
        );
    }
}

#[test]
fn the_convergence_suite_writes_its_table_and_plot() {
    let dir = tmp("convergence");
    let _ = std::fs::remove_dir_all(&dir);
    let out = sandbox2d()
        .args([
            "bench",
            "--suite",
            "convergence",
            "--filter",
            "pendulum",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let md = std::fs::read_to_string(dir.join("convergence.md")).unwrap();
    assert!(md.contains("| pendulum |"), "{md}");
    assert!(md.contains("Jacobi"), "the closed form is named: {md}");
    let svg = std::fs::read_to_string(dir.join("convergence.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("order"), "{svg}");
    let csv = std::fs::read_to_string(dir.join("convergence.csv")).unwrap();
    // a header and 3 solvers x 7 levels
    assert_eq!(csv.lines().count(), 1 + 3 * convergence::LEVELS, "{csv}");
    // a filter that matches nothing, and the options that do not apply: exit 2
    for args in [
        vec!["--filter", "nothing"],
        vec!["--jobs", "2"],
        vec!["--shard", "1/2"],
    ] {
        let out = sandbox2d()
            .args(["bench", "--suite", "convergence", "--out"])
            .arg(&dir)
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}
