//! Hinges four at a time: the rows of four hinge joints of one colour (no two share a
//! moving body) solved in lock step in SIMD lanes, as the contacts are (Box2D v3 solves
//! its revolute joints one by one; here they take lanes like its contacts).
//!
//! A hinge's rows, in the order the scalar rows take them (`joints.rs`): a velocity
//! motor on the relative angle (|lambda| <= max torque h), the lower and upper angle
//! limits (speculative while open, soft once reached), then the point (a 2x2 block):
//! soft in the biased sweeps (`joint_hertz`, `joint_damping_ratio`), rigid in the relax
//! sweep. The arms turn with each body's rotation since the step's start, and the
//! anchor gap is brought up to date from the bodies' motion: d = d0 + (dp_b - dp_a) +
//! (r_b - r_b0) - (r_a - r_a0). A hinge with a servo, compliance, or anything else the
//! lanes do not hold is solved by the scalar rows in its colour instead.

use super::joints::Prepared;
#[allow(unused_imports)]
use super::*;
use crate::defs::JointKind;
use crate::joint::{SLOTS, slot};
use glam::BVec4A;

/// Four hinges of one colour.
#[derive(Clone, Copy, Debug)]
pub(super) struct WideHinge {
    /// Bodies read, per lane (the rest slot for an empty lane).
    a: [u32; 4],
    b: [u32; 4],
    /// Bodies written, per lane: the body, or the sink for a body the solver does not
    /// move.
    wa: [u32; 4],
    wb: [u32; 4],
    /// The joint in each lane (`u32::MAX`: empty).
    pub(super) joint: [u32; 4],
    ima: Vec4,
    iia: Vec4,
    imb: Vec4,
    iib: Vec4,
    /// 1/I_a + 1/I_b: the angular rows' K (0 where neither turns: no angular row).
    axial_k: Vec4,
    /// Arms from the centres of mass to the anchors, and the anchor gap, at the step's
    /// start; the relative angle less the reference then.
    ra0x: Vec4,
    ra0y: Vec4,
    rb0x: Vec4,
    rb0y: Vec4,
    d0x: Vec4,
    d0y: Vec4,
    angle0: Vec4,
    /// Limits (lanes without: none solved), and the motor (lanes without: none).
    has_limits: BVec4A,
    lower: Vec4,
    upper: Vec4,
    has_motor: BVec4A,
    motor_speed: Vec4,
    /// max torque h
    motor_max: Vec4,
    /// Lambdas: the point's, the limits', the motor's.
    px: Vec4,
    py: Vec4,
    lower_impulse: Vec4,
    upper_impulse: Vec4,
    motor_impulse: Vec4,
}

impl WideHinge {
    /// Four empty lanes: they read the rest slot, write the sink, and weigh nothing.
    pub(super) fn empty(rest: u32, sink: u32) -> WideHinge {
        WideHinge {
            a: [rest; 4],
            b: [rest; 4],
            wa: [sink; 4],
            wb: [sink; 4],
            joint: [u32::MAX; 4],
            ima: Vec4::ZERO,
            iia: Vec4::ZERO,
            imb: Vec4::ZERO,
            iib: Vec4::ZERO,
            axial_k: Vec4::ZERO,
            ra0x: Vec4::ZERO,
            ra0y: Vec4::ZERO,
            rb0x: Vec4::ZERO,
            rb0y: Vec4::ZERO,
            d0x: Vec4::ZERO,
            d0y: Vec4::ZERO,
            angle0: Vec4::ZERO,
            has_limits: BVec4A::FALSE,
            lower: Vec4::ZERO,
            upper: Vec4::ZERO,
            has_motor: BVec4A::FALSE,
            motor_speed: Vec4::ZERO,
            motor_max: Vec4::ZERO,
            px: Vec4::ZERO,
            py: Vec4::ZERO,
            lower_impulse: Vec4::ZERO,
            upper_impulse: Vec4::ZERO,
            motor_impulse: Vec4::ZERO,
        }
    }

    /// Puts joint `i` (its prepared rows `p`) in lane k. `moves`, `inv_mass`: the
    /// solver's; `sink`: where a body that does not move is written; `h`: the substep.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn set_lane(
        &mut self,
        k: usize,
        i: u32,
        p: &Prepared,
        moves: &[bool],
        inv_mass: &[(f32, f32)],
        sink: u32,
        h: f32,
    ) {
        let (a, b) = (p.a, p.b);
        self.a[k] = a as u32;
        self.b[k] = b as u32;
        self.wa[k] = if moves[a] { a as u32 } else { sink };
        self.wb[k] = if moves[b] { b as u32 } else { sink };
        self.joint[k] = i;
        let ((ima, iia), (imb, iib)) = (inv_mass[a], inv_mass[b]);
        self.ima[k] = ima;
        self.iia[k] = iia;
        self.imb[k] = imb;
        self.iib[k] = iib;
        // (as the scalar rows' J M^-1 J^T of the angle row: 0 + 1/I_a + 0 + 1/I_b)
        self.axial_k[k] = ima * 0.0 + iia + imb * 0.0 + iib;
        self.ra0x[k] = p.ra0.x;
        self.ra0y[k] = p.ra0.y;
        self.rb0x[k] = p.rb0.x;
        self.rb0y[k] = p.rb0.y;
        self.d0x[k] = p.d0.x;
        self.d0y[k] = p.d0.y;
        self.angle0[k] = p.angle0;
        if let Some([lo, hi]) = p.limits {
            self.has_limits.set(k, true);
            self.lower[k] = lo;
            self.upper[k] = hi;
        }
        if let Some(m) = p.motor {
            self.has_motor.set(k, true);
            self.motor_speed[k] = m.speed;
            self.motor_max[k] = m.max_force.max(0.0) * h;
        }
        let l = &p.impulses;
        self.px[k] = l[slot::POINT_X];
        self.py[k] = l[slot::POINT_Y];
        self.lower_impulse[k] = l[slot::LOWER];
        self.upper_impulse[k] = l[slot::UPPER];
        self.motor_impulse[k] = l[slot::MOTOR];
    }

    /// Lane k's lambdas, as the joint keeps them.
    pub(super) fn impulses(&self, k: usize, into: &mut [f32; SLOTS]) {
        into[slot::POINT_X] = self.px[k];
        into[slot::POINT_Y] = self.py[k];
        into[slot::LOWER] = self.lower_impulse[k];
        into[slot::UPPER] = self.upper_impulse[k];
        into[slot::MOTOR] = self.motor_impulse[k];
    }
}

/// Whether a joint takes a hinge's lanes: a rigid hinge with at most a motor and limits
/// (and not while a test has the lanes off: `testing::no_hinge_lanes`).
pub(super) fn takes_lanes(j: &Joint) -> bool {
    j.kind == JointKind::Hinge
        && j.compliance == 0.0
        && j.servo.is_none()
        && !testing::NO_HINGE_LANES.with(std::cell::Cell::get)
}

/// The bodies of four lanes, their velocities to be written back.
struct Lanes4 {
    vax: Vec4,
    vay: Vec4,
    wa: Vec4,
    vbx: Vec4,
    vby: Vec4,
    wb: Vec4,
}

/// The arms now: r = q r0, with q the rotation since the step's start.
#[inline(always)]
fn arms(qc: Vec4, qs: Vec4, x0: Vec4, y0: Vec4) -> (Vec4, Vec4) {
    (qc * x0 - qs * y0, qs * x0 + qc * y0)
}

/// Applies the point impulse (x, y) to both bodies at their arms (the scalar rows'
/// `apply_point`, to the bit).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn apply_point(
    c: &WideHinge,
    v: &mut Lanes4,
    rax: Vec4,
    ray: Vec4,
    rbx: Vec4,
    rby: Vec4,
    x: Vec4,
    y: Vec4,
) {
    v.vax -= c.ima * x;
    v.vay -= c.ima * y;
    v.wa -= c.iia * (rax * y - ray * x);
    v.vbx += c.imb * x;
    v.vby += c.imb * y;
    v.wb += c.iib * (rbx * y - rby * x);
}

/// Applies the angular impulse `d` (J v = w_b - w_a) to both bodies.
#[inline(always)]
fn apply_angular(c: &WideHinge, v: &mut Lanes4, d: Vec4) {
    v.wa -= c.iia * d;
    v.wb += c.iib * d;
}

/// Applies four hinges' lambdas (the start of each substep).
pub(super) fn warm_start_hinges<const SHARED: bool>(hinges: &[WideHinge], bodies: BodyPtr) {
    for c in hinges {
        let (a, b) = (
            WideBody::gather(bodies, &c.a),
            WideBody::gather(bodies, &c.b),
        );
        let (rax, ray) = arms(a.qc, a.qs, c.ra0x, c.ra0y);
        let (rbx, rby) = arms(b.qc, b.qs, c.rb0x, c.rb0y);
        let mut v = Lanes4 {
            vax: a.vx,
            vay: a.vy,
            wa: a.w,
            vbx: b.vx,
            vby: b.vy,
            wb: b.w,
        };
        apply_point(c, &mut v, rax, ray, rbx, rby, c.px, c.py);
        // every angular row has J v = w_b - w_a (the upper limit's negated)
        apply_angular(
            c,
            &mut v,
            c.motor_impulse + c.lower_impulse - c.upper_impulse,
        );
        WideBody::scatter_velocities::<SHARED>(v.vax, v.vay, v.wa, a.dtheta, bodies, &c.wa);
        WideBody::scatter_velocities::<SHARED>(v.vbx, v.vby, v.wb, b.dtheta, bodies, &c.wb);
    }
}

/// One sweep over four hinges' rows at a time: with `BIAS` the soft rows (`soft`, the
/// step's joint softness), without the rigid relax rows. Returns the largest |delta
/// lambda|.
pub(super) fn solve_hinges<const BIAS: bool, const SHARED: bool>(
    hinges: &mut [WideHinge],
    bodies: BodyPtr,
    soft: &Softness,
    inv_h: f32,
) -> f32 {
    let zero = Vec4::ZERO;
    let inv_h = Vec4::splat(inv_h);
    let (bias_rate, mass_scale, impulse_scale) = if BIAS {
        (
            Vec4::splat(soft.bias_rate),
            Vec4::splat(soft.mass_scale),
            Vec4::splat(soft.impulse_scale),
        )
    } else {
        (zero, Vec4::ONE, zero)
    };
    let mut residual = zero;
    for c in hinges {
        let (a, b) = (
            WideBody::gather(bodies, &c.a),
            WideBody::gather(bodies, &c.b),
        );
        let mut v = Lanes4 {
            vax: a.vx,
            vay: a.vy,
            wa: a.w,
            vbx: b.vx,
            vby: b.vy,
            wb: b.w,
        };
        // (no angular row where neither body turns)
        let turns = c.axial_k.cmpgt(zero);
        // the motor: w_b - w_a = speed, |lambda| <= max torque h
        if c.has_motor.any() {
            let old = c.motor_impulse;
            let new =
                (old - (v.wb - v.wa - c.motor_speed) / c.axial_k).clamp(-c.motor_max, c.motor_max);
            let live = c.has_motor & turns;
            c.motor_impulse = Vec4::select(live, new, old);
            let d = Vec4::select(live, new - old, zero);
            apply_angular(c, &mut v, d);
            residual = residual.max(d.abs());
        }
        // the limits: angle - lower >= 0 and upper - angle >= 0
        if c.has_limits.any() {
            let angle = c.angle0 + b.dtheta - a.dtheta;
            for upper in [false, true] {
                let (cval, old) = if upper {
                    (c.upper - angle, c.upper_impulse)
                } else {
                    (angle - c.lower, c.lower_impulse)
                };
                // (the upper row's Jacobian is the lower's negated)
                let jv = if upper { v.wa - v.wb } else { v.wb - v.wa };
                // speculative while open (C / h), soft once reached (rigid in relax)
                let open = cval.cmpgt(zero);
                let bias = Vec4::select(open, cval * inv_h, bias_rate * cval);
                let ms = Vec4::select(open, Vec4::ONE, mass_scale);
                let is = Vec4::select(open, zero, impulse_scale);
                let d = -(ms / c.axial_k) * (jv + bias) - is * old;
                let new = (old + d).max(zero);
                let live = c.has_limits & turns;
                let new = Vec4::select(live, new, old);
                let d = Vec4::select(live, new - old, zero);
                apply_angular(c, &mut v, if upper { -d } else { d });
                if upper {
                    c.upper_impulse = new;
                } else {
                    c.lower_impulse = new;
                }
                residual = residual.max(d.abs());
            }
        }
        // the point: K d = -(C' + bias C), a 2x2 block
        let (rax, ray) = arms(a.qc, a.qs, c.ra0x, c.ra0y);
        let (rbx, rby) = arms(b.qc, b.qs, c.rb0x, c.rb0y);
        let cdx = v.vbx - v.wb * rby - v.vax + v.wa * ray;
        let cdy = v.vby + v.wb * rbx - v.vay - v.wa * rax;
        let (rhsx, rhsy) = if BIAS {
            // d = d0 + (dp_b - dp_a) + (r_b - r_b0) - (r_a - r_a0)
            let dx = c.d0x + (b.dpx - a.dpx) + (rbx - c.rb0x) - (rax - c.ra0x);
            let dy = c.d0y + (b.dpy - a.dpy) + (rby - c.rb0y) - (ray - c.ra0y);
            (cdx + bias_rate * dx, cdy + bias_rate * dy)
        } else {
            (cdx, cdy)
        };
        let m = c.ima + c.imb;
        let k11 = m + c.iia * ray * ray + c.iib * rby * rby;
        let k12 = -c.iia * rax * ray - c.iib * rbx * rby;
        let k22 = m + c.iia * rax * rax + c.iib * rbx * rbx;
        let det = k11 * k22 - k12 * k12;
        // (a singular K, both bodies unmoved: no impulse)
        let inv = Vec4::select(
            det.abs().cmpgt(Vec4::splat(f32::MIN_POSITIVE)),
            Vec4::ONE / det,
            zero,
        );
        let sx = inv * (k22 * rhsx - k12 * rhsy);
        let sy = inv * (k11 * rhsy - k12 * rhsx);
        let dx = -mass_scale * sx - impulse_scale * c.px;
        let dy = -mass_scale * sy - impulse_scale * c.py;
        c.px += dx;
        c.py += dy;
        apply_point(c, &mut v, rax, ray, rbx, rby, dx, dy);
        residual = residual.max(dx.abs().max(dy.abs()));
        WideBody::scatter_velocities::<SHARED>(v.vax, v.vay, v.wa, a.dtheta, bodies, &c.wa);
        WideBody::scatter_velocities::<SHARED>(v.vbx, v.vby, v.wb, b.dtheta, bodies, &c.wb);
    }
    residual.max_element()
}
