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

use sandbox2d::{SolverKind, SolverSettings, World};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(100);
    let steps: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(500);
    let kind = args
        .get(2)
        .and_then(|s| SolverKind::from_name(s))
        .unwrap_or_default();
    let def = sandbox2d::bench::scenes::joint_grid(n);
    let mut w = World::from_def(&def, SolverSettings::defaults(kind)).expect("builds");
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
        w.joint_count(),
        ms[ms.len() / 2]
    );
}
