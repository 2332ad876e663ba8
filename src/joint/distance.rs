//! The distance joint: an anchor on each body kept at a fixed distance (its `length`,
//! rigidly or with a compliance, a spring), or within a range (its `limits`: a rope).
//! One row along the anchors' direction: an equality, or the two limits.

use super::pgs::{Damping, Row, RowBuilder};
use super::soft::{Jac, Pair, Prepared, Sweep};
use super::xpbd::{Start, VelocityPass, linear_correction};
use super::{Joint, JointFrame, Kind, SLOTS, drive_force, outside, slot};
use crate::body::Body;
use crate::math::Vec2;

/// The distance joint's [`Kind`].
pub(super) struct Distance;

impl Kind for Distance {
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32) {
        (
            (l[slot::AXIAL] + l[slot::LOWER] - l[slot::UPPER]).abs(),
            0.0,
        )
    }

    fn default_anchors(ba: &Body, bb: &Body) -> (Vec2, Vec2) {
        // both centres of mass
        (ba.position, bb.position)
    }

    fn position_error(j: &Joint, f: &JointFrame, _bodies: &[Body]) -> f32 {
        let len = f.d.length();
        match j.limits {
            Some(l) => outside(len, l),
            None => (len - j.length).abs(),
        }
    }

    fn drive(j: &Joint, f: &JointFrame, bodies: &mut [Body], p: f32) {
        drive_force(j, bodies, (f.ra, f.rb, f.d.normalize_or(f.axis)), p);
    }

    fn pgs_rows(j: &Joint, f: &JointFrame, rows: &mut RowBuilder) {
        let len = f.d.length();
        let u = if len > 1e-9 { f.d / len } else { Vec2::Y };
        let r = Row::linear(rows.a, rows.b, f.ra, f.rb, u);
        match j.limits {
            Some([lo, hi]) => {
                let lower = rows.inequality(r, len - lo);
                rows.push(j, lower, slot::LOWER);
                let upper = rows.inequality(r.negated(), hi - len);
                rows.push(j, upper, slot::UPPER);
            }
            None => {
                let axial = rows.equality(r, len - j.length, j.compliance);
                rows.push(j, axial, slot::AXIAL);
            }
        }
        if j.damping.linear > 0.0 {
            rows.damp(r, j.damping.linear);
        }
    }

    fn project(j: &Joint, bodies: &mut [Body], t: &Start, h: f32, lambdas: &mut [f32; SLOTS]) {
        // alpha~ = alpha / h^2
        let soft = j.compliance / (h * h);
        let f = j.frame(bodies);
        let len = f.d.length();
        if len <= 1e-9 {
            return;
        }
        let n = f.d / len;
        let c = match j.limits {
            Some([lo, _]) if len < lo => len - lo,
            Some([_, hi]) if len > hi => len - hi,
            Some(_) => return,
            None => len - j.length,
        };
        let n0 = t.d0.normalize_or(n);
        linear_correction(
            bodies,
            j.a,
            j.b,
            [f.ra, f.rb, n],
            [t.ra0, t.rb0, n0],
            c,
            soft,
            &mut lambdas[slot::AXIAL],
        );
    }

    fn xpbd_velocity(j: &Joint, f: &JointFrame, pass: &mut VelocityPass) {
        let ax = Row::linear(pass.a, pass.b, f.ra, f.rb, f.d.normalize_or(Vec2::Y));
        pass.motor_of(j, Row::angle(pass.a, pass.b));
        if j.damping.linear > 0.0 {
            pass.damp(ax, j.damping.linear);
        }
        pass.spring_damper(j, ax);
    }

    fn soft_warm_start(p: &Prepared, _j: &Joint, pair: &mut Pair, g: &JointFrame) {
        let l = &p.impulses;
        let u = g.d.normalize_or(Vec2::Y);
        let r = Jac::linear(g.ra, g.rb, u);
        pair.apply(&r, l[slot::AXIAL] + l[slot::LOWER] - l[slot::UPPER]);
    }

    fn soft_solve(sw: &Sweep, p: &mut Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) -> f32 {
        let l = &mut p.impulses;
        let len = g.d.length();
        let u = if len > 1e-9 { g.d / len } else { Vec2::Y };
        let row = Jac::linear(g.ra, g.rb, u);
        match j.limits {
            Some([lo, hi]) => {
                let r1 = sw.inequality(pair, &row, len - lo, &mut l[slot::LOWER]);
                let r2 = sw.inequality(pair, &row.negated(), hi - len, &mut l[slot::UPPER]);
                r1.max(r2)
            }
            None => sw.equality(
                pair,
                &row,
                len - j.length,
                j.compliance,
                &mut l[slot::AXIAL],
            ),
        }
    }

    fn soft_damp(h: f32, j: &Joint, pair: &mut Pair, g: &JointFrame) {
        if j.damping.linear > 0.0 {
            pair.damp(
                Jac::linear(g.ra, g.rb, g.d.normalize_or(Vec2::Y)),
                h,
                j.damping.linear,
            );
        }
    }
}
