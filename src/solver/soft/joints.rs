//! Joint rows of the soft step (the scheme of Box2D v3's soft step, written for this
//! project): every joint of [`crate::joint`] and the mouse joint, solved beside the soft
//! contacts on the same substep velocities.
//!
//! The geometry is taken once per step (the arms `r0`, the anchor gap `d0`, the axis
//! and the relative angle at the step's start) and brought up to date in every sweep
//! from each body's motion since then: r = q r0, d = d0 + (dp_b - dp_a) + (r_b - r_b0)
//! - (r_a - r_a0), angle = angle0 + dtheta_b - dtheta_a. So a row always sees its
//!   current error without re-collecting positions.
//!
//! A rigid row (compliance 0) is soft in the biased sweeps (a spring-damper of
//! `joint_hertz` and `joint_damping_ratio`: lambda += -m s_m (J v + rate C) - s_i lambda,
//! see [`Softness`]) and rigid in the relax sweep (lambda += -m J v), which removes the
//! speed the spring's push-out left. A compliant row (compliance alpha) is XPBD's
//! implicit spring written for impulses in both sweeps:
//! (K + alpha/h^2) dlambda = -(J v + C/h + alpha/h^2 lambda), so a compliance means what
//! it means under the other solvers. A limit is speculative while open (J v >= -C/h) and
//! soft once reached. Motors are velocity rows bounded by max force times h; a servo is a
//! rigid equality on the angle (offset) error. Lambdas are impulses per substep; they
//! carry from substep to substep and, through the joint, to the next step (warm start).

use super::{BodyPtr, SoftBody, Softness};
use crate::parallel::{self, Pool};

/// Joints per block of a parallel pass over the joints.
const JOINT_BLOCK: usize = 512;
use crate::body::Body;
use crate::defs::{JointKind, SolverSettings};
use crate::joint::{Joint, MouseJoint, PulleyRopes, SLOTS, slot, wrap_angle};
use crate::math::{Vec2, cross, cross_sv};

/// A joint's geometry at the step's start and its lambdas.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Prepared {
    pub(super) a: usize,
    pub(super) b: usize,
    /// Arms from the centres of mass to the anchors, world frame, at the step's start.
    pub(super) ra0: Vec2,
    pub(super) rb0: Vec2,
    /// Anchor gap p_b - p_a at the step's start.
    pub(super) d0: Vec2,
    /// World axis at the step's start (prismatic; it turns with a).
    axis0: Vec2,
    /// theta_b - theta_a - ref at the step's start.
    pub(super) angle0: f32,
    /// Pulley: anchor less ground point, each side, at the step's start.
    ea0: Vec2,
    eb0: Vec2,
    /// Wheel: the suspension's softness (Box2D's soft constraint for its own hertz and
    /// damping ratio; the same in both sweeps).
    spring: Option<Softness>,
    pub(super) impulses: [f32; SLOTS],
}

/// The mouse joint, prepared: a soft point between a body's point and the target.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PreparedMouse {
    body: usize,
    rb0: Vec2,
    /// point - target at the step's start.
    c0: Vec2,
    soft: Softness,
    max_impulse: f32,
    impulse: Vec2,
}

/// The current geometry of a joint.
#[derive(Clone, Copy, Debug)]
struct Geometry {
    ra: Vec2,
    rb: Vec2,
    d: Vec2,
    axis: Vec2,
    angle: f32,
}

/// A scalar row's Jacobian: J v = la . v_a + ka w_a + lb . v_b + kb w_b.
#[derive(Clone, Copy, Debug)]
struct Jac {
    la: Vec2,
    ka: f32,
    lb: Vec2,
    kb: f32,
}

impl Jac {
    /// w_b - w_a
    fn angle() -> Jac {
        Jac {
            la: Vec2::ZERO,
            ka: -1.0,
            lb: Vec2::ZERO,
            kb: 1.0,
        }
    }

    /// e . (v_b + w_b x r_b - v_a - w_a x r_a)
    fn linear(ra: Vec2, rb: Vec2, e: Vec2) -> Jac {
        Jac {
            la: -e,
            ka: -cross(ra, e),
            lb: e,
            kb: cross(rb, e),
        }
    }

    /// A pulley: d/dt (length - len_a - r len_b).
    fn pulley(p: &PulleyRopes, ratio: f32) -> Jac {
        Jac {
            la: -p.ua,
            ka: -cross(p.ra, p.ua),
            lb: -ratio * p.ub,
            kb: -ratio * cross(p.rb, p.ub),
        }
    }

    fn negated(self) -> Jac {
        Jac {
            la: -self.la,
            ka: -self.ka,
            lb: -self.lb,
            kb: -self.kb,
        }
    }
}

/// The two bodies of a joint during a solve, with their inverse masses.
struct Pair {
    a: SoftBody,
    b: SoftBody,
    ima: f32,
    iia: f32,
    imb: f32,
    iib: f32,
}

impl Pair {
    /// J M^-1 J^T
    #[inline]
    fn k(&self, j: &Jac) -> f32 {
        self.ima * j.la.length_squared()
            + self.iia * j.ka * j.ka
            + self.imb * j.lb.length_squared()
            + self.iib * j.kb * j.kb
    }

    #[inline]
    fn jv(&self, j: &Jac) -> f32 {
        j.la.dot(self.a.v) + j.ka * self.a.w + j.lb.dot(self.b.v) + j.kb * self.b.w
    }

    /// v += M^-1 J^T lambda
    #[inline]
    fn apply(&mut self, j: &Jac, lambda: f32) {
        self.a.v += self.ima * lambda * j.la;
        self.a.w += self.iia * lambda * j.ka;
        self.b.v += self.imb * lambda * j.lb;
        self.b.w += self.iib * lambda * j.kb;
    }

    /// A point impulse p on b at rb and -p on a at ra.
    #[inline]
    fn apply_point(&mut self, ra: Vec2, rb: Vec2, p: Vec2) {
        self.a.v -= self.ima * p;
        self.a.w -= self.iia * cross(ra, p);
        self.b.v += self.imb * p;
        self.b.w += self.iib * cross(rb, p);
    }

    /// (v_b + w_b x r_b) - (v_a + w_a x r_a)
    #[inline]
    fn point_velocity(&self, ra: Vec2, rb: Vec2) -> Vec2 {
        self.b.v + cross_sv(self.b.w, rb) - self.a.v - cross_sv(self.a.w, ra)
    }

    /// The 2x2 K = M_a^-1 + M_b^-1 of a point between arms ra and rb, plus gamma on the
    /// diagonal, solved for rhs (zero where K is singular).
    #[inline]
    fn solve_point(&self, ra: Vec2, rb: Vec2, gamma: f32, rhs: Vec2) -> Vec2 {
        let m = self.ima + self.imb;
        let k11 = m + self.iia * ra.y * ra.y + self.iib * rb.y * rb.y + gamma;
        let k12 = -self.iia * ra.x * ra.y - self.iib * rb.x * rb.y;
        let k22 = m + self.iia * ra.x * ra.x + self.iib * rb.x * rb.x + gamma;
        let det = k11 * k22 - k12 * k12;
        if det.abs() <= f32::MIN_POSITIVE {
            return Vec2::ZERO;
        }
        let inv = 1.0 / det;
        Vec2::new(
            inv * (k22 * rhs.x - k12 * rhs.y),
            inv * (k11 * rhs.y - k12 * rhs.x),
        )
    }
}

/// How a row is softened in this sweep.
#[derive(Clone, Copy, Debug)]
pub(super) struct Sweep {
    /// The biased (soft) sweep, or the relax sweep.
    bias: bool,
    /// Rigid rows in the biased sweep.
    soft: Softness,
    h: f32,
    inv_h: f32,
    /// 1 / the world's step: the motor joint corrects its share of the error per step.
    inv_dt: f32,
}

impl Sweep {
    /// An equality row C = 0 with compliance alpha: returns the new lambda.
    #[inline]
    fn equality(&self, p: &mut Pair, j: &Jac, c: f32, compliance: f32, lambda: &mut f32) -> f32 {
        let k = p.k(j);
        let d = if compliance > 0.0 {
            // (K + alpha/h^2) dlambda = -(J v + C/h + alpha/h^2 lambda)
            let gamma = compliance * self.inv_h * self.inv_h;
            -(p.jv(j) + c * self.inv_h + gamma * *lambda) / (k + gamma)
        } else if k <= 0.0 {
            0.0
        } else if self.bias {
            // soft: -m s_m (J v + rate C) - s_i lambda
            -(self.soft.mass_scale / k) * (p.jv(j) + self.soft.bias_rate * c)
                - self.soft.impulse_scale * *lambda
        } else {
            -p.jv(j) / k
        };
        *lambda += d;
        p.apply(j, d);
        d.abs()
    }

    /// An inequality row C >= 0, lambda >= 0: speculative while open, soft once reached.
    #[inline]
    fn inequality(&self, p: &mut Pair, j: &Jac, c: f32, lambda: &mut f32) -> f32 {
        let k = p.k(j);
        if k <= 0.0 {
            return 0.0;
        }
        let (bias, ms, is) = if c > 0.0 {
            (c * self.inv_h, 1.0, 0.0)
        } else if self.bias {
            (
                self.soft.bias_rate * c,
                self.soft.mass_scale,
                self.soft.impulse_scale,
            )
        } else {
            (0.0, 1.0, 0.0)
        };
        let d = -(ms / k) * (p.jv(j) + bias) - is * *lambda;
        let new = (*lambda + d).max(0.0);
        let d = new - *lambda;
        *lambda = new;
        p.apply(j, d);
        d.abs()
    }

    /// A motor row: J v = speed with |lambda| <= max force h.
    #[inline]
    fn motor(&self, p: &mut Pair, j: &Jac, speed: f32, max_force: f32, lambda: &mut f32) -> f32 {
        let k = p.k(j);
        if k <= 0.0 {
            return 0.0;
        }
        let max = max_force * self.h;
        let new = (*lambda - (p.jv(j) - speed) / k).clamp(-max, max);
        let d = new - *lambda;
        *lambda = new;
        p.apply(j, d);
        d.abs()
    }

    /// A spring row C = 0 with its own softness (both sweeps alike).
    #[inline]
    fn spring(&self, p: &mut Pair, j: &Jac, c: f32, soft: &Softness, lambda: &mut f32) -> f32 {
        let k = p.k(j);
        if k <= 0.0 {
            return 0.0;
        }
        let d =
            -(soft.mass_scale / k) * (p.jv(j) + soft.bias_rate * c) - soft.impulse_scale * *lambda;
        *lambda += d;
        p.apply(j, d);
        d.abs()
    }

    /// The motor joint: the angle error and the point error d (b's centre less its
    /// target) driven out at `correction` per step, the torque and force bounded.
    #[inline]
    fn motor_joint(&self, p: &mut Pair, j: &Joint, g: &Geometry, l: &mut [f32; SLOTS]) -> f32 {
        let ang = Jac::angle();
        let k = p.k(&ang);
        let mut r = 0.0f32;
        if k > 0.0 {
            let max = j.max_torque.max(0.0) * self.h;
            let cdot = p.jv(&ang) + j.correction * g.angle * self.inv_dt;
            let old = l[slot::ANGLE];
            let new = (old - cdot / k).clamp(-max, max);
            l[slot::ANGLE] = new;
            p.apply(&ang, new - old);
            r = (new - old).abs();
        }
        let cdot = p.point_velocity(g.ra, g.rb) + j.correction * g.d * self.inv_dt;
        let old = Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]);
        let mut new = old - p.solve_point(g.ra, g.rb, 0.0, cdot);
        let (len, max) = (new.length(), j.max_force.max(0.0) * self.h);
        if len > max {
            new *= max / len;
        }
        (l[slot::POINT_X], l[slot::POINT_Y]) = (new.x, new.y);
        p.apply_point(g.ra, g.rb, new - old);
        r.max((new - old).abs().max_element())
    }

    /// A hinge or weld point: C = d (2 rows), as one 2x2 block.
    #[inline]
    fn point(&self, p: &mut Pair, g: &Geometry, compliance: f32, lambda: &mut Vec2) -> f32 {
        let cdot = p.point_velocity(g.ra, g.rb);
        let d = if compliance > 0.0 {
            let gamma = compliance * self.inv_h * self.inv_h;
            -p.solve_point(g.ra, g.rb, gamma, cdot + g.d * self.inv_h + gamma * *lambda)
        } else if self.bias {
            -self.soft.mass_scale * p.solve_point(g.ra, g.rb, 0.0, cdot + self.soft.bias_rate * g.d)
                - self.soft.impulse_scale * *lambda
        } else {
            -p.solve_point(g.ra, g.rb, 0.0, cdot)
        };
        *lambda += d;
        p.apply_point(g.ra, g.rb, d);
        d.abs().max_element()
    }
}

/// The soft step's joint rows and their lambdas.
#[derive(Clone, Debug, Default)]
pub(crate) struct SoftJoints {
    prepared: Vec<Prepared>,
    /// Each joint's two bodies (for the colouring), and whether it takes a wide hinge's
    /// lanes.
    ends: Vec<(u32, u32)>,
    lanes: Vec<bool>,
    mouse: Option<PreparedMouse>,
    soft: Softness,
    h: f32,
    dt: f32,
}

impl SoftJoints {
    /// Takes the joints' geometry at the step's start for substeps of `h`; lambdas start
    /// from the joints' stored ones if warm starting.
    pub fn prepare(
        &mut self,
        joints: &[Joint],
        mouse: Option<&MouseJoint>,
        bodies: &[Body],
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        self.h = h;
        self.dt = s.dt;
        // a rigid row's spring: at most a quarter of the substep rate
        let hertz = s.joint_hertz.min(0.25 / h);
        self.soft = Softness::new(hertz, s.joint_damping_ratio, h);
        // every joint's frames, split between the threads (a pass over the joints and
        // their bodies: a cache miss each on a large scene)
        self.prepared.resize(joints.len(), Prepared::default());
        self.ends.resize(joints.len(), (0, 0));
        self.lanes.resize(joints.len(), false);
        let warm = s.warm_start;
        // (a test may turn the lanes off, on the thread that prepares)
        let lanes_on = !super::testing::NO_HINGE_LANES.with(std::cell::Cell::get);
        parallel::chunks_mut3(
            pool,
            &mut self.prepared,
            &mut self.ends,
            &mut self.lanes,
            JOINT_BLOCK,
            &|_, offset, prepared, ends, lanes| {
                for (k, ((out, end), lane)) in prepared.iter_mut().zip(ends).zip(lanes).enumerate()
                {
                    let j = &joints[offset + k];
                    *end = (j.a as u32, j.b as u32);
                    *lane = lanes_on && super::hinge::takes_lanes(j);
                    if *lane {
                        // (a hinge in lanes takes its rows from the joint itself)
                        continue;
                    }
                    let f = j.frame(bodies);
                    let (mut ea0, mut eb0) = (Vec2::ZERO, Vec2::ZERO);
                    if j.kind == JointKind::Pulley {
                        let (pa, pb) = j.world_anchors(bodies);
                        (ea0, eb0) = (pa - j.ground[0], pb - j.ground[1]);
                    }
                    *out = Prepared {
                        a: j.a,
                        b: j.b,
                        ra0: f.ra,
                        rb0: f.rb,
                        d0: f.d,
                        axis0: f.axis,
                        angle0: f.angle,
                        ea0,
                        eb0,
                        spring: j
                            .spring
                            .filter(|sp| {
                                matches!(j.kind, JointKind::Wheel | JointKind::Hinge)
                                    && sp.hertz > 0.0
                            })
                            .map(|sp| Softness::new(sp.hertz, sp.damping_ratio.max(0.0), h)),
                        impulses: if warm { j.impulses } else { [0.0; SLOTS] },
                    };
                }
                0.0
            },
        );
        self.mouse = mouse.and_then(|m| {
            let b = bodies.get(m.body).filter(|b| b.is_dynamic())?;
            let rb0 = b.rot.rotate(m.local);
            // the spring as if the body's whole mass hung on it: k = m omega^2,
            // c = 2 m zeta omega, made per unit effective mass
            let rn = rb0.length_squared();
            let k_point = b.inv_mass + b.inv_inertia * rn;
            let m_eff = if k_point > 0.0 { 1.0 / k_point } else { b.mass };
            let omega = std::f32::consts::TAU * m.hertz.max(0.01);
            // the same stiffness and damping seen through the point's effective mass
            let omega_p = omega * (b.mass / m_eff).sqrt();
            let zeta_p = m.damping_ratio.max(0.0) * (b.mass / m_eff).sqrt();
            Some(PreparedMouse {
                body: m.body,
                rb0,
                c0: b.position + rb0 - m.target,
                soft: Softness::new(omega_p / std::f32::consts::TAU, zeta_p, h),
                max_impulse: m.max_force.max(0.0) * h,
                impulse: Vec2::ZERO,
            })
        });
    }

    /// Each joint's two bodies, in joint order.
    pub(super) fn ends(&self) -> &[(u32, u32)] {
        &self.ends
    }

    /// Whether each joint takes a wide hinge's lanes, in joint order.
    pub(super) fn lanes(&self) -> &[bool] {
        &self.lanes
    }

    /// Whether there is a mouse joint.
    pub(super) fn has_mouse(&self) -> bool {
        self.mouse.is_some()
    }

    /// The joint's two bodies as they are now.
    ///
    /// # Safety
    /// No other thread writes either body meanwhile (joints and contacts of one colour
    /// share no moving body; a body that does not move is never written).
    #[inline]
    unsafe fn pair(p: &Prepared, bodies: BodyPtr, inv_mass: &[(f32, f32)]) -> Pair {
        let ((ima, iia), (imb, iib)) = (inv_mass[p.a], inv_mass[p.b]);
        // SAFETY: in bounds (the joint's bodies are the world's), and no one else writes
        // them (above)
        let (a, b) = unsafe { (*bodies.at(p.a as u32), *bodies.at(p.b as u32)) };
        Pair {
            a,
            b,
            ima,
            iia,
            imb,
            iib,
        }
    }

    /// Writes the pair's velocities back to the bodies that move.
    ///
    /// # Safety
    /// As [`SoftJoints::pair`].
    #[inline]
    unsafe fn store_pair(p: &Prepared, pair: &Pair, bodies: BodyPtr, inv_mass: &[(f32, f32)]) {
        if inv_mass[p.a] != (0.0, 0.0) {
            // SAFETY: as above
            let a = unsafe { &mut *bodies.at(p.a as u32) };
            a.v = pair.a.v;
            a.w = pair.a.w;
        }
        if inv_mass[p.b] != (0.0, 0.0) {
            // SAFETY: as above
            let b = unsafe { &mut *bodies.at(p.b as u32) };
            b.v = pair.b.v;
            b.w = pair.b.w;
        }
    }

    /// The joint's geometry now, from the bodies' motion since the step's start.
    #[inline]
    fn geometry(p: &Prepared, pair: &Pair) -> Geometry {
        let ra = pair.a.dq.rotate(p.ra0);
        let rb = pair.b.dq.rotate(p.rb0);
        // d = d0 + (dp_b - dp_a) + (rb - rb0) - (ra - ra0)
        let d = p.d0 + (pair.b.dp - pair.a.dp) + (rb - p.rb0) - (ra - p.ra0);
        Geometry {
            ra,
            rb,
            d,
            axis: pair.a.dq.rotate(p.axis0),
            angle: p.angle0 + pair.b.dtheta - pair.a.dtheta,
        }
    }

    /// A pulley's ropes now, from the bodies' motion since the step's start.
    #[inline]
    fn ropes(p: &Prepared, pair: &Pair, g: &Geometry) -> PulleyRopes {
        let ea = p.ea0 + pair.a.dp + (g.ra - p.ra0);
        let eb = p.eb0 + pair.b.dp + (g.rb - p.rb0);
        PulleyRopes::new(g.ra, g.rb, ea, eb)
    }

    /// The rigid rows' softness in the biased sweeps.
    pub(super) fn softness(&self) -> Softness {
        self.soft
    }

    /// The constants of a sweep: with `bias`, rigid rows are soft springs that pull the
    /// error out; without, they only remove relative speed (relax).
    pub(super) fn sweep_params(&self, bias: bool) -> Sweep {
        Sweep {
            bias,
            soft: self.soft,
            h: self.h,
            inv_h: 1.0 / self.h,
            inv_dt: 1.0 / self.dt,
        }
    }

    /// Whether some joint is damped (the step then runs a damping pass).
    pub(super) fn any_damped(joints: &[Joint]) -> bool {
        joints
            .iter()
            .any(|j| j.damping.linear > 0.0 || j.damping.angular > 0.0)
    }

    /// The joints' prepared rows (by joint), and the mouse joint's.
    pub(super) fn parts(&mut self) -> (&mut [Prepared], &mut Option<PreparedMouse>) {
        (&mut self.prepared, &mut self.mouse)
    }

    /// Writes the lambdas back into the joints, for the next step's warm start.
    pub fn store(&self, joints: &mut [Joint], pool: Option<&Pool>) {
        let (prepared, lanes) = (&self.prepared, &self.lanes);
        parallel::chunks_mut(pool, joints, JOINT_BLOCK, &|_, offset, joints| {
            for ((j, p), &lane) in joints
                .iter_mut()
                .zip(&prepared[offset..])
                .zip(&lanes[offset..])
            {
                // (a hinge in lanes is stored from its lanes)
                if !lane {
                    j.impulses = p.impulses;
                }
            }
            0.0
        });
    }
}

/// Applies a joint's lambdas (`p`, its prepared rows) (start of each substep).
///
/// # Safety
/// As [`SoftJoints::pair`].
pub(super) unsafe fn warm_start_joint(
    p: &Prepared,
    j: &Joint,
    bodies: BodyPtr,
    inv_mass: &[(f32, f32)],
) {
    // SAFETY: the caller's
    let mut pair = unsafe { SoftJoints::pair(p, bodies, inv_mass) };
    let g = SoftJoints::geometry(p, &pair);
    let l = &p.impulses;
    match j.kind {
        JointKind::Hinge | JointKind::Weld => {
            pair.apply_point(g.ra, g.rb, Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]));
            // every angular row has J v = w_b - w_a (upper limit: negated)
            let ang =
                l[slot::ANGLE] + l[slot::MOTOR] + l[slot::SERVO] + l[slot::LOWER] - l[slot::UPPER];
            pair.apply(&Jac::angle(), ang);
        }
        JointKind::Prismatic => {
            let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
            let along = l[slot::MOTOR] + l[slot::SERVO] + l[slot::LOWER] - l[slot::UPPER];
            pair.apply(&ax, along);
            let perp = Jac::linear(g.ra + g.d, g.rb, g.axis.perp());
            pair.apply(&perp, l[slot::AXIAL]);
            pair.apply(&Jac::angle(), l[slot::ANGLE]);
        }
        JointKind::Distance => {
            let u = g.d.normalize_or(Vec2::Y);
            let r = Jac::linear(g.ra, g.rb, u);
            pair.apply(&r, l[slot::AXIAL] + l[slot::LOWER] - l[slot::UPPER]);
        }
        JointKind::Wheel => {
            let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
            pair.apply(&ax, l[slot::SPRING] + l[slot::LOWER] - l[slot::UPPER]);
            let perp = Jac::linear(g.ra + g.d, g.rb, g.axis.perp());
            pair.apply(&perp, l[slot::AXIAL]);
            pair.apply(&Jac::angle(), l[slot::MOTOR]);
        }
        JointKind::Motor => {
            pair.apply_point(g.ra, g.rb, Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]));
            pair.apply(&Jac::angle(), l[slot::ANGLE]);
        }
        JointKind::Pulley => {
            let ropes = SoftJoints::ropes(p, &pair, &g);
            pair.apply(&Jac::pulley(&ropes, j.ratio), l[slot::AXIAL]);
        }
    }
    // SAFETY: the caller's
    unsafe { SoftJoints::store_pair(p, &pair, bodies, inv_mass) };
}

/// Applies the mouse joint's lambda, if any (start of each substep).
pub(super) fn warm_start_mouse(
    m: &Option<PreparedMouse>,
    bodies: &mut [SoftBody],
    inv_mass: &[(f32, f32)],
) {
    if let Some(m) = m {
        let (im, ii) = inv_mass[m.body];
        let b = &mut bodies[m.body];
        let rb = b.dq.rotate(m.rb0);
        b.v += im * m.impulse;
        b.w += ii * cross(rb, m.impulse);
    }
}

/// A joint's rows in a sweep (`sw`, from [`SoftJoints::sweep_params`]); returns the
/// largest |delta lambda|.
///
/// # Safety
/// As [`SoftJoints::pair`]; and no other thread works on the joint meanwhile (its
/// entry is `p`).
pub(super) unsafe fn solve_joint(
    sw: &Sweep,
    p: &mut Prepared,
    j: &Joint,
    bodies: BodyPtr,
    inv_mass: &[(f32, f32)],
) -> f32 {
    // SAFETY: the caller's
    let mut pair = unsafe { SoftJoints::pair(p, bodies, inv_mass) };
    let g = SoftJoints::geometry(p, &pair);
    let ropes = (j.kind == JointKind::Pulley).then(|| SoftJoints::ropes(p, &pair, &g));
    let spring = p.spring;
    let l = &mut p.impulses;
    let alpha = j.compliance;
    let r = match j.kind {
        JointKind::Hinge | JointKind::Weld => {
            let ang = Jac::angle();
            // a hinge's torsion spring pulls its angle to 0 (in the lambda slot a
            // hinge's servo would use: it has one or the other)
            let mut r = match &spring {
                Some(soft) => sw.spring(&mut pair, &ang, g.angle, soft, &mut l[slot::SPRING]),
                None => 0.0,
            };
            r = r.max(motor_row(sw, &mut pair, j, &ang, l));
            if j.kind == JointKind::Hinge {
                r = r.max(range(sw, &mut pair, j, &ang, g.angle, true, l));
            } else {
                r = r.max(sw.equality(&mut pair, &ang, g.angle, alpha, &mut l[slot::ANGLE]));
            }
            // the point last: it matters most (positions do not move within a
            // sweep, so the geometry still holds)
            let mut lam = Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]);
            r = r.max(sw.point(&mut pair, &g, alpha, &mut lam));
            (l[slot::POINT_X], l[slot::POINT_Y]) = (lam.x, lam.y);
            r
        }
        JointKind::Prismatic => {
            let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
            let mut r = motor_row(sw, &mut pair, j, &ax, l);
            r = r.max(range(sw, &mut pair, j, &ax, g.axis.dot(g.d), false, l));
            let perp = g.axis.perp();
            let pr = Jac::linear(g.ra + g.d, g.rb, perp);
            r = r.max(sw.equality(&mut pair, &pr, perp.dot(g.d), alpha, &mut l[slot::AXIAL]));
            r.max(sw.equality(
                &mut pair,
                &Jac::angle(),
                g.angle,
                alpha,
                &mut l[slot::ANGLE],
            ))
        }
        JointKind::Wheel => {
            let mut r = motor_row(sw, &mut pair, j, &Jac::angle(), l);
            let ax = Jac::linear(g.ra + g.d, g.rb, g.axis);
            let t = g.axis.dot(g.d);
            if let Some(soft) = &spring {
                r = r.max(sw.spring(&mut pair, &ax, t, soft, &mut l[slot::SPRING]));
            }
            r = r.max(range(sw, &mut pair, j, &ax, t, false, l));
            let perp = g.axis.perp();
            let pr = Jac::linear(g.ra + g.d, g.rb, perp);
            r.max(sw.equality(&mut pair, &pr, perp.dot(g.d), alpha, &mut l[slot::AXIAL]))
        }
        JointKind::Motor => sw.motor_joint(&mut pair, j, &g, l),
        JointKind::Pulley => match ropes {
            Some(ropes) => {
                let c = j.length - ropes.len_a - j.ratio * ropes.len_b;
                sw.inequality(
                    &mut pair,
                    &Jac::pulley(&ropes, j.ratio),
                    c,
                    &mut l[slot::AXIAL],
                )
            }
            None => 0.0,
        },
        JointKind::Distance => {
            let len = g.d.length();
            let u = if len > 1e-9 { g.d / len } else { Vec2::Y };
            let row = Jac::linear(g.ra, g.rb, u);
            match j.limits {
                Some([lo, hi]) => {
                    let r1 = sw.inequality(&mut pair, &row, len - lo, &mut l[slot::LOWER]);
                    let r2 =
                        sw.inequality(&mut pair, &row.negated(), hi - len, &mut l[slot::UPPER]);
                    r1.max(r2)
                }
                None => sw.equality(&mut pair, &row, len - j.length, alpha, &mut l[slot::AXIAL]),
            }
        }
    };
    // SAFETY: the caller's
    unsafe { SoftJoints::store_pair(p, &pair, bodies, inv_mass) };
    r
}

/// Joint damping of one joint (`p`, its prepared rows, over substeps of `h`): removes the fraction min(h c, 1) of the relative
/// velocity along each damped row, once per substep (the seed's DampLinear /
/// DampAngular).
///
/// # Safety
/// As [`SoftJoints::pair`].
pub(super) unsafe fn damp_joint(
    h: f32,
    p: &Prepared,
    j: &Joint,
    bodies: BodyPtr,
    inv_mass: &[(f32, f32)],
) {
    if j.damping.linear <= 0.0 && j.damping.angular <= 0.0 {
        return;
    }
    // SAFETY: the caller's
    let mut pair = unsafe { SoftJoints::pair(p, bodies, inv_mass) };
    let g = SoftJoints::geometry(p, &pair);
    let damp = |pair: &mut Pair, row: Jac, c: f32| {
        let k = pair.k(&row);
        if k > 0.0 {
            let d = -(pair.jv(&row) / k) * (h * c).min(1.0);
            pair.apply(&row, d);
        }
    };
    if j.damping.linear > 0.0 {
        match j.kind {
            JointKind::Prismatic | JointKind::Wheel => damp(
                &mut pair,
                Jac::linear(g.ra + g.d, g.rb, g.axis),
                j.damping.linear,
            ),
            JointKind::Distance => damp(
                &mut pair,
                Jac::linear(g.ra, g.rb, g.d.normalize_or(Vec2::Y)),
                j.damping.linear,
            ),
            _ => {}
        }
    }
    let turns = matches!(
        j.kind,
        JointKind::Hinge | JointKind::Prismatic | JointKind::Weld
    );
    if j.damping.angular > 0.0 && turns {
        damp(&mut pair, Jac::angle(), j.damping.angular);
    }
    // SAFETY: the caller's
    unsafe { SoftJoints::store_pair(p, &pair, bodies, inv_mass) };
}

/// The joint's motor row along `row`, if it has a motor; returns |delta lambda|.
fn motor_row(sw: &Sweep, pair: &mut Pair, j: &Joint, row: &Jac, l: &mut [f32; SLOTS]) -> f32 {
    match j.motor {
        Some(m) => sw.motor(pair, row, m.speed, m.max_force, &mut l[slot::MOTOR]),
        None => 0.0,
    }
}

/// Limits and servo rows on the joint's angle (hinge) or offset (prismatic) x.
fn range(
    sw: &Sweep,
    pair: &mut Pair,
    j: &Joint,
    row: &Jac,
    x: f32,
    angular: bool,
    l: &mut [f32; SLOTS],
) -> f32 {
    let mut r = 0.0f32;
    if let Some([lo, hi]) = j.limits {
        r = r.max(sw.inequality(pair, row, x - lo, &mut l[slot::LOWER]));
        r = r.max(sw.inequality(pair, &row.negated(), hi - x, &mut l[slot::UPPER]));
    }
    if let Some(s) = j.servo {
        let c = if angular {
            wrap_angle(x - s.target)
        } else {
            x - s.target
        };
        r = r.max(sw.equality(pair, row, c, 0.0, &mut l[slot::SERVO]));
    }
    r
}

/// The mouse: a soft point between the body's point and the target, the same in both
/// sweeps, its lambda bounded by max force times h.
pub(super) fn solve_mouse(
    m: &mut Option<PreparedMouse>,
    bodies: &mut [SoftBody],
    inv_mass: &[(f32, f32)],
) -> f32 {
    let Some(m) = m else {
        return 0.0;
    };
    let (im, ii) = inv_mass[m.body];
    let b = &mut bodies[m.body];
    let rb = b.dq.rotate(m.rb0);
    // C = point - target, brought up to date from the body's motion
    let c = m.c0 + b.dp + (rb - m.rb0);
    let cdot = b.v + cross_sv(b.w, rb);
    let pair = Pair {
        a: SoftBody::default(),
        b: *b,
        ima: 0.0,
        iia: 0.0,
        imb: im,
        iib: ii,
    };
    let rhs = cdot + m.soft.bias_rate * c;
    let d = -m.soft.mass_scale * pair.solve_point(Vec2::ZERO, rb, 0.0, rhs)
        - m.soft.impulse_scale * m.impulse;
    let mut new = m.impulse + d;
    let len = new.length();
    if len > m.max_impulse {
        new *= m.max_impulse / len;
    }
    let d = new - m.impulse;
    m.impulse = new;
    b.v += im * d;
    b.w += ii * cross(rb, d);
    d.abs().max_element()
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverKind;
    use crate::joint::slot;
    use crate::step::testing::hanging_disc;

    #[test]
    fn a_hanging_disc_pulls_its_hinge_with_its_weight_each_substep() {
        // at rest the point row carries m g h per substep upwards: 2 kg, g 10
        let mut w = hanging_disc(SolverKind::Soft);
        for _ in 0..120 {
            w.step().unwrap();
        }
        let j = &w.joints()[0];
        let h = w.settings.dt / w.settings.substeps as f32;
        let want = 2.0 * 10.0 * h;
        let (x, y) = (j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
        assert!(x.abs() < 1e-3 * want, "{x}");
        assert!((y - want).abs() < 0.01 * want, "{y} vs {want}");
        // and the joint holds: the soft row's sag is m g / (m omega^2) at most
        let omega = std::f32::consts::TAU * w.settings.joint_hertz.min(0.25 / h);
        assert!(
            w.joint_error() <= 10.0 / (omega * omega),
            "{}",
            w.joint_error()
        );
    }

    #[test]
    fn a_compliant_distance_joint_stretches_by_its_compliance_times_the_load() {
        // a spring of compliance alpha under a 2 kg load stretches alpha m g (Hooke)
        let sc = crate::scene::load_str(
            "name = \"spring\"\n[world]\ngravity = [0.0, -10.0]\n\
             [[body]]\nname = \"top\"\ntype = \"static\"\nshape = { circle = 0.05 }\nposition = [0.0, 0.0]\n\
             [[body]]\nname = \"bob\"\nshape = { circle = 0.1 }\nmass = 2.0\nposition = [0.0, -1.0]\n\
             [[joint]]\ntype = \"distance\"\nbodies = [\"top\", \"bob\"]\ncompliance = 0.001\n\
             damping = { linear = 5.0 }\n",
            "spring.toml",
        )
        .unwrap();
        let settings = crate::SolverSettings {
            sleep: false,
            ..crate::SolverSettings::soft()
        };
        let mut w = crate::World::from_def(&sc.world, settings).unwrap();
        for _ in 0..600 {
            w.step().unwrap();
        }
        let stretch = -1.0 - w.bodies[1].position.y;
        let want = 0.001 * 2.0 * 10.0;
        assert!((stretch - want).abs() < 0.02 * want, "{stretch} vs {want}");
    }
}
