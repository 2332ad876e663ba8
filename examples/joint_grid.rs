//! Box2D's joint grid benchmark layout: n x n circles of radius 0.4 at 1 m spacing, each
//! hinged to its left and lower neighbours (2 n (n - 1) hinges), 7 static anchors in the
//! middle of the top row. Neighbours are 0.2 m apart, so they never touch (the layout
//! needs no filters). Prints the largest joint stretch at step 60 and over the run, and
//! the median ms/step.
//!
//! ```sh
//! cargo run --release --example joint_grid -- [n=100] [steps=500] [soft|pgs|xpbd]
//! ```

use std::time::Instant;

use glam::Vec2;
use sandbox2d::{
    BodyDef, BodyType, JointDef, JointKind, ShapeDef, SolverKind, SolverSettings, World,
};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(100);
    let steps: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(500);
    let kind = args
        .get(2)
        .and_then(|s| SolverKind::from_name(s))
        .unwrap_or_default();
    let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::defaults(kind));
    let mut index = vec![vec![0usize; n]; n];
    for (k, row) in index.iter_mut().enumerate() {
        for (i, slot) in row.iter_mut().enumerate() {
            let anchor = k == n - 1 && i + 3 >= n / 2 && i <= n / 2 + 3;
            *slot = w
                .add_body(&BodyDef {
                    name: format!("b{k}_{i}"),
                    body_type: if anchor {
                        BodyType::Static
                    } else {
                        BodyType::Dynamic
                    },
                    shape: ShapeDef::Circle { radius: 0.4 },
                    position: Vec2::new(i as f32, k as f32),
                    ..Default::default()
                })
                .expect("body");
        }
    }
    let hinge = |a: usize, b: usize, at: Vec2| JointDef {
        kind: JointKind::Hinge,
        bodies: [a, b],
        anchor: Some(at),
        anchors: None,
        length: None,
        axis: None,
        limits: None,
        motor: None,
        servo: None,
        compliance: 0.0,
        damping: Default::default(),
        collide_connected: false,
    };
    for k in 0..n {
        for i in 0..n {
            let here = Vec2::new(i as f32, k as f32);
            if i > 0 {
                w.add_joint(&hinge(
                    index[k][i - 1],
                    index[k][i],
                    here - Vec2::new(0.5, 0.0),
                ))
                .expect("joint");
            }
            if k > 0 {
                w.add_joint(&hinge(
                    index[k - 1][i],
                    index[k][i],
                    here - Vec2::new(0.0, 0.5),
                ))
                .expect("joint");
            }
        }
    }
    let (mut worst, mut at60) = (0.0f32, 0.0f32);
    let mut ms = Vec::with_capacity(steps);
    for s in 1..=steps {
        let t = Instant::now();
        if let Err(e) = w.step() {
            println!("{}: {e}", kind.name());
            std::process::exit(1);
        }
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        let e = w.joint_error();
        worst = worst.max(e);
        if s == 60 {
            at60 = e;
        }
    }
    ms.sort_by(f64::total_cmp);
    println!(
        "{} {n}x{n} joint grid ({} joints), {steps} steps: stretch at step 60 {at60:.4} m, \
         largest {worst:.4} m, median {:.3} ms/step",
        kind.name(),
        w.joints().len(),
        ms[ms.len() / 2]
    );
}
