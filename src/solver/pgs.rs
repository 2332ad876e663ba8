//! The contact MLCP solved by projected Gauss-Seidel, matrix-free (sequential impulses).
//!
//! Each contact point gives two rows of A lambda + w = b: a normal row with
//! lambda_n in [0, inf) and a Coulomb friction row with lambda_t in [-mu lambda_n, mu lambda_n].
//! A sweep visits every row once, solves it alone with the others fixed, and projects
//! lambda onto its bounds. Our lambdas are impulses (N s): the seed's force lambda times dt.
//!
//! Position error (Baumgarte, S = min(sigma + slop, 0)) is either part of the velocity
//! rows' right-hand side, or (split impulse) solved apart as pseudo-velocities that move
//! positions this step and are then forgotten, so correcting overlap adds no energy.

use super::contact_cache::Contact;
use crate::body::Body;
use crate::defs::SolverSettings;
use crate::math::{Vec2, cross, cross_sv};

pub use crate::constraint::SolverBody;

/// The velocities of a constraint's two bodies, loaded once, updated by each row, stored back.
struct PairVel {
    va: Vec2,
    wa: f32,
    vb: Vec2,
    wb: f32,
    ima: f32,
    iia: f32,
    imb: f32,
    iib: f32,
}

impl PairVel {
    #[inline]
    fn load(bodies: &[SolverBody], a: u32, b: u32) -> PairVel {
        let (ba, bb) = (bodies[a as usize], bodies[b as usize]);
        PairVel {
            va: ba.v,
            wa: ba.w,
            vb: bb.v,
            wb: bb.w,
            ima: ba.inv_m,
            iia: ba.inv_i,
            imb: bb.inv_m,
            iib: bb.inv_i,
        }
    }

    #[inline]
    fn load_pseudo(bodies: &[SolverBody], pseudo: &[(Vec2, f32)], a: u32, b: u32) -> PairVel {
        let mut pv = PairVel::load(bodies, a, b);
        (pv.va, pv.wa) = pseudo[a as usize];
        (pv.vb, pv.wb) = pseudo[b as usize];
        pv
    }

    #[inline]
    fn store(&self, bodies: &mut [SolverBody], a: u32, b: u32) {
        bodies[a as usize].v = self.va;
        bodies[a as usize].w = self.wa;
        bodies[b as usize].v = self.vb;
        bodies[b as usize].w = self.wb;
    }

    /// Relative velocity of the contact point: vb + wb x rb - va - wa x ra.
    #[inline]
    fn relative(&self, ra: Vec2, rb: Vec2) -> Vec2 {
        self.vb + cross_sv(self.wb, rb) - self.va - cross_sv(self.wa, ra)
    }

    /// Applies the impulse P (on b, -P on a): v += P/m, w += (r x P)/I.
    #[inline]
    fn apply(&mut self, imp: Vec2, ra: Vec2, rb: Vec2) {
        self.va -= self.ima * imp;
        self.wa -= self.iia * cross(ra, imp);
        self.vb += self.imb * imp;
        self.wb += self.iib * cross(rb, imp);
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Point {
    ra: Vec2,
    rb: Vec2,
    /// 1 / (J M^-1 J^T) of the normal row
    normal_mass: f32,
    /// 1 / (J M^-1 J^T) of the friction row
    tangent_mass: f32,
    normal_impulse: f32,
    tangent_impulse: f32,
    /// the normal row's target velocity (speculative gap, or Baumgarte without split impulse)
    velocity_bias: f32,
    /// the pseudo-velocity row's target: -beta/dt S
    position_bias: f32,
    pseudo_impulse: f32,
    /// the gap at the step start (m, < 0 overlapping), to tell whether a collision is due
    separation: f32,
}

#[derive(Clone, Copy, Debug, Default)]
struct Constraint {
    a: u32,
    b: u32,
    normal: Vec2,
    friction: f32,
    restitution: f32,
    count: u32,
    points: [Point; 2],
    /// collided this step (its time-of-impact correction is made once)
    collided: bool,
    /// Two points solved together: the normal rows' 2x2 block K = J M^-1 J^T as
    /// (k11, k12, k22), or `None` where the manifold has one point or K is too close to
    /// singular (the points nearly coincide) to invert safely.
    block: Option<Block>,
}

/// The 2x2 normal block of a two-point manifold and its inverse.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Block {
    k: [f32; 3],
    pub(crate) inv: [f32; 3],
}

impl Block {
    /// Above this condition estimate, k11^2 / det K, the rows are solved one by one.
    const MAX_CONDITION: f32 = 1000.0;

    pub(crate) fn new(k11: f32, k12: f32, k22: f32) -> Option<Block> {
        let det = k11 * k22 - k12 * k12;
        if !(det > 0.0) || k11 * k11 >= Self::MAX_CONDITION * det {
            return None;
        }
        let id = 1.0 / det;
        Some(Block {
            k: [k11, k12, k22],
            inv: [k22 * id, -k12 * id, k11 * id],
        })
    }

    /// One block step of a manifold's two normal rows on the velocities `pv`: the gaps
    /// J v - `bias`, the LCP below from the accumulated `lambda`s, which are updated
    /// and their change applied along `n`. Returns the larger |delta lambda|.
    fn step(
        &self,
        pv: &mut PairVel,
        n: Vec2,
        [p, q]: [&mut Point; 2],
        bias: impl Fn(&Point) -> f32,
        lambda: impl Fn(&mut Point) -> &mut f32,
    ) -> f32 {
        let gap = [
            pv.relative(p.ra, p.rb).dot(n) - bias(p),
            pv.relative(q.ra, q.rb).dot(n) - bias(q),
        ];
        let (lp, lq) = (*lambda(p), *lambda(q));
        let x = self.solve([lp, lq], gap);
        let (d1, d2) = (x[0] - lp, x[1] - lq);
        (*lambda(p), *lambda(q)) = (x[0], x[1]);
        pv.apply(d1 * n, p.ra, p.rb);
        pv.apply(d2 * n, q.ra, q.rb);
        d1.abs().max(d2.abs())
    }

    /// The 2x2 LCP: find x >= 0 with w = K x + q >= 0 and x . w = 0, where
    /// q = (J v - target) - K x_old is taken at the accumulated x_old. Tries, in order,
    /// both rows pushing, only the first, only the second, neither; K symmetric positive
    /// definite makes exactly one of them hold (up to rounding: then `x_old` is kept).
    pub(crate) fn solve(&self, x_old: [f32; 2], gap: [f32; 2]) -> [f32; 2] {
        let [k11, k12, k22] = self.k;
        // q = gap - K x_old
        let q1 = gap[0] - (k11 * x_old[0] + k12 * x_old[1]);
        let q2 = gap[1] - (k12 * x_old[0] + k22 * x_old[1]);
        // both: x = -K^-1 q
        let [i11, i12, i22] = self.inv;
        let x1 = -(i11 * q1 + i12 * q2);
        let x2 = -(i12 * q1 + i22 * q2);
        if x1 >= 0.0 && x2 >= 0.0 {
            return [x1, x2];
        }
        // first only: x1 = -q1 / k11, then w2 = k12 x1 + q2 >= 0
        let x1 = -q1 / k11;
        if x1 >= 0.0 && k12 * x1 + q2 >= 0.0 {
            return [x1, 0.0];
        }
        // second only
        let x2 = -q2 / k22;
        if x2 >= 0.0 && k12 * x2 + q1 >= 0.0 {
            return [0.0, x2];
        }
        // neither: both rows separating
        if q1 >= 0.0 && q2 >= 0.0 {
            return [0.0, 0.0];
        }
        x_old
    }
}

/// What one solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Velocity sweeps run (at most the iteration cap).
    pub iterations: u32,
    /// Largest |delta lambda| of the last velocity sweep (N s).
    pub residual: f32,
    /// Pseudo-velocity (split impulse) sweeps run.
    pub position_iterations: u32,
}

/// The PGS contact solver and its reusable buffers.
#[derive(Clone, Default, Debug)]
pub struct PgsSolver {
    constraints: Vec<Constraint>,
    /// Solver copies of the bodies' velocities.
    pub bodies: Vec<SolverBody>,
    /// Pseudo-velocities (split impulse) of this step: (v, w).
    pub pseudo: Vec<(Vec2, f32)>,
    /// Time-of-impact corrections of this step's collisions, as velocities over the
    /// step (the displacement is h times them): (v, w). Zero where nothing collided.
    pub impact: Vec<(Vec2, f32)>,
}

impl PgsSolver {
    /// Builds the rows of this step's contacts. Body velocities must already include
    /// this step's forces. Lambdas from the cache start the solve if warm starting.
    pub fn prepare(&mut self, bodies: &[Body], contacts: &[Contact], s: &SolverSettings, dt: f32) {
        let inv_dt = 1.0 / dt;
        self.bodies.clear();
        self.bodies.extend(bodies.iter().map(|b| SolverBody {
            v: b.velocity,
            w: b.angular_velocity,
            inv_m: b.inv_mass,
            inv_i: b.inv_inertia,
        }));
        self.pseudo.clear();
        self.pseudo.resize(bodies.len(), (Vec2::ZERO, 0.0));
        self.impact.clear();
        self.impact.resize(bodies.len(), (Vec2::ZERO, 0.0));
        self.constraints.clear();
        for c in contacts {
            let ba = self.bodies[c.a as usize];
            let bb = self.bodies[c.b as usize];
            let n = c.manifold.normal;
            let t = Vec2::new(n.y, -n.x);
            let mut con = Constraint {
                a: c.a,
                b: c.b,
                normal: n,
                friction: c.friction,
                restitution: c.restitution,
                count: c.manifold.count as u32,
                points: [Point::default(); 2],
                collided: false,
                block: None,
            };
            for (i, cp) in c.manifold.points().iter().enumerate() {
                let (ra, rb) = (cp.anchor_a, cp.anchor_b);
                let rna = cross(ra, n);
                let rnb = cross(rb, n);
                // K = 1/mA + 1/mB + (ra x n)^2/IA + (rb x n)^2/IB
                let kn = ba.inv_m + bb.inv_m + ba.inv_i * rna * rna + bb.inv_i * rnb * rnb;
                let rta = cross(ra, t);
                let rtb = cross(rb, t);
                let kt = ba.inv_m + bb.inv_m + ba.inv_i * rta * rta + bb.inv_i * rtb * rtb;
                let sep = cp.separation;
                // S = min(sigma + slop, 0): the overlap beyond the slop
                let s_err = (sep + s.slop).min(0.0);
                let (velocity_bias, position_bias) = if sep > 0.0 {
                    // speculative: the bodies may close the gap this step, not more
                    (-sep * inv_dt, 0.0)
                } else if s.split_impulse {
                    (0.0, -s.baumgarte * inv_dt * s_err)
                } else {
                    // J v >= -beta/dt S
                    (-s.baumgarte * inv_dt * s_err, 0.0)
                };
                let (ni, ti) = if s.warm_start {
                    (cp.normal_impulse, cp.tangent_impulse)
                } else {
                    (0.0, 0.0)
                };
                con.points[i] = Point {
                    ra,
                    rb,
                    normal_mass: if kn > 0.0 { 1.0 / kn } else { 0.0 },
                    tangent_mass: if kt > 0.0 { 1.0 / kt } else { 0.0 },
                    normal_impulse: ni,
                    tangent_impulse: ti,
                    velocity_bias,
                    position_bias,
                    pseudo_impulse: 0.0,
                    separation: sep,
                };
            }
            if con.count == 2 && s.block_solve {
                let (p, q) = (&con.points[0], &con.points[1]);
                let k = |r1: Vec2, r2: Vec2, ra1: Vec2, ra2: Vec2| {
                    ba.inv_m
                        + bb.inv_m
                        + ba.inv_i * cross(ra1, n) * cross(ra2, n)
                        + bb.inv_i * cross(r1, n) * cross(r2, n)
                };
                con.block = Block::new(
                    k(p.rb, p.rb, p.ra, p.ra),
                    k(p.rb, q.rb, p.ra, q.ra),
                    k(q.rb, q.rb, q.ra, q.ra),
                );
            }
            self.constraints.push(con);
        }
    }

    /// Applies the cached lambdas (warm start).
    pub fn warm_start(&mut self) {
        for c in &self.constraints {
            let t = Vec2::new(c.normal.y, -c.normal.x);
            let mut pv = PairVel::load(&self.bodies, c.a, c.b);
            for p in &c.points[..c.count as usize] {
                pv.apply(
                    p.normal_impulse * c.normal + p.tangent_impulse * t,
                    p.ra,
                    p.rb,
                );
            }
            pv.store(&mut self.bodies, c.a, c.b);
        }
    }

    /// One projected Gauss-Seidel sweep over every velocity row; returns max |delta lambda|.
    pub fn sweep_velocity(&mut self) -> f32 {
        let bodies = &mut self.bodies;
        let mut residual = 0.0f32;
        for c in &mut self.constraints {
            let n = c.normal;
            let t = Vec2::new(n.y, -n.x);
            let mut pv = PairVel::load(bodies, c.a, c.b);
            let count = c.count as usize;
            // friction rows first: their bounds use the normal lambdas of the last sweep
            for p in &mut c.points[..count] {
                // lambda = -m_t (J v), projected onto [-mu lambda_n, mu lambda_n]
                let d = -p.tangent_mass * pv.relative(p.ra, p.rb).dot(t);
                let bound = c.friction * p.normal_impulse;
                let new = (p.tangent_impulse + d).clamp(-bound, bound);
                let d = new - p.tangent_impulse;
                p.tangent_impulse = new;
                residual = residual.max(d.abs());
                pv.apply(d * t, p.ra, p.rb);
            }
            if let Some(block) = &c.block {
                // both normal rows at once (the 2x2 LCP)
                let [p, q] = &mut c.points;
                let d = block.step(
                    &mut pv,
                    n,
                    [p, q],
                    |p| p.velocity_bias,
                    |p| &mut p.normal_impulse,
                );
                residual = residual.max(d);
                pv.store(bodies, c.a, c.b);
                continue;
            }
            for p in &mut c.points[..count] {
                // lambda = -m_n (J v - bias), projected onto [0, inf)
                let d = -p.normal_mass * (pv.relative(p.ra, p.rb).dot(n) - p.velocity_bias);
                let new = (p.normal_impulse + d).max(0.0);
                let d = new - p.normal_impulse;
                p.normal_impulse = new;
                residual = residual.max(d.abs());
                pv.apply(d * n, p.ra, p.rb);
            }
            pv.store(bodies, c.a, c.b);
        }
        residual
    }

    /// Restitution as a sequence of collisions, run before the velocity sweeps (the
    /// collision phase of Guendelman et al. 2003). A manifold whose points approach faster
    /// than `threshold` and would meet within `dt` collides: its normal impulses (and
    /// friction, bounded by mu times them) are solved to the target v_n' = -e v_n, with
    /// v_n the approach speed *now*. Sweeps repeat, up to `max_sweeps`, while any
    /// manifold collides, so a collision passes along a row of touching bodies one pair
    /// at a time, as in Newton's cradle, instead of the row sharing it at once. These
    /// impulses are not cached: the velocity sweeps that follow see separating pairs and
    /// leave them alone.
    ///
    /// A pair still apart at the step start (gap g > 0, a speculative contact) meets at
    /// tau = g / -v_n into the step, not at its start. Reversing it at once would end the
    /// step (1 + e) g too far apart and gain that much height every bounce, so the first
    /// collision of a pair in a step also records, in `impact`, the displacement that
    /// closes that difference.
    pub fn resolve_collisions(&mut self, threshold: f32, dt: f32, max_sweeps: u32) {
        // inner Gauss-Seidel passes over one manifold's (at most 2 normal + 2 friction) rows
        const INNER: usize = 4;
        if self.constraints.iter().all(|c| c.restitution == 0.0) {
            return;
        }
        let inv_dt = 1.0 / dt;
        for _ in 0..max_sweeps {
            let mut collided = false;
            for c in &mut self.constraints {
                if c.restitution == 0.0 {
                    continue;
                }
                let n = c.normal;
                let t = Vec2::new(n.y, -n.x);
                let count = c.count as usize;
                let mut pv = PairVel::load(&self.bodies, c.a, c.b);
                let mut target = [0.0f32; 2];
                let mut active = [false; 2];
                let mut hit = [false; 2];
                for (i, p) in c.points[..count].iter().enumerate() {
                    let vn = pv.relative(p.ra, p.rb).dot(n);
                    // touching, or the gap closes before the step ends
                    if p.separation + vn * dt < 0.0 {
                        active[i] = true;
                        if vn < -threshold {
                            target[i] = -c.restitution * vn;
                            hit[i] = true;
                        }
                    }
                }
                if !hit[0] && !hit[1] {
                    continue;
                }
                collided = true;
                let (mut ln, mut lt) = ([0.0f32; 2], [0.0f32; 2]);
                for _ in 0..INNER {
                    for i in 0..count {
                        if !active[i] {
                            continue;
                        }
                        let p = &c.points[i];
                        let d = -p.tangent_mass * pv.relative(p.ra, p.rb).dot(t);
                        let bound = c.friction * ln[i];
                        let new = (lt[i] + d).clamp(-bound, bound);
                        pv.apply((new - lt[i]) * t, p.ra, p.rb);
                        lt[i] = new;
                    }
                    for i in 0..count {
                        if !active[i] {
                            continue;
                        }
                        let p = &c.points[i];
                        let d = -p.normal_mass * (pv.relative(p.ra, p.rb).dot(n) - target[i]);
                        let new = (ln[i] + d).max(0.0);
                        pv.apply((new - ln[i]) * n, p.ra, p.rb);
                        ln[i] = new;
                    }
                }
                pv.store(&mut self.bodies, c.a, c.b);
                if !c.collided {
                    c.collided = true;
                    // the gap at the step's end should be (1 + e) g smaller than a
                    // reversal at the start leaves it: solve J u = -(1 + e) g / dt for
                    // the displacement velocities u, pulling only
                    let gapped = |i: usize| hit[i] && c.points[i].separation > 0.0;
                    if gapped(0) || (count > 1 && gapped(1)) {
                        let mut uv = PairVel::load_pseudo(&self.bodies, &self.impact, c.a, c.b);
                        let mut q = [0.0f32; 2];
                        for _ in 0..INNER {
                            #[allow(clippy::needless_range_loop)] // i indexes q and c.points
                            for i in 0..count {
                                if !gapped(i) {
                                    continue;
                                }
                                let p = &c.points[i];
                                let goal = -(1.0 + c.restitution) * p.separation * inv_dt;
                                let d = -p.normal_mass * (uv.relative(p.ra, p.rb).dot(n) - goal);
                                let new = (q[i] + d).min(0.0);
                                uv.apply((new - q[i]) * n, p.ra, p.rb);
                                q[i] = new;
                            }
                        }
                        self.impact[c.a as usize] = (uv.va, uv.wa);
                        self.impact[c.b as usize] = (uv.vb, uv.wb);
                    }
                }
            }
            if !collided {
                break;
            }
        }
    }

    /// Whether any point has position error beyond the slop to correct apart.
    pub fn needs_position_solve(&self) -> bool {
        self.constraints.iter().any(|c| {
            c.points[..c.count as usize]
                .iter()
                .any(|p| p.position_bias > 0.0)
        })
    }

    /// One sweep of the split-impulse system J M^-1 J^T lambda_p = -beta/dt S (as
    /// impulses), lambda_p >= 0, on the pseudo-velocities; returns max |delta lambda|.
    pub fn sweep_position(&mut self) -> f32 {
        let mut residual = 0.0f32;
        for c in &mut self.constraints {
            let n = c.normal;
            let mut pv = PairVel::load_pseudo(&self.bodies, &self.pseudo, c.a, c.b);
            if let Some(block) = &c.block {
                let [p, q] = &mut c.points;
                let d = block.step(
                    &mut pv,
                    n,
                    [p, q],
                    |p| p.position_bias,
                    |p| &mut p.pseudo_impulse,
                );
                residual = residual.max(d);
                self.pseudo[c.a as usize] = (pv.va, pv.wa);
                self.pseudo[c.b as usize] = (pv.vb, pv.wb);
                continue;
            }
            for p in &mut c.points[..c.count as usize] {
                let d = -p.normal_mass * (pv.relative(p.ra, p.rb).dot(n) - p.position_bias);
                let new = (p.pseudo_impulse + d).max(0.0);
                let d = new - p.pseudo_impulse;
                p.pseudo_impulse = new;
                residual = residual.max(d.abs());
                pv.apply(d * n, p.ra, p.rb);
            }
            self.pseudo[c.a as usize] = (pv.va, pv.wa);
            self.pseudo[c.b as usize] = (pv.vb, pv.wb);
        }
        residual
    }

    /// Writes the lambdas back into the contacts, for next step's warm start.
    pub fn store_impulses(&self, contacts: &mut [Contact]) {
        for (c, con) in contacts.iter_mut().zip(&self.constraints) {
            for (p, q) in c.manifold.points[..c.manifold.count]
                .iter_mut()
                .zip(&con.points)
            {
                p.normal_impulse = q.normal_impulse;
                p.tangent_impulse = q.tangent_impulse;
            }
        }
    }

    /// The normal and friction lambdas of every row, contact by contact (for measuring
    /// the residual against a converged solve).
    pub fn lambdas(&self, out: &mut Vec<f32>) {
        out.clear();
        for c in &self.constraints {
            for p in &c.points[..c.count as usize] {
                out.push(p.normal_impulse);
                out.push(p.tangent_impulse);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverKind;
    use crate::step::testing::{normal_sum, resting_box};

    #[test]
    fn a_resting_box_is_held_by_its_weight_each_step() {
        // the MLCP at rest: the normal lambdas sum to m g dt
        let mut w = resting_box(SolverKind::Pgs);
        for _ in 0..120 {
            w.step().unwrap();
        }
        let want = 10.0 * w.settings.dt;
        let sum = normal_sum(&w);
        assert!((sum - want).abs() < 0.01 * want, "{sum} vs {want}");
        // and the two points share it evenly (the box is centred)
        let mut l = Vec::new();
        w.contact_lambdas(&mut l);
        assert_eq!(l.len(), 4);
        assert!((l[0] - l[2]).abs() < 0.05 * want, "{l:?}");
    }
}
