//! The hinge (a revolute joint): the bodies pinned together at one anchor, turning
//! freely about it, within limits, held at an angle by a servo, driven by a motor, or
//! pulled to its zero angle by a torsion spring (a servo or a spring, not both).
//!
//! Rows, in the order each solver takes them: the torsion spring, the motor, the lower
//! and upper limits and the servo on the relative angle, then the point (a 2x2 block),
//! last because it matters most. The soft step solves most hinges four at a time in the
//! solver's SIMD lanes (`crate::solver::soft`); the rows here take the rest.

use super::pgs::{Damping, Row, RowBuilder};
use super::soft::{Jac, Pair, Prepared, Sweep, own_spring};
use super::xpbd::{
    Start, VelocityPass, angular_correction, project_point, project_range, spring_compliance,
};
use super::{Joint, JointFrame, Kind, SLOTS, drive_torque, slot};
use crate::body::Body;
use crate::defs::JointDef;
use crate::math::Vec2;

/// The hinge's [`Kind`].
pub(super) struct Hinge;

impl Kind for Hinge {
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32) {
        super::point_and_angle(l)
    }

    fn check(def: &JointDef) -> Result<(), String> {
        if def.servo.is_some() && def.spring.is_some() {
            return Err("a hinge takes a servo or a spring, not both".into());
        }
        Ok(())
    }

    fn init(j: &mut Joint, def: &JointDef, _ends: (&Body, &Body), _anchors: (Vec2, Vec2)) {
        // a torsion spring to the hinge's zero, which the def may set apart from the
        // angle at creation
        j.spring = def.spring;
        j.ref_angle = def.angle.unwrap_or(j.ref_angle);
    }

    fn position_error(_j: &Joint, f: &JointFrame, _bodies: &[Body]) -> f32 {
        f.d.length()
    }

    fn angle_error(j: &Joint, f: &JointFrame) -> f32 {
        j.limits
            .map_or(0.0, |[lo, hi]| (lo - f.angle).max(f.angle - hi).max(0.0))
    }

    fn drive(j: &Joint, _f: &JointFrame, bodies: &mut [Body], p: f32) {
        drive_torque(j, bodies, p);
    }

    #[inline(always)]
    fn pgs_rows(j: &Joint, f: &JointFrame, rows: &mut RowBuilder) {
        let ang = Row::angle(rows.a, rows.b);
        // the torsion spring, to its zero angle
        if let Some(sp) = j.spring {
            let r = rows.spring(ang, f.angle, sp.hertz, sp.damping_ratio);
            rows.push(j, r, slot::SPRING);
        }
        rows.motor_of(j, ang);
        rows.range(j, ang, f.angle, true);
        rows.point(j, f);
        rows.damp_angle(j, ang);
    }

    fn project(j: &Joint, bodies: &mut [Body], t: &Start, h: f32, lambdas: &mut [f32; SLOTS]) {
        // alpha~ = alpha / h^2
        let soft = j.compliance / (h * h);
        let f = project_point(j, bodies, t, soft, lambdas);
        // the torsion spring: C = angle with compliance 1 / k, k = I_eff omega^2 (its
        // damping is applied in the velocity pass)
        let w = bodies[j.a].inv_inertia + bodies[j.b].inv_inertia;
        if let Some(alpha) = spring_compliance(j, w) {
            let spring = &mut lambdas[slot::SPRING];
            angular_correction(bodies, j.a, j.b, f.angle, alpha / (h * h), spring);
        }
        let f = j.frame(bodies);
        project_range(j, bodies, f.angle, lambdas, None);
    }

    fn xpbd_velocity(j: &Joint, _f: &JointFrame, pass: &mut VelocityPass) {
        let ang = Row::angle(pass.a, pass.b);
        pass.motor_of(j, ang);
        // the torsion spring's damper, on the angle
        pass.spring_damper(j, ang);
        pass.damp_angle(j, ang);
    }

    fn soft_prepare(j: &Joint, _bodies: &[Body], h: f32, p: &mut Prepared) {
        p.spring = own_spring(j, h);
    }

    fn soft_warm_start(p: &Prepared, _j: &Joint, pair: &mut Pair, g: &JointFrame) {
        warm_start_point_and_angle(p, pair, g);
    }

    fn soft_solve(sw: &Sweep, p: &mut Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) -> f32 {
        let spring = p.spring;
        let l = &mut p.impulses;
        let ang = Jac::angle();
        // the torsion spring pulls the angle to 0 (in the lambda slot a servo would
        // use: a hinge has one or the other)
        let mut r = match &spring {
            Some(soft) => sw.spring(pair, &ang, g.angle, soft, &mut l[slot::SPRING]),
            None => 0.0,
        };
        r = r.max(sw.motor_of(pair, j, &ang, l));
        r = r.max(sw.range(pair, j, &ang, g.angle, true, l));
        // the point last: it matters most (positions do not move within a sweep, so
        // the geometry still holds)
        r.max(sw.point_of(pair, g, j.compliance, l))
    }

    fn soft_damp(h: f32, j: &Joint, pair: &mut Pair, _g: &JointFrame) {
        pair.damp_angle(j, h);
    }
}

/// The warm start of a point and the rows on the relative angle (hinge, weld): every
/// angular row has J v = w_b - w_a (the upper limit negated).
#[inline]
pub(super) fn warm_start_point_and_angle(p: &Prepared, pair: &mut Pair, g: &JointFrame) {
    let l = &p.impulses;
    pair.apply_point(g.ra, g.rb, Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]));
    let ang = l[slot::ANGLE] + l[slot::MOTOR] + l[slot::SERVO] + l[slot::LOWER] - l[slot::UPPER];
    pair.apply(&Jac::angle(), ang);
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverKind;
    use crate::joint::slot;
    use crate::step::testing::hanging_disc;

    #[test]
    fn a_hanging_disc_pulls_its_hinge_with_its_weight() {
        // at rest the hinge's PGS point row carries m g dt upwards (on b): 2 kg, g 10
        let mut w = hanging_disc(SolverKind::Pgs);
        for _ in 0..60 {
            w.step().unwrap();
        }
        let j = &w.joints[0];
        let want = 2.0 * 10.0 * w.settings.dt;
        let (x, y) = (j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
        assert!(x.abs() < 1e-4 * want, "{x}");
        assert!((y - want).abs() < 0.01 * want, "{y} vs {want}");
    }
}
