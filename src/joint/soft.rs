//! Joint rows of the soft step (the scheme of Box2D v3's soft step, written for this
//! project): what every kind's rows ([`super::Kind::soft_solve`]) are made of, solved
//! beside the soft contacts on the same substep velocities. The solver
//! (`crate::solver::soft`) loads a joint's two bodies into a [`Pair`], calls the joint,
//! and stores the pair back.
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

use super::{Joint, JointFrame, SLOTS, slot, wrap_angle};
use crate::body::Body;
use crate::constraint::{SoftBody, Softness};
use crate::math::{Vec2, cross, cross_sv};

/// A joint's geometry at the step's start and its lambdas.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Prepared {
    pub(crate) a: usize,
    pub(crate) b: usize,
    /// Arms from the centres of mass to the anchors, world frame, at the step's start.
    pub(crate) ra0: Vec2,
    pub(crate) rb0: Vec2,
    /// Anchor gap p_b - p_a at the step's start.
    pub(crate) d0: Vec2,
    /// World axis at the step's start (prismatic; it turns with a).
    pub(super) axis0: Vec2,
    /// theta_b - theta_a - ref at the step's start.
    pub(crate) angle0: f32,
    /// Pulley: anchor less ground point, each side, at the step's start.
    pub(super) ea0: Vec2,
    pub(super) eb0: Vec2,
    /// Wheel, hinge: the spring's softness (Box2D's soft constraint for its own hertz
    /// and damping ratio; the same in both sweeps).
    pub(super) spring: Option<Softness>,
    pub(crate) impulses: [f32; SLOTS],
}

impl Prepared {
    /// The joint's geometry at the step's start (`bodies` as they are now) for substeps
    /// of `h`; its lambdas from the joint's stored ones if `warm`, else zero.
    #[inline]
    pub(crate) fn of(j: &Joint, bodies: &[Body], h: f32, warm: bool) -> Prepared {
        let f = j.frame(bodies);
        let mut p = Prepared {
            a: j.a,
            b: j.b,
            ra0: f.ra,
            rb0: f.rb,
            d0: f.d,
            axis0: f.axis,
            angle0: f.angle,
            ea0: Vec2::ZERO,
            eb0: Vec2::ZERO,
            spring: None,
            impulses: if warm { j.impulses } else { [0.0; SLOTS] },
        };
        j.soft_prepare(bodies, h, &mut p);
        p
    }
}

/// A joint's frame now (arms, anchor gap, axis, relative angle), from the bodies'
/// motion since the step's start (`p`'s frame).
#[inline]
pub(crate) fn frame_now(p: &Prepared, pair: &Pair) -> JointFrame {
    let ra = pair.a.dq.rotate(p.ra0);
    let rb = pair.b.dq.rotate(p.rb0);
    // d = d0 + (dp_b - dp_a) + (rb - rb0) - (ra - ra0)
    let d = p.d0 + (pair.b.dp - pair.a.dp) + (rb - p.rb0) - (ra - p.ra0);
    JointFrame {
        ra,
        rb,
        d,
        axis: pair.a.dq.rotate(p.axis0),
        angle: p.angle0 + pair.b.dtheta - pair.a.dtheta,
    }
}

/// A scalar row's Jacobian: J v = la . v_a + ka w_a + lb . v_b + kb w_b.
#[derive(Clone, Copy, Debug)]
pub(super) struct Jac {
    pub(super) la: Vec2,
    pub(super) ka: f32,
    pub(super) lb: Vec2,
    pub(super) kb: f32,
}

impl Jac {
    /// w_b - w_a
    #[inline]
    pub(super) fn angle() -> Jac {
        Jac {
            la: Vec2::ZERO,
            ka: -1.0,
            lb: Vec2::ZERO,
            kb: 1.0,
        }
    }

    /// e . (v_b + w_b x r_b - v_a - w_a x r_a)
    #[inline]
    pub(super) fn linear(ra: Vec2, rb: Vec2, e: Vec2) -> Jac {
        Jac {
            la: -e,
            ka: -cross(ra, e),
            lb: e,
            kb: cross(rb, e),
        }
    }

    #[inline]
    pub(super) fn negated(self) -> Jac {
        Jac {
            la: -self.la,
            ka: -self.ka,
            lb: -self.lb,
            kb: -self.kb,
        }
    }
}

/// The two bodies of a joint during a solve, with their inverse masses.
pub(crate) struct Pair {
    pub(crate) a: SoftBody,
    pub(crate) b: SoftBody,
    pub(crate) ima: f32,
    pub(crate) iia: f32,
    pub(crate) imb: f32,
    pub(crate) iib: f32,
}

impl Pair {
    /// J M^-1 J^T
    #[inline]
    pub(super) fn k(&self, j: &Jac) -> f32 {
        self.ima * j.la.length_squared()
            + self.iia * j.ka * j.ka
            + self.imb * j.lb.length_squared()
            + self.iib * j.kb * j.kb
    }

    #[inline]
    pub(super) fn jv(&self, j: &Jac) -> f32 {
        j.la.dot(self.a.v) + j.ka * self.a.w + j.lb.dot(self.b.v) + j.kb * self.b.w
    }

    /// v += M^-1 J^T lambda
    #[inline]
    pub(super) fn apply(&mut self, j: &Jac, lambda: f32) {
        self.a.v += self.ima * lambda * j.la;
        self.a.w += self.iia * lambda * j.ka;
        self.b.v += self.imb * lambda * j.lb;
        self.b.w += self.iib * lambda * j.kb;
    }

    /// A point impulse p on b at rb and -p on a at ra.
    #[inline]
    pub(super) fn apply_point(&mut self, ra: Vec2, rb: Vec2, p: Vec2) {
        self.a.v -= self.ima * p;
        self.a.w -= self.iia * cross(ra, p);
        self.b.v += self.imb * p;
        self.b.w += self.iib * cross(rb, p);
    }

    /// (v_b + w_b x r_b) - (v_a + w_a x r_a)
    #[inline]
    pub(super) fn point_velocity(&self, ra: Vec2, rb: Vec2) -> Vec2 {
        self.b.v + cross_sv(self.b.w, rb) - self.a.v - cross_sv(self.a.w, ra)
    }

    /// The 2x2 K = M_a^-1 + M_b^-1 of a point between arms ra and rb, plus gamma on the
    /// diagonal, solved for rhs (zero where K is singular).
    #[inline]
    pub(super) fn solve_point(&self, ra: Vec2, rb: Vec2, gamma: f32, rhs: Vec2) -> Vec2 {
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

    /// The joint's angular damping (if any) over a substep of `h`.
    #[inline]
    pub(super) fn damp_angle(&mut self, j: &Joint, h: f32) {
        if j.damping.angular > 0.0 {
            self.damp(Jac::angle(), h, j.damping.angular);
        }
    }

    /// Joint damping along `row`: removes the fraction min(h c, 1) of the relative
    /// velocity along it (the seed's DampLinear / DampAngular).
    #[inline]
    pub(super) fn damp(&mut self, row: Jac, h: f32, c: f32) {
        let k = self.k(&row);
        if k > 0.0 {
            let d = -(self.jv(&row) / k) * (h * c).min(1.0);
            self.apply(&row, d);
        }
    }
}

/// How a row is softened in this sweep.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sweep {
    /// The biased (soft) sweep, or the relax sweep.
    bias: bool,
    /// Rigid rows in the biased sweep.
    soft: Softness,
    pub(super) h: f32,
    pub(super) inv_h: f32,
    /// 1 / the world's step: the motor joint corrects its share of the error per step.
    pub(super) inv_dt: f32,
}

impl Sweep {
    /// The constants of a sweep over substeps of `h` in steps of `dt`: with `bias`,
    /// rigid rows are soft springs (`soft`) that pull the error out; without, they only
    /// remove relative speed (relax).
    pub(crate) fn new(bias: bool, soft: Softness, h: f32, dt: f32) -> Sweep {
        Sweep {
            bias,
            soft,
            h,
            inv_h: 1.0 / h,
            inv_dt: 1.0 / dt,
        }
    }

    /// An equality row C = 0 with compliance alpha: returns the new lambda.
    #[inline]
    pub(super) fn equality(
        &self,
        p: &mut Pair,
        j: &Jac,
        c: f32,
        compliance: f32,
        lambda: &mut f32,
    ) -> f32 {
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
    pub(super) fn inequality(&self, p: &mut Pair, j: &Jac, c: f32, lambda: &mut f32) -> f32 {
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
    pub(super) fn spring(
        &self,
        p: &mut Pair,
        j: &Jac,
        c: f32,
        soft: &Softness,
        lambda: &mut f32,
    ) -> f32 {
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

    /// A hinge or weld point: C = d (2 rows), as one 2x2 block.
    #[inline]
    pub(super) fn point(
        &self,
        p: &mut Pair,
        g: &JointFrame,
        compliance: f32,
        lambda: &mut Vec2,
    ) -> f32 {
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

    /// The point of a hinge or weld, its lambda in the point slots.
    #[inline]
    pub(super) fn point_of(
        &self,
        pair: &mut Pair,
        g: &JointFrame,
        compliance: f32,
        l: &mut [f32; SLOTS],
    ) -> f32 {
        let mut lam = Vec2::new(l[slot::POINT_X], l[slot::POINT_Y]);
        let r = self.point(pair, g, compliance, &mut lam);
        (l[slot::POINT_X], l[slot::POINT_Y]) = (lam.x, lam.y);
        r
    }

    /// The joint's motor row along `row`, if it has a motor; returns |delta lambda|.
    #[inline]
    pub(super) fn motor_of(
        &self,
        pair: &mut Pair,
        j: &Joint,
        row: &Jac,
        l: &mut [f32; SLOTS],
    ) -> f32 {
        match j.motor {
            Some(m) => self.motor(pair, row, m.speed, m.max_force, &mut l[slot::MOTOR]),
            None => 0.0,
        }
    }

    /// Limits and servo rows on the joint's angle (hinge) or offset (prismatic) x.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn range(
        &self,
        pair: &mut Pair,
        j: &Joint,
        row: &Jac,
        x: f32,
        angular: bool,
        l: &mut [f32; SLOTS],
    ) -> f32 {
        let mut r = 0.0f32;
        if let Some([lo, hi]) = j.limits {
            r = r.max(self.inequality(pair, row, x - lo, &mut l[slot::LOWER]));
            r = r.max(self.inequality(pair, &row.negated(), hi - x, &mut l[slot::UPPER]));
        }
        if let Some(s) = j.servo {
            let c = if angular {
                wrap_angle(x - s.target)
            } else {
                x - s.target
            };
            r = r.max(self.equality(pair, row, c, 0.0, &mut l[slot::SERVO]));
        }
        r
    }

    /// The row keeping the second anchor on the first body's axis line (prismatic,
    /// wheel): C = perp . d, with the joint's compliance.
    #[inline]
    pub(super) fn line(
        &self,
        pair: &mut Pair,
        j: &Joint,
        g: &JointFrame,
        l: &mut [f32; SLOTS],
    ) -> f32 {
        let perp = g.axis.perp();
        let pr = Jac::linear(g.ra + g.d, g.rb, perp);
        self.equality(pair, &pr, perp.dot(g.d), j.compliance, &mut l[slot::AXIAL])
    }
}

/// The soft spring of a hinge's torsion or a wheel's suspension at substep h, if it has
/// one.
#[inline]
pub(super) fn own_spring(j: &Joint, h: f32) -> Option<Softness> {
    j.spring
        .filter(|sp| sp.hertz > 0.0)
        .map(|sp| Softness::new(sp.hertz, sp.damping_ratio.max(0.0), h))
}
