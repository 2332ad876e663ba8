//! `bench --suite convergence`: every solver at halving steps on the closed-form
//! scenes, then convergence.csv, convergence.md and convergence.svg.

use sandbox2d::SolverKind;
use sandbox2d::bench::convergence;
use sandbox2d::output;

use crate::args::BenchArgs;
use crate::failure::{self, Failure};
use crate::paths::write_file;
use crate::progress::bench_progress;

/// Every solver on each scene, then the reports and each series' order.
pub fn bench_convergence(a: &BenchArgs, sharded: bool) -> Result<(), Failure> {
    super::one_case_at_a_time(a, sharded, "convergence", "runs in seconds on one thread")?;
    let scenes = super::filtered(
        a,
        convergence::scenes(a.filter.as_deref()),
        "scene of the convergence suite (projectile_drag, pendulum, spring, rolling_disk, sliding_box)",
    )?;
    failure::graceful();
    let bar = bench_progress(scenes.len() * SolverKind::ALL.len());
    let series = convergence::run_all(&scenes, |done, _, what| {
        bar.set_position(done as u64);
        bar.set_message(what.to_string());
    });
    bar.finish_and_clear();
    let series = match series {
        Ok(s) => s,
        Err(_) if output::interrupted() => {
            return Err(Failure::nothing_written());
        }
        Err(e) => return Err(Failure::run(e)),
    };
    let command = super::suite_command(a, "convergence", false);
    write_file(
        &a.out.join("convergence.svg"),
        &convergence::svg(&series).map_err(Failure::run)?,
    )?;
    write_file(&a.out.join("convergence.csv"), &convergence::csv(&series))?;
    write_file(
        &a.out.join("convergence.md"),
        &convergence::markdown(&series, &command),
    )?;
    say!(
        "wrote {}: convergence.csv, convergence.md and convergence.svg",
        a.out.display()
    )?;
    for x in &series {
        say!(
            "{:<16} {:<10} order {}",
            x.scene,
            x.kind.name(),
            x.fit.map_or("-".to_string(), |f| format!("{:.2}", f.order))
        )?;
    }
    Ok(())
}
