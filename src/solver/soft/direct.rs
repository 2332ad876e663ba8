//! Exact solves of small contact islands whose masses differ widely (the soft step's
//! answer to a heavy body on light ones).
//!
//! Gauss-Seidel sweeps converge at a rate set by the mass ratio: on a box of mass M on
//! a box of mass m on the ground, the error of the two normal rows shrinks by a factor
//! 1 / (1 + m / M) per sweep, so at M / m = 1e4 thousands of sweeps barely move it and
//! the light boxes are squeezed out sideways. A soft row also leaks a share of its load
//! each sweep (a spring of stiffness m_n omega^2, m_n the light body's share), so the
//! heavy body sinks by its weight over that stiffness: 7 cm at 1e3, more than a box at
//! 1e4.
//!
//! So an island (bodies joined by contacts between moving bodies) of at most
//! [`MAX_POINTS`] points in which some contact joins bodies of mass ratio
//! [`MASS_RATIO`] or more is solved exactly after every sweep: the sweep's rows of the
//! island as one box-constrained problem,
//!
//!   w = (A + C) lambda + q,  lo <= lambda <= hi,  w = 0 where lo < lambda < hi,
//!
//! A = J M^-1 J^T of the island's rows, C the soft rows' compliance
//! (a3 / (m_n a2 a3), the fixed point of the sweep's soft row), q the rows' velocity at
//! lambda = 0 plus their bias. Normal rows have lo = 0, hi = inf; friction rows (relax
//! sweep only) +-mu lambda_n. It is a convex quadratic programme; an active-set method
//! with a dense f64 factorisation solves it in a few passes at these sizes. The sweep's
//! own update of those rows is overwritten, so the result is the exact fixed point of
//! the same rows, whatever the mass ratio. The island's contacts also leak no more load
//! than holds them within a slop past the slop (see `Fill::wide`).
//!
//! Deep overlaps make an island a candidate too (a contact deeper than
//! [`deep_overlap`]): bodies started or pushed well inside each other. The soft sweep
//! pushes each contact apart at up to `max_push_speed`, so a column of such contacts
//! stacks its push-outs (four boxes each 0.25 m inside the one below: the top one
//! leaves at 7 m/s), and one relax sweep, Gauss-Seidel from one end of the column, takes
//! back only part of it: the stack jumps and rocks for seconds. The exact relax solve
//! takes it all back (what is left separating is only what no contact may pull), and
//! solves a manifold's two points together, so the push starts no turn.

use super::{SoftBody, WideConstraint};
use crate::math::{Vec2, cross};
use crate::solver::dense::cholesky_solve;

/// Contacts joining moving bodies whose masses differ by this factor or more make their
/// island a candidate for the exact solve.
pub(super) const MASS_RATIO: f32 = 10.0;
/// The most contact points an exactly solved island may have (its problem has twice as
/// many rows in the relax sweep).
pub(super) const MAX_POINTS: usize = 24;
/// How deep (m) a contact overlaps to be deep: past the slop by more than a whole
/// step's push-out at `max_push_speed` (5.5 cm at the defaults), an overlap the soft rows
/// take more than a step to push out. Islands with such a contact between moving bodies
/// are solved exactly, as lopsided ones are. (A loaded pyramid's lowest contacts, whose
/// soft rows hold them 2 cm deep, are not deep.)
pub(super) fn deep_overlap(s: &crate::defs::SolverSettings) -> f32 {
    s.slop + s.max_push_speed * s.dt
}

/// Active-set passes at most per solve (each adds or removes one bound).
const MAX_PASSES: usize = 64;

/// One row of an island: a point's normal or friction direction.
#[derive(Clone, Copy, Debug)]
struct Row {
    /// Wide constraint and lane of its contact, and the point.
    wide: u32,
    lane: u8,
    point: u8,
    tangent: bool,
    /// Body read at each end (a, b), and whether the solver moves it.
    body: [u32; 2],
    moves: [bool; 2],
    /// The Jacobian at each end: linear (2) and angular parts.
    lin: [Vec2; 2],
    ang: [f32; 2],
    inv_m: [f32; 2],
    inv_i: [f32; 2],
}

/// The exactly solved islands of a step and their scratch.
#[derive(Clone, Debug, Default)]
pub(super) struct DirectIslands {
    /// Normal rows, island by island; the friction rows follow each island's normals
    /// in `rows` in the same order.
    rows: Vec<Row>,
    /// Island i's rows are rows[starts[i]..starts[i + 1]]: its normal rows, then as
    /// many friction rows.
    starts: Vec<u32>,
    /// A of each island (dense, row-major, normal and friction rows), one after another.
    a: Vec<f64>,
    a_starts: Vec<u32>,
    // scratch
    m: Vec<f64>,
    x: Vec<f64>,
    old: Vec<f64>,
    y: Vec<f64>,
    k: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    q: Vec<f64>,
    state: Vec<Bound>,
    free: Vec<usize>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Bound {
    Free,
    Lo,
    Hi,
}

impl DirectIslands {
    pub(super) fn clear(&mut self) {
        self.rows.clear();
        self.starts.clear();
        self.a.clear();
        self.a_starts.clear();
    }

    pub(super) fn is_empty(&self) -> bool {
        self.starts.len() < 2
    }

    /// Adds an island: its contacts' (wide index, lane, point count), read from the
    /// built wide constraints. Call after the wide constraints are filled.
    pub(super) fn add_island(
        &mut self,
        lanes: &[(u32, u8, u8)],
        wide: &[WideConstraint],
        moves: &[bool],
    ) {
        if self.starts.is_empty() {
            self.starts.push(0);
        }
        let first = self.rows.len();
        for tangent in [false, true] {
            for &(wi, k, count) in lanes {
                let c = &wide[wi as usize];
                let kk = k as usize;
                let n = Vec2::new(c.nx[kk], c.ny[kk]);
                // t = (ny, -nx), as the sweeps' friction rows
                let d = if tangent { Vec2::new(n.y, -n.x) } else { n };
                for i in 0..count {
                    let p = &c.points[i as usize];
                    let ra = Vec2::new(p.rax[kk], p.ray[kk]);
                    let rb = Vec2::new(p.rbx[kk], p.rby[kk]);
                    let (a, b) = (c.a[kk], c.b[kk]);
                    self.rows.push(Row {
                        wide: wi,
                        lane: k,
                        point: i,
                        tangent,
                        body: [a, b],
                        moves: [moves_of(moves, a), moves_of(moves, b)],
                        lin: [-d, d],
                        ang: [-cross(ra, d), cross(rb, d)],
                        inv_m: [c.m.ima[kk], c.m.imb[kk]],
                        inv_i: [c.m.iia[kk], c.m.iib[kk]],
                    });
                }
            }
        }
        self.starts.push(self.rows.len() as u32);
        // A = J M^-1 J^T over the moving bodies the rows share
        let rows = &self.rows[first..];
        let n = rows.len();
        if self.a_starts.is_empty() {
            self.a_starts.push(0);
        }
        for ri in rows {
            for rj in rows {
                let mut s = 0.0f64;
                for e in 0..2 {
                    for f in 0..2 {
                        if ri.moves[e] && rj.moves[f] && ri.body[e] == rj.body[f] {
                            s += (ri.lin[e].dot(rj.lin[f]) * ri.inv_m[e]
                                + ri.ang[e] * rj.ang[f] * ri.inv_i[e])
                                as f64;
                        }
                    }
                }
                self.a.push(s);
            }
        }
        debug_assert_eq!(
            self.a.len() - *self.a_starts.last().unwrap() as usize,
            n * n
        );
        self.a_starts.push(self.a.len() as u32);
    }

    /// Solves every island's rows exactly: the normal rows with the biased sweep's soft
    /// rows (`BIAS`), or the normal and friction rows with the relax sweep's rigid ones.
    /// Writes the lambdas into the wide constraints and the velocities into the bodies.
    /// Returns the largest change of a lambda.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn solve<const BIAS: bool>(
        &mut self,
        wide: &mut [WideConstraint],
        bodies: &mut [SoftBody],
        inv_h: f32,
        slop: f32,
        max_push: f32,
        keep_max: bool,
    ) -> f32 {
        let mut residual = 0.0f32;
        for isl in 0..self.starts.len().saturating_sub(1) {
            let (r0, r1) = (self.starts[isl] as usize, self.starts[isl + 1] as usize);
            let half = (r1 - r0) / 2;
            // the biased sweep solves the normal rows only
            let n = if BIAS { half } else { r1 - r0 };
            let full = r1 - r0;
            let a0 = self.a_starts[isl] as usize;
            self.m.clear();
            self.q.clear();
            self.x.clear();
            self.lo.clear();
            self.hi.clear();
            for i in 0..n {
                let r = self.rows[r0 + i];
                let c = &wide[r.wide as usize];
                let (k, p) = (r.lane as usize, &c.points[r.point as usize]);
                let lambda = if r.tangent {
                    p.tangent_impulse[k]
                } else {
                    p.normal_impulse[k]
                };
                // the row's velocity now
                let mut v = 0.0f32;
                for e in 0..2 {
                    let b = &bodies[r.body[e] as usize];
                    v += r.lin[e].dot(b.v) + r.ang[e] * b.w;
                }
                let (bias, compliance) = if r.tangent {
                    (0.0, 0.0)
                } else {
                    let s = separation(c, k, r.point as usize, bodies);
                    if s > 0.0 {
                        // speculative: may close the gap this substep, not more
                        (s * inv_h, 0.0)
                    } else if BIAS {
                        let bias = (c.bias_rate[k] * (s + slop).min(0.0)).max(-max_push);
                        let (ms, is) = (c.mass_scale[k], c.impulse_scale[k]);
                        let nm = p.normal_mass[k];
                        let cfm = if ms > 0.0 && nm > 0.0 {
                            is / (nm * ms)
                        } else {
                            0.0
                        };
                        (bias, cfm)
                    } else {
                        (0.0, 0.0)
                    }
                };
                self.x.push(lambda as f64);
                self.q.push((v + bias) as f64);
                self.lo.push(0.0);
                self.hi.push(f64::INFINITY);
                for j in 0..n {
                    let mut aij = self.a[a0 + i * full + j];
                    if i == j {
                        // the soft rows' compliance, and a trace of regularisation so
                        // that dependent rows (a box wedged tight) still factor
                        aij += compliance as f64 + aij * 1e-9 + 1e-30;
                    }
                    self.m.push(aij);
                }
            }
            // q: the rows' velocity at lambda = 0 (v now less what today's lambdas add)
            for i in 0..n {
                let mut s = 0.0;
                for j in 0..n {
                    let aij = self.a[a0 + i * full + j];
                    s += aij * self.x[j];
                }
                self.q[i] -= s;
            }
            self.old.clear();
            self.old.extend_from_slice(&self.x);
            // friction bounds from the normal lambdas; two rounds let the bounds follow
            let rounds = if BIAS { 1 } else { 3 };
            for _ in 0..rounds {
                if !BIAS {
                    for i in half..n {
                        let r = self.rows[r0 + i];
                        let mu = wide[r.wide as usize].friction[r.lane as usize] as f64;
                        let ln = self.x[i - half].max(0.0);
                        self.lo[i] = -mu * ln;
                        self.hi[i] = mu * ln;
                    }
                }
                self.box_qp(n);
            }
            // apply the change: v += M^-1 J^T d lambda, and store the lambdas
            for i in 0..n {
                let d = (self.x[i] - self.old[i]) as f32;
                let r = self.rows[r0 + i];
                let lambda = self.x[i] as f32;
                residual = residual.max(d.abs());
                {
                    let c = &mut wide[r.wide as usize];
                    let (k, p) = (r.lane as usize, &mut c.points[r.point as usize]);
                    if r.tangent {
                        p.tangent_impulse[k] = lambda;
                    } else {
                        p.normal_impulse[k] = lambda;
                        if keep_max {
                            p.max_normal_impulse[k] = p.max_normal_impulse[k].max(lambda);
                        }
                    }
                }
                if d == 0.0 {
                    continue;
                }
                for e in 0..2 {
                    if r.moves[e] {
                        let b = &mut bodies[r.body[e] as usize];
                        b.v += r.lin[e] * (r.inv_m[e] * d);
                        b.w += r.ang[e] * r.inv_i[e] * d;
                    }
                }
            }
        }
        residual
    }

    /// Solves the box-constrained problem in `m` (n x n), `q`, `lo`, `hi` from the start
    /// `x` (clamped into the bounds): an active-set method that frees or fixes one
    /// variable a pass. Leaves the solution in `x`.
    fn box_qp(&mut self, n: usize) {
        self.state.clear();
        for i in 0..n {
            let x = self.x[i].clamp(self.lo[i], self.hi[i]);
            self.x[i] = x;
            // start from the last solution's active set: what sat on a bound stays
            // (and a friction row whose bounds meet, lambda_n = 0, is fixed)
            let at_lo = (x <= self.lo[i] && self.lo[i] == 0.0) || self.lo[i] == self.hi[i];
            self.state.push(if at_lo { Bound::Lo } else { Bound::Free });
        }
        for _ in 0..MAX_PASSES {
            // solve the free rows with the bound ones held
            self.free.clear();
            self.free
                .extend((0..n).filter(|&i| self.state[i] == Bound::Free));
            let nf = self.free.len();
            let (mut y, mut k) = (std::mem::take(&mut self.y), std::mem::take(&mut self.k));
            y.clear();
            y.resize(nf, 0.0);
            k.clear();
            k.resize(nf * nf, 0.0);
            for (fi, &i) in self.free.iter().enumerate() {
                let mut r = -self.q[i];
                for j in 0..n {
                    if self.state[j] != Bound::Free {
                        r -= self.m[i * n + j] * self.x[j];
                    }
                }
                y[fi] = r;
                for (fj, &j) in self.free.iter().enumerate() {
                    k[fi * nf + fj] = self.m[i * n + j];
                }
            }
            let solved = cholesky_solve(&mut k, &mut y, nf);
            self.k = k;
            if !solved {
                self.y = y;
                return;
            }
            // the most out-of-bounds free variable goes to its bound
            let mut worst: Option<(usize, Bound, f64)> = None;
            for (fi, &i) in self.free.iter().enumerate() {
                let v = y[fi];
                let (over, b) = if v < self.lo[i] {
                    (self.lo[i] - v, Bound::Lo)
                } else if v > self.hi[i] {
                    (v - self.hi[i], Bound::Hi)
                } else {
                    continue;
                };
                let scale = 1.0 + self.lo[i].abs().max(self.hi[i].abs().min(1e30));
                if worst.is_none_or(|w| over / scale > w.2) {
                    worst = Some((i, b, over / scale));
                }
            }
            if let Some((i, b, _)) = worst {
                self.state[i] = b;
                self.x[i] = if b == Bound::Lo {
                    self.lo[i]
                } else {
                    self.hi[i]
                };
                self.y = y;
                continue;
            }
            for (fi, &i) in self.free.iter().enumerate() {
                self.x[i] = y[fi];
            }
            self.y = y;
            // a bound variable whose row pulls it off its bound is freed (the worst one)
            let mut release: Option<(usize, f64)> = None;
            for i in 0..n {
                let g = || {
                    let mut s = self.q[i];
                    for j in 0..n {
                        s += self.m[i * n + j] * self.x[j];
                    }
                    s
                };
                let pull = match self.state[i] {
                    Bound::Free => continue,
                    Bound::Lo if self.lo[i] < self.hi[i] => -g(),
                    Bound::Hi => g(),
                    Bound::Lo => continue,
                };
                let tol = 1e-9 * self.m[i * n + i].abs().max(1e-30);
                if pull > tol && release.is_none_or(|r| pull > r.1) {
                    release = Some((i, pull));
                }
            }
            match release {
                Some((i, _)) => self.state[i] = Bound::Free,
                None => return,
            }
        }
    }
}

fn moves_of(moves: &[bool], i: u32) -> bool {
    moves.get(i as usize).copied().unwrap_or(false)
}

/// The separation of lane k's point i now: s0 - n.(rb - ra) + n.(dp_b - dp_a + q_b rb -
/// q_a ra), as the sweeps compute it.
fn separation(c: &WideConstraint, k: usize, i: usize, bodies: &[SoftBody]) -> f32 {
    let p = &c.points[i];
    let (sa, sb) = (&bodies[c.a[k] as usize], &bodies[c.b[k] as usize]);
    let ra = Vec2::new(p.rax[k], p.ray[k]);
    let rb = Vec2::new(p.rbx[k], p.rby[k]);
    let qra = Vec2::new(
        sa.dq.c * ra.x - sa.dq.s * ra.y,
        sa.dq.s * ra.x + sa.dq.c * ra.y,
    );
    let qrb = Vec2::new(
        sb.dq.c * rb.x - sb.dq.s * rb.y,
        sb.dq.s * rb.x + sb.dq.c * rb.y,
    );
    let n = Vec2::new(c.nx[k], c.ny[k]);
    p.base_separation[k] + n.dot(sb.dp - sa.dp + qrb - qra)
}

#[cfg(test)]
mod tests {
    use super::{Bound, DirectIslands};
    use crate::bench::extremes::{Sweep, world_def};
    use crate::defs::SolverSettings;
    use crate::step::soft::SoftStepper;
    use crate::world::World;

    /// The extremes suite's heavy box (density `r`) on two 1 m boxes, default solver,
    /// no sleeping, after `steps` steps.
    fn heavy_on_light(r: f64, steps: usize) -> World {
        let def = world_def(Sweep::MassRatio, r);
        let s = SolverSettings {
            sleep: false,
            ..Default::default()
        };
        let mut w = World::from_def(&def, s).unwrap();
        for _ in 0..steps {
            w.step().unwrap();
        }
        w
    }

    #[test]
    fn each_contact_of_a_heavy_column_carries_the_weight_above_it() {
        // statics: per substep the contact under a body carries the weight of it and all
        // above it, W h (heavy box r kg, light boxes 1 kg, g 10), to 0.1%, at r = 1e4;
        // the island is solved exactly (it is flagged direct)
        let r = 1e4f32;
        let w = heavy_on_light(r as f64, 120);
        let st = w.stepper_as::<SoftStepper>().unwrap();
        assert!(!st.soft.direct.is_empty(), "the island is solved exactly");
        let h = w.settings.dt / w.settings.substeps as f32;
        let ys: Vec<f32> = w.bodies.iter().map(|b| b.position.y).collect();
        let mut loads: Vec<(f32, f32)> = w
            .contacts()
            .iter()
            .map(|c| {
                // the contact's height: its upper body's centre
                let top = ys[c.a as usize].max(ys[c.b as usize]);
                let sum: f32 = c.manifold.points().iter().map(|p| p.normal_impulse).sum();
                (top, sum)
            })
            .collect();
        loads.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(loads.len(), 3);
        // bottom contact: r + 2 kg above it; middle: r + 1; top: r
        for ((_, sum), above) in loads.iter().zip([r + 2.0, r + 1.0, r]) {
            let want = above * 10.0 * h;
            assert!((sum - want).abs() < 1e-3 * want, "{sum} vs {want}");
        }
    }

    #[test]
    fn a_box_qp_with_one_row_at_its_bound_frees_it_only_when_pulled() {
        // min 1/2 x^T K x + q^T x, x0 >= 0, x1 in [-1, 1]; K = [[2, 1], [1, 2]].
        // q = [1, -6]: unconstrained x = -K^-1 q = [-8/3, 13/3]; the solution (by the
        // KKT conditions) is x = [0, 1]: gradient K x + q = [2, -4], >= 0 at x0's lower
        // bound and <= 0 at x1's upper one
        let mut d = DirectIslands {
            m: vec![2.0, 1.0, 1.0, 2.0],
            q: vec![1.0, -6.0],
            lo: vec![0.0, -1.0],
            hi: vec![f64::INFINITY, 1.0],
            x: vec![0.5, 0.0],
            ..Default::default()
        };
        d.box_qp(2);
        assert_eq!(d.x, vec![0.0, 1.0]);
        assert_eq!(d.state, vec![Bound::Lo, Bound::Hi]);
        d.q = vec![-4.0, 0.0];
        d.x = vec![0.0, 0.0];
        d.box_qp(2);
        // q = [-4, 0]: unconstrained x = [8/3, -4/3], below x1's bound: x1 = -1, then
        // 2 x0 - 1 = 4, x0 = 2.5 (gradient of x1: x0 + 2 x1 = 0.5 >= 0 at its lower bound)
        assert!((d.x[0] - 2.5).abs() < 1e-12 && d.x[1] == -1.0, "{:?}", d.x);
    }
}
