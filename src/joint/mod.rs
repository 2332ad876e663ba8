//! Joints: distance (attach, rope), hinge (limits, servo, motor, torsion spring),
//! prismatic (limits, servo, motor), weld, wheel (suspension spring, motor, limits),
//! motor joint, pulley, and the mouse joint that drags a body towards a point.
//!
//! A joint is stored in its bodies' frames (anchors and axis relative to each body's
//! centre of mass), so it follows the bodies. Every solver reads the same [`Joint`].
//!
//! One file per kind of joint holds all of that kind: how it is built from its
//! [`JointDef`] and checked, its errors, its drive, and its rows under each solver (the
//! soft step's warm start, solve and damping; PGS's velocity rows; XPBD's position
//! projection and velocity pass), as the `Kind` trait lists them. This file holds the
//! joint itself, the frames every kind measures from, and the one place that turns a
//! [`JointKind`] into its file (`by_kind!`). What each solver's rows are made of lies
//! beside: `soft.rs` (the soft step's rows, after Box2D v3's soft step), `pgs.rs`
//! (projected Gauss-Seidel's velocity rows, which XPBD's velocity pass shares) and
//! `xpbd.rs` (positional corrections, after Mueller et al. 2020 and the Ten Minute
//! Physics joint notes). A new kind of joint is a [`JointKind`] variant, a file here
//! that implements `Kind`, and its line in `by_kind!`.
//!
//! The soft step solves hinges four at a time in SIMD lanes beside the contacts; those
//! lanes are a layout of the solver's (`crate::solver::soft`), which takes a hinge into
//! them where it can and leaves the rest to the rows here.
//!
//! This module does not reach into the world: the solvers give it the bodies and their
//! states.

use crate::body::Body;
use crate::defs::{DampingDef, JointDef, JointKind, MotorDef, ServoDef, SpringDef};
use crate::math::{Rot, Vec2};

mod chain;
mod distance;
mod hinge;
mod motor;
pub(crate) mod mouse;
pub(crate) mod pgs;
mod prismatic;
mod pulley;
pub(crate) mod soft;
mod weld;
mod wheel;
pub(crate) mod xpbd;

pub use mouse::MouseJoint;

/// A joint's place in its world's creation order (the world's API names joints by
/// [`crate::JointKey`]).
pub type JointId = usize;

/// A joint between bodies `a` and `b`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Joint {
    /// What the joint holds (see [`JointKind`]).
    pub kind: JointKind,
    /// Index of the first body in the world (its key: [`crate::World::joint_bodies`]).
    pub(crate) a: usize,
    /// Index of the second body in the world.
    pub(crate) b: usize,
    /// Anchor on `a`, in a's frame, from its centre of mass (m).
    pub local_a: Vec2,
    /// Anchor on `b`, in b's frame, from its centre of mass (m).
    pub local_b: Vec2,
    /// Unit axis in a's frame (prismatic).
    pub local_axis: Vec2,
    /// theta_b - theta_a at creation (rad): the hinge's zero angle.
    pub ref_angle: f32,
    /// Rest length (distance), m.
    pub length: f32,
    /// [min, max]: hinge angle (rad), prismatic offset (m), distance length range (m).
    pub limits: Option<[f32; 2]>,
    /// Drives the joint's speed with a bounded force or torque (hinge, prismatic,
    /// wheel); `None` = none.
    pub motor: Option<MotorDef>,
    /// Holds the hinge angle or prismatic offset at a target; `None` = none.
    pub servo: Option<ServoDef>,
    /// m/N (rad/(N m) for angles); 0 = rigid.
    pub compliance: f32,
    /// Damping of the joint's free relative motion (see [`DampingDef`]).
    pub damping: DampingDef,
    /// Whether the two joined bodies still collide with each other.
    pub collide_connected: bool,
    /// A force (N, prismatic and distance, along the axis) or torque (N m, hinge and
    /// weld) applied to b, and its reaction to a, every step: the seed's ApplyForce /
    /// ApplyTorque. Set with [`crate::World::set_joint_drive`].
    pub drive: f32,
    /// PGS lambdas (N s) kept for warm starting, by row slot (see `Slot`).
    pub(crate) impulses: [f32; SLOTS],
    /// Wheel: the suspension spring along the axis.
    #[serde(default)]
    pub spring: Option<SpringDef>,
    /// Motor joint: largest force (N) and torque (N m); the share of the error
    /// corrected per (sub)step. Its target offset is `local_a` (b's centre of mass in
    /// a's frame, from a's), its target angle `ref_angle`.
    #[serde(default)]
    pub max_force: f32,
    /// Motor joint: largest torque (N m).
    #[serde(default)]
    pub max_torque: f32,
    /// Motor joint: the share of the position error corrected per (sub)step, in [0, 1].
    #[serde(default)]
    pub correction: f32,
    /// Pulley: the ground points (world); `length` is length_a + ratio length_b at most.
    #[serde(default)]
    pub ground: [Vec2; 2],
    /// Pulley: the factor on b's rope in the held sum length_a + ratio length_b
    /// (> 0); 1 for the other kinds.
    #[serde(default = "one")]
    pub ratio: f32,
    /// The constraint force (N, its linear part's magnitude) past which the joint
    /// breaks after a step; `None` = never.
    #[serde(default)]
    pub break_force: Option<f32>,
    /// The constraint torque (N m) past which the joint breaks; `None` = never.
    #[serde(default)]
    pub break_torque: Option<f32>,
    /// XPBD: the step's impulses (N s) by row slot, each substep's lambda / h summed
    /// (kept only for a joint that may break; the other solvers keep `impulses`).
    #[serde(skip)]
    pub(crate) step_impulses: [f32; SLOTS],
}

fn one() -> f32 {
    1.0
}

/// The rows a joint may have, for storing their lambdas between steps.
pub(crate) const SLOTS: usize = 8;
pub(crate) mod slot {
    pub const POINT_X: usize = 0;
    pub const POINT_Y: usize = 1;
    pub const AXIAL: usize = 2;
    pub const ANGLE: usize = 3;
    pub const LOWER: usize = 4;
    pub const UPPER: usize = 5;
    pub const MOTOR: usize = 6;
    pub const SERVO: usize = 7;
    /// The wheel joint's suspension spring (a wheel has no servo).
    pub const SPRING: usize = 7;
}

/// Wraps an angle into (-pi, pi].
#[inline]
pub fn wrap_angle(a: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let mut x = a % TAU;
    if x > PI {
        x -= TAU;
    } else if x <= -PI {
        x += TAU;
    }
    x
}

/// Where a joint's parts are now: world arms from the centres of mass to the anchors,
/// the anchor gap d = p_b - p_a, the axis (prismatic) and the relative angle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JointFrame {
    pub ra: Vec2,
    pub rb: Vec2,
    pub d: Vec2,
    pub axis: Vec2,
    /// theta_b - theta_a - ref (not wrapped: the body angles are continuous, and a
    /// wrapped angle would jump from pi to -pi and flip which limit looks violated).
    pub angle: f32,
}

impl JointFrame {
    /// The geometry of anchors `local_a` on `ba` and `local_b` on `bb` (in their frames),
    /// with reference angle `ref_angle` and axis `local_axis` (in a's frame).
    #[inline]
    pub(crate) fn of(
        ba: &Body,
        bb: &Body,
        local_a: Vec2,
        local_b: Vec2,
        ref_angle: f32,
        local_axis: Vec2,
    ) -> JointFrame {
        let ra = ba.rot.rotate(local_a);
        let rb = bb.rot.rotate(local_b);
        JointFrame {
            ra,
            rb,
            d: (bb.position + rb) - (ba.position + ra),
            axis: ba.rot.rotate(local_axis),
            angle: bb.angle - ba.angle - ref_angle,
        }
    }
}

/// What a kind of joint is made of: one file per kind implements it, and the joint's
/// methods reach the kind through `by_kind!`. Each solver's part receives the joint,
/// the bodies (or the solver's states of them) and the joint's frame.
pub(crate) trait Kind {
    /// The two anchors (world) when the definition gives none.
    #[inline]
    fn default_anchors(_ba: &Body, bb: &Body) -> (Vec2, Vec2) {
        (bb.position, bb.position)
    }

    /// What the definition must hold beyond what every joint must (in words).
    #[inline]
    fn check(_def: &JointDef) -> Result<(), String> {
        Ok(())
    }

    /// Sets what is the kind's own once the common fields are set (`ends`: the bodies
    /// a and b; `anchors`: the world anchors).
    #[inline]
    fn init(_j: &mut Joint, _def: &JointDef, _ends: (&Body, &Body), _anchors: (Vec2, Vec2)) {}

    /// The linear impulse's magnitude (N s) and the angular impulse (N m s) that the
    /// lambdas `l` (by row slot, as the kind's soft warm start applies them) put
    /// through the joint.
    fn reaction(l: &[f32; SLOTS]) -> (f32, f32);

    /// How far the joint is from holding (m), given its frame `f`.
    fn position_error(j: &Joint, f: &JointFrame, bodies: &[Body]) -> f32;

    /// How far the angle is from where the joint holds it (rad).
    #[inline]
    fn angle_error(_j: &Joint, _f: &JointFrame) -> f32 {
        0.0
    }

    /// Applies the joint's drive as the impulse `p` (N s or N m s) on b, its reaction
    /// on a.
    #[inline]
    fn drive(_j: &Joint, _f: &JointFrame, _bodies: &mut [Body], _p: f32) {}

    /// PGS: the joint's velocity rows of this (sub)step.
    fn pgs_rows(j: &Joint, f: &JointFrame, rows: &mut pgs::RowBuilder);

    /// XPBD: one projection of the joint's position constraints (see
    /// [`Joint::project`]).
    fn project(j: &Joint, bodies: &mut [Body], then: &xpbd::Start, h: f32, l: &mut [f32; SLOTS]);

    /// XPBD's velocity pass: the joint's motor solved now, its damping rows queued.
    #[inline]
    fn xpbd_velocity(_j: &Joint, _f: &JointFrame, _pass: &mut xpbd::VelocityPass) {}

    /// The soft step: the joint's own soft spring (wheel suspension, hinge torsion),
    /// and a pulley's ropes (anchor less ground point, each side) at the step's start.
    #[inline]
    fn soft_prepare(_j: &Joint, _bodies: &[Body], _h: f32, _p: &mut soft::Prepared) {}

    /// The soft step: applies the joint's lambdas (start of each substep).
    fn soft_warm_start(p: &soft::Prepared, j: &Joint, pair: &mut soft::Pair, g: &JointFrame);

    /// The soft step: the joint's rows in one sweep; returns the largest |delta lambda|.
    fn soft_solve(
        sw: &soft::Sweep,
        p: &mut soft::Prepared,
        j: &Joint,
        pair: &mut soft::Pair,
        g: &JointFrame,
    ) -> f32;

    /// The soft step: the joint's damping over a substep of `h`: the fraction
    /// min(h c, 1) of the relative velocity along each damped row removed.
    #[inline]
    fn soft_damp(_h: f32, _j: &Joint, _pair: &mut soft::Pair, _g: &JointFrame) {}
}

/// Calls the [`Kind`] function `f` of the kind `kind`: the one place a joint kind is
/// turned into its file.
macro_rules! by_kind {
    ($kind:expr, $f:ident($($arg:expr),* $(,)?)) => {
        match $kind {
            JointKind::Distance => <distance::Distance as Kind>::$f($($arg),*),
            JointKind::Hinge => <hinge::Hinge as Kind>::$f($($arg),*),
            JointKind::Prismatic => <prismatic::Prismatic as Kind>::$f($($arg),*),
            JointKind::Weld => <weld::Weld as Kind>::$f($($arg),*),
            JointKind::Wheel => <wheel::Wheel as Kind>::$f($($arg),*),
            JointKind::Motor => <motor::Motor as Kind>::$f($($arg),*),
            JointKind::Pulley => <pulley::Pulley as Kind>::$f($($arg),*),
        }
    };
}

impl Joint {
    /// Builds a joint from its description and the bodies as they are now.
    /// `def.bodies` must be valid, distinct indices (the world checks).
    pub(crate) fn from_def(def: &JointDef, bodies: &[Body]) -> Joint {
        let (ba, bb) = (&bodies[def.bodies[0]], &bodies[def.bodies[1]]);
        let (wa, wb) = match (def.anchors, def.anchor) {
            (Some([p, q]), _) => (p, q),
            (None, Some(p)) => (p, p),
            // no anchor given: the kind's (b's centre of mass; distance: both centres)
            (None, None) => by_kind!(def.kind, default_anchors(ba, bb)),
        };
        let axis = def.axis.unwrap_or(Vec2::X).normalize_or(Vec2::X);
        let mut j = Joint {
            kind: def.kind,
            a: def.bodies[0],
            b: def.bodies[1],
            local_a: ba.rot.inv_rotate(wa - ba.position),
            local_b: bb.rot.inv_rotate(wb - bb.position),
            local_axis: ba.rot.inv_rotate(axis),
            ref_angle: bb.angle - ba.angle,
            length: def.length.unwrap_or(wa.distance(wb)),
            limits: def.limits,
            motor: def.motor,
            servo: def.servo,
            compliance: def.compliance,
            damping: def.damping,
            collide_connected: def.collide_connected,
            drive: 0.0,
            impulses: [0.0; SLOTS],
            spring: None,
            max_force: 0.0,
            max_torque: 0.0,
            correction: 0.0,
            ground: [Vec2::ZERO; 2],
            ratio: 1.0,
            break_force: def.break_force,
            break_torque: def.break_torque,
            step_impulses: [0.0; SLOTS],
        };
        by_kind!(def.kind, init(&mut j, def, (ba, bb), (wa, wb)));
        j
    }

    /// Why the definition cannot make a joint (in words), past what the world checks
    /// itself (that its bodies exist and differ); the first thing wrong.
    pub(crate) fn check_def(def: &JointDef) -> Result<(), String> {
        if let Some([lo, hi]) = def.limits
            && !(lo <= hi)
        {
            return Err(format!("limits min {lo} > max {hi}"));
        }
        if let Some(ax) = def.axis
            && (!ax.is_finite() || ax.length() <= 1e-6)
        {
            return Err("prismatic axis must have a non-zero length".into());
        }
        if !(def.compliance >= 0.0) || !def.compliance.is_finite() {
            return Err(format!("compliance must be >= 0, got {}", def.compliance));
        }
        if let Some(l) = def.length
            && (!(l >= 0.0) || !l.is_finite())
        {
            return Err(format!("length must be >= 0, got {l}"));
        }
        let finite = [def.anchor, def.axis, def.offset]
            .iter()
            .flatten()
            .chain(def.anchors.iter().flatten())
            .chain(def.ground_anchors.iter().flatten())
            .all(|v| v.is_finite());
        if !finite || !def.angle.is_none_or(f32::is_finite) {
            return Err("anchors, axis, offset and angle must be finite".into());
        }
        for (what, v) in [
            ("break_force", def.break_force),
            ("break_torque", def.break_torque),
        ] {
            if let Some(v) = v
                && !(v > 0.0 && v.is_finite())
            {
                return Err(format!("{what} must be > 0 and finite, got {v}"));
            }
        }
        if let Some(sp) = def.spring
            && !(sp.hertz > 0.0 && sp.hertz.is_finite() && sp.damping_ratio >= 0.0)
        {
            return Err(format!(
                "spring needs hertz > 0 and damping_ratio >= 0, got {} and {}",
                sp.hertz, sp.damping_ratio
            ));
        }
        by_kind!(def.kind, check(def))
    }

    /// The first derived value of the joint that is not finite, by name.
    pub(crate) fn not_finite(&self) -> Option<&'static str> {
        if !self.length.is_finite() {
            Some("length")
        } else if !(self.local_a.is_finite() && self.local_b.is_finite()) {
            Some("anchor offset")
        } else if !(self.local_axis.is_finite() && self.ref_angle.is_finite()) {
            Some("axis or reference angle")
        } else {
            None
        }
    }

    /// The joint's geometry now.
    #[inline]
    pub(crate) fn frame(&self, bodies: &[Body]) -> JointFrame {
        let (ba, bb) = (&bodies[self.a], &bodies[self.b]);
        JointFrame::of(
            ba,
            bb,
            self.local_a,
            self.local_b,
            self.ref_angle,
            self.local_axis,
        )
    }

    /// World positions of the two anchors (for drawing).
    /// A motor joint's are b's target point and the point of b it drives there (b's
    /// centre of mass when the joint was made); a pulley's its bodies' anchors.
    pub(crate) fn world_anchors(&self, bodies: &[Body]) -> (Vec2, Vec2) {
        let f = self.frame(bodies);
        let pa = bodies[self.a].position + f.ra;
        (pa, pa + f.d)
    }

    /// How far the joint is from holding (m): the anchor separation of a hinge or weld,
    /// the length error (or range violation) of a distance joint, the off-axis offset
    /// plus the range violation of a prismatic or wheel joint, the stretch of a pulley
    /// past its length; 0 for a motor joint (a bounded drive, not a constraint).
    pub(crate) fn position_error(&self, bodies: &[Body]) -> f32 {
        let f = self.frame(bodies);
        by_kind!(self.kind, position_error(self, &f, bodies))
    }

    /// The linear impulse's magnitude (N s) and the angular impulse (N m s, its
    /// magnitude) that the lambdas `l` (by row slot) put through the joint.
    pub(crate) fn reaction(&self, l: &[f32; SLOTS]) -> (f32, f32) {
        let (f, t) = by_kind!(self.kind, reaction(l));
        (f, t.abs())
    }

    /// Whether the joint may break (a break force or torque is set).
    #[inline]
    pub fn breakable(&self) -> bool {
        self.break_force.is_some() || self.break_torque.is_some()
    }

    /// How far the angle is outside the hinge's limits, or off a weld or prismatic
    /// joint's rest angle (rad).
    pub(crate) fn angle_error(&self, bodies: &[Body]) -> f32 {
        let f = self.frame(bodies);
        by_kind!(self.kind, angle_error(self, &f))
    }

    /// One XPBD projection of the joint's position constraints over a substep of `h`
    /// seconds. `lambdas` are this substep's accumulated multipliers, one per slot;
    /// `prev` holds each body's position and rotation at the start of the substep.
    ///
    /// The corrections move the bodies along the constraint gradients of the substep's
    /// start (as SHAKE does), not of the predicted positions: with one Newton step per
    /// substep this keeps a pendulum's energy (0.1% over 20 s at 20 substeps where the
    /// predicted-gradient form loses 17%), at the same cost.
    #[inline]
    pub(crate) fn project(
        &self,
        bodies: &mut [Body],
        prev: &[(Vec2, Rot)],
        h: f32,
        lambdas: &mut [f32; SLOTS],
    ) {
        let then = xpbd::Start::of(self, prev);
        by_kind!(self.kind, project(self, bodies, &then, h, lambdas))
    }
}

/// The solvers' parts of a joint, each handed to the joint's kind.
impl Joint {
    /// PGS: the joint's velocity rows of this (sub)step, from its frame `f` now.
    #[inline(always)]
    pub(crate) fn pgs_rows(&self, f: &JointFrame, rows: &mut pgs::RowBuilder) {
        by_kind!(self.kind, pgs_rows(self, f, rows))
    }

    /// XPBD's velocity pass: the joint's motor solved, its damping rows queued.
    #[inline]
    pub(crate) fn xpbd_velocity(&self, f: &JointFrame, pass: &mut xpbd::VelocityPass) {
        by_kind!(self.kind, xpbd_velocity(self, f, pass))
    }

    /// The soft step: what the kind adds to its rows' start (`p`).
    #[inline]
    pub(crate) fn soft_prepare(&self, bodies: &[Body], h: f32, p: &mut soft::Prepared) {
        by_kind!(self.kind, soft_prepare(self, bodies, h, p))
    }

    /// The soft step: applies the joint's lambdas `p` to its bodies `pair`.
    #[inline]
    pub(crate) fn soft_warm_start(&self, p: &soft::Prepared, pair: &mut soft::Pair) {
        let g = soft::frame_now(p, pair);
        by_kind!(self.kind, soft_warm_start(p, self, pair, &g))
    }

    /// The soft step: the joint's rows in the sweep `sw`; the largest |delta lambda|.
    #[inline]
    pub(crate) fn soft_solve(
        &self,
        sw: &soft::Sweep,
        p: &mut soft::Prepared,
        pair: &mut soft::Pair,
    ) -> f32 {
        let g = soft::frame_now(p, pair);
        by_kind!(self.kind, soft_solve(sw, p, self, pair, &g))
    }

    /// The soft step: the joint's damping over a substep of `h`.
    #[inline]
    pub(crate) fn soft_damp(&self, h: f32, p: &soft::Prepared, pair: &mut soft::Pair) {
        let g = soft::frame_now(p, pair);
        by_kind!(self.kind, soft_damp(h, self, pair, &g))
    }
}

/// Applies each joint's drive (the seed's ApplyForce / ApplyTorque) for a step of h:
/// an impulse drive h along the joint's axis on b and its reaction on a.
pub(crate) fn apply_drives(joints: &[Joint], bodies: &mut [Body], h: f32) {
    for j in joints {
        if j.drive == 0.0 {
            continue;
        }
        let f = j.frame(bodies);
        let p = j.drive * h;
        by_kind!(j.kind, drive(j, &f, bodies, p));
    }
}

/// A torque drive `p` (N m s) about the joint: w_b += p / I_b, w_a -= p / I_a.
#[inline]
fn drive_torque(j: &Joint, bodies: &mut [Body], p: f32) {
    let ia = bodies[j.a].inv_inertia;
    bodies[j.a].angular_velocity -= ia * p;
    let ib = bodies[j.b].inv_inertia;
    bodies[j.b].angular_velocity += ib * p;
}

/// A force drive `p` (N s) along the unit direction `e` between arms `ra` and `rb`: on
/// b, its reaction on a.
#[inline]
fn drive_force(j: &Joint, bodies: &mut [Body], (ra, rb, e): (Vec2, Vec2, Vec2), p: f32) {
    use crate::math::cross;
    let imp = p * e;
    let ba = &mut bodies[j.a];
    ba.velocity -= ba.inv_mass * imp;
    ba.angular_velocity -= ba.inv_inertia * cross(ra, imp);
    let bb = &mut bodies[j.b];
    bb.velocity += bb.inv_mass * imp;
    bb.angular_velocity += bb.inv_inertia * cross(rb, imp);
}

/// The reaction of a point and the rows on the relative angle (hinge, weld): the point
/// impulse's magnitude, and the angular rows summed as their warm start applies them.
#[inline]
fn point_and_angle(l: &[f32; SLOTS]) -> (f32, f32) {
    use slot::*;
    let ang = l[ANGLE] + l[MOTOR] + l[SERVO] + l[LOWER] - l[UPPER];
    (l[POINT_X].hypot(l[POINT_Y]), ang)
}

/// v scaled down to length `max` if longer (a bounded point impulse).
#[inline(always)]
fn clamp_length(v: Vec2, max: f32) -> Vec2 {
    let len = v.length();
    if len > max { v * (max / len) } else { v }
}

/// How far `x` is outside `[lo, hi]` (0 inside).
#[inline]
fn outside(x: f32, [lo, hi]: [f32; 2]) -> f32 {
    (lo - x).max(x - hi).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_lands_in_half_open_range() {
        use std::f32::consts::PI;
        for a in [-10.0f32, -PI, -3.0, 0.0, 1.0, PI, 3.2, 7.0, 100.0] {
            let w = wrap_angle(a);
            assert!(w > -PI - 1e-6 && w <= PI + 1e-6, "{a} -> {w}");
            // same direction
            assert!((w.sin() - a.sin()).abs() < 1e-4 && (w.cos() - a.cos()).abs() < 1e-4);
        }
    }
}
