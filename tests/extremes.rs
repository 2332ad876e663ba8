//! The claims of docs/stability.md, re-checked: every "holds through" value must hold
//! and every "fails at" value must fail, with the same scenes and bounds as
//! `sandbox2d bench --suite extremes` (closed forms and bounds in src/bench/extremes.rs).

use sandbox2d::bench::extremes::{self, CaseResult, Sweep};

fn doc() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/stability.md"))
        .expect("docs/stability.md")
}

fn claims_hold(sweep: Sweep) {
    let claims = extremes::parse_claims(&doc()).expect("the summary table parses");
    for c in claims.iter().filter(|c| c.sweep == sweep) {
        if let Some(v) = c.holds_through {
            let r = extremes::check(sweep, v, &c.setting.setting);
            assert!(
                r.held(),
                "{} {}: the doc says it holds at {}, got {r:?}",
                sweep.name(),
                c.setting.label,
                sweep.format_value(v)
            );
        }
        if let Some(v) = c.fails_at {
            let r = extremes::check(sweep, v, &c.setting.setting);
            assert!(
                matches!(r, CaseResult::Failed(_)),
                "{} {}: the doc says it fails at {}, got {r:?}",
                sweep.name(),
                c.setting.label,
                sweep.format_value(v)
            );
        }
    }
}

#[test]
fn the_table_covers_every_sweep_and_setting() {
    let text = doc();
    let claims = extremes::parse_claims(&text).unwrap();
    for sweep in Sweep::ALL {
        for s in extremes::settings(sweep) {
            let row = format!("| {} | {} |", sweep.name(), s.label);
            assert!(text.contains(&row), "no row {row}");
        }
    }
    assert!(!claims.is_empty());
}

#[test]
fn mass_ratio() {
    claims_hold(Sweep::MassRatio);
}

#[test]
fn mass_ratio_chain() {
    claims_hold(Sweep::MassRatioChain);
}

#[test]
fn time_step() {
    claims_hold(Sweep::TimeStep);
}

#[test]
fn tunneling() {
    claims_hold(Sweep::Tunneling);
}

#[test]
fn stack_height() {
    claims_hold(Sweep::StackHeight);
}

#[test]
fn distance_from_the_origin() {
    claims_hold(Sweep::Distance);
}

#[test]
fn iterations() {
    claims_hold(Sweep::Iterations);
}

#[test]
fn friction() {
    claims_hold(Sweep::Friction);
}

#[test]
fn restitution() {
    claims_hold(Sweep::Restitution);
}
