//! The joints under XPBD (Mueller et al. 2020, and the Ten Minute Physics joint notes):
//! the positional corrections every kind projects with ([`super::Kind::project`]), and
//! the velocity pass after the positions (motors, the motor joint, damping), built from
//! the PGS rows of [`super::pgs`].
//!
//! A correction moves the bodies along the constraint gradients of the substep's start
//! (as SHAKE does), not of the predicted positions (see [`super::Joint::project`]).

use super::pgs::{Damping, JointRows, Row, damping_row, motor};
use super::{Joint, JointFrame, SLOTS, slot, wrap_angle};
use crate::body::Body;
use crate::constraint::SolverBody;
use crate::math::{Rot, Vec2, cross};

/// A joint's arms, anchor gap and axis at the start of the substep.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Start {
    pub ra0: Vec2,
    pub rb0: Vec2,
    pub d0: Vec2,
    pub axis0: Vec2,
}

impl Start {
    /// The joint's frame from the bodies' positions and rotations `prev`.
    #[inline]
    pub(super) fn of(j: &Joint, prev: &[(Vec2, Rot)]) -> Start {
        let ((xa, qa), (xb, qb)) = (prev[j.a], prev[j.b]);
        let ra = qa.rotate(j.local_a);
        let rb = qb.rotate(j.local_b);
        Start {
            ra0: ra,
            rb0: rb,
            d0: (xb + rb) - (xa + ra),
            axis0: qa.rotate(j.local_axis),
        }
    }
}

/// XPBD positional correction of C (m), measured along the unit direction n between
/// points at arms ra, rb (`now` = [ra, rb, n]), applied along the substep start's
/// direction and arms (`then` = [ra0, rb0, n0]):
/// delta lambda = (-C - alpha~ lambda) / (w + alpha~), where w is the change of C per unit
/// lambda, w = sum 1/m (n . n0) + (r0 x n0)(r x n) / I; b moves by +delta lambda n0,
/// a by its reaction.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn linear_correction(
    bodies: &mut [Body],
    a: usize,
    b: usize,
    now: [Vec2; 3],
    then: [Vec2; 3],
    c: f32,
    soft: f32,
    lambda: &mut f32,
) {
    let [ra, rb, n] = now;
    let (ima, iia) = (bodies[a].inv_mass, bodies[a].inv_inertia);
    let (imb, iib) = (bodies[b].inv_mass, bodies[b].inv_inertia);
    let (rna, rnb) = (cross(ra, n), cross(rb, n));
    let w_now = ima + iia * rna * rna + imb + iib * rnb * rnb;
    let [mut ra0, mut rb0, mut n0] = then;
    let nn = n.dot(n0);
    let mut w = (ima + imb) * nn + iia * cross(ra0, n0) * rna + iib * cross(rb0, n0) * rnb;
    if !(w > 0.5 * w_now) {
        // the start's gradient is too far from today's: use today's
        (ra0, rb0, n0, w) = (ra, rb, n, w_now);
    }
    if w + soft <= 0.0 {
        return;
    }
    let dl = (-c - soft * *lambda) / (w + soft);
    *lambda += dl;
    let p = dl * n0;
    move_body(&mut bodies[a], -ima * p, -iia * cross(ra0, p));
    move_body(&mut bodies[b], imb * p, iib * cross(rb0, p));
}

/// 1 / m_eff of a linear row along n between arms ra and rb (`now` = [ra, rb, n]).
#[inline]
pub(super) fn effective_inverse_mass(bodies: &[Body], a: usize, b: usize, now: [Vec2; 3]) -> f32 {
    let [ra, rb, n] = now;
    let (ba, bb) = (&bodies[a], &bodies[b]);
    let (rna, rnb) = (cross(ra, n), cross(rb, n));
    ba.inv_mass + ba.inv_inertia * rna * rna + bb.inv_mass + bb.inv_inertia * rnb * rnb
}

/// XPBD: a rigid point constraint (hinge, weld) is projected with alpha~ = this x
/// trace(K) / 2, which removes 1/1.1 of the error per projection. With alpha~ = 0 a grid
/// of hinges (redundant rows: every cell is a closed loop) pumps energy into itself, the
/// more the more substeps (Box2D's 100 x 100 joint grid: non-finite at step 106 with 20
/// substeps, 77 with 40); with 0.1 it runs 500 steps finite, largest stretch 0.09 m
/// (`cargo run --release --example joint_grid -- 100 500 xpbd`). The price on a chain:
/// `ball_and_chain` (500:1) stretches 0.023 m at most instead of 0.018.
const RIGID_POINT_REGULARIZATION: f32 = 0.1;

/// XPBD correction of a point constraint d = p_b - p_a = 0 (hinge, weld): an impulse-like
/// vector P applied at the substep start's arms ra0, rb0, with K P = -d - alpha~ lambda,
/// K = (1/m_a + 1/m_b) I + perp(ra) perp(ra0)^T / I_a + perp(rb) perp(rb0)^T / I_b + alpha~ I.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn point_correction(
    bodies: &mut [Body],
    a: usize,
    b: usize,
    ra: Vec2,
    rb: Vec2,
    ra0: Vec2,
    rb0: Vec2,
    d: Vec2,
    soft: f32,
    lambda: &mut Vec2,
) {
    let (ima, iia) = (bodies[a].inv_mass, bodies[a].inv_inertia);
    let (imb, iib) = (bodies[b].inv_mass, bodies[b].inv_inertia);
    let (pa, pa0, pb, pb0) = (ra.perp(), ra0.perp(), rb.perp(), rb0.perp());
    let soft = if soft > 0.0 {
        soft
    } else {
        // trace(K) / 2 at today's arms
        RIGID_POINT_REGULARIZATION
            * (ima + imb + 0.5 * (iia * ra.length_squared() + iib * rb.length_squared()))
    };
    let m = ima + imb + soft;
    let k11 = m + iia * pa.x * pa0.x + iib * pb.x * pb0.x;
    let k12 = iia * pa.x * pa0.y + iib * pb.x * pb0.y;
    let k21 = iia * pa.y * pa0.x + iib * pb.y * pb0.x;
    let k22 = m + iia * pa.y * pa0.y + iib * pb.y * pb0.y;
    let det = k11 * k22 - k12 * k21;
    if !(det.abs() > 1e-12) {
        return;
    }
    let rhs = -d - soft * *lambda;
    let p = Vec2::new(k22 * rhs.x - k12 * rhs.y, k11 * rhs.y - k21 * rhs.x) / det;
    *lambda += p;
    move_body(&mut bodies[a], -ima * p, -iia * cross(ra0, p));
    move_body(&mut bodies[b], imb * p, iib * cross(rb0, p));
}

/// The point of a hinge or weld projected: d = 0 with the joint's compliance (`soft` =
/// alpha~), its lambda in the point slots. Returns the joint's frame after.
#[inline]
pub(super) fn project_point(
    j: &Joint,
    bodies: &mut [Body],
    t: &Start,
    soft: f32,
    lambdas: &mut [f32; SLOTS],
) -> JointFrame {
    let f = j.frame(bodies);
    let mut lam = Vec2::new(lambdas[slot::POINT_X], lambdas[slot::POINT_Y]);
    point_correction(
        bodies, j.a, j.b, f.ra, f.rb, t.ra0, t.rb0, f.d, soft, &mut lam,
    );
    (lambdas[slot::POINT_X], lambdas[slot::POINT_Y]) = (lam.x, lam.y);
    j.frame(bodies)
}

/// The compliance alpha = w / omega^2 of the joint's spring on a row whose inverse
/// effective mass is `w` (k = m_eff omega^2), if it has a spring and the row moves
/// something.
#[inline]
pub(super) fn spring_compliance(j: &Joint, w: f32) -> Option<f32> {
    let sp = j.spring.filter(|sp| sp.hertz > 0.0)?;
    if !(w > 0.0) {
        return None;
    }
    let omega = std::f32::consts::TAU * sp.hertz;
    Some(w / (omega * omega))
}

/// XPBD angular correction of C (rad): delta lambda = (-C - alpha~ lambda) / (1/I_a + 1/I_b + alpha~).
#[inline]
pub(super) fn angular_correction(
    bodies: &mut [Body],
    a: usize,
    b: usize,
    c: f32,
    soft: f32,
    lambda: &mut f32,
) {
    let (iia, iib) = (bodies[a].inv_inertia, bodies[b].inv_inertia);
    let w = iia + iib;
    if w + soft <= 0.0 {
        return;
    }
    let dl = (-c - soft * *lambda) / (w + soft);
    *lambda += dl;
    move_body(&mut bodies[a], Vec2::ZERO, -iia * dl);
    move_body(&mut bodies[b], Vec2::ZERO, iib * dl);
}

/// Keeps the second anchor on the first body's axis line (prismatic, wheel): the
/// off-axis offset C = perp . d, corrected with compliance `soft`; `t` is the substep's
/// start.
#[inline]
pub(super) fn line_correction(
    j: &Joint,
    bodies: &mut [Body],
    t: &Start,
    soft: f32,
    lambda: &mut f32,
) {
    let f = j.frame(bodies);
    let perp = f.axis.perp();
    linear_correction(
        bodies,
        j.a,
        j.b,
        [f.ra + f.d, f.rb, perp],
        [t.ra0 + t.d0, t.rb0, t.axis0.perp()],
        perp.dot(f.d),
        soft,
        lambda,
    );
}

/// Limits and servo of a hinge (angle) or prismatic joint (offset along the axis):
/// `x` is the current value; `linear` carries the arms and axis of a prismatic joint.
pub(super) fn project_range(
    j: &Joint,
    bodies: &mut [Body],
    x: f32,
    lambdas: &mut [f32; SLOTS],
    linear: Option<([Vec2; 3], [Vec2; 3])>,
) {
    let correct = |bodies: &mut [Body], c: f32, lambda: &mut f32| match linear {
        Some((now, then)) => linear_correction(bodies, j.a, j.b, now, then, c, 0.0, lambda),
        None => angular_correction(bodies, j.a, j.b, c, 0.0, lambda),
    };
    if let Some([lo, hi]) = j.limits {
        if x < lo {
            correct(bodies, x - lo, &mut lambdas[slot::LOWER]);
        } else if x > hi {
            correct(bodies, x - hi, &mut lambdas[slot::UPPER]);
        }
    }
    if let Some(s) = j.servo {
        let c = if linear.is_some() {
            x - s.target
        } else {
            wrap_angle(x - s.target)
        };
        correct(bodies, c, &mut lambdas[slot::SERVO]);
    }
}

/// Shifts a body by dx and turns it by dtheta, keeping its rotation in step.
#[inline]
pub(crate) fn move_body(b: &mut Body, dx: Vec2, dtheta: f32) {
    // a static or kinematic body has zero inverse mass, but 0 x NaN is NaN: never touch it
    if !b.is_dynamic() {
        return;
    }
    b.position += dx;
    b.correction += dx;
    b.correction_angle += dtheta;
    if dtheta != 0.0 {
        b.angle += dtheta;
        b.rot = crate::math::Rot::from_angle(b.angle);
    }
}

/// What a joint's part of XPBD's velocity pass works on: the solver's velocities (a
/// motor is solved at once) and the damping rows (applied after every joint's motor).
pub(crate) struct VelocityPass<'a> {
    pub(super) bodies: &'a mut [SolverBody],
    damping: &'a mut Vec<(Row, f32)>,
    pub(super) a: u32,
    pub(super) b: u32,
    /// The joint's index.
    pub(super) joint: u32,
    /// The substep, and the world's step.
    pub(super) h: f32,
    pub(super) dt: f32,
}

impl Damping for VelocityPass<'_> {
    #[inline]
    fn damp(&mut self, r: Row, rate: f32) {
        let row = damping_row(r, self.bodies, self.h);
        self.damping.push((row, rate));
    }
}

impl VelocityPass<'_> {
    /// Solves the joint's motor (if any) on row r, once, its impulse bounded by max
    /// force times h.
    #[inline]
    pub(super) fn motor_of(&mut self, j: &Joint, r: Row) {
        if let Some(m) = j.motor {
            motor(r, self.bodies, m.speed, m.max_force, self.h).solve(self.bodies);
        }
    }

    /// A spring's damper along r (the wheel's suspension, a hinge's torsion spring),
    /// c = 2 m_eff zeta omega: a rate of 2 zeta omega.
    #[inline]
    pub(super) fn spring_damper(&mut self, j: &Joint, r: Row) {
        if let Some(sp) = j.spring.filter(|sp| sp.damping_ratio > 0.0) {
            let rate = 2.0 * sp.damping_ratio * std::f32::consts::TAU * sp.hertz;
            self.damp(r, rate);
        }
    }
}

/// XPBD's velocity pass for joints: motors (one row each, their impulse bounded by
/// max force times h), the motor joint, and damping, on the velocities derived from the
/// positions; `dt` is the world's step (the motor joint's correction is per step).
pub(crate) fn velocity_pass(
    joints: &[Joint],
    world_bodies: &[Body],
    bodies: &mut [SolverBody],
    (h, dt): (f32, f32),
    rows: &mut JointRows,
) {
    let damping = rows.damping_only();
    for (ji, j) in joints.iter().enumerate() {
        let spring_damped = j.spring.is_some_and(|sp| sp.damping_ratio > 0.0);
        if j.motor.is_none()
            && j.damping.linear <= 0.0
            && j.damping.angular <= 0.0
            && j.kind != crate::defs::JointKind::Motor
            && !spring_damped
        {
            continue;
        }
        let f = j.frame(world_bodies);
        let mut pass = VelocityPass {
            bodies: &mut *bodies,
            damping: &mut *damping,
            a: j.a as u32,
            b: j.b as u32,
            joint: ji as u32,
            h,
            dt,
        };
        j.xpbd_velocity(&f, &mut pass);
    }
    rows.damp(bodies, h);
}
