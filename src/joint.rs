//! Joints: distance (attach, rope), hinge (limits, servo, motor), prismatic (limits,
//! servo, motor), weld, wheel (suspension spring, motor, limits), motor joint, pulley,
//! and the mouse joint that drags a body towards a point.
//!
//! A joint is stored in its bodies' frames (anchors and axis relative to each body's
//! centre of mass), so it follows the bodies. Both solvers read the same [`Joint`]:
//! PGS builds velocity rows from it (`solver::joint_rows`), XPBD projects
//! positions with it (`Joint::project`, after Mueller et al. 2020 and the Ten Minute
//! Physics joint notes).

use crate::body::Body;
use crate::defs::{DampingDef, JointDef, JointKind, MotorDef, ServoDef, SpringDef};
use crate::math::{Rot, Vec2, cross};

/// Index of a joint in its world, in creation order.
pub type JointId = usize;

/// A joint between bodies `a` and `b`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Joint {
    /// What the joint holds (see [`JointKind`]).
    pub kind: JointKind,
    /// Index of the first body in the world.
    pub a: usize,
    /// Index of the second body in the world.
    pub b: usize,
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

/// Drags one body's point towards a world target with a damped spring (the window's mouse).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MouseJoint {
    /// Index of the dragged body in the world.
    pub body: usize,
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

/// A pulley's two ropes: arms, unit directions (ground to anchor) and lengths.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PulleyRopes {
    pub ra: Vec2,
    pub rb: Vec2,
    pub ua: Vec2,
    pub ub: Vec2,
    pub len_a: f32,
    pub len_b: f32,
}

impl PulleyRopes {
    /// From the arms and the vectors ground point to anchor (ea, eb).
    #[inline]
    pub fn new(ra: Vec2, rb: Vec2, ea: Vec2, eb: Vec2) -> PulleyRopes {
        let (len_a, len_b) = (ea.length(), eb.length());
        PulleyRopes {
            ra,
            rb,
            ua: if len_a > 1e-9 { ea / len_a } else { Vec2::Y },
            ub: if len_b > 1e-9 { eb / len_b } else { Vec2::Y },
            len_a,
            len_b,
        }
    }
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

impl Joint {
    /// Builds a joint from its description and the bodies as they are now.
    /// `def.bodies` must be valid, distinct indices (the world checks).
    pub fn from_def(def: &JointDef, bodies: &[Body]) -> Joint {
        let (ba, bb) = (&bodies[def.bodies[0]], &bodies[def.bodies[1]]);
        let (wa, wb) = match (def.anchors, def.anchor) {
            (Some([p, q]), _) => (p, q),
            (None, Some(p)) => (p, p),
            // no anchor given: b's centre of mass (distance: both centres)
            (None, None) => match def.kind {
                JointKind::Distance | JointKind::Pulley => (ba.position, bb.position),
                _ => (bb.position, bb.position),
            },
        };
        let axis = def.axis.unwrap_or(Vec2::X).normalize_or(Vec2::X);
        let ground = def.ground_anchors.unwrap_or([wa, wb]);
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
        };
        match def.kind {
            JointKind::Wheel => {
                j.servo = None;
                j.spring = def.spring;
            }
            JointKind::Hinge => {
                // a torsion spring to the hinge's zero, which the def may set apart from
                // the angle at creation
                j.spring = def.spring;
                j.ref_angle = def.angle.unwrap_or(j.ref_angle);
            }
            JointKind::Motor => {
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
            JointKind::Pulley => {
                j.ground = ground;
                j.ratio = def.ratio;
                j.length = def
                    .length
                    .unwrap_or(wa.distance(ground[0]) + def.ratio * wb.distance(ground[1]));
                (j.servo, j.motor, j.limits) = (None, None, None);
            }
            _ => {}
        }
        j
    }

    /// A pulley's ropes now: for each side the unit direction from its ground point to
    /// its anchor and its length, with the world arms (ra, rb).
    #[inline]
    pub(crate) fn pulley_ropes(&self, bodies: &[Body]) -> PulleyRopes {
        let (ba, bb) = (&bodies[self.a], &bodies[self.b]);
        let ra = ba.rot.rotate(self.local_a);
        let rb = bb.rot.rotate(self.local_b);
        PulleyRopes::new(
            ra,
            rb,
            ba.position + ra - self.ground[0],
            bb.position + rb - self.ground[1],
        )
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
    /// A motor joint's are b's target point and b's centre; a pulley's its bodies' anchors.
    pub fn world_anchors(&self, bodies: &[Body]) -> (Vec2, Vec2) {
        let f = self.frame(bodies);
        let pa = bodies[self.a].position + f.ra;
        (pa, pa + f.d)
    }

    /// How far the joint is from holding (m): the anchor separation of a hinge or weld,
    /// the length error (or range violation) of a distance joint, the off-axis offset
    /// plus the range violation of a prismatic or wheel joint, the stretch of a pulley
    /// past its length; 0 for a motor joint (a bounded drive, not a constraint).
    pub fn position_error(&self, bodies: &[Body]) -> f32 {
        let f = self.frame(bodies);
        let outside = |x: f32, [lo, hi]: [f32; 2]| (lo - x).max(x - hi).max(0.0);
        match self.kind {
            JointKind::Motor => 0.0,
            JointKind::Pulley => {
                let p = self.pulley_ropes(bodies);
                (p.len_a + self.ratio * p.len_b - self.length).max(0.0)
            }
            JointKind::Hinge | JointKind::Weld => f.d.length(),
            JointKind::Distance => {
                let len = f.d.length();
                match self.limits {
                    Some(l) => outside(len, l),
                    None => (len - self.length).abs(),
                }
            }
            JointKind::Prismatic | JointKind::Wheel => {
                let off = f.axis.perp().dot(f.d).abs();
                off + self.limits.map_or(0.0, |l| outside(f.axis.dot(f.d), l))
            }
        }
    }

    /// How far the angle is outside the hinge's limits, or off a weld or prismatic
    /// joint's rest angle (rad).
    pub fn angle_error(&self, bodies: &[Body]) -> f32 {
        let f = self.frame(bodies);
        match self.kind {
            JointKind::Hinge => self
                .limits
                .map_or(0.0, |[lo, hi]| (lo - f.angle).max(f.angle - hi).max(0.0)),
            JointKind::Weld | JointKind::Prismatic => f.angle.abs(),
            JointKind::Distance | JointKind::Wheel | JointKind::Motor | JointKind::Pulley => 0.0,
        }
    }

    /// The joint's geometry at the start of the substep (positions and rotations given).
    #[inline]
    /// Keeps the second anchor on the first body's axis line (prismatic, wheel): the
    /// off-axis offset C = perp . d, corrected with compliance `soft`; `then` is
    /// [`Joint::frame_at`]'s frame at the substep's start.
    fn line_correction(
        &self,
        bodies: &mut [Body],
        (ra0, rb0, d0, axis0): (Vec2, Vec2, Vec2, Vec2),
        soft: f32,
        lambda: &mut f32,
    ) {
        let f = self.frame(bodies);
        let perp = f.axis.perp();
        linear_correction(
            bodies,
            self.a,
            self.b,
            [f.ra + f.d, f.rb, perp],
            [ra0 + d0, rb0, axis0.perp()],
            perp.dot(f.d),
            soft,
            lambda,
        );
    }

    fn frame_at(&self, prev: &[(Vec2, Rot)]) -> (Vec2, Vec2, Vec2, Vec2) {
        let ((xa, qa), (xb, qb)) = (prev[self.a], prev[self.b]);
        let ra = qa.rotate(self.local_a);
        let rb = qb.rotate(self.local_b);
        (ra, rb, (xb + rb) - (xa + ra), qa.rotate(self.local_axis))
    }

    /// One XPBD projection of the joint's position constraints over a substep of `h`
    /// seconds. `lambdas` are this substep's accumulated multipliers, one per slot;
    /// `prev` holds each body's position and rotation at the start of the substep.
    ///
    /// The corrections move the bodies along the constraint gradients of the substep's
    /// start (as SHAKE does), not of the predicted positions: with one Newton step per
    /// substep this keeps a pendulum's energy (0.1% over 20 s at 20 substeps where the
    /// predicted-gradient form loses 17%), at the same cost.
    pub(crate) fn project(
        &self,
        bodies: &mut [Body],
        prev: &[(Vec2, Rot)],
        h: f32,
        lambdas: &mut [f32; SLOTS],
    ) {
        // alpha~ = alpha / h^2
        let soft = self.compliance / (h * h);
        let (ra0, rb0, d0, axis0) = self.frame_at(prev);
        match self.kind {
            JointKind::Hinge | JointKind::Weld => {
                let f = self.frame(bodies);
                let mut lam = Vec2::new(lambdas[slot::POINT_X], lambdas[slot::POINT_Y]);
                point_correction(
                    bodies, self.a, self.b, f.ra, f.rb, ra0, rb0, f.d, soft, &mut lam,
                );
                (lambdas[slot::POINT_X], lambdas[slot::POINT_Y]) = (lam.x, lam.y);
                let f = self.frame(bodies);
                if self.kind == JointKind::Weld {
                    angular_correction(
                        bodies,
                        self.a,
                        self.b,
                        f.angle,
                        soft,
                        &mut lambdas[slot::ANGLE],
                    );
                } else {
                    // the torsion spring: C = angle with compliance 1 / k, k = I_eff
                    // omega^2 (its damping is applied in the velocity pass)
                    if let Some(sp) = self.spring
                        && sp.hertz > 0.0
                    {
                        let w = bodies[self.a].inv_inertia + bodies[self.b].inv_inertia;
                        if w > 0.0 {
                            let omega = std::f32::consts::TAU * sp.hertz;
                            let alpha = w / (omega * omega);
                            angular_correction(
                                bodies,
                                self.a,
                                self.b,
                                f.angle,
                                alpha / (h * h),
                                &mut lambdas[slot::SPRING],
                            );
                        }
                    }
                    let f = self.frame(bodies);
                    self.project_range(bodies, f.angle, lambdas, None);
                }
            }
            JointKind::Prismatic => {
                self.line_correction(
                    bodies,
                    (ra0, rb0, d0, axis0),
                    soft,
                    &mut lambdas[slot::AXIAL],
                );
                let f = self.frame(bodies);
                angular_correction(
                    bodies,
                    self.a,
                    self.b,
                    f.angle,
                    soft,
                    &mut lambdas[slot::ANGLE],
                );
                let f = self.frame(bodies);
                self.project_range(
                    bodies,
                    f.axis.dot(f.d),
                    lambdas,
                    Some(([f.ra + f.d, f.rb, f.axis], [ra0 + d0, rb0, axis0])),
                );
            }
            JointKind::Wheel => {
                self.line_correction(
                    bodies,
                    (ra0, rb0, d0, axis0),
                    soft,
                    &mut lambdas[slot::AXIAL],
                );
                let f = self.frame(bodies);
                let t = f.axis.dot(f.d);
                let now = [f.ra + f.d, f.rb, f.axis];
                let then = [ra0 + d0, rb0, axis0];
                // the suspension: C = axis . d with compliance 1 / k, k = m_eff omega^2
                // (its damping is applied in the velocity pass)
                if let Some(sp) = self.spring
                    && sp.hertz > 0.0
                {
                    let w = effective_inverse_mass(bodies, self.a, self.b, now);
                    if w > 0.0 {
                        let omega = std::f32::consts::TAU * sp.hertz;
                        let alpha = w / (omega * omega);
                        linear_correction(
                            bodies,
                            self.a,
                            self.b,
                            now,
                            then,
                            t,
                            alpha / (h * h),
                            &mut lambdas[slot::SPRING],
                        );
                    }
                }
                let f = self.frame(bodies);
                self.project_range(
                    bodies,
                    f.axis.dot(f.d),
                    lambdas,
                    Some(([f.ra + f.d, f.rb, f.axis], then)),
                );
            }
            // a bounded drive: XPBD applies it in the velocity pass
            JointKind::Motor => {}
            JointKind::Pulley => {
                let p = self.pulley_ropes(bodies);
                let c = p.len_a + self.ratio * p.len_b - self.length;
                if c > 0.0 {
                    pulley_correction(bodies, self.a, self.b, &p, self.ratio, c);
                }
            }
            JointKind::Distance => {
                let f = self.frame(bodies);
                let len = f.d.length();
                if len <= 1e-9 {
                    return;
                }
                let n = f.d / len;
                let c = match self.limits {
                    Some([lo, _]) if len < lo => len - lo,
                    Some([_, hi]) if len > hi => len - hi,
                    Some(_) => return,
                    None => len - self.length,
                };
                let n0 = d0.normalize_or(n);
                linear_correction(
                    bodies,
                    self.a,
                    self.b,
                    [f.ra, f.rb, n],
                    [ra0, rb0, n0],
                    c,
                    soft,
                    &mut lambdas[slot::AXIAL],
                );
            }
        }
    }

    /// Limits and servo of a hinge (angle) or prismatic joint (offset along the axis):
    /// `x` is the current value; `linear` carries the arms and axis of a prismatic joint.
    fn project_range(
        &self,
        bodies: &mut [Body],
        x: f32,
        lambdas: &mut [f32; SLOTS],
        linear: Option<([Vec2; 3], [Vec2; 3])>,
    ) {
        let correct = |bodies: &mut [Body], c: f32, lambda: &mut f32| match linear {
            Some((now, then)) => {
                linear_correction(bodies, self.a, self.b, now, then, c, 0.0, lambda)
            }
            None => angular_correction(bodies, self.a, self.b, c, 0.0, lambda),
        };
        if let Some([lo, hi]) = self.limits {
            if x < lo {
                correct(bodies, x - lo, &mut lambdas[slot::LOWER]);
            } else if x > hi {
                correct(bodies, x - hi, &mut lambdas[slot::UPPER]);
            }
        }
        if let Some(s) = self.servo {
            let c = if linear.is_some() {
                x - s.target
            } else {
                wrap_angle(x - s.target)
            };
            correct(bodies, c, &mut lambdas[slot::SERVO]);
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
pub(crate) fn effective_inverse_mass(bodies: &[Body], a: usize, b: usize, now: [Vec2; 3]) -> f32 {
    let [ra, rb, n] = now;
    let (ba, bb) = (&bodies[a], &bodies[b]);
    let (rna, rnb) = (cross(ra, n), cross(rb, n));
    ba.inv_mass + ba.inv_inertia * rna * rna + bb.inv_mass + bb.inv_inertia * rnb * rnb
}

/// XPBD correction of a pulley stretched by c > 0 (C = len_a + r len_b - length): each
/// anchor is pulled towards its ground point, b's with the ratio's leverage.
#[inline]
pub(crate) fn pulley_correction(
    bodies: &mut [Body],
    a: usize,
    b: usize,
    p: &PulleyRopes,
    ratio: f32,
    c: f32,
) {
    let (ima, iia) = (bodies[a].inv_mass, bodies[a].inv_inertia);
    let (imb, iib) = (bodies[b].inv_mass, bodies[b].inv_inertia);
    let (rua, rub) = (cross(p.ra, p.ua), cross(p.rb, p.ub));
    let w = ima + iia * rua * rua + ratio * ratio * (imb + iib * rub * rub);
    if w <= 0.0 {
        return;
    }
    // dC/dx_a = u_a, dC/dx_b = r u_b
    let dl = -c / w;
    let (pa, pb) = (dl * p.ua, dl * ratio * p.ub);
    move_body(&mut bodies[a], ima * pa, iia * cross(p.ra, pa));
    move_body(&mut bodies[b], imb * pb, iib * cross(p.rb, pb));
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
pub(crate) fn point_correction(
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

/// XPBD angular correction of C (rad): delta lambda = (-C - alpha~ lambda) / (1/I_a + 1/I_b + alpha~).
#[inline]
pub(crate) fn angular_correction(
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
