//! The passes of a step and how they run. A step's substeps are one list of phases (the
//! plan, [`SoftSolver::run`]): per substep the force increments, the warm start colour
//! by colour, `iterations` soft sweeps colour by colour, positions, one relax sweep
//! colour by colour (the colours from the last to the first on odd steps without
//! joints: see [`SoftSolver::set_odd_step`]); a colour's phase solves its joints, then
//! its contacts. After each pass's colours come the constraints no colour was free for
//! and the mouse joint (one by one), and after each sweep the islands solved exactly.
//! One thread runs the phases in order; with threads, the whole list is one job of the
//! pool (Box2D's stage list for 1 to N workers): the same list, so the same bits.

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

/// Four lanes of rows side by side (a wide constraint, a wide hinge): the bodies they
/// write, per lane (a sink for a body the solver does not move).
pub(super) trait Lanes {
    fn written(&self) -> (&[u32; 4], &[u32; 4]);
}

impl Lanes for WideConstraint {
    fn written(&self) -> (&[u32; 4], &[u32; 4]) {
        (&self.wa, &self.wb)
    }
}

/// How many of the wide rows `w`, counted in the order they run (from the last if
/// `reversed`), reach the last one in that order that touches a body in `least..=most`:
/// 0 if none does.
pub(super) fn reach_touching<W: Lanes>(w: &[W], reversed: bool, least: u32, most: u32) -> usize {
    let touches = |c: &W| {
        let (wa, wb) = c.written();
        wa.iter().chain(wb).any(|&i| least <= i && i <= most)
    };
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

/// [`add_increments`], then each body's damping (`damping`: its velocities' factors):
/// v = (v + dv) / (1 + h c_linear), w = (w + dw) / (1 + h c_angular).
pub(super) fn add_damped_increments(
    bodies: &mut [SoftBody],
    increments: &[(Vec2, f32)],
    damping: &[(f32, f32)],
) {
    for ((s, &(dv, dw)), &(dl, da)) in bodies.iter_mut().zip(increments).zip(damping) {
        s.v = (s.v + dv) * dl;
        s.w = (s.w + dw) * da;
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

/// What a phase of a step's plan does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pass {
    /// Each thread works out which of its blocks of each colour the other may wait for
    /// (two threads, contacts alone).
    Bounds,
    /// The substep's force increments (every substep after the first).
    Increments,
    /// One colour's warm start, soft sweep or relax sweep: its joints, then its contacts.
    WarmStart,
    Sweep,
    Relax,
    /// The same for the rest: the joints and contacts no colour was free for, and the
    /// mouse joint, one by one (one thread).
    RestWarmStart,
    RestSweep,
    RestRelax,
    /// The islands solved exactly, after a soft sweep or a relax sweep (one thread).
    DirectSweep,
    DirectRelax,
    /// Joint damping (one thread).
    Damp,
    /// Positions.
    Integrate,
}

impl Pass {
    /// A phase one thread runs while the others wait.
    fn serial(self) -> bool {
        matches!(
            self,
            Pass::RestWarmStart
                | Pass::RestSweep
                | Pass::RestRelax
                | Pass::DirectSweep
                | Pass::DirectRelax
                | Pass::Damp
        )
    }

    /// A phase that touches what any share of the phases beside it may touch.
    fn full(self) -> bool {
        self.serial() || matches!(self, Pass::Increments | Pass::Integrate)
    }
}

impl SoftSolver {
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

    /// Thread j's share of used colour c's wide constraints (the whole colour where the
    /// colours were cut for one thread).
    pub(super) fn contact_share(&self, c: usize, j: usize) -> std::ops::Range<usize> {
        if self.cut_threads > 1 {
            color_share(&self.color_cuts, self.cut_threads, c, j)
        } else {
            let (a, b) = self.color_ranges[c];
            a as usize..b as usize
        }
    }

    /// Whether the substeps' job on `n` threads lets each thread run ahead into the next
    /// colour once the other has done the blocks of its share that touch bodies of the
    /// first's share (see `phases_ahead`; each works out which those are first): with
    /// two threads, the bodies each share writes known, and no joint solved one by one
    /// in a colour (contacts and wide hinges).
    pub(super) fn runs_ahead(&self, n: usize) -> bool {
        n == 2 && self.share_bodies.len() == n && self.joint_ranges.iter().all(|r| r.0 == r.1)
    }

    /// Whether anything is left for the rest phases: constraints no colour was free for,
    /// or the mouse joint.
    fn has_rest(&self) -> bool {
        let colored = self.color_ranges.last().map_or(0, |r| r.1 as usize);
        colored < self.wide.len()
            || self.joint_rest.0 < self.joint_rest.1
            || self.joints.has_mouse()
    }

    /// Runs `substeps` substeps of the step's constraints, each but the first beginning
    /// with the force increments (`take_increments` or `prepare_integrating` left them):
    /// the plan (see the module docs), on the caller alone or, with a pool of the threads
    /// the colours were cut for, as one job of the pool. `joints` are the ones `prepare`
    /// was given. Returns the last relax sweep's largest |delta lambda|.
    pub fn run(
        &mut self,
        joints: &[Joint],
        substeps: usize,
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) -> f32 {
        let pool = pool.filter(|p| p.threads() > 1 && p.threads() == self.cut_threads);
        let n = pool.map_or(1, Pool::threads);
        let colors = self.color_ranges.len();
        let (rest, direct) = (self.has_rest(), !self.direct.is_empty());
        let damped = self.joints.any_damped();
        // odd steps without joints take the colours from the last to the first (joints
        // keep the one order: see `set_odd_step`)
        let reversed = self.odd_step && self.joints.ends().is_empty() && !self.joints.has_mouse();
        // the plan
        let plan = &mut self.plan;
        plan.clear();
        let mut last_relax = 0;
        for i in 0..substeps {
            if i > 0 {
                plan.push((Pass::Increments, 0));
            }
            let pass = |plan: &mut Vec<(Pass, u8)>, colored, rest_pass, direct_pass| {
                // (the colours from the last to the first on the steps that reverse them)
                let color = |c: usize| if reversed { colors - 1 - c } else { c };
                plan.extend((0..colors).map(|c| (colored, color(c) as u8)));
                if rest {
                    plan.push((rest_pass, 0));
                }
                if let (true, Some(d)) = (direct, direct_pass) {
                    plan.push((d, 0));
                }
            };
            if s.warm_start {
                pass(plan, Pass::WarmStart, Pass::RestWarmStart, None);
            }
            for _ in 0..s.iterations {
                pass(plan, Pass::Sweep, Pass::RestSweep, Some(Pass::DirectSweep));
            }
            if damped {
                plan.push((Pass::Damp, 0));
            }
            plan.push((Pass::Integrate, 0));
            last_relax = plan.len();
            pass(plan, Pass::Relax, Pass::RestRelax, Some(Pass::DirectRelax));
        }
        let ahead = self.runs_ahead(n);
        if ahead {
            self.plan.insert(0, (Pass::Bounds, 0));
            last_relax += 1;
            self.ahead_blocks.0.clear();
            self.ahead_blocks
                .0
                .resize_with(n * colors, || AtomicU32::new(0));
        }
        let k = self.sweep_consts();
        let nb = self.bodies.len();
        let (plan, increments, color_shares) = (&self.plan, &self.increments, &self.shares);
        let damping = &self.damping[..];
        let joint_order = &self.joint_order;
        let joint_rest = self.joint_rest.0 as usize..self.joint_rest.1 as usize;
        let colored = self.color_ranges.last().map_or(0, |r| r.1 as usize);
        let soft = self.joints.softness();
        let hinges = Disjoint::new(&mut self.hinges);
        let hinge_rows = Disjoint::new(&mut self.hinge_rows);
        let share_bodies = &self.share_bodies;
        let cuts = &self.color_cuts;
        let inv_mass = &self.inv_mass[..];
        let (sw_bias, sw_relax) = (
            self.joints.sweep_params(true),
            self.joints.sweep_params(false),
        );
        let (prepared, mouse) = self.joints.parts();
        let prepared = Disjoint::new(prepared);
        let mouse = Disjoint::new(std::slice::from_mut(mouse));
        let direct_islands = Disjoint::new(std::slice::from_mut(&mut self.direct));
        let (inv_h, slop, max_push, restitution) =
            (self.inv_h, self.slop, self.max_push, self.restitution);
        let bodies = BodyPtr::new(&mut self.bodies, self.sink);
        let wide = Disjoint::new(&mut self.wide);
        let ahead_blocks = &self.ahead_blocks.0;
        let awake = &self.awake[..];
        // each share's part of a phase
        let share = |p: usize, j: usize| -> std::ops::Range<usize> {
            match plan[p] {
                (Pass::Increments, _) => parallel::split(increments.len(), n, j),
                (Pass::Integrate, _) => parallel::split(nb, n, j),
                (Pass::Bounds, _) => j..j + 1,
                (pass, _) if pass.serial() => {
                    if j == 0 {
                        0..1
                    } else {
                        0..0
                    }
                }
                (_, c) => {
                    let sh = &color_shares[c as usize * n + j];
                    sh.first as usize..(sh.first + sh.len()) as usize
                }
            }
        };
        let block = |p: usize| match plan[p].0 {
            Pass::Increments | Pass::Integrate => BODY_BLOCK,
            Pass::WarmStart | Pass::Sweep | Pass::Relax => PHASE_BLOCK,
            _ => 1,
        };
        let (avx2, shared) = (k.avx2, n > 1);
        let kernel = |t: usize, p: usize, r: std::ops::Range<usize>| -> f32 {
            let mine = bodies.for_thread(t);
            let (pass, c) = (plan[p].0, plan[p].1 as usize);
            let tracked = p >= last_relax;
            let keep = |d: f32| if tracked { d } else { f32::NEG_INFINITY };
            // SAFETY (each arm): the blocks of a phase tile its shares, which tile what
            // the phase covers; within a colour no two constraints share a moving body;
            // a serial phase runs alone; and the phases run one after another (or ahead
            // only where `Pass::Bounds` found they touch nothing of each other's)
            match pass {
                Pass::Bounds => {
                    // share j's row (phase 0's block of share j is j..j + 1), from its
                    // own shares of the colours, only read while others write theirs.
                    // A share runs its wide hinges, then its contacts (no joint one by
                    // one: see `ahead`); share 0 runs from its end
                    let j = r.start;
                    let (least, most) = share_bodies[1 - j];
                    for c in 0..colors {
                        let sh = &color_shares[c * n + j];
                        debug_assert_eq!(sh.joints.0, sh.joints.1);
                        let (hs, w) = unsafe {
                            (
                                hinges.range(sh.hinges.0 as usize..sh.hinges.1 as usize),
                                wide.range(color_share(cuts, n, c, j)),
                            )
                        };
                        let reach_h = reach_touching(hs, j == 0, least, most);
                        let reach_c = reach_touching(w, j == 0, least, most);
                        let k = match (j == 0, reach_h, reach_c) {
                            (true, 0, k) => k,
                            (true, k, _) => k + w.len(),
                            (false, k, 0) => k,
                            (false, _, k) => hs.len() + k,
                        };
                        ahead_blocks[j * colors + c].store(k as u32, Ordering::Relaxed);
                    }
                    f32::NEG_INFINITY
                }
                Pass::Increments => {
                    each_awake(awake, r, |r| {
                        let soft = unsafe { bodies.range(r.clone()) };
                        if damping.is_empty() {
                            add_increments(soft, &increments[r]);
                        } else {
                            add_damped_increments(soft, &increments[r.clone()], &damping[r]);
                        }
                    });
                    f32::NEG_INFINITY
                }
                Pass::Integrate => {
                    each_awake(awake, r, |r| integrate_range(unsafe { bodies.range(r) }, h));
                    f32::NEG_INFINITY
                }
                Pass::WarmStart | Pass::Sweep | Pass::Relax => {
                    // which share the block is of (a block lies in one share), and its
                    // joints, hinges and contacts
                    let of_color = &color_shares[c * n..(c + 1) * n];
                    let sh = of_color
                        .iter()
                        .find(|sh| r.start < (sh.first + sh.len()) as usize)
                        .unwrap_or(&of_color[n - 1]);
                    let (lo, hi) = (r.start - sh.first as usize, r.end - sh.first as usize);
                    let js = sh.joints.0 as usize..sh.joints.1 as usize;
                    let nj = js.len();
                    let mut d = f32::NEG_INFINITY;
                    for &i in &joint_order[js.start + lo.min(nj)..js.start + hi.min(nj)] {
                        let i = i as usize;
                        let p = unsafe { &mut prepared.range(i..i + 1)[0] };
                        let jt = &joints[i];
                        d = d.max(match pass {
                            Pass::WarmStart => {
                                unsafe { joints::warm_start_joint(p, jt, mine, inv_mass) };
                                f32::NEG_INFINITY
                            }
                            Pass::Sweep => unsafe {
                                joints::solve_joint(&sw_bias, p, jt, mine, inv_mass)
                            },
                            _ => unsafe { joints::solve_joint(&sw_relax, p, jt, mine, inv_mass) },
                        });
                    }
                    // then the wide hinges, then the contacts
                    let (lo, hi) = (lo.max(nj) - nj, hi.max(nj) - nj);
                    let hs = sh.hinges.0 as usize..sh.hinges.1 as usize;
                    let nh = hs.len();
                    let hw = hs.start + lo.min(nh)..hs.start + hi.min(nh);
                    if !hw.is_empty() {
                        let (hr, hw) = unsafe { (hinge_rows.range(hw.clone()), hinges.range(hw)) };
                        d = d.max(match (pass, shared) {
                            (Pass::WarmStart, true) => {
                                warm_start_hinges::<true>(hw, hr, mine);
                                f32::NEG_INFINITY
                            }
                            (Pass::WarmStart, false) => {
                                warm_start_hinges::<false>(hw, hr, mine);
                                f32::NEG_INFINITY
                            }
                            (Pass::Sweep, true) => {
                                solve_hinges::<true, true>(hw, hr, mine, &soft, inv_h)
                            }
                            (Pass::Sweep, false) => {
                                solve_hinges::<true, false>(hw, hr, mine, &soft, inv_h)
                            }
                            (_, true) => solve_hinges::<false, true>(hw, hr, mine, &soft, inv_h),
                            (_, false) => solve_hinges::<false, false>(hw, hr, mine, &soft, inv_h),
                        });
                    }
                    let (lo, hi) = (lo.max(nh) - nh, hi.max(nh) - nh);
                    let w = sh.contacts.0 as usize + lo..sh.contacts.0 as usize + hi;
                    if !w.is_empty() {
                        let w = unsafe { wide.range(w) };
                        d = d.max(match (pass, shared) {
                            (Pass::WarmStart, true) => {
                                warm_start_range::<true>(w, mine, avx2, true);
                                f32::NEG_INFINITY
                            }
                            (Pass::WarmStart, false) => {
                                warm_start_range::<false>(w, mine, avx2, true);
                                f32::NEG_INFINITY
                            }
                            (Pass::Sweep, true) => sweep_range::<true, true>(w, mine, &k, true),
                            (Pass::Sweep, false) => sweep_range::<true, false>(w, mine, &k, true),
                            (_, true) => sweep_range::<false, true>(w, mine, &k, true),
                            (_, false) => sweep_range::<false, false>(w, mine, &k, true),
                        });
                    }
                    keep(d)
                }
                Pass::RestWarmStart | Pass::RestSweep | Pass::RestRelax => {
                    // alone: the overflow joints, the mouse, the overflow contacts, one
                    // by one (the sink shared: no other thread runs)
                    let all = bodies;
                    let mut d = f32::NEG_INFINITY;
                    for &i in &joint_order[joint_rest.clone()] {
                        let i = i as usize;
                        let p = unsafe { &mut prepared.range(i..i + 1)[0] };
                        let jt = &joints[i];
                        d = d.max(match pass {
                            Pass::RestWarmStart => {
                                unsafe { joints::warm_start_joint(p, jt, all, inv_mass) };
                                f32::NEG_INFINITY
                            }
                            Pass::RestSweep => unsafe {
                                joints::solve_joint(&sw_bias, p, jt, all, inv_mass)
                            },
                            _ => unsafe { joints::solve_joint(&sw_relax, p, jt, all, inv_mass) },
                        });
                    }
                    let m = unsafe { &mut mouse.range(0..1)[0] };
                    let everyone = unsafe { all.range(0..nb) };
                    d = d.max(match pass {
                        Pass::RestWarmStart => {
                            joints::warm_start_mouse(m, everyone, inv_mass);
                            f32::NEG_INFINITY
                        }
                        _ => joints::solve_mouse(m, everyone, inv_mass),
                    });
                    let w = unsafe { wide.range(colored..wide.len()) };
                    d = d.max(match pass {
                        Pass::RestWarmStart => {
                            warm_start_range::<false>(w, all, avx2, false);
                            f32::NEG_INFINITY
                        }
                        Pass::RestSweep => sweep_range::<true, false>(w, all, &k, false),
                        _ => sweep_range::<false, false>(w, all, &k, false),
                    });
                    keep(d)
                }
                Pass::DirectSweep | Pass::DirectRelax => {
                    let islands = unsafe { &mut direct_islands.range(0..1)[0] };
                    let (w, everyone) = unsafe { (wide.range(0..wide.len()), bodies.range(0..nb)) };
                    let d = if pass == Pass::DirectSweep {
                        islands.solve::<true>(w, everyone, inv_h, slop, max_push, restitution)
                    } else {
                        islands.solve::<false>(w, everyone, inv_h, slop, max_push, restitution)
                    };
                    keep(d)
                }
                Pass::Damp => {
                    for (i, jt) in joints.iter().enumerate() {
                        let p = unsafe { &prepared.range(i..i + 1)[0] };
                        unsafe { joints::damp_joint(h, p, jt, bodies, inv_mass) };
                    }
                    f32::NEG_INFINITY
                }
            }
        };
        let r = match pool {
            Some(pool) if ahead => {
                let full = |p: usize| plan[p].0.full();
                let run_ahead = |p: usize, t: usize| match plan[p] {
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
                    plan.len(),
                    &share,
                    &block,
                    &full,
                    &run_ahead,
                    &kernel,
                )
            }
            // every phase begins once the one before is done
            Some(pool) => {
                parallel::phases_max(pool, &mut self.phases, plan.len(), &share, &block, &kernel)
            }
            None => (0..plan.len())
                .map(|p| kernel(0, p, share(p, 0)))
                .fold(f32::NEG_INFINITY, f32::max),
        };
        r.max(0.0)
    }
}
