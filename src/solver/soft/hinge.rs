//! Hinges four at a time: the rows of four hinge joints of one colour (no two share a
//! moving body) solved in lock step in SIMD lanes, as the contacts are (Box2D v3 solves
//! its revolute joints one by one; here they take lanes like its contacts).
//!
//! The lanes are a layout of this solver's, not a kind of joint: they are filled and
//! swept beside the contacts' lanes, colour by colour, so they live with them here
//! rather than with the hinge in `crate::joint::hinge`, which holds the same rows one
//! joint at a time (and solves the hinges the lanes do not take). The lanes read and
//! write the bodies through the solver's own pointers in the same passes as the contact
//! lanes; routing them through the joint's file would put a call and a copy of the pair
//! in the sweep's hottest loop on a joint grid.
//!
//! A hinge's rows, in the order the scalar rows take them: a torsion
//! spring to its zero angle (soft, its own hertz and damping ratio), a velocity
//! motor on the relative angle (|lambda| <= max torque h), the lower and upper angle
//! limits (speculative while open, soft once reached), then the point (a 2x2 block):
//! soft in the biased sweeps (`joint_hertz`, `joint_damping_ratio`), rigid in the relax
//! sweep. The arms turn with each body's rotation since the step's start, and the
//! anchor gap is brought up to date from the bodies' motion: d = d0 + (dp_b - dp_a) +
//! (r_b - r_b0) - (r_a - r_a0). A hinge with a servo, compliance, or anything else the
//! lanes do not hold is solved by the scalar rows in its colour instead.

#[allow(unused_imports)]
use super::*;
use crate::body::Body;
use crate::defs::JointKind;
use crate::joint::{JointFrame, SLOTS, slot};
use glam::BVec4A;

/// Four hinges of one colour: what every sweep reads (the rows of limits and motors, which
/// few hinges have, lie apart in [`HingeRows`], read only where `rows` says so).
#[derive(Clone, Copy, Debug)]
pub(super) struct WideHinge {
    /// Bodies read, per lane (the rest slot for an empty lane).
    a: [u32; 4],
    b: [u32; 4],
    /// Bodies written, per lane: the body, or the sink for a body the solver does not
    /// move.
    wa: [u32; 4],
    wb: [u32; 4],
    ima: Vec4,
    iia: Vec4,
    imb: Vec4,
    iib: Vec4,
    /// Arms from the centres of mass to the anchors, and the anchor gap, at the step's
    /// start.
    ra0x: Vec4,
    ra0y: Vec4,
    rb0x: Vec4,
    rb0y: Vec4,
    d0x: Vec4,
    d0y: Vec4,
    /// The point's lambda.
    px: Vec4,
    py: Vec4,
    /// Whether some lane has a limit, a motor or a spring (its [`HingeRows`] then
    /// count).
    rows: bool,
}

/// The angular rows of four hinges: the spring, the limits and the motor.
#[derive(Clone, Copy, Debug)]
pub(super) struct HingeRows {
    /// 1/I_a + 1/I_b: the angular rows' K (0 where neither turns: no angular row).
    axial_k: Vec4,
    /// The relative angle less the reference at the step's start.
    angle0: Vec4,
    has_limits: BVec4A,
    lower: Vec4,
    upper: Vec4,
    has_motor: BVec4A,
    motor_speed: Vec4,
    /// max torque h
    motor_max: Vec4,
    lower_impulse: Vec4,
    upper_impulse: Vec4,
    motor_impulse: Vec4,
    has_spring: BVec4A,
    /// The spring's softness at the substep (bias rate, mass scale, impulse scale).
    spring_bias: Vec4,
    spring_mass: Vec4,
    spring_scale: Vec4,
    spring_impulse: Vec4,
}

/// The joint in each lane of four hinges (`u32::MAX`: empty), whose anchors, limits,
/// motor, spring and lambdas are read anew every step while the layout holds (a joint
/// may be changed, or replaced by another between the same bodies, between steps).
#[derive(Clone, Copy, Debug)]
pub(super) struct HingeFrames {
    joint: [u32; 4],
}

impl Default for HingeFrames {
    fn default() -> Self {
        HingeFrames {
            joint: [u32::MAX; 4],
        }
    }
}

impl Default for HingeRows {
    fn default() -> Self {
        HingeRows {
            axial_k: Vec4::ZERO,
            angle0: Vec4::ZERO,
            has_limits: BVec4A::FALSE,
            lower: Vec4::ZERO,
            upper: Vec4::ZERO,
            has_motor: BVec4A::FALSE,
            motor_speed: Vec4::ZERO,
            motor_max: Vec4::ZERO,
            lower_impulse: Vec4::ZERO,
            upper_impulse: Vec4::ZERO,
            motor_impulse: Vec4::ZERO,
            has_spring: BVec4A::FALSE,
            spring_bias: Vec4::ZERO,
            spring_mass: Vec4::ZERO,
            spring_scale: Vec4::ZERO,
            spring_impulse: Vec4::ZERO,
        }
    }
}

impl super::schedule::Lanes for WideHinge {
    fn written(&self) -> (&[u32; 4], &[u32; 4]) {
        (&self.wa, &self.wb)
    }
}

impl WideHinge {
    /// Four empty lanes: they read the rest slot, write the sink, and weigh nothing.
    pub(super) fn empty(rest: u32, sink: u32) -> WideHinge {
        WideHinge {
            a: [rest; 4],
            b: [rest; 4],
            wa: [sink; 4],
            wb: [sink; 4],
            ima: Vec4::ZERO,
            iia: Vec4::ZERO,
            imb: Vec4::ZERO,
            iib: Vec4::ZERO,
            ra0x: Vec4::ZERO,
            ra0y: Vec4::ZERO,
            rb0x: Vec4::ZERO,
            rb0y: Vec4::ZERO,
            d0x: Vec4::ZERO,
            d0y: Vec4::ZERO,
            px: Vec4::ZERO,
            py: Vec4::ZERO,
            rows: false,
        }
    }

    /// The four lanes of the joints `idx` of `joints` (`u32::MAX`: an empty lane), their
    /// geometry taken from the bodies now (the step's start) and their lambdas from the
    /// joints if `warm`. `moves`, `inv_mass`: the solver's; `rest`, `sink`: where an
    /// empty lane reads and a body that does not move is written; `h`: the substep.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn fill(
        idx: &[u32; 4],
        joints: &[Joint],
        bodies: &[Body],
        moves: &[bool],
        inv_mass: &[(f32, f32)],
        (rest, sink): (u32, u32),
        h: f32,
        warm: bool,
    ) -> (WideHinge, HingeRows, HingeFrames) {
        let mut c = WideHinge::empty(rest, sink);
        let (mut r, mut f) = (HingeRows::default(), HingeFrames::default());
        for (k, &i) in idx.iter().enumerate() {
            if i == u32::MAX {
                continue;
            }
            let j = &joints[i as usize];
            let (a, b) = (j.a, j.b);
            c.a[k] = a as u32;
            c.b[k] = b as u32;
            c.wa[k] = if moves[a] { a as u32 } else { sink };
            c.wb[k] = if moves[b] { b as u32 } else { sink };
        }
        f.joint = *idx;
        c.refresh(&mut r, &f, joints, bodies, inv_mass, h, warm);
        (c, r, f)
    }

    /// Takes the four lanes' geometry and masses from the bodies as they are now (the
    /// step's start), and from their joints (`f`'s) the anchors, limits, motors,
    /// springs (`h`: the substep) and, if `warm`, the lambdas (else zero). What
    /// [`WideHinge::fill`] gives, to the bit, while the joints' bodies and which of them
    /// move stay as they were.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn refresh(
        &mut self,
        r: &mut HingeRows,
        f: &HingeFrames,
        joints: &[Joint],
        bodies: &[Body],
        inv_mass: &[(f32, f32)],
        h: f32,
        warm: bool,
    ) {
        self.rows = false;
        (r.has_limits, r.has_motor, r.has_spring) = (BVec4A::FALSE, BVec4A::FALSE, BVec4A::FALSE);
        for k in 0..4 {
            let Some(j) = joints.get(f.joint[k] as usize) else {
                continue;
            };
            if let Some([lo, hi]) = j.limits {
                r.has_limits.set(k, true);
                r.lower[k] = lo;
                r.upper[k] = hi;
                self.rows = true;
            }
            if let Some(m) = j.motor {
                r.has_motor.set(k, true);
                r.motor_speed[k] = m.speed;
                r.motor_max[k] = m.max_force.max(0.0) * h;
                self.rows = true;
            }
            if let Some(sp) = j.spring.filter(|sp| sp.hertz > 0.0) {
                // (as the scalar rows' spring)
                let soft = Softness::new(sp.hertz, sp.damping_ratio.max(0.0), h);
                r.has_spring.set(k, true);
                r.spring_bias[k] = soft.bias_rate;
                r.spring_mass[k] = soft.mass_scale;
                r.spring_scale[k] = soft.impulse_scale;
                self.rows = true;
            }
        }
        for k in 0..4 {
            let (a, b) = (self.a[k] as usize, self.b[k] as usize);
            if a >= bodies.len() {
                // (an empty lane reads the rest slot)
                continue;
            }
            let j = &joints[f.joint[k] as usize];
            let g = JointFrame::of(
                &bodies[a],
                &bodies[b],
                j.local_a,
                j.local_b,
                j.ref_angle,
                Vec2::X,
            );
            let l = if warm { j.impulses } else { [0.0; SLOTS] };
            self.px[k] = l[slot::POINT_X];
            self.py[k] = l[slot::POINT_Y];
            r.lower_impulse[k] = l[slot::LOWER];
            r.upper_impulse[k] = l[slot::UPPER];
            r.motor_impulse[k] = l[slot::MOTOR];
            r.spring_impulse[k] = l[slot::SPRING];
            let ((ima, iia), (imb, iib)) = (inv_mass[a], inv_mass[b]);
            self.ima[k] = ima;
            self.iia[k] = iia;
            self.imb[k] = imb;
            self.iib[k] = iib;
            self.ra0x[k] = g.ra.x;
            self.ra0y[k] = g.ra.y;
            self.rb0x[k] = g.rb.x;
            self.rb0y[k] = g.rb.y;
            self.d0x[k] = g.d.x;
            self.d0y[k] = g.d.y;
            // (as the scalar rows' J M^-1 J^T of the angle row: 0 + 1/I_a + 0 + 1/I_b)
            r.axial_k[k] = ima * 0.0 + iia + imb * 0.0 + iib;
            r.angle0[k] = g.angle;
        }
    }

    /// Lane k's lambdas, as the joint keeps them.
    pub(super) fn impulses(&self, rows: &HingeRows, k: usize, into: &mut [f32; SLOTS]) {
        into[slot::POINT_X] = self.px[k];
        into[slot::POINT_Y] = self.py[k];
        into[slot::LOWER] = rows.lower_impulse[k];
        into[slot::UPPER] = rows.upper_impulse[k];
        into[slot::MOTOR] = rows.motor_impulse[k];
        into[slot::SPRING] = rows.spring_impulse[k];
    }
}

/// Whether a joint takes a hinge's lanes: a rigid hinge with at most a spring, a motor
/// and limits (no servo, compliance or damping).
pub(super) fn takes_lanes(j: &Joint) -> bool {
    j.kind == JointKind::Hinge
        && j.compliance == 0.0
        && j.servo.is_none()
        && j.damping.linear <= 0.0
        && j.damping.angular <= 0.0
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

impl Lanes4 {
    fn of(a: &WideBody, b: &WideBody) -> Lanes4 {
        Lanes4 {
            vax: a.vx,
            vay: a.vy,
            wa: a.w,
            vbx: b.vx,
            vby: b.vy,
            wb: b.w,
        }
    }
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

/// Applies four hinges' lambdas at a time (the start of each substep); `rows` lie beside
/// `hinges`.
pub(super) fn warm_start_hinges<const SHARED: bool>(
    hinges: &[WideHinge],
    rows: &[HingeRows],
    bodies: BodyPtr,
) {
    for (c, r) in hinges.iter().zip(rows) {
        let (a, b) = (
            WideBody::gather(bodies, &c.a),
            WideBody::gather(bodies, &c.b),
        );
        let (rax, ray) = arms(a.qc, a.qs, c.ra0x, c.ra0y);
        let (rbx, rby) = arms(b.qc, b.qs, c.rb0x, c.rb0y);
        let mut v = Lanes4::of(&a, &b);
        apply_point(c, &mut v, rax, ray, rbx, rby, c.px, c.py);
        if c.rows {
            // every angular row has J v = w_b - w_a (the upper limit's negated)
            apply_angular(
                c,
                &mut v,
                r.motor_impulse + r.spring_impulse + r.lower_impulse - r.upper_impulse,
            );
        }
        WideBody::scatter_velocities::<SHARED>(v.vax, v.vay, v.wa, a.dtheta, bodies, &c.wa);
        WideBody::scatter_velocities::<SHARED>(v.vbx, v.vby, v.wb, b.dtheta, bodies, &c.wb);
    }
}

/// The constants of a hinge sweep.
struct HingeConsts {
    inv_h: Vec4,
    bias_rate: Vec4,
    mass_scale: Vec4,
    impulse_scale: Vec4,
}

impl HingeConsts {
    /// With `bias` the soft rows' (`soft`), without the rigid relax rows'.
    fn new(bias: bool, soft: &Softness, inv_h: f32) -> HingeConsts {
        let (bias_rate, mass_scale, impulse_scale) = if bias {
            (
                Vec4::splat(soft.bias_rate),
                Vec4::splat(soft.mass_scale),
                Vec4::splat(soft.impulse_scale),
            )
        } else {
            (Vec4::ZERO, Vec4::ONE, Vec4::ZERO)
        };
        HingeConsts {
            inv_h: Vec4::splat(inv_h),
            bias_rate,
            mass_scale,
            impulse_scale,
        }
    }
}

/// Four hinges' spring, motor and limit rows; returns the largest |delta lambda| per lane.
#[inline(always)]
fn angular_rows(
    c: &WideHinge,
    r: &mut HingeRows,
    v: &mut Lanes4,
    angle: Vec4,
    k: &HingeConsts,
) -> Vec4 {
    let zero = Vec4::ZERO;
    let mut residual = zero;
    // (no angular row where neither body turns)
    let turns = r.axial_k.cmpgt(zero);
    // the spring: soft, to the zero angle
    if r.has_spring.any() {
        let old = r.spring_impulse;
        let d = -(r.spring_mass / r.axial_k) * (v.wb - v.wa + r.spring_bias * angle)
            - r.spring_scale * old;
        let live = r.has_spring & turns;
        r.spring_impulse = Vec4::select(live, old + d, old);
        let d = Vec4::select(live, d, zero);
        apply_angular(c, v, d);
        residual = residual.max(d.abs());
    }
    // the motor: w_b - w_a = speed, |lambda| <= max torque h
    if r.has_motor.any() {
        let old = r.motor_impulse;
        let new =
            (old - (v.wb - v.wa - r.motor_speed) / r.axial_k).clamp(-r.motor_max, r.motor_max);
        let live = r.has_motor & turns;
        r.motor_impulse = Vec4::select(live, new, old);
        let d = Vec4::select(live, new - old, zero);
        apply_angular(c, v, d);
        residual = residual.max(d.abs());
    }
    // the limits: angle - lower >= 0 and upper - angle >= 0
    if r.has_limits.any() {
        for upper in [false, true] {
            let (cval, old) = if upper {
                (r.upper - angle, r.upper_impulse)
            } else {
                (angle - r.lower, r.lower_impulse)
            };
            // (the upper row's Jacobian is the lower's negated)
            let jv = if upper { v.wa - v.wb } else { v.wb - v.wa };
            // speculative while open (C / h), soft once reached (rigid in relax)
            let open = cval.cmpgt(zero);
            let bias = Vec4::select(open, cval * k.inv_h, k.bias_rate * cval);
            let ms = Vec4::select(open, Vec4::ONE, k.mass_scale);
            let is = Vec4::select(open, zero, k.impulse_scale);
            let d = -(ms / r.axial_k) * (jv + bias) - is * old;
            let new = (old + d).max(zero);
            let live = r.has_limits & turns;
            let new = Vec4::select(live, new, old);
            let d = Vec4::select(live, new - old, zero);
            apply_angular(c, v, if upper { -d } else { d });
            if upper {
                r.upper_impulse = new;
            } else {
                r.lower_impulse = new;
            }
            residual = residual.max(d.abs());
        }
    }
    residual
}

/// One sweep over four hinges' rows at a time (`rows` lie beside `hinges`): with `BIAS`
/// the soft rows (`soft`, the step's joint softness), without the rigid relax rows.
/// Returns the largest |delta lambda|.
pub(super) fn solve_hinges<const BIAS: bool, const SHARED: bool>(
    hinges: &mut [WideHinge],
    rows: &mut [HingeRows],
    bodies: BodyPtr,
    soft: &Softness,
    inv_h: f32,
) -> f32 {
    let k = HingeConsts::new(BIAS, soft, inv_h);
    let zero = Vec4::ZERO;
    let mut residual = zero;
    for (c, r) in hinges.iter_mut().zip(rows) {
        let (a, b) = (
            WideBody::gather(bodies, &c.a),
            WideBody::gather(bodies, &c.b),
        );
        let mut v = Lanes4::of(&a, &b);
        if c.rows {
            let angle = r.angle0 + b.dtheta - a.dtheta;
            residual = residual.max(angular_rows(c, r, &mut v, angle, &k));
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
            (cdx + k.bias_rate * dx, cdy + k.bias_rate * dy)
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
        let dx = -k.mass_scale * sx - k.impulse_scale * c.px;
        let dy = -k.mass_scale * sy - k.impulse_scale * c.py;
        c.px += dx;
        c.py += dy;
        apply_point(c, &mut v, rax, ray, rbx, rby, dx, dy);
        residual = residual.max(dx.abs().max(dy.abs()));
        WideBody::scatter_velocities::<SHARED>(v.vax, v.vay, v.wa, a.dtheta, bodies, &c.wa);
        WideBody::scatter_velocities::<SHARED>(v.vbx, v.vby, v.wb, b.dtheta, bodies, &c.wb);
    }
    residual.max_element()
}
