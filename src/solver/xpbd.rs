//! XPBD contacts (Mueller et al. 2020): the step's manifolds are found once, each point
//! kept as an anchor on each body; every substep measures the gap between the anchors
//! again, pushes overlapping bodies apart with alpha = 0, cancels the tangential motion
//! of the touching points while lambda_t <= mu lambda_n (static friction), and, after the
//! velocities are derived, applies dynamic friction and restitution at the velocity level.

use super::contact_cache::Contact;
use super::pgs::{Block, SolverBody};
use crate::body::Body;
use crate::joint::xpbd::{linear_correction, move_body};
use crate::math::{Rot, Vec2, cross, cross_sv};
use crate::shape::Shape;

/// One contact point as XPBD keeps it across the substeps of a step.
#[derive(Clone, Copy, Debug, Default)]
pub struct XpbdPoint {
    pub a: u32,
    pub b: u32,
    /// Point on a's surface, a's frame, from its centre of mass.
    pub local_a: Vec2,
    /// Point on b's surface, b's frame.
    pub local_b: Vec2,
    /// Normal (a to b) in a's frame.
    pub local_n: Vec2,
    pub friction: f32,
    pub restitution: f32,
    /// This substep's multipliers (N s^2).
    pub lambda_n: f32,
    pub lambda_t: f32,
    /// Normal relative velocity before the substep's solve (m/s), for restitution.
    pub vn_before: f32,
    /// The least gap this substep's projection asks for (m): 0, or for an overlap already
    /// there at the substep's start, that overlap less the push-out speed times h.
    pub floor: f32,
    /// Which manifold point of which contact it came from (for reporting lambdas).
    pub contact: u32,
    pub index: u8,
}

/// The XPBD solver's per-step state.
#[derive(Clone, Debug, Default)]
pub struct XpbdContacts {
    pub points: Vec<XpbdPoint>,
    /// Positions and rotations at the start of the substep.
    pub prev_rot: Vec<(Vec2, Rot)>,
    /// Project a manifold's two points together (`block_solve`).
    pub block: bool,
    /// The velocity pass's normal impulses (scratch).
    jn: Vec<f32>,
    /// Whether some point began the substep overlapping deeper than one substep's
    /// push-out (its floor below 0): the velocity pass then sweeps the normal rows
    /// [`PUSHED_OUT_SWEEPS`] times.
    pushing_out: bool,
}

/// The velocity pass's sweeps of the normal rows while an overlap is being pushed out.
/// The projection turns each contact's push into speed (v = dx / h), and a column of
/// overlapping bodies stacks those speeds (four boxes each 0.25 m inside the one below:
/// 1.6, 2.8, 4.9, 4.9 m/s); one Gauss-Seidel sweep from one end of the column takes
/// back only part of them, and the top boxes flew 0.6 m and landed after a second.
/// Repeated sweeps meet every point's target together.
const PUSHED_OUT_SWEEPS: usize = 4;

struct Geo {
    ra: Vec2,
    rb: Vec2,
    n: Vec2,
    /// signed gap (pb - pa) . n
    gap: f32,
}

/// The gap is measured between the anchors, except on a circle, whose point facing
/// the other body is its surface point along the normal wherever it has turned: a
/// rolling disk's anchor, turned with it during the substep, rises off the surface
/// (r w^2 h^2 / 2 against g h^2 pressing it down: above 2 m/s for r = 0.25 m), and the
/// contact, and its friction, were lost for the substep (the disk rolled 2% fast).
#[inline]
fn geometry(p: &XpbdPoint, bodies: &[Body]) -> Geo {
    let (ba, bb) = (&bodies[p.a as usize], &bodies[p.b as usize]);
    let n = ba.rot.rotate(p.local_n);
    let ra = match ba.shape {
        Shape::Circle { radius } => radius * n,
        _ => ba.rot.rotate(p.local_a),
    };
    let rb = match bb.shape {
        Shape::Circle { radius } => -radius * n,
        _ => bb.rot.rotate(p.local_b),
    };
    let gap = ((bb.position + rb) - (ba.position + ra)).dot(n);
    Geo { ra, rb, n, gap }
}

/// Static friction at one touching point: cancels the relative tangential motion of
/// its two anchors since the substep began while |lambda_t| <= mu lambda_n.
fn static_friction(p: &mut XpbdPoint, bodies: &mut [Body], prev_at_start: &[(Vec2, Rot)]) {
    let (a, b) = (p.a as usize, p.b as usize);
    let g = geometry(p, bodies);
    // the anchors as material points of their bodies (a circle's turns with it)
    let pa_now = bodies[a].position + bodies[a].rot.rotate(p.local_a);
    let pb_now = bodies[b].position + bodies[b].rot.rotate(p.local_b);
    let (xa0, qa0) = prev_at_start[a];
    let (xb0, qb0) = prev_at_start[b];
    let pa_then = xa0 + qa0.rotate(p.local_a);
    let pb_then = xb0 + qb0.rotate(p.local_b);
    let dp = (pb_now - pb_then) - (pa_now - pa_then);
    let dt = dp - dp.dot(g.n) * g.n;
    let slide = dt.length();
    if slide <= 1e-9 {
        return;
    }
    let t = dt / slide;
    let (ima, iia) = (bodies[a].inv_mass, bodies[a].inv_inertia);
    let (imb, iib) = (bodies[b].inv_mass, bodies[b].inv_inertia);
    let (rta, rtb) = (cross(g.ra, t), cross(g.rb, t));
    let w = ima + iia * rta * rta + imb + iib * rtb * rtb;
    if w <= 0.0 {
        return;
    }
    // delta lambda_t = -slide / w, applied while |lambda_t| <= mu_s lambda_n
    let dlt = -slide / w;
    if (p.lambda_t + dlt).abs() <= p.friction * p.lambda_n {
        p.lambda_t += dlt;
        let imp = dlt * t;
        move_body(&mut bodies[a], -ima * imp, -iia * cross(g.ra, imp));
        move_body(&mut bodies[b], imb * imp, iib * cross(g.rb, imp));
    }
}

impl XpbdContacts {
    /// Turns the step's manifolds into anchored points.
    pub fn prepare(&mut self, bodies: &[Body], contacts: &[Contact]) {
        self.points.clear();
        for (ci, c) in contacts.iter().enumerate() {
            let (ba, bb) = (&bodies[c.a as usize], &bodies[c.b as usize]);
            let n = c.manifold.normal;
            for (k, cp) in c.manifold.points().iter().enumerate() {
                // the surfaces' points: p -/+ n sigma / 2, so (pb - pa) . n = sigma
                let half = 0.5 * cp.separation * n;
                self.points.push(XpbdPoint {
                    a: c.a,
                    b: c.b,
                    local_a: ba.rot.inv_rotate(cp.anchor_a - half),
                    local_b: bb.rot.inv_rotate(cp.anchor_b + half),
                    local_n: ba.rot.inv_rotate(n),
                    friction: c.friction,
                    restitution: c.restitution,
                    contact: ci as u32,
                    index: k as u8,
                    ..Default::default()
                });
            }
        }
    }

    /// Records where the bodies are at the start of a substep (after the prediction the
    /// caller does next) and the normal velocities before the solve; resets lambdas.
    ///
    /// An overlap present at the substep's start is pushed out at no more than
    /// `max_push_speed` (m/s): the projection asks for gap >= min(0, gap_start + v h).
    /// Removing a whole overlap in one projection turns it into speed (v += dx / h): three
    /// boxes started 0.25 m inside one another left at 100 m/s; with the cap (3 m/s) they
    /// are at rest within 1.5 s.
    pub fn begin_substep(&mut self, bodies: &[Body], h: f32, max_push_speed: f32) {
        self.prev_rot.clear();
        self.prev_rot
            .extend(bodies.iter().map(|b| (b.position, b.rot)));
        self.pushing_out = false;
        for p in &mut self.points {
            let (ba, bb) = (&bodies[p.a as usize], &bodies[p.b as usize]);
            // A circle's anchor is its surface point facing the other body at the
            // substep's start (the material point static friction holds still), not where
            // the step's collide found it: a rolling disk turns 0.2 rad a step at 3 m/s
            // for r = 0.25 m.
            let n = ba.rot.rotate(p.local_n);
            if let Shape::Circle { radius } = bb.shape {
                p.local_b = bb.rot.inv_rotate(-radius * n);
            }
            if let Shape::Circle { radius } = ba.shape {
                p.local_a = ba.rot.inv_rotate(radius * n);
            }
            let g = geometry(p, bodies);
            p.vn_before =
                (bb.velocity_at(bb.position + g.rb) - ba.velocity_at(ba.position + g.ra)).dot(g.n);
            p.floor = (g.gap + max_push_speed * h).min(0.0);
            p.lambda_n = 0.0;
            p.lambda_t = 0.0;
            self.pushing_out |= p.floor < 0.0;
        }
    }

    /// One projection of every contact: the overlap (C = gap < 0), then static friction
    /// on the tangential motion of the two points since the substep began.
    /// Returns the deepest overlap met (m).
    ///
    /// A manifold's two points are projected together, as the 2x2 LCP of their position
    /// rows (the same block as PGS's, `Block`): one point after the other, the first
    /// push tips the body about the second point and the second tips it back, so a
    /// resting box rocked about its bottom face and a stack of 10 fell. Points that
    /// nearly coincide (the block too close to singular) go one by one.
    pub fn project(&mut self, bodies: &mut [Body]) -> f32 {
        let mut deepest = 0.0f32;
        let mut i = 0;
        while i < self.points.len() {
            let pair = self.block
                && i + 1 < self.points.len()
                && self.points[i + 1].contact == self.points[i].contact;
            if pair && self.project_pair(bodies, i, &mut deepest) {
                i += 2;
                continue;
            }
            let p = &mut self.points[i];
            let g = geometry(p, bodies);
            if g.gap < p.floor {
                deepest = deepest.max(-g.gap);
                let (a, b) = (p.a as usize, p.b as usize);
                let mut dl = 0.0;
                let now = [g.ra, g.rb, g.n];
                linear_correction(bodies, a, b, now, now, g.gap - p.floor, 0.0, &mut dl);
                p.lambda_n += dl.max(0.0);
                static_friction(p, bodies, &self.prev_rot);
            }
            i += 1;
        }
        deepest
    }

    /// The normal rows of points `i` and `i + 1` (one manifold) solved together, then
    /// static friction at each. `false` (nothing done) where the block is singular.
    fn project_pair(&mut self, bodies: &mut [Body], i: usize, deepest: &mut f32) -> bool {
        let (p, q) = (&self.points[i], &self.points[i + 1]);
        let (gp, gq) = (geometry(p, bodies), geometry(q, bodies));
        let c = [gp.gap - p.floor, gq.gap - q.floor];
        if c[0] >= 0.0 && c[1] >= 0.0 {
            return true;
        }
        let (a, b) = (p.a as usize, p.b as usize);
        let (ima, iia) = (bodies[a].inv_mass, bodies[a].inv_inertia);
        let (imb, iib) = (bodies[b].inv_mass, bodies[b].inv_inertia);
        let n = gp.n;
        let (rap, rbp) = (cross(gp.ra, n), cross(gp.rb, n));
        let (raq, rbq) = (cross(gq.ra, n), cross(gq.rb, n));
        let k = |x1: f32, y1: f32, x2: f32, y2: f32| ima + imb + iia * x1 * x2 + iib * y1 * y2;
        let Some(block) = Block::new(
            k(rap, rbp, rap, rbp),
            k(rap, rbp, raq, rbq),
            k(raq, rbq, raq, rbq),
        ) else {
            return false;
        };
        *deepest = deepest.max(-gp.gap.min(gq.gap));
        // position impulses x >= 0 with C + K x >= 0, complementary
        let x = block.solve([0.0, 0.0], c);
        for (g, xi) in [(&gp, x[0]), (&gq, x[1])] {
            if xi > 0.0 {
                let imp = xi * n;
                move_body(&mut bodies[a], -ima * imp, -iia * cross(g.ra, imp));
                move_body(&mut bodies[b], imb * imp, iib * cross(g.rb, imp));
            }
        }
        for (j, xi) in [(i, x[0]), (i + 1, x[1])] {
            let p = &mut self.points[j];
            p.lambda_n += xi;
            if xi > 0.0 {
                static_friction(p, bodies, &self.prev_rot);
            }
        }
        true
    }

    /// The velocity pass of the touching points: restitution, then dynamic friction, an
    /// impulse against the sliding velocity v_t of at most mu times the net normal impulse
    /// (and no more than stops the sliding); restitution
    /// v_n' = max(-e v_n_before, 0) (e = 0 below the threshold speed). The normal targets
    /// of a manifold's two points are met together (`block_solve`), then friction.
    pub fn velocity_pass(
        &mut self,
        world: &[Body],
        bodies: &mut [SolverBody],
        h: f32,
        threshold: f32,
    ) {
        let mut jn = std::mem::take(&mut self.jn);
        jn.clear();
        jn.resize(self.points.len(), 0.0);
        let target_of = |p: &XpbdPoint| {
            let e = if p.vn_before.abs() <= threshold {
                0.0
            } else {
                p.restitution
            };
            (-e * p.vn_before).max(0.0)
        };
        let sweeps = if self.pushing_out {
            PUSHED_OUT_SWEEPS
        } else {
            1
        };
        for _ in 0..sweeps {
            self.normal_sweep(world, bodies, &mut jn, &target_of);
        }
        self.friction_pass(world, bodies, &jn, h);
        self.jn = jn;
    }

    /// One sweep of the velocity pass's normal rows: each touching point's normal
    /// velocity to its target (`target_of`), a manifold's two points together; adds the
    /// impulses to `jn`.
    fn normal_sweep(
        &self,
        world: &[Body],
        bodies: &mut [SolverBody],
        jn: &mut [f32],
        target_of: &impl Fn(&XpbdPoint) -> f32,
    ) {
        let mut i = 0;
        while i < self.points.len() {
            let p = &self.points[i];
            if p.lambda_n <= 0.0 {
                i += 1;
                continue;
            }
            let (a, b) = (p.a as usize, p.b as usize);
            let (ima, iia) = (bodies[a].inv_m, bodies[a].inv_i);
            let (imb, iib) = (bodies[b].inv_m, bodies[b].inv_i);
            let g = geometry(p, world);
            if self.block
                && i + 1 < self.points.len()
                && self.points[i + 1].contact == p.contact
                && self.points[i + 1].lambda_n > 0.0
            {
                let q = &self.points[i + 1];
                let gq = geometry(q, world);
                let n = g.n;
                let (rap, rbp) = (cross(g.ra, n), cross(g.rb, n));
                let (raq, rbq) = (cross(gq.ra, n), cross(gq.rb, n));
                let k =
                    |x1: f32, y1: f32, x2: f32, y2: f32| ima + imb + iia * x1 * x2 + iib * y1 * y2;
                if let Some(block) = Block::new(
                    k(rap, rbp, rap, rbp),
                    k(rap, rbp, raq, rbq),
                    k(raq, rbq, raq, rbq),
                ) {
                    let (sa, sb) = (bodies[a], bodies[b]);
                    let vn = |ra: Vec2, rb: Vec2| {
                        (sb.v + cross_sv(sb.w, rb) - sa.v - cross_sv(sa.w, ra)).dot(n)
                    };
                    // K j = target - v_n, both rows at once (an equality: j may pull)
                    let r1 = target_of(p) - vn(g.ra, g.rb);
                    let r2 = target_of(q) - vn(gq.ra, gq.rb);
                    let [i11, i12, i22] = block.inv;
                    let (j1, j2) = (i11 * r1 + i12 * r2, i12 * r1 + i22 * r2);
                    for (gg, j) in [(&g, j1), (&gq, j2)] {
                        let imp = j * n;
                        bodies[a].v -= ima * imp;
                        bodies[a].w -= iia * cross(gg.ra, imp);
                        bodies[b].v += imb * imp;
                        bodies[b].w += iib * cross(gg.rb, imp);
                    }
                    jn[i] += j1;
                    jn[i + 1] += j2;
                    i += 2;
                    continue;
                }
            }
            let (sa, sb) = (bodies[a], bodies[b]);
            let vn = (sb.v + cross_sv(sb.w, g.rb) - sa.v - cross_sv(sa.w, g.ra)).dot(g.n);
            let (ra_n, rb_n) = (cross(g.ra, g.n), cross(g.rb, g.n));
            let wn = ima + iia * ra_n * ra_n + imb + iib * rb_n * rb_n;
            if wn > 0.0 {
                let j = (target_of(p) - vn) / wn;
                let imp = j * g.n;
                bodies[a].v -= ima * imp;
                bodies[a].w -= iia * cross(g.ra, imp);
                bodies[b].v += imb * imp;
                bodies[b].w += iib * cross(g.rb, imp);
                jn[i] += j;
            }
            i += 1;
        }
    }

    /// The velocity pass's dynamic friction, after the normal rows took `jn`.
    fn friction_pass(&self, world: &[Body], bodies: &mut [SolverBody], jn: &[f32], h: f32) {
        for (p, &j) in self.points.iter().zip(jn) {
            if p.lambda_n <= 0.0 {
                continue;
            }
            let g = geometry(p, world);
            let (a, b) = (p.a as usize, p.b as usize);
            let (ima, iia) = (bodies[a].inv_m, bodies[a].inv_i);
            let (imb, iib) = (bodies[b].inv_m, bodies[b].inv_i);
            // dynamic friction, bounded by mu times the substep's net normal impulse:
            // the push-out lambda_n / h less what the pass above took back (the push-out
            // leaves a separating velocity that the pass removes; counting only the
            // push-out would double the friction of a resting contact)
            let (sa, sb) = (bodies[a], bodies[b]);
            let rel = sb.v + cross_sv(sb.w, g.rb) - sa.v - cross_sv(sa.w, g.ra);
            let vt = rel - rel.dot(g.n) * g.n;
            let speed_t = vt.length();
            let normal = (p.lambda_n / h + j).max(0.0);
            if speed_t > 1e-9 {
                let t = -vt / speed_t;
                let (ra_t, rb_t) = (cross(g.ra, t), cross(g.rb, t));
                let w = ima + iia * ra_t * ra_t + imb + iib * rb_t * rb_t;
                if w > 0.0 {
                    let imp = (p.friction * normal).min(speed_t / w) * t;
                    bodies[a].v -= ima * imp;
                    bodies[a].w -= iia * cross(g.ra, imp);
                    bodies[b].v += imb * imp;
                    bodies[b].w += iib * cross(g.rb, imp);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverKind;
    use crate::step::testing::{normal_sum, resting_box};

    #[test]
    fn a_resting_box_is_pushed_by_its_weight_over_the_step() {
        // each substep's position multiplier is m g h^2; lambda / h summed over the
        // substeps is the step's impulse m g dt
        let mut w = resting_box(SolverKind::Xpbd);
        for _ in 0..120 {
            w.step().unwrap();
        }
        let want = 10.0 * w.settings.dt;
        let sum = normal_sum(&w);
        assert!((sum - want).abs() < 0.02 * want, "{sum} vs {want}");
    }
}
