//! The passes of a step (warm start, sweeps, positions, relax, colour after colour) and
//! how they run: on one thread, as one job a pass, or every substep in one job.

#[allow(unused_imports)]
use super::*;

/// Thread j's share of colour `color` (wide constraints), with the colours cut for `n`
/// threads in `cuts` (see `SoftSolver::color_cuts`).
pub(super) fn color_share(
    cuts: &[u32],
    n: usize,
    color: usize,
    j: usize,
) -> std::ops::Range<usize> {
    let c = &cuts[color * (n + 1) + j..][..2];
    c[0] as usize..c[1] as usize
}

/// How many of the wide constraints `w`, counted in the order they run (from the last
/// if `reversed`), reach the last one in that order that touches a body in
/// `least..=most`: 0 if none does.
pub(super) fn reach_touching(w: &[WideConstraint], reversed: bool, least: u32, most: u32) -> usize {
    let touches = |c: &WideConstraint| c.wa.iter().chain(&c.wb).any(|&i| least <= i && i <= most);
    if reversed {
        w.iter().position(touches).map_or(0, |i| w.len() - i)
    } else {
        w.iter().rposition(touches).map_or(0, |i| i + 1)
    }
}

/// Adds each body's force increment for one substep: v += dv, w += dw.
pub(super) fn add_increments(bodies: &mut [SoftBody], increments: &[(Vec2, f32)]) {
    for (s, &(dv, dw)) in bodies.iter_mut().zip(increments) {
        s.v += dv;
        s.w += dw;
    }
}

/// Moves each body by its velocity for one substep of `h`.
pub(super) fn integrate_range(bodies: &mut [SoftBody], h: f32) {
    for s in bodies {
        s.dp += h * s.v;
        s.dtheta += h * s.w;
        // q' = q + h w (-s, c), then |q'| = 1
        let hw = h * s.w;
        let (c, sn) = (s.dq.c - hw * s.dq.s, s.dq.s + hw * s.dq.c);
        let inv = 1.0 / (c * c + sn * sn).sqrt();
        s.dq = Rot {
            c: c * inv,
            s: sn * inv,
        };
    }
}

/// What a phase of [`SoftSolver::substeps_in_one_job`] does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pass {
    /// Each thread works out which of its blocks of each colour the other may wait for.
    Bounds,
    /// The substep's force increments (every substep after the first).
    Increments,
    /// One colour's warm start, soft sweep or relax sweep.
    WarmStart,
    Sweep,
    Relax,
    /// Positions.
    Integrate,
}

impl SoftSolver {
    /// Applies the accumulated lambdas (the last substep's impulses).
    pub fn warm_start(&mut self, pool: Option<&Pool>) {
        let avx2 = use_avx2();
        let bodies = BodyPtr::new(&mut self.bodies, self.sink);
        self.for_colors(pool, &|t, chunk, pairs| {
            match t {
                Some(t) => warm_start_range::<true>(chunk, bodies.for_thread(t), avx2, pairs),
                None => warm_start_range::<false>(chunk, bodies, avx2, pairs),
            }
            0.0
        });
    }

    /// The sweeps' constants for this step.
    pub(super) fn sweep_consts(&self) -> SweepConsts {
        SweepConsts {
            inv_h: self.inv_h,
            slop: self.slop,
            max_push: self.max_push,
            // the largest normal impulse of each point is read only by restitution: kept
            // only when some contact of the step has restitution
            max_impulse: self.restitution,
            avx2: use_avx2(),
        }
    }

    /// One sweep over every row: with `BIAS`, soft rows that push overlap out; without,
    /// rigid rows that only remove approach speed (relax). Returns max |delta lambda|.
    pub fn sweep<const BIAS: bool>(&mut self, pool: Option<&Pool>) -> f32 {
        let k = self.sweep_consts();
        let bodies = BodyPtr::new(&mut self.bodies, self.sink);
        let r = self.for_colors(pool, &|t, chunk, pairs| match t {
            Some(t) => sweep_range::<BIAS, true>(chunk, bodies.for_thread(t), &k, pairs),
            None => sweep_range::<BIAS, false>(chunk, bodies, &k, pairs),
        });
        if self.direct.is_empty() {
            return r;
        }
        let d = self.direct.solve::<BIAS>(
            &mut self.wide,
            &mut self.bodies,
            self.inv_h,
            self.slop,
            self.max_push,
            self.restitution,
        );
        r.max(d)
    }

    /// Runs `f(thread, constraints, one_colour)` over every wide constraint, colour after
    /// colour: the constraints of one colour split between the pool's threads (they share
    /// no moving body; `Some(thread)`) or on the caller alone (`None`, with one thread),
    /// then the overflow group on the caller alone (`one_colour` false: they may share
    /// bodies, so one by one). Returns the largest value `f` returned.
    pub(super) fn for_colors(&mut self, pool: Option<&Pool>, f: &ColorKernel<'_>) -> f32 {
        let pool = pool.filter(|p| p.threads() > 1);
        let done = self.color_ranges.last().map_or(0, |r| r.1 as usize);
        let r = match pool {
            // the colours one after another in one job, each thread solving its share
            // of each colour first
            Some(pool) if pool.threads() == self.cut_threads => {
                let (n, cuts) = (self.cut_threads, &self.color_cuts);
                let wide = Disjoint::new(&mut self.wide[..done]);
                parallel::phases_max(
                    pool,
                    &mut self.phases,
                    self.color_ranges.len(),
                    &|c, j| color_share(cuts, n, c, j),
                    &|_| PHASE_BLOCK,
                    // SAFETY: the blocks of one phase tile its colour's shares, which
                    // tile the colour, and the phases run one after another
                    &|t, _, r| f(Some(t), unsafe { wide.range(r) }, true),
                )
            }
            _ => {
                let mut r = f32::NEG_INFINITY;
                for &(start, end) in &self.color_ranges {
                    let wide = &mut self.wide[start as usize..end as usize];
                    r = r.max(match pool {
                        Some(pool) => {
                            parallel::chunks_mut(Some(pool), wide, WIDE_BLOCK, &|t, _, c| {
                                f(Some(t), c, true)
                            })
                        }
                        None => f(None, wide, true),
                    });
                }
                r
            }
        };
        r.max(f(None, &mut self.wide[done..], false))
    }

    /// Moves every body by its velocity for one substep: dp += h v, dtheta += h w,
    /// q += h w q_perp (normalised).
    pub fn integrate_positions(&mut self, h: f32, pool: Option<&Pool>) {
        parallel::chunks_mut(pool, &mut self.bodies, BODY_BLOCK, &|_, _, bodies| {
            integrate_range(bodies, h);
            0.0
        });
    }

    /// Whether [`SoftSolver::substeps_in_one_job`] can run this step's substeps: with a
    /// pool of threads the colours were cut for, and every constraint in a colour (no
    /// overflow group, no lopsided contact solved apart).
    pub fn can_run_substeps_in_one_job(&self, pool: Option<&Pool>) -> bool {
        let colored = self.color_ranges.last().map_or(0, |r| r.1 as usize);
        pool.is_some_and(|p| p.threads() > 1 && p.threads() == self.cut_threads)
            && colored == self.wide.len()
            && colored > 0
            && self.direct.is_empty()
    }

    /// `substeps` substeps of the contacts alone (no joints), each but the first
    /// beginning with the force increments: warm start, `iterations` soft sweeps,
    /// positions, one relax sweep, as the step runs them pass by pass, but all in one job
    /// of the pool whose phases are each pass's colours (and the passes over the
    /// bodies): the threads meet at each phase's end and no job is posted between them.
    /// The same bits as the substeps one by one. Returns the last relax sweep's
    /// residual. Call only when [`SoftSolver::can_run_substeps_in_one_job`] says so.
    pub fn substeps_in_one_job(
        &mut self,
        substeps: usize,
        s: &SolverSettings,
        h: f32,
        pool: &Pool,
    ) -> f32 {
        assert!(self.can_run_substeps_in_one_job(Some(pool)), "cannot fuse");
        let colors = self.color_ranges.len();
        self.fused.clear();
        for i in 0..substeps {
            if i > 0 {
                self.fused.push((Pass::Increments, 0));
            }
            let passes = [
                (Pass::WarmStart, usize::from(s.warm_start)),
                (Pass::Sweep, s.iterations as usize),
            ];
            for (pass, times) in passes {
                for _ in 0..times {
                    self.fused.extend((0..colors).map(|c| (pass, c as u8)));
                }
            }
            self.fused.push((Pass::Integrate, 0));
            self.fused
                .extend((0..colors).map(|c| (Pass::Relax, c as u8)));
        }
        // with two threads, each may run ahead into the next colour once the other has
        // done the blocks of its share that touch bodies of the first's share (see
        // `phases_ahead`): each works out which those are in a first phase
        let n = self.cut_threads;
        let ahead = n == 2 && self.share_bodies.len() == n;
        if ahead {
            self.fused.insert(0, (Pass::Bounds, 0));
            self.ahead_blocks.0.clear();
            self.ahead_blocks
                .0
                .resize_with(n * colors, || AtomicU32::new(0));
        }
        // the last relax sweep's colours
        let last_relax = self.fused.len() - colors;
        let k = self.sweep_consts();
        let nb = self.bodies.len();
        let (cuts, fused, increments) = (&self.color_cuts, &self.fused, &self.increments);
        let share_bodies = &self.share_bodies;
        let bodies = BodyPtr::new(&mut self.bodies, self.sink);
        let wide = Disjoint::new(&mut self.wide);
        let ahead_blocks = &self.ahead_blocks.0;
        // each thread's share of a colour, or of the bodies a pass goes over
        let share = |p: usize, j: usize| match fused[p] {
            (Pass::Increments, _) => parallel::split(increments.len(), n, j),
            (Pass::Integrate, _) => parallel::split(nb, n, j),
            (Pass::Bounds, _) => j..j + 1,
            (_, c) => color_share(cuts, n, c as usize, j),
        };
        let block = |p: usize| match fused[p].0 {
            Pass::Increments | Pass::Integrate => BODY_BLOCK,
            Pass::Bounds => 1,
            _ => PHASE_BLOCK,
        };
        let (avx2, pairs) = (k.avx2, true);
        let kernel = |t: usize, p: usize, r: std::ops::Range<usize>| {
            let mine = bodies.for_thread(t);
            // SAFETY (each arm): the blocks of a phase tile the shares of its colour or
            // of the bodies, which tile them, and the phases run one after another (or
            // ahead only where `Pass::Bounds` found they touch nothing of each other's)
            match fused[p].0 {
                Pass::Bounds => {
                    // share j's row (phase 0's block of share j is j..j + 1), from its
                    // own shares of the colours, only read while others write theirs
                    let j = r.start;
                    let (least, most) = share_bodies[1 - j];
                    for c in 0..colors {
                        let items = color_share(cuts, n, c, j);
                        let w = unsafe { wide.range(items) };
                        let k = reach_touching(w, j == 0, least, most) as u32;
                        ahead_blocks[j * colors + c].store(k, Ordering::Relaxed);
                    }
                }
                Pass::Increments => {
                    add_increments(unsafe { bodies.range(r.clone()) }, &increments[r]);
                }
                Pass::Integrate => integrate_range(unsafe { bodies.range(r) }, h),
                Pass::WarmStart => {
                    warm_start_range::<true>(unsafe { wide.range(r) }, mine, avx2, pairs);
                }
                Pass::Sweep => {
                    sweep_range::<true, true>(unsafe { wide.range(r) }, mine, &k, pairs);
                }
                Pass::Relax => {
                    let d = sweep_range::<false, true>(unsafe { wide.range(r) }, mine, &k, pairs);
                    if p >= last_relax {
                        return d;
                    }
                }
            }
            f32::NEG_INFINITY
        };
        if ahead {
            let full = |p: usize| matches!(fused[p].0, Pass::Increments | Pass::Integrate);
            let run_ahead = |p: usize, t: usize| match fused[p] {
                (Pass::Bounds, _) => (0, false),
                // share t's row, written in phase 0 (which is done before this is asked)
                (_, c) => {
                    let k = ahead_blocks[t * colors + c as usize].load(Ordering::Relaxed);
                    (k as usize, t == 0)
                }
            };
            parallel::phases_ahead(
                pool,
                &mut self.phases,
                fused.len(),
                &share,
                &block,
                &full,
                &run_ahead,
                &kernel,
            )
        } else {
            parallel::phases_max(pool, &mut self.phases, fused.len(), &share, &block, &kernel)
        }
    }
}
