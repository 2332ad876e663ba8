//! Joint rows at the velocity level, solved by projected Gauss-Seidel beside the contact
//! rows (PGS), and the velocity-level parts XPBD shares: motors, damping. Each kind of
//! joint builds its rows here ([`super::Kind::pgs_rows`]) from the pieces below.
//!
//! A scalar row is J v + bias + gamma lambda = 0 with lambda in [lo, hi], where
//! J v = l_a . v_a + k_a w_a + l_b . v_b + k_b w_b. A rigid equality row takes the
//! Baumgarte bias beta C / h; a compliant one (compliance alpha) the implicit spring
//! bias C / h with gamma = alpha / h^2, which is XPBD's update written for impulses.
//! An inequality (limit) row is speculative while its gap is open: bias C / h lets the
//! gap close in this step but not more. The point of a hinge or weld is one 2x2 block.

use super::chain::Chains;
use super::{Joint, JointFrame, MouseJoint, clamp_length, slot, wrap_angle};
use crate::body::Body;
use crate::constraint::SolverBody;
use crate::defs::SolverSettings;
use crate::math::{Vec2, cross, cross_sv};

/// A rigid point row is regularised by gamma = this x trace(K) / 2 (a relative
/// constraint-force mixing). Without it a grid of hinges, whose loops make the rows
/// redundant, feeds energy into itself from the warm start and the Baumgarte bias and goes
/// non-finite (Box2D's 100 x 100 joint grid: near step 225 with gamma = 0, 500 steps finite
/// with 0.01; `cargo run --release --example joint_grid -- 100 500 pgs`). A chain, whose
/// rows are independent, barely notices: the point moves 1% less per sweep.
const POINT_REGULARIZATION: f32 = 0.01;

/// A scalar velocity row.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Row {
    a: u32,
    b: u32,
    la: Vec2,
    ka: f32,
    lb: Vec2,
    kb: f32,
    /// 1 / (J M^-1 J^T + gamma)
    mass: f32,
    bias: f32,
    gamma: f32,
    lo: f32,
    hi: f32,
    impulse: f32,
    joint: u32,
    slot: u8,
    /// A rigid row that also holds in the position (pseudo-velocity) solve (split impulse).
    pub(super) positional: bool,
    pos_impulse: f32,
}

/// A 2x2 point block: v_b + w_b x r_b - v_a - w_a x r_a + bias + gamma lambda = 0.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Point {
    pub(super) a: u32,
    pub(super) b: u32,
    pub(super) ra: Vec2,
    pub(super) rb: Vec2,
    /// (K + gamma I)^-1, column-major
    pub(super) inv_k: [f32; 4],
    pub(super) bias: Vec2,
    pub(super) gamma: f32,
    pub(super) impulse: Vec2,
    /// |lambda| bound (the mouse's max force times h); infinite for joints.
    pub(super) max_impulse: f32,
    /// `MOUSE` for the mouse joint.
    pub(super) joint: u32,
    /// Rigid (not the mouse, not compliant): it also holds in the position solve.
    pub(super) positional: bool,
    pub(super) pos_impulse: Vec2,
    /// Solved with its chain at once ([`super::chain`]), not point by point.
    pub(super) exact: bool,
}

/// The joint index of the mouse joint's point.
pub(super) const MOUSE: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
pub(super) enum Item {
    Row(Row),
    Point(Point),
}

/// The joint rows of one (sub)step and their lambdas.
#[derive(Clone, Debug, Default)]
pub struct JointRows {
    items: Vec<Item>,
    /// Whether the position errors go to the position solve (split impulse).
    split: bool,
    /// Damping rows, applied once after the sweeps.
    damping: Vec<(Row, f32)>,
    /// The small chains of rigid points solved exactly.
    chains: Chains,
}

#[inline(always)]
pub(super) fn load(bodies: &[SolverBody], i: u32) -> SolverBody {
    bodies[i as usize]
}

impl Row {
    /// J M^-1 J^T
    fn k(&self, bodies: &[SolverBody]) -> f32 {
        let (a, b) = (load(bodies, self.a), load(bodies, self.b));
        a.inv_m * self.la.length_squared()
            + a.inv_i * self.ka * self.ka
            + b.inv_m * self.lb.length_squared()
            + b.inv_i * self.kb * self.kb
    }

    #[inline(always)]
    fn jv(&self, bodies: &[SolverBody]) -> f32 {
        let (a, b) = (load(bodies, self.a), load(bodies, self.b));
        self.la.dot(a.v) + self.ka * a.w + self.lb.dot(b.v) + self.kb * b.w
    }

    /// v += M^-1 J^T d
    #[inline(always)]
    fn apply(&self, bodies: &mut [SolverBody], d: f32) {
        let a = &mut bodies[self.a as usize];
        a.v += a.inv_m * d * self.la;
        a.w += a.inv_i * d * self.ka;
        let b = &mut bodies[self.b as usize];
        b.v += b.inv_m * d * self.lb;
        b.w += b.inv_i * d * self.kb;
    }

    /// delta lambda = -(J v + bias + gamma lambda) / (K + gamma), projected onto [lo, hi].
    #[inline(always)]
    pub(super) fn solve(&mut self, bodies: &mut [SolverBody]) -> f32 {
        let d = -self.mass * (self.jv(bodies) + self.bias + self.gamma * self.impulse);
        let new = (self.impulse + d).clamp(self.lo, self.hi);
        let d = new - self.impulse;
        self.impulse = new;
        self.apply(bodies, d);
        d.abs()
    }

    pub(super) fn negated(mut self) -> Row {
        self.la = -self.la;
        self.ka = -self.ka;
        self.lb = -self.lb;
        self.kb = -self.kb;
        self
    }

    /// The angle row: J v = w_b - w_a.
    pub(super) fn angle(a: u32, b: u32) -> Row {
        Row {
            a,
            b,
            ka: -1.0,
            kb: 1.0,
            ..Default::default()
        }
    }

    /// The row along world direction e between anchors, where e turns with body a
    /// (prismatic) or is the anchor direction (distance):
    /// J v = e . (v_b + w_b x r_b - v_a - w_a x (r_a + d')).
    pub(super) fn linear(a: u32, b: u32, ra: Vec2, rb: Vec2, e: Vec2) -> Row {
        Row {
            a,
            b,
            la: -e,
            ka: -cross(ra, e),
            lb: e,
            kb: cross(rb, e),
            ..Default::default()
        }
    }

    /// A row of the given Jacobian (la, ka, lb, kb).
    pub(super) fn of(a: u32, b: u32, (la, ka): (Vec2, f32), (lb, kb): (Vec2, f32)) -> Row {
        Row {
            a,
            b,
            la,
            ka,
            lb,
            kb,
            ..Default::default()
        }
    }
}

impl Point {
    /// The anchors' relative velocity, J v = v_b + w_b x r_b - v_a - w_a x r_a.
    #[inline(always)]
    pub(super) fn cdot(&self, bodies: &[SolverBody]) -> Vec2 {
        let (a, b) = (load(bodies, self.a), load(bodies, self.b));
        b.v + cross_sv(b.w, self.rb) - a.v - cross_sv(a.w, self.ra)
    }

    /// (Always inlined: the sweeps' hottest call on a grid of hinges.)
    #[inline(always)]
    pub(super) fn solve(&mut self, bodies: &mut [SolverBody]) -> f32 {
        let cdot = self.cdot(bodies);
        let rhs = -(cdot + self.bias + self.gamma * self.impulse);
        let k = self.inv_k;
        let d = Vec2::new(k[0] * rhs.x + k[2] * rhs.y, k[1] * rhs.x + k[3] * rhs.y);
        let new = clamp_length(self.impulse + d, self.max_impulse);
        let d = new - self.impulse;
        self.impulse = new;
        self.apply(bodies, d);
        d.abs().max_element()
    }

    #[inline(always)]
    pub(super) fn apply(&self, bodies: &mut [SolverBody], p: Vec2) {
        let a = &mut bodies[self.a as usize];
        a.v -= a.inv_m * p;
        a.w -= a.inv_i * cross(self.ra, p);
        let b = &mut bodies[self.b as usize];
        b.v += b.inv_m * p;
        b.w += b.inv_i * cross(self.rb, p);
    }
}

/// 2x2 K = M_a^-1 + M_b^-1 for a point between arms ra and rb, plus gamma on the
/// diagonal, inverted.
pub(super) fn point_inv_k(
    a: &SolverBody,
    b: &SolverBody,
    ra: Vec2,
    rb: Vec2,
    gamma: f32,
) -> [f32; 4] {
    let m = a.inv_m + b.inv_m;
    let k11 = m + a.inv_i * ra.y * ra.y + b.inv_i * rb.y * rb.y + gamma;
    let k12 = -a.inv_i * ra.x * ra.y - b.inv_i * rb.x * rb.y;
    let k22 = m + a.inv_i * ra.x * ra.x + b.inv_i * rb.x * rb.x + gamma;
    let det = k11 * k22 - k12 * k12;
    if det.abs() <= f32::MIN_POSITIVE {
        return [0.0; 4];
    }
    let inv = 1.0 / det;
    [inv * k22, -inv * k12, -inv * k12, inv * k11]
}

/// Fills a row's mass and bias for an equality C = 0 with the given compliance.
fn equality(mut r: Row, bodies: &[SolverBody], c: f32, compliance: f32, beta: f32, h: f32) -> Row {
    let k = r.k(bodies);
    if compliance > 0.0 {
        // implicit spring: (K + alpha/h^2) dlambda = -(J v + C/h + alpha/h^2 lambda)
        r.gamma = compliance / (h * h);
        r.bias = c / h;
    } else {
        // Baumgarte: J v = -beta C / h
        r.bias = beta * c / h;
        r.positional = true;
    }
    r.mass = if k + r.gamma > 0.0 {
        1.0 / (k + r.gamma)
    } else {
        0.0
    };
    r.lo = f32::NEG_INFINITY;
    r.hi = f32::INFINITY;
    r
}

/// Fills a row for the inequality C >= 0: speculative while open (J v >= -C/h),
/// Baumgarte once violated (J v >= -beta C / h).
fn inequality(mut r: Row, bodies: &[SolverBody], c: f32, beta: f32, h: f32) -> Row {
    let k = r.k(bodies);
    r.bias = if c > 0.0 { c / h } else { beta * c / h };
    r.positional = c <= 0.0;
    r.mass = if k > 0.0 { 1.0 / k } else { 0.0 };
    r.lo = 0.0;
    r.hi = f32::INFINITY;
    r
}

/// A spring row (the wheel's suspension): a soft equality C = 0 of frequency `hertz` and
/// damping ratio `zeta` for the row's effective mass m_eff = 1 / K: k = m_eff omega^2,
/// c = 2 m_eff zeta omega, gamma = 1 / (h (c + h k)), bias = h k gamma C.
fn spring(mut r: Row, bodies: &[SolverBody], c: f32, hertz: f32, zeta: f32, h: f32) -> Row {
    let k = r.k(bodies);
    r.lo = f32::NEG_INFINITY;
    r.hi = f32::INFINITY;
    if !(k > 0.0) || !(hertz > 0.0) {
        return r;
    }
    let m_eff = 1.0 / k;
    let omega = std::f32::consts::TAU * hertz;
    let stiffness = m_eff * omega * omega;
    let damp = 2.0 * m_eff * zeta.max(0.0) * omega;
    r.gamma = 1.0 / (h * (damp + h * stiffness));
    r.bias = h * stiffness * r.gamma * c;
    r.mass = 1.0 / (k + r.gamma);
    r
}

/// A motor row: J v = speed, |lambda| <= max_force h.
pub(super) fn motor(mut r: Row, bodies: &[SolverBody], speed: f32, max_force: f32, h: f32) -> Row {
    let k = r.k(bodies);
    r.bias = -speed;
    r.mass = if k > 0.0 { 1.0 / k } else { 0.0 };
    r.hi = max_force * h;
    r.lo = -r.hi;
    r
}

/// A damping row along r (no bias: it only measures J v and its mass).
#[inline]
pub(super) fn damping_row(r: Row, bodies: &[SolverBody], h: f32) -> Row {
    equality(r, bodies, 0.0, 0.0, 0.0, h)
}

/// What a joint's rows of a (sub)step are built from, and where they go: the kinds'
/// [`super::Kind::pgs_rows`] fill it.
pub(crate) struct RowBuilder<'a> {
    items: &'a mut Vec<Item>,
    damping: &'a mut Vec<(Row, f32)>,
    /// The solver's velocities and inverse masses.
    pub(super) bodies: &'a [SolverBody],
    /// The bodies (positions, for a pulley's ropes).
    pub(super) world: &'a [Body],
    joint: u32,
    /// The joint's bodies.
    pub(super) a: u32,
    pub(super) b: u32,
    warm: bool,
    beta: f32,
    /// The (sub)step, and the world's step (the motor joint's correction is per step).
    pub(super) h: f32,
    pub(super) dt: f32,
}

/// Where a joint's damping rows go (PGS's rows of a step, XPBD's velocity pass): each
/// removes min(h c, 1) of the relative velocity along its row, after the sweeps.
pub(super) trait Damping {
    /// Queues a damping row along r at `rate` (1/s).
    fn damp(&mut self, r: Row, rate: f32);

    /// Queues the joint's angular damping (if any) on the angle row `ang`.
    #[inline]
    fn damp_angle(&mut self, j: &Joint, ang: Row) {
        if j.damping.angular > 0.0 {
            self.damp(ang, j.damping.angular);
        }
    }
}

impl Damping for RowBuilder<'_> {
    #[inline]
    fn damp(&mut self, r: Row, rate: f32) {
        self.damping
            .push((damping_row(r, self.bodies, self.h), rate));
    }
}

impl RowBuilder<'_> {
    /// Adds a row of the joint, in its lambda slot (warm started from the joint's
    /// stored lambda, clamped to the row's bounds).
    #[inline(always)]
    pub(super) fn push(&mut self, j: &Joint, mut r: Row, slot: usize) {
        r.joint = self.joint;
        r.slot = slot as u8;
        r.impulse = if self.warm {
            j.impulses[slot].clamp(r.lo, r.hi)
        } else {
            0.0
        };
        self.items.push(Item::Row(r));
    }

    /// An equality C = 0 with the given compliance (0: rigid, Baumgarte).
    #[inline]
    pub(super) fn equality(&self, r: Row, c: f32, compliance: f32) -> Row {
        equality(r, self.bodies, c, compliance, self.beta, self.h)
    }

    /// An inequality C >= 0.
    #[inline]
    pub(super) fn inequality(&self, r: Row, c: f32) -> Row {
        inequality(r, self.bodies, c, self.beta, self.h)
    }

    /// A spring row C = 0 of its own frequency and damping ratio.
    #[inline]
    pub(super) fn spring(&self, r: Row, c: f32, hertz: f32, zeta: f32) -> Row {
        spring(r, self.bodies, c, hertz, zeta, self.h)
    }

    /// A motor row J v = speed, its force bounded.
    #[inline]
    pub(super) fn motor(&self, r: Row, speed: f32, max_force: f32) -> Row {
        motor(r, self.bodies, speed, max_force, self.h)
    }

    /// The joint's motor on row r, if it has one.
    #[inline]
    pub(super) fn motor_of(&mut self, j: &Joint, r: Row) {
        if let Some(m) = j.motor {
            let r = self.motor(r, m.speed, m.max_force);
            self.push(j, r, slot::MOTOR);
        }
    }

    /// Adds a point block (its lambda already set).
    #[inline]
    pub(super) fn push_point(&mut self, p: Point) {
        self.items.push(Item::Point(p));
    }

    /// Whether the rows start from the joint's stored lambdas.
    #[inline]
    pub(super) fn warm(&self) -> bool {
        self.warm
    }

    /// The joint's index, for a point block.
    #[inline]
    pub(super) fn joint(&self) -> u32 {
        self.joint
    }

    /// The point of a hinge or weld, d = p_b - p_a = 0, as one 2x2 block: rigid
    /// (Baumgarte, regularised) or with the joint's compliance.
    #[inline(always)]
    pub(super) fn point(&mut self, j: &Joint, f: &JointFrame) {
        let (h, beta) = (self.h, self.beta);
        let ba = &self.bodies[j.a];
        let bb = &self.bodies[j.b];
        let rigid = j.compliance <= 0.0;
        let gamma = if !rigid {
            j.compliance / (h * h)
        } else {
            // trace(K) / 2, K = M_a^-1 + M_b^-1 at the arms
            let m = ba.inv_m + bb.inv_m;
            let k = m + 0.5 * (ba.inv_i * f.ra.length_squared() + bb.inv_i * f.rb.length_squared());
            POINT_REGULARIZATION * k
        };
        let bias = if !rigid { f.d / h } else { beta * f.d / h };
        let imp = Vec2::new(j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
        let p = Point {
            a: self.a,
            b: self.b,
            ra: f.ra,
            rb: f.rb,
            inv_k: point_inv_k(ba, bb, f.ra, f.rb, gamma),
            bias,
            gamma,
            impulse: if self.warm { imp } else { Vec2::ZERO },
            max_impulse: f32::INFINITY,
            joint: self.joint,
            positional: rigid,
            pos_impulse: Vec2::ZERO,
            exact: false,
        };
        self.push_point(p);
    }

    /// Limits and servo rows on the joint's angle (hinge) or offset (prismatic) x.
    #[inline(always)]
    pub(super) fn range(&mut self, j: &Joint, r: Row, x: f32, angular: bool) {
        if let Some([lo, hi]) = j.limits {
            let lower = self.inequality(r, x - lo);
            self.push(j, lower, slot::LOWER);
            let upper = self.inequality(r.negated(), hi - x);
            self.push(j, upper, slot::UPPER);
        }
        if let Some(s) = j.servo {
            let c = if angular {
                wrap_angle(x - s.target)
            } else {
                x - s.target
            };
            let servo = self.equality(r, c, 0.0);
            self.push(j, servo, slot::SERVO);
        }
    }

    /// The row that keeps the second anchor on the first body's axis line (prismatic,
    /// wheel): C = perp . d along the axis's perpendicular, with the joint's compliance.
    pub(super) fn line(&mut self, j: &Joint, f: &JointFrame) {
        let perp = f.axis.perp();
        let pr = Row::linear(self.a, self.b, f.ra + f.d, f.rb, perp);
        let r = self.equality(pr, perp.dot(f.d), j.compliance);
        self.push(j, r, slot::AXIAL);
    }
}

impl JointRows {
    /// Builds this step's rows from the joints (and the mouse joint) at the bodies'
    /// current positions; `bodies` are the solver's velocities and inverse masses.
    /// With warm starting, last step's lambdas start the rows.
    pub fn prepare(
        &mut self,
        joints: &[Joint],
        mouse: Option<&MouseJoint>,
        world_bodies: &[Body],
        bodies: &[SolverBody],
        s: &SolverSettings,
        h: f32,
    ) {
        self.items.clear();
        self.damping.clear();
        for (ji, j) in joints.iter().enumerate() {
            let f = j.frame(world_bodies);
            let mut rows = RowBuilder {
                items: &mut self.items,
                damping: &mut self.damping,
                bodies,
                world: world_bodies,
                joint: ji as u32,
                a: j.a as u32,
                b: j.b as u32,
                warm: s.warm_start,
                beta: s.baumgarte,
                h,
                dt: s.dt,
            };
            j.pgs_rows(&f, &mut rows);
        }
        if let Some(m) = mouse
            && let Some(p) = m.pgs_point(world_bodies, bodies, h)
        {
            self.items.push(Item::Point(p));
        }
        self.chains.build(&mut self.items, bodies);
        // With split impulse the joints also hold in the position solve (J v_p = 0), so
        // the pseudo-velocities that push overlapping bodies apart do not pull joints
        // apart; their own drift stays with the warm-started velocity rows (Baumgarte),
        // which converge on long chains where a cold position solve does not.
        self.split = s.split_impulse;
    }

    /// Forgets every row, and gives the damping rows to fill (XPBD's velocity pass).
    pub(super) fn damping_only(&mut self) -> &mut Vec<(Row, f32)> {
        self.items.clear();
        self.chains.clear();
        self.damping.clear();
        &mut self.damping
    }

    /// Whether the position solve has joint rows (split impulse and any rigid row).
    pub fn has_position_rows(&self) -> bool {
        self.split
            && self.items.iter().any(|it| match it {
                Item::Row(r) => r.positional,
                Item::Point(p) => p.positional,
            })
    }

    /// One sweep of the joints' rigid rows on the pseudo-velocities `bodies`: J v_p = 0
    /// (equalities), J v_p >= 0 (reached limits).
    pub fn sweep_position(&mut self, bodies: &mut [SolverBody]) -> f32 {
        let mut residual = 0.0f32;
        for it in &mut self.items {
            match it {
                Item::Row(r) if r.positional => {
                    let d = -r.mass * r.jv(bodies);
                    let new = (r.pos_impulse + d).clamp(r.lo, r.hi);
                    let d = new - r.pos_impulse;
                    r.pos_impulse = new;
                    r.apply(bodies, d);
                    residual = residual.max(d.abs());
                }
                Item::Point(p) if p.positional && !p.exact => {
                    let rhs = -p.cdot(bodies);
                    let k = p.inv_k;
                    let d = Vec2::new(k[0] * rhs.x + k[2] * rhs.y, k[1] * rhs.x + k[3] * rhs.y);
                    p.pos_impulse += d;
                    p.apply(bodies, d);
                    residual = residual.max(d.abs().max_element());
                }
                _ => {}
            }
        }
        residual.max(self.chains.solve(&mut self.items, bodies, true))
    }

    /// Applies the warm-start lambdas.
    pub fn warm_start(&self, bodies: &mut [SolverBody]) {
        for it in &self.items {
            match it {
                Item::Row(r) => r.apply(bodies, r.impulse),
                Item::Point(p) if p.joint != MOUSE => p.apply(bodies, p.impulse),
                Item::Point(_) => {}
            }
        }
    }

    /// One Gauss-Seidel sweep over the joint rows; returns max |delta lambda|.
    pub fn sweep(&mut self, bodies: &mut [SolverBody]) -> f32 {
        let mut residual = 0.0f32;
        for it in &mut self.items {
            let d = match it {
                Item::Row(r) => r.solve(bodies),
                Item::Point(p) if p.joint == MOUSE => MouseJoint::pgs_solve(p, bodies),
                Item::Point(p) if p.exact => 0.0,
                Item::Point(p) => p.solve(bodies),
            };
            residual = residual.max(d);
        }
        residual.max(self.chains.solve(&mut self.items, bodies, false))
    }

    /// Joint damping: removes the fraction min(h c, 1) of the relative velocity along
    /// each damped row (the seed's DampLinear / DampAngular).
    pub fn damp(&self, bodies: &mut [SolverBody], h: f32) {
        for (r, c) in &self.damping {
            let f = (h * c).min(1.0);
            let d = -r.mass * r.jv(bodies) * f;
            r.apply(bodies, d);
        }
    }

    /// Whether there are any rows.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty() && self.damping.is_empty()
    }

    /// Writes the lambdas back into the joints for next step's warm start.
    pub fn store(&self, joints: &mut [Joint]) {
        for it in &self.items {
            match it {
                Item::Row(r) => joints[r.joint as usize].impulses[r.slot as usize] = r.impulse,
                Item::Point(p) if p.joint != MOUSE => {
                    let j = &mut joints[p.joint as usize];
                    j.impulses[slot::POINT_X] = p.impulse.x;
                    j.impulses[slot::POINT_Y] = p.impulse.y;
                }
                Item::Point(_) => {}
            }
        }
    }
}
