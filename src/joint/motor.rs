//! The motor joint: b driven towards a target offset and angle relative to a (the
//! target fixed in a's frame) by a bounded force and torque, correcting a share of the
//! error per step. A drive, not a constraint: its error counts as 0, and XPBD applies it
//! in the velocity pass only.
//!
//! Rows: the angle, J v = w_b - w_a driven to -correction angle / dt with |lambda| <= max
//! torque h, and the point, the velocity of b's centre relative to its target driven to
//! -correction d / dt with |lambda| <= max force h (dt the world's step, so the share of
//! the error removed per step is the same whatever the substeps).

use super::pgs::{Point, Row, RowBuilder, motor, point_inv_k};
use super::soft::{Jac, Pair, Prepared, Sweep};
use super::xpbd::{Start, VelocityPass};
use super::{Joint, JointFrame, Kind, SLOTS, clamp_length, slot};
use crate::body::Body;
use crate::constraint::SolverBody;
use crate::defs::JointDef;
use crate::math::Vec2;

/// The motor joint's [`Kind`].
pub(super) struct Motor;

impl Kind for Motor {
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32) {
        (l[slot::POINT_X].hypot(l[slot::POINT_Y]), l[slot::ANGLE])
    }

    fn check(def: &JointDef) -> Result<(), String> {
        if !(def.max_force >= 0.0 && def.max_torque >= 0.0 && (0.0..=1.0).contains(&def.correction))
        {
            return Err(format!(
                "a motor joint needs max_force, max_torque >= 0 and correction in [0, 1], got {}, {}, {}",
                def.max_force, def.max_torque, def.correction
            ));
        }
        Ok(())
    }

    fn init(j: &mut Joint, def: &JointDef, (ba, bb): (&Body, &Body), _anchors: (Vec2, Vec2)) {
        // the target: b's centre in a's frame, and theta_b - theta_a
        j.local_a = def
            .offset
            .unwrap_or_else(|| ba.rot.inv_rotate(bb.position - ba.position));
        j.local_b = Vec2::ZERO;
        j.ref_angle = def.angle.unwrap_or(j.ref_angle);
        j.max_force = def.max_force;
        j.max_torque = def.max_torque;
        j.correction = def.correction;
        (j.servo, j.motor, j.limits) = (None, None, None);
    }

    fn position_error(_j: &Joint, _f: &JointFrame, _bodies: &[Body]) -> f32 {
        0.0
    }

    fn pgs_rows(j: &Joint, f: &JointFrame, rows: &mut RowBuilder) {
        let r = angle_row(j, (rows.a, rows.b), f.angle, rows.bodies, rows.h, rows.dt);
        rows.push(j, r, slot::ANGLE);
        let imp = Vec2::new(j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
        let mut p = point(j, f, rows.bodies, (rows.h, rows.dt), rows.joint());
        if rows.warm() {
            p.impulse = clamp_length(imp, p.max_impulse);
        }
        rows.push_point(p);
    }

    fn project(_j: &Joint, _bodies: &mut [Body], _t: &Start, _h: f32, _l: &mut [f32; SLOTS]) {
        // a bounded drive: XPBD applies it in the velocity pass
    }

    fn xpbd_velocity(j: &Joint, f: &JointFrame, pass: &mut VelocityPass) {
        // the motor joint is a bounded velocity drive: solved here only
        let (h, dt) = (pass.h, pass.dt);
        angle_row(j, (pass.a, pass.b), f.angle, pass.bodies, h, dt).solve(pass.bodies);
        point(j, f, pass.bodies, (h, dt), pass.joint).solve(pass.bodies);
    }

    fn soft_warm_start(p: &Prepared, _j: &Joint, pair: &mut Pair, g: &JointFrame) {
        let l = &p.impulses;
        pair.apply_point(g.ra, g.rb, Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]));
        pair.apply(&Jac::angle(), l[slot::ANGLE]);
    }

    /// The angle error and the point error d (b's centre less its target) driven out at
    /// `correction` per step, the torque and force bounded.
    fn soft_solve(sw: &Sweep, p: &mut Prepared, j: &Joint, pair: &mut Pair, g: &JointFrame) -> f32 {
        let l = &mut p.impulses;
        let ang = Jac::angle();
        let k = pair.k(&ang);
        let mut r = 0.0f32;
        if k > 0.0 {
            let max = j.max_torque.max(0.0) * sw.h;
            let cdot = pair.jv(&ang) + j.correction * g.angle * sw.inv_dt;
            let old = l[slot::ANGLE];
            let new = (old - cdot / k).clamp(-max, max);
            l[slot::ANGLE] = new;
            pair.apply(&ang, new - old);
            r = (new - old).abs();
        }
        let cdot = pair.point_velocity(g.ra, g.rb) + j.correction * g.d * sw.inv_dt;
        let old = Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]);
        let new = clamp_length(
            old - pair.solve_point(g.ra, g.rb, 0.0, cdot),
            j.max_force.max(0.0) * sw.h,
        );
        (l[slot::POINT_X], l[slot::POINT_Y]) = (new.x, new.y);
        pair.apply_point(g.ra, g.rb, new - old);
        r.max((new - old).abs().max_element())
    }
}

/// The angular row (PGS, XPBD's velocity pass): J v = w_b - w_a driven to -correction
/// angle / dt, |lambda| <= max torque h.
fn angle_row(
    j: &Joint,
    (a, b): (u32, u32),
    angle: f32,
    bodies: &[SolverBody],
    h: f32,
    dt: f32,
) -> Row {
    let mut r = motor(
        Row::angle(a, b),
        bodies,
        -j.correction * angle / dt,
        j.max_torque,
        h,
    );
    r.positional = false;
    r
}

/// The linear block (PGS, XPBD's velocity pass): the point velocity driven to
/// -correction d / dt (d = b's centre less its target), |lambda| <= max force h.
fn point(
    j: &Joint,
    f: &JointFrame,
    bodies: &[SolverBody],
    (h, dt): (f32, f32),
    joint: u32,
) -> Point {
    let (ba, bb) = (&bodies[j.a], &bodies[j.b]);
    // the arms: from a's centre to the target (fixed in a), b's centre: J v = d'
    let ra = f.ra;
    Point {
        a: j.a as u32,
        b: j.b as u32,
        ra,
        rb: f.rb,
        inv_k: point_inv_k(ba, bb, ra, f.rb, 0.0),
        bias: j.correction * f.d / dt,
        gamma: 0.0,
        impulse: Vec2::ZERO,
        max_impulse: j.max_force.max(0.0) * h,
        joint,
        positional: false,
        pos_impulse: Vec2::ZERO,
        exact: false,
    }
}
