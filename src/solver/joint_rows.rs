//! Joint rows at the velocity level, solved by projected Gauss-Seidel beside the contact
//! rows (PGS), and the velocity-level parts XPBD shares: motors, damping.
//!
//! A scalar row is J v + bias + gamma lambda = 0 with lambda in [lo, hi], where
//! J v = l_a . v_a + k_a w_a + l_b . v_b + k_b w_b. A rigid equality row takes the
//! Baumgarte bias beta C / h; a compliant one (compliance alpha) the implicit spring
//! bias C / h with gamma = alpha / h^2, which is XPBD's update written for impulses.
//! An inequality (limit) row is speculative while its gap is open: bias C / h lets the
//! gap close in this step but not more. The point of a hinge or weld is one 2x2 block.

use super::pgs::SolverBody;
use crate::body::Body;
use crate::defs::{JointKind, SolverSettings};
use crate::joint::{Joint, JointFrame, MouseJoint, PulleyRopes, slot, wrap_angle};
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
struct Row {
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
    positional: bool,
    pos_impulse: f32,
}

/// A 2x2 point block: v_b + w_b x r_b - v_a - w_a x r_a + bias + gamma lambda = 0.
#[derive(Clone, Copy, Debug, Default)]
struct Point {
    a: u32,
    b: u32,
    ra: Vec2,
    rb: Vec2,
    /// (K + gamma I)^-1, column-major
    inv_k: [f32; 4],
    bias: Vec2,
    gamma: f32,
    impulse: Vec2,
    /// |lambda| bound (the mouse's max force times h); infinite for joints.
    max_impulse: f32,
    /// u32::MAX for the mouse joint.
    joint: u32,
    /// Rigid (not the mouse, not compliant): it also holds in the position solve.
    positional: bool,
    pos_impulse: Vec2,
}

#[derive(Clone, Copy, Debug)]
enum Item {
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
}

#[inline]
fn load(bodies: &[SolverBody], i: u32) -> SolverBody {
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

    #[inline]
    fn jv(&self, bodies: &[SolverBody]) -> f32 {
        let (a, b) = (load(bodies, self.a), load(bodies, self.b));
        self.la.dot(a.v) + self.ka * a.w + self.lb.dot(b.v) + self.kb * b.w
    }

    /// v += M^-1 J^T d
    #[inline]
    fn apply(&self, bodies: &mut [SolverBody], d: f32) {
        let a = &mut bodies[self.a as usize];
        a.v += a.inv_m * d * self.la;
        a.w += a.inv_i * d * self.ka;
        let b = &mut bodies[self.b as usize];
        b.v += b.inv_m * d * self.lb;
        b.w += b.inv_i * d * self.kb;
    }

    /// delta lambda = -(J v + bias + gamma lambda) / (K + gamma), projected onto [lo, hi].
    #[inline]
    fn solve(&mut self, bodies: &mut [SolverBody]) -> f32 {
        let d = -self.mass * (self.jv(bodies) + self.bias + self.gamma * self.impulse);
        let new = (self.impulse + d).clamp(self.lo, self.hi);
        let d = new - self.impulse;
        self.impulse = new;
        self.apply(bodies, d);
        d.abs()
    }

    fn negated(mut self) -> Row {
        self.la = -self.la;
        self.ka = -self.ka;
        self.lb = -self.lb;
        self.kb = -self.kb;
        self
    }
}

impl Point {
    #[inline]
    fn solve(&mut self, bodies: &mut [SolverBody]) -> f32 {
        let (a, b) = (load(bodies, self.a), load(bodies, self.b));
        let cdot = b.v + cross_sv(b.w, self.rb) - a.v - cross_sv(a.w, self.ra);
        let rhs = -(cdot + self.bias + self.gamma * self.impulse);
        let k = self.inv_k;
        let d = Vec2::new(k[0] * rhs.x + k[2] * rhs.y, k[1] * rhs.x + k[3] * rhs.y);
        let mut new = self.impulse + d;
        let len = new.length();
        if len > self.max_impulse {
            new *= self.max_impulse / len;
        }
        let d = new - self.impulse;
        self.impulse = new;
        self.apply(bodies, d);
        d.abs().max_element()
    }

    #[inline]
    fn apply(&self, bodies: &mut [SolverBody], p: Vec2) {
        let a = &mut bodies[self.a as usize];
        a.v -= a.inv_m * p;
        a.w -= a.inv_i * cross(self.ra, p);
        let b = &mut bodies[self.b as usize];
        b.v += b.inv_m * p;
        b.w += b.inv_i * cross(self.rb, p);
    }
}

/// The angle row: J v = w_b - w_a.
fn angle_row(a: u32, b: u32) -> Row {
    Row {
        a,
        b,
        ka: -1.0,
        kb: 1.0,
        ..Default::default()
    }
}

/// The row along world direction e between anchors, where e turns with body a (prismatic)
/// or is the anchor direction (distance): J v = e . (v_b + w_b x r_b - v_a - w_a x (r_a + d')).
fn linear_row(a: u32, b: u32, ra: Vec2, rb: Vec2, e: Vec2) -> Row {
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

/// 2x2 K = M_a^-1 + M_b^-1 for a point between arms ra and rb, plus gamma on the diagonal, inverted.
fn point_inv_k(a: &SolverBody, b: &SolverBody, ra: Vec2, rb: Vec2, gamma: f32) -> [f32; 4] {
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
/// The row that keeps the second anchor on the first body's axis line (prismatic,
/// wheel): C = perp . d along the axis's perpendicular.
fn line_row(
    a: u32,
    b: u32,
    f: &crate::joint::JointFrame,
    bodies: &[SolverBody],
    compliance: f32,
    beta: f32,
    h: f32,
) -> Row {
    let perp = f.axis.perp();
    let pr = linear_row(a, b, f.ra + f.d, f.rb, perp);
    equality(pr, bodies, perp.dot(f.d), compliance, beta, h)
}

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

/// A pulley's row: J v = d/dt (length - len_a - r len_b) = -(u_a . v_pa + r u_b . v_pb).
fn pulley_row(a: u32, b: u32, p: &PulleyRopes, ratio: f32) -> Row {
    Row {
        a,
        b,
        la: -p.ua,
        ka: -cross(p.ra, p.ua),
        lb: -ratio * p.ub,
        kb: -ratio * cross(p.rb, p.ub),
        ..Default::default()
    }
}

/// A motor row: J v = speed, |lambda| <= max_force h.
fn motor(mut r: Row, bodies: &[SolverBody], speed: f32, max_force: f32, h: f32) -> Row {
    let k = r.k(bodies);
    r.bias = -speed;
    r.mass = if k > 0.0 { 1.0 / k } else { 0.0 };
    r.hi = max_force * h;
    r.lo = -r.hi;
    r
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
        let beta = s.baumgarte;
        for (ji, j) in joints.iter().enumerate() {
            let f = j.frame(world_bodies);
            let (a, b) = (j.a as u32, j.b as u32);
            let warm = s.warm_start;
            let push = |items: &mut Vec<Item>, mut r: Row, slot: usize| {
                r.joint = ji as u32;
                r.slot = slot as u8;
                r.impulse = if warm {
                    j.impulses[slot].clamp(r.lo, r.hi)
                } else {
                    0.0
                };
                items.push(Item::Row(r));
            };
            match j.kind {
                JointKind::Hinge | JointKind::Weld => {
                    let ang = angle_row(a, b);
                    // a hinge's torsion spring, to its zero angle
                    if let Some(sp) = j.spring.filter(|_| j.kind == JointKind::Hinge) {
                        push(
                            &mut self.items,
                            spring(ang, bodies, f.angle, sp.hertz, sp.damping_ratio, h),
                            slot::SPRING,
                        );
                    }
                    if let Some(m) = j.motor {
                        push(
                            &mut self.items,
                            motor(ang, bodies, m.speed, m.max_force, h),
                            slot::MOTOR,
                        );
                    }
                    if j.kind == JointKind::Hinge {
                        range_rows(
                            &mut self.items,
                            j,
                            ang,
                            f.angle,
                            bodies,
                            beta,
                            h,
                            true,
                            &push,
                        );
                    } else {
                        push(
                            &mut self.items,
                            equality(ang, bodies, f.angle, j.compliance, beta, h),
                            slot::ANGLE,
                        );
                    }
                    let ba = &bodies[j.a];
                    let bb = &bodies[j.b];
                    let rigid = j.compliance <= 0.0;
                    let gamma = if !rigid {
                        j.compliance / (h * h)
                    } else {
                        // trace(K) / 2, K = M_a^-1 + M_b^-1 at the arms
                        let m = ba.inv_m + bb.inv_m;
                        let k = m + 0.5
                            * (ba.inv_i * f.ra.length_squared() + bb.inv_i * f.rb.length_squared());
                        POINT_REGULARIZATION * k
                    };
                    let bias = if !rigid { f.d / h } else { beta * f.d / h };
                    let imp = Vec2::new(j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
                    self.items.push(Item::Point(Point {
                        a,
                        b,
                        ra: f.ra,
                        rb: f.rb,
                        inv_k: point_inv_k(ba, bb, f.ra, f.rb, gamma),
                        bias,
                        gamma,
                        impulse: if s.warm_start { imp } else { Vec2::ZERO },
                        max_impulse: f32::INFINITY,
                        joint: ji as u32,
                        positional: rigid,
                        pos_impulse: Vec2::ZERO,
                    }));
                    if j.damping.angular > 0.0 {
                        self.damping
                            .push((equality(ang, bodies, 0.0, 0.0, 0.0, h), j.damping.angular));
                    }
                }
                JointKind::Prismatic => {
                    let ax = linear_row(a, b, f.ra + f.d, f.rb, f.axis);
                    if let Some(m) = j.motor {
                        push(
                            &mut self.items,
                            motor(ax, bodies, m.speed, m.max_force, h),
                            slot::MOTOR,
                        );
                    }
                    let t = f.axis.dot(f.d);
                    range_rows(&mut self.items, j, ax, t, bodies, beta, h, false, &push);
                    push(
                        &mut self.items,
                        line_row(a, b, &f, bodies, j.compliance, beta, h),
                        slot::AXIAL,
                    );
                    push(
                        &mut self.items,
                        equality(angle_row(a, b), bodies, f.angle, j.compliance, beta, h),
                        slot::ANGLE,
                    );
                    if j.damping.linear > 0.0 {
                        self.damping
                            .push((equality(ax, bodies, 0.0, 0.0, 0.0, h), j.damping.linear));
                    }
                    if j.damping.angular > 0.0 {
                        let ang = angle_row(a, b);
                        self.damping
                            .push((equality(ang, bodies, 0.0, 0.0, 0.0, h), j.damping.angular));
                    }
                }
                JointKind::Wheel => {
                    if let Some(m) = j.motor {
                        push(
                            &mut self.items,
                            motor(angle_row(a, b), bodies, m.speed, m.max_force, h),
                            slot::MOTOR,
                        );
                    }
                    let ax = linear_row(a, b, f.ra + f.d, f.rb, f.axis);
                    let t = f.axis.dot(f.d);
                    if let Some(sp) = j.spring {
                        push(
                            &mut self.items,
                            spring(ax, bodies, t, sp.hertz, sp.damping_ratio, h),
                            slot::SPRING,
                        );
                    }
                    range_rows(&mut self.items, j, ax, t, bodies, beta, h, false, &push);
                    push(
                        &mut self.items,
                        line_row(a, b, &f, bodies, j.compliance, beta, h),
                        slot::AXIAL,
                    );
                    if j.damping.linear > 0.0 {
                        self.damping
                            .push((equality(ax, bodies, 0.0, 0.0, 0.0, h), j.damping.linear));
                    }
                }
                JointKind::Motor => {
                    push(
                        &mut self.items,
                        motor_joint_angle(j, (a, b), f.angle, bodies, h, s.dt),
                        slot::ANGLE,
                    );
                    let imp = Vec2::new(j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
                    let mut p = motor_joint_point(j, &f, bodies, (h, s.dt), ji as u32);
                    if s.warm_start {
                        p.impulse = clamp_length(imp, p.max_impulse);
                    }
                    self.items.push(Item::Point(p));
                }
                JointKind::Pulley => {
                    let p = j.pulley_ropes(world_bodies);
                    let c = j.length - p.len_a - j.ratio * p.len_b;
                    push(
                        &mut self.items,
                        inequality(pulley_row(a, b, &p, j.ratio), bodies, c, beta, h),
                        slot::AXIAL,
                    );
                }
                JointKind::Distance => {
                    let len = f.d.length();
                    let u = if len > 1e-9 { f.d / len } else { Vec2::Y };
                    let r = linear_row(a, b, f.ra, f.rb, u);
                    match j.limits {
                        Some([lo, hi]) => {
                            push(
                                &mut self.items,
                                inequality(r, bodies, len - lo, beta, h),
                                slot::LOWER,
                            );
                            push(
                                &mut self.items,
                                inequality(r.negated(), bodies, hi - len, beta, h),
                                slot::UPPER,
                            );
                        }
                        None => push(
                            &mut self.items,
                            equality(r, bodies, len - j.length, j.compliance, beta, h),
                            slot::AXIAL,
                        ),
                    }
                    if j.damping.linear > 0.0 {
                        self.damping
                            .push((equality(r, bodies, 0.0, 0.0, 0.0, h), j.damping.linear));
                    }
                }
            }
        }
        if let Some(m) = mouse {
            self.push_mouse(m, world_bodies, bodies, h);
        }
        // With split impulse the joints also hold in the position solve (J v_p = 0), so
        // the pseudo-velocities that push overlapping bodies apart do not pull joints
        // apart; their own drift stays with the warm-started velocity rows (Baumgarte),
        // which converge on long chains where a cold position solve does not.
        self.split = s.split_impulse;
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
                Item::Point(p) if p.positional => {
                    let (a, b) = (load(bodies, p.a), load(bodies, p.b));
                    let cdot = b.v + cross_sv(b.w, p.rb) - a.v - cross_sv(a.w, p.ra);
                    let rhs = -cdot;
                    let k = p.inv_k;
                    let d = Vec2::new(k[0] * rhs.x + k[2] * rhs.y, k[1] * rhs.x + k[3] * rhs.y);
                    p.pos_impulse += d;
                    p.apply(bodies, d);
                    residual = residual.max(d.abs().max_element());
                }
                _ => {}
            }
        }
        residual
    }

    /// The mouse joint: a soft point constraint (spring hertz, damping ratio) between the
    /// grabbed point and the target, its force bounded.
    fn push_mouse(&mut self, m: &MouseJoint, world_bodies: &[Body], bodies: &[SolverBody], h: f32) {
        let Some(body) = world_bodies.get(m.body) else {
            return;
        };
        if !body.is_dynamic() {
            return;
        }
        let rb = body.rot.rotate(m.local);
        let c = body.position + rb - m.target;
        // k = m omega^2, c = 2 m zeta omega; gamma = 1/(h (c + h k)), bias = h k gamma C
        let omega = std::f32::consts::TAU * m.hertz.max(0.01);
        let stiffness = body.mass * omega * omega;
        let damp = 2.0 * body.mass * m.damping_ratio.max(0.0) * omega;
        let gamma = 1.0 / (h * (damp + h * stiffness));
        let bias = h * stiffness * gamma * c;
        // the world's "a" side is the body itself with zero inverse mass
        let fixed = SolverBody::default();
        let bb = &bodies[m.body];
        self.items.push(Item::Point(Point {
            a: m.body as u32,
            b: m.body as u32,
            ra: Vec2::ZERO,
            rb,
            inv_k: point_inv_k(&fixed, bb, Vec2::ZERO, rb, gamma),
            bias,
            gamma,
            impulse: Vec2::ZERO,
            max_impulse: m.max_force.max(0.0) * h,
            joint: u32::MAX,
            positional: false,
            pos_impulse: Vec2::ZERO,
        }));
    }

    /// Applies the warm-start lambdas.
    pub fn warm_start(&self, bodies: &mut [SolverBody]) {
        for it in &self.items {
            match it {
                Item::Row(r) => r.apply(bodies, r.impulse),
                Item::Point(p) if p.joint != u32::MAX => p.apply(bodies, p.impulse),
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
                Item::Point(p) if p.joint == u32::MAX => {
                    // the mouse: only b moves; a aliases b, so solve with a's part removed
                    mouse_solve(p, bodies)
                }
                Item::Point(p) => p.solve(bodies),
            };
            residual = residual.max(d);
        }
        residual
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
                Item::Point(p) if p.joint != u32::MAX => {
                    let j = &mut joints[p.joint as usize];
                    j.impulses[slot::POINT_X] = p.impulse.x;
                    j.impulses[slot::POINT_Y] = p.impulse.y;
                }
                Item::Point(_) => {}
            }
        }
    }
}

/// v scaled down to length `max` if longer.
#[inline]
fn clamp_length(v: Vec2, max: f32) -> Vec2 {
    let len = v.length();
    if len > max { v * (max / len) } else { v }
}

/// The motor joint's angular row: J v = w_b - w_a driven to -correction angle / dt
/// (angle = the error theta_b - theta_a - target; dt the world's step, so the share of
/// the error removed per step is the same whatever the substeps), |lambda| <= max torque h.
fn motor_joint_angle(
    j: &Joint,
    (a, b): (u32, u32),
    angle: f32,
    bodies: &[SolverBody],
    h: f32,
    dt: f32,
) -> Row {
    let mut r = motor(
        angle_row(a, b),
        bodies,
        -j.correction * angle / dt,
        j.max_torque,
        h,
    );
    r.positional = false;
    r
}

/// The motor joint's linear block: the point velocity driven to -correction d / dt (d =
/// b's centre less its target), |lambda| <= max force h.
fn motor_joint_point(
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
    }
}

/// Limits and servo rows on the joint's angle (hinge) or offset (prismatic) x.
#[allow(clippy::too_many_arguments)]
fn range_rows(
    items: &mut Vec<Item>,
    j: &Joint,
    r: Row,
    x: f32,
    bodies: &[SolverBody],
    beta: f32,
    h: f32,
    angular: bool,
    push: &impl Fn(&mut Vec<Item>, Row, usize),
) {
    if let Some([lo, hi]) = j.limits {
        push(items, inequality(r, bodies, x - lo, beta, h), slot::LOWER);
        push(
            items,
            inequality(r.negated(), bodies, hi - x, beta, h),
            slot::UPPER,
        );
    }
    if let Some(s) = j.servo {
        let c = if angular {
            wrap_angle(x - s.target)
        } else {
            x - s.target
        };
        push(items, equality(r, bodies, c, 0.0, beta, h), slot::SERVO);
    }
}

/// The mouse's point row, where the fixed side is the world.
fn mouse_solve(p: &mut Point, bodies: &mut [SolverBody]) -> f32 {
    let b = load(bodies, p.b);
    let cdot = b.v + cross_sv(b.w, p.rb);
    let rhs = -(cdot + p.bias + p.gamma * p.impulse);
    let k = p.inv_k;
    let d = Vec2::new(k[0] * rhs.x + k[2] * rhs.y, k[1] * rhs.x + k[3] * rhs.y);
    let mut new = p.impulse + d;
    let len = new.length();
    if len > p.max_impulse {
        new *= p.max_impulse / len;
    }
    let d = new - p.impulse;
    p.impulse = new;
    let b = &mut bodies[p.b as usize];
    b.v += b.inv_m * d;
    b.w += b.inv_i * cross(p.rb, d);
    d.abs().max_element()
}

/// Applies each joint's drive (the seed's ApplyForce / ApplyTorque) for a step of h:
/// an impulse drive h along the joint's axis on b and its reaction on a.
pub fn apply_drives(joints: &[Joint], bodies: &mut [Body], h: f32) {
    for j in joints {
        if j.drive == 0.0 {
            continue;
        }
        let f: JointFrame = j.frame(bodies);
        let p = j.drive * h;
        match j.kind {
            JointKind::Motor | JointKind::Pulley => {}
            JointKind::Hinge | JointKind::Weld | JointKind::Wheel => {
                // torque: w_b += tau h / I_b, w_a -= tau h / I_a
                let ia = bodies[j.a].inv_inertia;
                bodies[j.a].angular_velocity -= ia * p;
                let ib = bodies[j.b].inv_inertia;
                bodies[j.b].angular_velocity += ib * p;
            }
            JointKind::Prismatic | JointKind::Distance => {
                let e = if j.kind == JointKind::Prismatic {
                    f.axis
                } else {
                    f.d.normalize_or(f.axis)
                };
                let ra = if j.kind == JointKind::Prismatic {
                    f.ra + f.d
                } else {
                    f.ra
                };
                let imp = p * e;
                let ba = &mut bodies[j.a];
                ba.velocity -= ba.inv_mass * imp;
                ba.angular_velocity -= ba.inv_inertia * cross(ra, imp);
                let bb = &mut bodies[j.b];
                bb.velocity += bb.inv_mass * imp;
                bb.angular_velocity += bb.inv_inertia * cross(f.rb, imp);
            }
        }
    }
}

/// XPBD's velocity pass for joints: motors (one row each, their impulse bounded by
/// max force times h), the motor joint, and damping, on the velocities derived from the
/// positions; `dt` is the world's step (the motor joint's correction is per step).
pub fn xpbd_velocity_pass(
    joints: &[Joint],
    world_bodies: &[Body],
    bodies: &mut [SolverBody],
    (h, dt): (f32, f32),
    rows: &mut JointRows,
) {
    rows.items.clear();
    rows.damping.clear();
    for (ji, j) in joints.iter().enumerate() {
        let spring_damped = j.spring.is_some_and(|sp| sp.damping_ratio > 0.0);
        if j.motor.is_none()
            && j.damping.linear <= 0.0
            && j.damping.angular <= 0.0
            && j.kind != JointKind::Motor
            && !spring_damped
        {
            continue;
        }
        let f = j.frame(world_bodies);
        let (a, b) = (j.a as u32, j.b as u32);
        if j.kind == JointKind::Motor {
            // the motor joint is a bounded velocity drive: solved here only
            motor_joint_angle(j, (a, b), f.angle, bodies, h, dt).solve(bodies);
            motor_joint_point(j, &f, bodies, (h, dt), ji as u32).solve(bodies);
            continue;
        }
        let axis_row = match j.kind {
            JointKind::Prismatic | JointKind::Wheel => {
                Some(linear_row(a, b, f.ra + f.d, f.rb, f.axis))
            }
            JointKind::Distance => Some(linear_row(a, b, f.ra, f.rb, f.d.normalize_or(Vec2::Y))),
            _ => None,
        };
        if let Some(m) = j.motor {
            let r = match (j.kind, axis_row) {
                (JointKind::Prismatic, Some(r)) => r,
                _ => angle_row(a, b),
            };
            let mut r = motor(r, bodies, m.speed, m.max_force, h);
            r.joint = ji as u32;
            r.solve(bodies);
        }
        if j.damping.linear > 0.0
            && let Some(r) = axis_row
        {
            rows.damping
                .push((equality(r, bodies, 0.0, 0.0, 0.0, h), j.damping.linear));
        }
        // the wheel's suspension damper (a hinge's torsion damper, on its angle),
        // c = 2 m_eff zeta omega: a rate of 2 zeta omega
        if let Some(sp) = j.spring.filter(|_| spring_damped) {
            let rate = 2.0 * sp.damping_ratio * std::f32::consts::TAU * sp.hertz;
            let row = match j.kind {
                JointKind::Hinge => Some(angle_row(a, b)),
                _ => axis_row,
            };
            if let Some(r) = row {
                rows.damping
                    .push((equality(r, bodies, 0.0, 0.0, 0.0, h), rate));
            }
        }
        let turns = matches!(
            j.kind,
            JointKind::Hinge | JointKind::Prismatic | JointKind::Weld
        );
        if j.damping.angular > 0.0 && turns {
            rows.damping.push((
                equality(angle_row(a, b), bodies, 0.0, 0.0, 0.0, h),
                j.damping.angular,
            ));
        }
    }
    rows.damp(bodies, h);
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverKind;
    use crate::joint::slot;
    use crate::step::testing::hanging_disc;

    #[test]
    fn a_hanging_disc_pulls_its_hinge_with_its_weight() {
        // at rest the hinge's point row carries m g dt upwards (on b): 2 kg, g 10
        let mut w = hanging_disc(SolverKind::Pgs);
        for _ in 0..60 {
            w.step().unwrap();
        }
        let j = &w.joints()[0];
        let want = 2.0 * 10.0 * w.settings.dt;
        let (x, y) = (j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
        assert!(x.abs() < 1e-4 * want, "{x}");
        assert!((y - want).abs() < 0.01 * want, "{y} vs {want}");
    }
}
