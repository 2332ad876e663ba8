//! Classic PGS's chains of rigid joints solved exactly.
//!
//! Gauss-Seidel passes a load along a chain of joints one link per sweep, so a heavy
//! body on a long light chain (a loaded bridge of planks) leaves most of the load
//! unpassed after ten sweeps, and the regularisation that keeps a large grid of loops
//! finite holds each loaded joint open by gamma lambda h / beta: a 20-plank bridge under
//! a box of 33 planks' mass had its hinges 3 cm open at rest. So the rigid points
//! (hinges, welds) that join the same moving bodies, [`MIN_POINTS`] to [`MAX_POINTS`] of
//! them, are solved together: their rows' K = J M^-1 J^T (plus a tenth of the
//! regularisation) is factored once a (sub)step, and each sweep solves the chain's rows
//! at once against what the other rows left (block Gauss-Seidel). A loop makes rows
//! depend on each other; the factor gives such a row nothing (`crate::solver::dense`),
//! so a closed loop stays finite too. Larger islands (a grid of thousands of joints) and
//! shorter chains stay with the regularised point-by-point sweeps.

use super::pgs::{Item, Point};
use crate::constraint::SolverBody;
use crate::math::Vec2;
use crate::solver::dense;

/// The share of the point-by-point regularisation a chain keeps.
const CHAIN_REGULARIZATION: f32 = 0.1;

/// The fewest rigid points solved together: a shorter chain (a ragdoll's ten hinges, a
/// double pendulum) passes its load within the default ten sweeps, and its exact solve
/// cost a pile of ragdolls 30% more time for no smaller joint error.
pub(crate) const MIN_POINTS: usize = 12;

/// The most rigid points solved together (2 rows each: a 64 x 64 factor).
pub(crate) const MAX_POINTS: usize = 32;

/// This (sub)step's exactly solved chains and their factors.
#[derive(Clone, Debug, Default)]
pub(crate) struct Chains {
    /// The items (points) of each chain, chain after chain.
    members: Vec<u32>,
    /// Each chain: its first member, its count, where its factor starts, its band (rows
    /// off the diagonal where K may be nonzero).
    chains: Vec<(u32, u32, u32, u32)>,
    factors: Vec<f64>,
    /// Scratch: the right-hand side and solution of one chain's solve.
    y: Vec<f64>,
    /// Scratch: union-find over the bodies, and (root, item) of each rigid point.
    parent: Vec<u32>,
    order: Vec<(u32, u32)>,
    /// Scratch: the rigid points of each island, by its root body.
    size: Vec<u32>,
    /// Scratch: (body, point) for each moving body a chain's point acts on.
    touch: Vec<(u32, u32)>,
}

fn moves(b: &SolverBody) -> bool {
    b.inv_m > 0.0 || b.inv_i > 0.0
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

/// The ranges of a sorted list's runs of one key.
fn runs(v: &[(u32, u32)]) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    let mut start = 0;
    v.chunk_by(|a, b| a.0 == b.0).map(move |g| {
        let r = start..start + g.len();
        start = r.end;
        r
    })
}

/// The point's Jacobian on body `x` (0 if the point does not act on it): (sign, arm).
#[inline]
fn arm(p: &Point, x: u32) -> Option<(f64, Vec2)> {
    if p.a == x {
        Some((-1.0, p.ra))
    } else if p.b == x {
        Some((1.0, p.rb))
    } else {
        None
    }
}

impl Chains {
    /// Forgets the chains.
    pub(crate) fn clear(&mut self) {
        self.members.clear();
        self.chains.clear();
        self.factors.clear();
    }

    /// Finds the chains among the items' rigid points, factors each, and marks their
    /// points exact (their regularisation cut to a tenth). A chain whose matrix cannot be factored (not
    /// finite) keeps its points on the regularised sweeps.
    pub(crate) fn build(&mut self, items: &mut [Item], bodies: &[SolverBody]) {
        self.clear();
        self.parent.clear();
        self.parent.extend(0..bodies.len() as u32);
        let rigid = |it: &Item| match it {
            Item::Point(p) if p.positional && p.joint != super::pgs::MOUSE => Some(*p),
            _ => None,
        };
        for it in items.iter() {
            if let Some(p) = rigid(it)
                && moves(&bodies[p.a as usize])
                && moves(&bodies[p.b as usize])
            {
                let (ra, rb) = (find(&mut self.parent, p.a), find(&mut self.parent, p.b));
                if ra != rb {
                    // the lower root wins: the same chains whatever the order of joining
                    let (lo, hi) = (ra.min(rb), ra.max(rb));
                    self.parent[hi as usize] = lo;
                }
            }
        }
        self.order.clear();
        for (i, it) in items.iter().enumerate() {
            if let Some(p) = rigid(it) {
                let body = if moves(&bodies[p.a as usize]) {
                    p.a
                } else if moves(&bodies[p.b as usize]) {
                    p.b
                } else {
                    continue;
                };
                self.order.push((find(&mut self.parent, body), i as u32));
            }
        }
        // only the islands of a chain's size are sorted into chains (a pile of ragdolls
        // or a grid of thousands of hinges has none)
        self.size.clear();
        self.size.resize(bodies.len(), 0);
        for &(root, _) in &self.order {
            self.size[root as usize] += 1;
        }
        let size = &self.size;
        self.order.retain(|&(root, _)| {
            (MIN_POINTS..=MAX_POINTS).contains(&(size[root as usize] as usize))
        });
        self.order.sort_unstable();
        let order = std::mem::take(&mut self.order);
        for run in runs(&order) {
            let (first, count) = (self.members.len(), run.len());
            self.members.extend(order[run].iter().map(|&(_, i)| i));
            if !self.factor_chain(items, bodies, first, count) {
                self.members.truncate(first);
            }
        }
        self.order = order;
    }

    /// Builds and factors K of the chain whose points are `members[first..first +
    /// count]`; on success records the chain and marks its points.
    fn factor_chain(
        &mut self,
        items: &mut [Item],
        bodies: &[SolverBody],
        first: usize,
        count: usize,
    ) -> bool {
        let n = 2 * count;
        let at = self.factors.len();
        self.factors.resize(at + n * n, 0.0);
        let point = |items: &[Item], m: u32| match items[m as usize] {
            Item::Point(p) => p,
            Item::Row(_) => unreachable!("a chain holds points only"),
        };
        // each moving body's points, body by body: K_ij = J_i M^-1 J_j^T is the sum over
        // the bodies both points act on of s_i s_j (1/m I + 1/I u_i u_j^T), u = perp(arm)
        self.touch.clear();
        for k in 0..count {
            let p = point(items, self.members[first + k]);
            for x in [p.a, p.b] {
                if moves(&bodies[x as usize]) {
                    self.touch.push((x, k as u32));
                }
            }
        }
        self.touch.sort_unstable();
        let mut band = 0;
        for run in runs(&self.touch) {
            let x = self.touch[run.start].0;
            let b = &bodies[x as usize];
            let (m, ii) = (b.inv_m as f64, b.inv_i as f64);
            for e in run.clone() {
                for f in run.start..=e {
                    let (i, j) = (self.touch[e].1 as usize, self.touch[f].1 as usize);
                    let (pi, pj) = (
                        point(items, self.members[first + i]),
                        point(items, self.members[first + j]),
                    );
                    let (Some((si, ri)), Some((sj, rj))) = (arm(&pi, x), arm(&pj, x)) else {
                        continue;
                    };
                    band = band.max(i.abs_diff(j));
                    let (ui, uj) = (ri.perp(), rj.perp());
                    let s = si * sj;
                    let block = [
                        [
                            s * (m + ii * (ui.x * uj.x) as f64),
                            s * ii * (ui.x * uj.y) as f64,
                        ],
                        [
                            s * ii * (ui.y * uj.x) as f64,
                            s * (m + ii * (ui.y * uj.y) as f64),
                        ],
                    ];
                    for (r, row) in block.iter().enumerate() {
                        for (c, v) in row.iter().enumerate() {
                            let (gi, gj) = (2 * i + r, 2 * j + c);
                            self.factors[at + gi * n + gj] += v;
                            if i != j {
                                self.factors[at + gj * n + gi] += v;
                            }
                        }
                    }
                }
            }
        }
        // rows of points `band` apart meet in K: 2 band + 1 rows off the diagonal
        let band = (2 * band + 1).min(n);
        // the regularisation, a tenth of the point-by-point sweeps': a compliance that
        // still lets a taut run of joints hold a load across it (without it a straight
        // bridge between two posts has no state of rest: it cannot sag without
        // stretching)
        for i in 0..count {
            if let Item::Point(p) = &mut items[self.members[first + i] as usize] {
                p.gamma *= CHAIN_REGULARIZATION;
                for r in [2 * i, 2 * i + 1] {
                    self.factors[at + r * n + r] += p.gamma as f64;
                }
            }
        }
        if !dense::factor_banded(&mut self.factors[at..], n, band) {
            self.factors.truncate(at);
            return false;
        }
        for &m in &self.members[first..first + count] {
            if let Item::Point(p) = &mut items[m as usize] {
                p.exact = true;
            }
        }
        self.chains
            .push((first as u32, count as u32, at as u32, band as u32));
        true
    }

    /// Solves every chain's rows at once against the velocities `bodies` (K dlambda =
    /// -(J v + bias), or -J v for the position pass) and applies the change; returns
    /// the largest |dlambda|.
    pub(crate) fn solve(
        &mut self,
        items: &mut [Item],
        bodies: &mut [SolverBody],
        position: bool,
    ) -> f32 {
        let mut largest = 0.0f32;
        for &(first, count, at, band) in &self.chains {
            let (first, count, at) = (first as usize, count as usize, at as usize);
            let n = 2 * count;
            self.y.clear();
            for &m in &self.members[first..first + count] {
                if let Item::Point(p) = &items[m as usize] {
                    let cdot = p.cdot(bodies);
                    let rhs = if position {
                        -cdot
                    } else {
                        -(cdot + p.bias + p.gamma * p.impulse)
                    };
                    self.y.extend([rhs.x as f64, rhs.y as f64]);
                }
            }
            dense::solve_banded(&self.factors[at..at + n * n], &mut self.y, n, band as usize);
            for (k, &m) in self.members[first..first + count].iter().enumerate() {
                if let Item::Point(p) = &mut items[m as usize] {
                    let d = Vec2::new(self.y[2 * k] as f32, self.y[2 * k + 1] as f32);
                    if position {
                        p.pos_impulse += d;
                    } else {
                        p.impulse += d;
                    }
                    p.apply(bodies, d);
                    largest = largest.max(d.abs().max_element());
                }
            }
        }
        largest
    }
}
