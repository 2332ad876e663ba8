//! The prismatic joint: b slides along an axis fixed in a and does not turn relative
//! to a; the offset along the axis within limits, held by a servo or driven by a motor.
//!
//! Rows: the motor, the limits and the servo along the axis, the line (the off-axis
//! offset, C = perp . d) and the angle.

use super::pgs::{Damping, Row, RowBuilder};
use super::soft::{Jac, Pair, Prepared, Sweep};
use super::xpbd::{Start, VelocityPass, angular_correction, line_correction, project_range};
use super::{Joint, JointFrame, Kind, SLOTS, drive_force, outside, slot};
use crate::body::Body;

/// The prismatic joint's [`Kind`].
pub(super) struct Prismatic;

impl Kind for Prismatic {
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32) {
        let along = l[slot::MOTOR] + l[slot::SERVO] + l[slot::LOWER] - l[slot::UPPER];
        (along.hypot(l[slot::AXIAL]), l[slot::ANGLE])
    }

    fn position_error(j: &Joint, f: &JointFrame, _bodies: &[Body]) -> f32 {
        off_axis_error(j, f)
    }

    fn angle_error(_j: &Joint, f: &JointFrame) -> f32 {
        f.angle.abs()
    }

    fn drive(j: &Joint, f: &JointFrame, bodies: &mut [Body], p: f32) {
        drive_force(j, bodies, (f.ra + f.d, f.rb, f.axis), p);
    }

    fn pgs_rows(j: &Joint, f: &JointFrame, rows: &mut RowBuilder) {
        let ax = Row::linear(rows.a, rows.b, f.ra + f.d, f.rb, f.axis);
        rows.motor_of(j, ax);
        let t = f.axis.dot(f.d);
        rows.range(j, ax, t, false);
        rows.line(j, f);
        let r = rows.equality(Row::angle(rows.a, rows.b), f.angle, j.compliance);
        rows.push(j, r, slot::ANGLE);
        if j.damping.linear > 0.0 {
            rows.damp(ax, j.damping.linear);
        }
        rows.damp_angle(j, Row::angle(rows.a, rows.b));
    }

    fn project(j: &Joint, bodies: &mut [Body], t: &Start, h: f32, lambdas: &mut [f32; SLOTS]) {
        // alpha~ = alpha / h^2
        let soft = j.compliance / (h * h);
        line_correction(j, bodies, t, soft, &mut lambdas[slot::AXIAL]);
        let f = j.frame(bodies);
        angular_correction(bodies, j.a, j.b, f.angle, soft, &mut lambdas[slot::ANGLE]);
        let f = j.frame(bodies);
        project_range(
            j,
            bodies,
            f.axis.dot(f.d),
            lambdas,
            Some(([f.ra + f.d, f.rb, f.axis], [t.ra0 + t.d0, t.rb0, t.axis0])),
        );
    }

    fn xpbd_velocity(j: &Joint, f: &JointFrame, pass: &mut VelocityPass) {
        let ax = Row::linear(pass.a, pass.b, f.ra + f.d, f.rb, f.axis);
        pass.motor_of(j, ax);
        if j.damping.linear > 0.0 {
            pass.damp(ax, j.damping.linear);
        }
        pass.spring_damper(j, ax);
        pass.damp_angle(j, Row::angle(pass.a, pass.b));
    }

    fn soft_warm_start(p: &Prepared, _j: &Joint, pair: &mut Pair, g: &JointFrame) {
        let l = &p.impulses;
        let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
        let along = l[slot::MOTOR] + l[slot::SERVO] + l[slot::LOWER] - l[slot::UPPER];
        pair.apply(&ax, along);
        let perp = Jac::linear(g.ra + g.d, g.rb, g.axis.perp());
        pair.apply(&perp, l[slot::AXIAL]);
        pair.apply(&Jac::angle(), l[slot::ANGLE]);
    }

    fn soft_solve(sw: &Sweep, p: &mut Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) -> f32 {
        let l = &mut p.impulses;
        let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
        let mut r = sw.motor_of(pair, j, &ax, l);
        r = r.max(sw.range(pair, j, &ax, g.axis.dot(g.d), false, l));
        r = r.max(sw.line(pair, j, g, l));
        r.max(sw.equality(
            pair,
            &Jac::angle(),
            g.angle,
            j.compliance,
            &mut l[slot::ANGLE],
        ))
    }

    fn soft_damp(h: f32, j: &Joint, pair: &mut Pair, g: &JointFrame) {
        if j.damping.linear > 0.0 {
            pair.damp(Jac::linear(g.ra + g.d, g.rb, g.axis), h, j.damping.linear);
        }
        pair.damp_angle(j, h);
    }
}

/// The off-axis offset plus how far the offset along the axis is outside the limits
/// (prismatic, wheel), m.
#[inline]
pub(super) fn off_axis_error(j: &Joint, f: &JointFrame) -> f32 {
    let off = f.axis.perp().dot(f.d).abs();
    off + j.limits.map_or(0.0, |l| outside(f.axis.dot(f.d), l))
}
