//! The mouse joint: one body's point dragged towards a world target by a damped spring
//! (frequency and damping ratio as if the body's whole mass hung on it), its force
//! bounded. The window's hand; it is not one of the world's joints, and each solver
//! takes it after them: a soft point (soft step, PGS) or a compliant attach and a
//! damper (XPBD).

use super::clamp_length;
use super::pgs::{MOUSE, Point, load, point_inv_k};
use super::soft::Pair;
use crate::body::Body;
use crate::constraint::{SoftBody, Softness, SolverBody};
use crate::math::{Vec2, cross, cross_sv};

/// Drags one body's point towards a world target with a damped spring (the window's mouse).
/// Made by [`crate::World::grab`] (a body by key); its target and feel may be changed
/// before it is handed to [`crate::World::set_mouse`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MouseJoint {
    /// Index of the dragged body in the world ([`crate::World::mouse_body`] gives its key).
    pub(crate) body: usize,
    /// The grabbed point, in the body's frame from its centre of mass (m).
    pub local: Vec2,
    /// Where the point is pulled (world, m).
    pub target: Vec2,
    /// Spring frequency (Hz) as if the body's whole mass hung on it.
    pub hertz: f32,
    /// Damping ratio (1 = critical).
    pub damping_ratio: f32,
    /// Largest pulling force (N).
    pub max_force: f32,
}

/// The mouse joint as the soft step prepared it: a soft point between a body's point
/// and the target.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PreparedMouse {
    body: usize,
    rb0: Vec2,
    /// point - target at the step's start.
    c0: Vec2,
    soft: Softness,
    max_impulse: f32,
    impulse: Vec2,
}

impl MouseJoint {
    /// The held body, if it is one the solvers move.
    #[inline]
    fn held<'a>(&self, bodies: &'a [Body]) -> Option<&'a Body> {
        bodies.get(self.body).filter(|b| b.is_dynamic())
    }

    /// PGS: the soft point (spring hertz, damping ratio) between the grabbed point and
    /// the target, its force bounded; `bodies` are the solver's.
    pub(super) fn pgs_point(&self, world: &[Body], bodies: &[SolverBody], h: f32) -> Option<Point> {
        let body = self.held(world)?;
        let rb = body.rot.rotate(self.local);
        let c = body.position + rb - self.target;
        // k = m omega^2, c = 2 m zeta omega; gamma = 1/(h (c + h k)), bias = h k gamma C
        let omega = std::f32::consts::TAU * self.hertz.max(0.01);
        let stiffness = body.mass * omega * omega;
        let damp = 2.0 * body.mass * self.damping_ratio.max(0.0) * omega;
        let gamma = 1.0 / (h * (damp + h * stiffness));
        let bias = h * stiffness * gamma * c;
        // the world's "a" side is the body itself with zero inverse mass
        let fixed = SolverBody::default();
        let bb = &bodies[self.body];
        Some(Point {
            a: self.body as u32,
            b: self.body as u32,
            ra: Vec2::ZERO,
            rb,
            inv_k: point_inv_k(&fixed, bb, Vec2::ZERO, rb, gamma),
            bias,
            gamma,
            impulse: Vec2::ZERO,
            max_impulse: self.max_force.max(0.0) * h,
            joint: MOUSE,
            positional: false,
            pos_impulse: Vec2::ZERO,
            exact: false,
        })
    }

    /// PGS: the mouse's point row, where the fixed side is the world (a aliases b: only
    /// b's part is solved).
    pub(super) fn pgs_solve(p: &mut Point, bodies: &mut [SolverBody]) -> f32 {
        let b = load(bodies, p.b);
        let cdot = b.v + cross_sv(b.w, p.rb);
        let rhs = -(cdot + p.bias + p.gamma * p.impulse);
        let k = p.inv_k;
        let d = Vec2::new(k[0] * rhs.x + k[2] * rhs.y, k[1] * rhs.x + k[3] * rhs.y);
        let new = clamp_length(p.impulse + d, p.max_impulse);
        let d = new - p.impulse;
        p.impulse = new;
        let b = &mut bodies[p.b as usize];
        b.v += b.inv_m * d;
        b.w += b.inv_i * cross(p.rb, d);
        d.abs().max_element()
    }

    /// The soft step: the mouse at the step's start, for substeps of `h`.
    pub(crate) fn soft_prepare(&self, bodies: &[Body], h: f32) -> Option<PreparedMouse> {
        let b = self.held(bodies)?;
        let rb0 = b.rot.rotate(self.local);
        // the spring as if the body's whole mass hung on it: k = m omega^2,
        // c = 2 m zeta omega, made per unit effective mass
        let rn = rb0.length_squared();
        let k_point = b.inv_mass + b.inv_inertia * rn;
        let m_eff = if k_point > 0.0 { 1.0 / k_point } else { b.mass };
        let omega = std::f32::consts::TAU * self.hertz.max(0.01);
        // the same stiffness and damping seen through the point's effective mass
        let omega_p = omega * (b.mass / m_eff).sqrt();
        let zeta_p = self.damping_ratio.max(0.0) * (b.mass / m_eff).sqrt();
        Some(PreparedMouse {
            body: self.body,
            rb0,
            c0: b.position + rb0 - self.target,
            soft: Softness::new(omega_p / std::f32::consts::TAU, zeta_p, h),
            max_impulse: self.max_force.max(0.0) * h,
            impulse: Vec2::ZERO,
        })
    }

    /// XPBD: a compliant attach of the grabbed point to the target, alpha = 1 / k with
    /// k = m (2 pi f)^2, its correction bounded by max force times h^2.
    pub(crate) fn xpbd_project(&self, bodies: &mut [Body], h: f32) {
        let Some(b) = bodies.get_mut(self.body) else {
            return;
        };
        if !b.is_dynamic() {
            return;
        }
        let r = b.rot.rotate(self.local);
        let d = self.target - (b.position + r);
        let len = d.length();
        if len <= 1e-9 {
            return;
        }
        let n = d / len;
        let omega = std::f32::consts::TAU * self.hertz.max(0.01);
        let k = b.mass * omega * omega;
        // alpha~ = alpha / h^2 = 1 / (k h^2)
        let soft = 1.0 / (k * h * h);
        let rn = cross(r, n);
        let w = b.inv_mass + b.inv_inertia * rn * rn;
        let dl = (len / (w + soft)).min(self.max_force * h * h);
        let p = dl * n;
        super::xpbd::move_body(b, b.inv_mass * p, b.inv_inertia * cross(r, p));
    }

    /// XPBD's velocity pass: removes min(h c / m, 1) of the grabbed point's velocity,
    /// c = 2 m zeta omega.
    pub(crate) fn xpbd_damp(&self, world: &[Body], bodies: &mut [SolverBody], h: f32) {
        if self.held(world).is_none() {
            return;
        }
        let b = &world[self.body];
        let r = b.rot.rotate(self.local);
        let sb = &mut bodies[self.body];
        let v = sb.v + cross_sv(sb.w, r);
        let speed = v.length();
        if speed <= 1e-9 {
            return;
        }
        let n = v / speed;
        let omega = std::f32::consts::TAU * self.hertz.max(0.01);
        let f = (h * 2.0 * self.damping_ratio.max(0.0) * omega).min(1.0);
        let rn = cross(r, n);
        let w = sb.inv_m + sb.inv_i * rn * rn;
        if w <= 0.0 {
            return;
        }
        let imp = -(f * speed / w) * n;
        sb.v += sb.inv_m * imp;
        sb.w += sb.inv_i * cross(r, imp);
    }
}

/// The soft step: applies the mouse joint's lambda, if any (start of each substep).
pub(crate) fn soft_warm_start(
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

/// The soft step: a soft point between the body's point and the target, the same in
/// both sweeps, its lambda bounded by max force times h.
pub(crate) fn soft_solve(
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
    let new = clamp_length(m.impulse + d, m.max_impulse);
    let d = new - m.impulse;
    m.impulse = new;
    b.v += im * d;
    b.w += ii * cross(rb, d);
    d.abs().max_element()
}
