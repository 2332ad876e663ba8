//! The wheel joint: b (a wheel) slides along an axis fixed in a (a chassis) on a
//! suspension spring, turns freely or by a motor, and stays on the axis's line, within
//! limits along it.
//!
//! Rows: the motor on the angle, the suspension spring along the axis, the limits, and
//! the line (the off-axis offset, C = perp . d). A wheel has no servo: its spring takes
//! the servo's lambda slot.

use super::pgs::{Damping, Row, RowBuilder};
use super::prismatic::off_axis_error;
use super::soft::{Jac, Pair, Prepared, Sweep, own_spring};
use super::xpbd::{
    Start, VelocityPass, effective_inverse_mass, line_correction, linear_correction, project_range,
    spring_compliance,
};
use super::{Joint, JointFrame, Kind, SLOTS, drive_torque, slot};
use crate::body::Body;
use crate::defs::JointDef;
use crate::math::Vec2;

/// The wheel joint's [`Kind`].
pub(super) struct Wheel;

impl Kind for Wheel {
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32) {
        let along = l[slot::SPRING] + l[slot::LOWER] - l[slot::UPPER];
        (along.hypot(l[slot::AXIAL]), l[slot::MOTOR])
    }

    fn init(j: &mut Joint, def: &JointDef, _ends: (&Body, &Body), _anchors: (Vec2, Vec2)) {
        j.servo = None;
        j.spring = def.spring;
    }

    fn position_error(j: &Joint, f: &JointFrame, _bodies: &[Body]) -> f32 {
        off_axis_error(j, f)
    }

    fn drive(j: &Joint, _f: &JointFrame, bodies: &mut [Body], p: f32) {
        drive_torque(j, bodies, p);
    }

    fn pgs_rows(j: &Joint, f: &JointFrame, rows: &mut RowBuilder) {
        rows.motor_of(j, Row::angle(rows.a, rows.b));
        let ax = Row::linear(rows.a, rows.b, f.ra + f.d, f.rb, f.axis);
        let t = f.axis.dot(f.d);
        if let Some(sp) = j.spring {
            let r = rows.spring(ax, t, sp.hertz, sp.damping_ratio);
            rows.push(j, r, slot::SPRING);
        }
        rows.range(j, ax, t, false);
        rows.line(j, f);
        if j.damping.linear > 0.0 {
            rows.damp(ax, j.damping.linear);
        }
    }

    fn project(j: &Joint, bodies: &mut [Body], t0: &Start, h: f32, lambdas: &mut [f32; SLOTS]) {
        // alpha~ = alpha / h^2
        let soft = j.compliance / (h * h);
        line_correction(j, bodies, t0, soft, &mut lambdas[slot::AXIAL]);
        let f = j.frame(bodies);
        let t = f.axis.dot(f.d);
        let now = [f.ra + f.d, f.rb, f.axis];
        let then = [t0.ra0 + t0.d0, t0.rb0, t0.axis0];
        // the suspension: C = axis . d with compliance 1 / k, k = m_eff omega^2 (its
        // damping is applied in the velocity pass)
        let w = effective_inverse_mass(bodies, j.a, j.b, now);
        if let Some(alpha) = spring_compliance(j, w) {
            let spring = &mut lambdas[slot::SPRING];
            linear_correction(bodies, j.a, j.b, now, then, t, alpha / (h * h), spring);
        }
        let f = j.frame(bodies);
        project_range(
            j,
            bodies,
            f.axis.dot(f.d),
            lambdas,
            Some(([f.ra + f.d, f.rb, f.axis], then)),
        );
    }

    fn xpbd_velocity(j: &Joint, f: &JointFrame, pass: &mut VelocityPass) {
        let ax = Row::linear(pass.a, pass.b, f.ra + f.d, f.rb, f.axis);
        pass.motor_of(j, Row::angle(pass.a, pass.b));
        if j.damping.linear > 0.0 {
            pass.damp(ax, j.damping.linear);
        }
        // the suspension's damper
        pass.spring_damper(j, ax);
    }

    fn soft_prepare(j: &Joint, _bodies: &[Body], h: f32, p: &mut Prepared) {
        p.spring = own_spring(j, h);
    }

    fn soft_warm_start(p: &Prepared, _j: &Joint, pair: &mut Pair, g: &JointFrame) {
        let l = &p.impulses;
        let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
        pair.apply(&ax, l[slot::SPRING] + l[slot::LOWER] - l[slot::UPPER]);
        let perp = Jac::linear(g.ra + g.d, g.rb, g.axis.perp());
        pair.apply(&perp, l[slot::AXIAL]);
        pair.apply(&Jac::angle(), l[slot::MOTOR]);
    }

    fn soft_solve(sw: &Sweep, p: &mut Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) -> f32 {
        let spring = p.spring;
        let l = &mut p.impulses;
        let mut r = sw.motor_of(pair, j, &Jac::angle(), l);
        let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
        let t = g.axis.dot(g.d);
        if let Some(soft) = &spring {
            r = r.max(sw.spring(pair, &ax, t, soft, &mut l[slot::SPRING]));
        }
        r = r.max(sw.range(pair, j, &ax, t, false, l));
        r.max(sw.line(pair, j, g, l))
    }

    fn soft_damp(h: f32, j: &Joint, pair: &mut Pair, g: &JointFrame) {
        if j.damping.linear > 0.0 {
            pair.damp(Jac::linear(g.ra + g.d, g.rb, g.axis), h, j.damping.linear);
        }
    }
}
