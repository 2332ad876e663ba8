//! The weld: b held fixed relative to a, its anchor on a's and its angle at the angle
//! of creation, rigidly or with a compliance. Rows: a motor on the angle (if given),
//! the angle, then the point (a 2x2 block).

use super::hinge::warm_start_point_and_angle;
use super::pgs::{Damping, Row, RowBuilder};
use super::soft::{Jac, Pair, Prepared, Sweep};
use super::xpbd::{Start, VelocityPass, angular_correction, project_point};
use super::{Joint, JointFrame, Kind, SLOTS, drive_torque, slot};
use crate::body::Body;

/// The weld's [`Kind`].
pub(super) struct Weld;

impl Kind for Weld {
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32) {
        super::point_and_angle(l)
    }

    fn position_error(_j: &Joint, f: &JointFrame, _bodies: &[Body]) -> f32 {
        f.d.length()
    }

    fn angle_error(_j: &Joint, f: &JointFrame) -> f32 {
        f.angle.abs()
    }

    fn drive(j: &Joint, _f: &JointFrame, bodies: &mut [Body], p: f32) {
        drive_torque(j, bodies, p);
    }

    fn pgs_rows(j: &Joint, f: &JointFrame, rows: &mut RowBuilder) {
        let ang = Row::angle(rows.a, rows.b);
        rows.motor_of(j, ang);
        let r = rows.equality(ang, f.angle, j.compliance);
        rows.push(j, r, slot::ANGLE);
        rows.point(j, f);
        rows.damp_angle(j, ang);
    }

    fn project(j: &Joint, bodies: &mut [Body], t: &Start, h: f32, lambdas: &mut [f32; SLOTS]) {
        // alpha~ = alpha / h^2
        let soft = j.compliance / (h * h);
        let f = project_point(j, bodies, t, soft, lambdas);
        angular_correction(bodies, j.a, j.b, f.angle, soft, &mut lambdas[slot::ANGLE]);
    }

    fn xpbd_velocity(j: &Joint, _f: &JointFrame, pass: &mut VelocityPass) {
        let ang = Row::angle(pass.a, pass.b);
        pass.motor_of(j, ang);
        pass.damp_angle(j, ang);
    }

    fn soft_warm_start(p: &Prepared, _j: &Joint, pair: &mut Pair, g: &JointFrame) {
        warm_start_point_and_angle(p, pair, g);
    }

    fn soft_solve(sw: &Sweep, p: &mut Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) -> f32 {
        let l = &mut p.impulses;
        let ang = Jac::angle();
        // (a weld has no spring: its rows start from 0)
        let mut r = 0.0f32.max(sw.motor_of(pair, j, &ang, l));
        r = r.max(sw.equality(pair, &ang, g.angle, j.compliance, &mut l[slot::ANGLE]));
        // the point last: it matters most
        r.max(sw.point_of(pair, g, j.compliance, l))
    }

    fn soft_damp(h: f32, j: &Joint, pair: &mut Pair, _g: &JointFrame) {
        pair.damp_angle(j, h);
    }
}
