//! The constraint build: lays the coloured constraints out colour by colour, four to a
//! wide constraint, cuts each colour between the threads, and fills them.

#[allow(unused_imports)]
use super::*;

/// What `prepare` builds each wide constraint from (shared by the threads that build
/// them, each writing its own wide constraints).
pub(super) struct Fill<'a> {
    contacts: &'a [Contact],
    lane_contact: &'a [u32],
    bodies: &'a [SoftBody],
    inv_mass: &'a [(f32, f32)],
    moves: &'a [bool],
    soft_dynamic: Softness,
    soft_static: Softness,
    /// omega^2 of the two (rad^2/s^2)
    omega2_dynamic: f32,
    omega2_static: f32,
    /// 1 / (h depth): a contact whose load would hold it `depth` deeper than the slop
    /// at its own frequency is stiffened until it does not (see `wide`)
    load_scale: f32,
    /// Per contact: solved exactly (`direct`), so its leak is load-aware.
    direct: &'a [bool],
    warm_start: bool,
    /// The approach speed below which restitution leaves a point be (m/s).
    restitution_threshold: f32,
    rest: u32,
    sink: u32,
}

/// How many wide constraints ahead `prepare` asks for the contacts it will read: the
/// lanes hold contacts colour by colour, an order the hardware cannot guess.
pub(super) const PREFETCH_AHEAD: usize = 4;

impl Fill<'_> {
    /// Asks the cache for the contacts of wide constraint `wi`'s lanes (nothing past
    /// the end). A hint only: the results do not depend on it.
    #[inline(always)]
    fn prefetch(&self, wi: usize) {
        if let Some(lanes) = self.lane_contact.get(wi * 4..wi * 4 + 4) {
            for &i in lanes {
                prefetch(self.contacts, i as usize, usize::MAX);
            }
        }
    }

    /// The contacts of wide constraint `wi`'s lanes.
    fn lanes(&self, wi: usize) -> impl Iterator<Item = (usize, &Contact)> {
        self.lane_contact[wi * 4..wi * 4 + 4]
            .iter()
            .enumerate()
            .filter(|(_, i)| **i != u32::MAX)
            .map(|(k, &i)| (k, &self.contacts[i as usize]))
    }

    fn wide(&self, wi: usize, w: &mut WideConstraint) {
        *w = WideConstraint::empty(self.rest, self.sink);
        for (k, c) in self.lanes(wi) {
            let ((ima, iia), (imb, iib)) =
                (self.inv_mass[c.a as usize], self.inv_mass[c.b as usize]);
            let (ma, mb) = (self.moves[c.a as usize], self.moves[c.b as usize]);
            let (soft, omega2) = if ma && mb {
                (self.soft_dynamic, self.omega2_dynamic)
            } else {
                (self.soft_static, self.omega2_static)
            };
            // omega^2 the load needs: at rest a soft row holds its load F = lambda / h at
            // a depth F / (m_n omega^2) past the slop (m_n = 1 / K), so a point carrying
            // more than m_n omega^2 depth sinks further: its frequency rises to hold it
            let mut need = 0.0f32;
            let n = c.manifold.normal;
            let t = Vec2::new(n.y, -n.x);
            w.a[k] = c.a;
            w.b[k] = c.b;
            w.wa[k] = if ma { c.a } else { self.sink };
            w.wb[k] = if mb { c.b } else { self.sink };
            w.nx.as_mut()[k] = n.x;
            w.ny.as_mut()[k] = n.y;
            w.friction.as_mut()[k] = c.friction;
            w.m.ima.as_mut()[k] = ima;
            w.m.iia.as_mut()[k] = iia;
            w.m.imb.as_mut()[k] = imb;
            w.m.iib.as_mut()[k] = iib;
            for (i, cp) in c.manifold.points().iter().enumerate() {
                let (ra, rb) = (cp.anchor_a, cp.anchor_b);
                let rna = cross(ra, n);
                let rnb = cross(rb, n);
                // K = 1/mA + 1/mB + (ra x n)^2/IA + (rb x n)^2/IB
                let kn = ima + imb + iia * rna * rna + iib * rnb * rnb;
                let rta = cross(ra, t);
                let rtb = cross(rb, t);
                let kt = ima + imb + iia * rta * rta + iib * rtb * rtb;
                let (ni, ti) = if self.warm_start {
                    (cp.normal_impulse, cp.tangent_impulse)
                } else {
                    (0.0, 0.0)
                };
                let p = &mut w.points[i];
                p.rax.as_mut()[k] = ra.x;
                p.ray.as_mut()[k] = ra.y;
                p.rbx.as_mut()[k] = rb.x;
                p.rby.as_mut()[k] = rb.y;
                // s0 - n . (rb - ra)
                p.base_separation.as_mut()[k] = cp.separation - n.dot(rb - ra);
                // K for now: the masses 1 / K are taken below, four lanes at once
                p.normal_mass.as_mut()[k] = kn;
                p.tangent_mass.as_mut()[k] = kt;
                p.normal_impulse.as_mut()[k] = ni;
                p.tangent_impulse.as_mut()[k] = ti;
                need = need.max(ni * kn * self.load_scale);
            }
            // need > omega^2 only under a load some times a body's own weight (a heavy
            // body on light ones, the foot of a tall stack)
            let direct = self
                .direct
                .get(self.lane_contact[wi * 4 + k] as usize)
                .copied()
                .unwrap_or(false);
            let soft = if direct && need > omega2 {
                Softness {
                    impulse_scale: soft.impulse_scale * (omega2 / need),
                    ..soft
                }
            } else {
                soft
            };
            w.bias_rate.as_mut()[k] = soft.bias_rate;
            w.mass_scale.as_mut()[k] = soft.mass_scale;
            w.impulse_scale.as_mut()[k] = soft.impulse_scale;
        }
        // 1 / K where K > 0 (lanes and points not in use hold 0): the same quotients as
        // one at a time
        let inv = |k: Vec4| Vec4::select(k.cmpgt(Vec4::ZERO), Vec4::ONE / k, Vec4::ZERO);
        for p in &mut w.points {
            p.normal_mass = inv(p.normal_mass);
            p.tangent_mass = inv(p.tangent_mass);
        }
    }

    /// The cold half of wide constraint `wi`, and whether some lane has restitution to
    /// apply: a restitution above zero and a point that approaches faster than the
    /// threshold (restitution leaves every other lane be, so those keep none).
    fn cold(&self, wi: usize) -> (WideCold, bool) {
        let mut cold = WideCold::default();
        let mut any = false;
        for (k, c) in self.lanes(wi) {
            cold.count[k] = c.manifold.count as u8;
            if c.restitution == 0.0 {
                continue;
            }
            // dv = vb + wb x rb - va - wa x ra (read only by restitution)
            let (ba, bb) = (self.bodies[c.a as usize], self.bodies[c.b as usize]);
            let n = c.manifold.normal;
            let mut approaching = false;
            for (i, cp) in c.manifold.points().iter().enumerate() {
                let (ra, rb) = (cp.anchor_a, cp.anchor_b);
                let dv = bb.v + cross_sv(bb.w, rb) - ba.v - cross_sv(ba.w, ra);
                let rv = n.dot(dv);
                cold.relative_velocity[i][k] = rv;
                // (the test restitution makes of each point, negated)
                approaching |= !(rv > -self.restitution_threshold);
            }
            if approaching {
                cold.restitution[k] = c.restitution;
                any = true;
            }
        }
        (cold, any)
    }
}

/// The depth past the slop a contact's load may hold it at, when the slop is less.
pub(super) const MIN_LOAD_DEPTH: f32 = 1e-3;

impl SoftSolver {
    /// The rest of [`SoftSolver::prepare`], once the bodies are loaded: colours the
    /// contacts and builds the wide constraints.
    pub(super) fn build(
        &mut self,
        bodies: &[Body],
        contacts: &[Contact],
        joints: &[Joint],
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        let threads = pool.map_or(1, Pool::threads);
        let may_lopsided = may_be_lopsided(self.inv_mass_range);
        self.joints_kept = self.kept_joints.hold(&self.joints, &self.moves, pool);
        let found = color_contacts(
            contacts,
            self.joints.ends(),
            &self.moves,
            may_lopsided.then_some(&self.inv_mass[..]),
            self.deep_gate(s),
            threads,
            &mut self.body_colors,
            &mut self.colors,
            &mut self.joint_colors,
            !self.joints_kept,
            &mut self.cut_lanes,
        );
        self.build_colored(bodies, contacts, joints, found, s, h, pool);
    }

    /// Where the collide found an overlap deeper than [`direct::deep_overlap`], that
    /// depth: the colouring then looks for such a contact between
    /// moving bodies (a column's push-outs add up only there).
    pub(super) fn deep_gate(&self, s: &SolverSettings) -> Option<f32> {
        let depth = direct::deep_overlap(s);
        (self.deepest > depth).then_some(depth)
    }

    /// The rest of [`SoftSolver::build`], once the contacts are coloured (`found`, and
    /// `colors`, `cut_lanes` as [`color_contacts`] leaves them): lays the constraints out
    /// colour by colour and fills them.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn build_colored(
        &mut self,
        bodies: &[Body],
        contacts: &[Contact],
        joints: &[Joint],
        found: Colored,
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        let nb = bodies.len();
        self.inv_h = 1.0 / h;
        self.slop = s.slop;
        self.max_push = s.max_push_speed;
        self.restitution = false;
        let (rest, sink) = (nb as u32, nb as u32 + 1);
        let one_lane = testing::ONE_LANE.with(std::cell::Cell::get);
        let Colored {
            counts,
            joint_counts,
            points,
            lopsided,
            deep,
        } = found;
        // a colour is used by its contacts or its joints (the overflow counts as one)
        let mut used = [0u32; OVERFLOW + 1];
        for (u, (&c, &j)) in used.iter_mut().zip(counts.iter().zip(&joint_counts)) {
            *u = c + j;
        }
        self.colors_used = used.iter().filter(|&&n| n > 0).count();
        // first lane of each colour; a colour starts on a fresh wide constraint, and an
        // overflow constraint has one to itself
        let step = |color: usize| if color == OVERFLOW || one_lane { 4 } else { 1 };
        let mut next = [0u32; OVERFLOW + 1];
        let mut acc = 0u32;
        self.color_ranges.clear();
        for (color, (nx, &n)) in next.iter_mut().zip(&counts).enumerate() {
            *nx = acc;
            acc += if step(color) == 4 {
                4 * n
            } else {
                n.div_ceil(4) * 4
            };
            if color < OVERFLOW && used[color] > 0 {
                self.color_ranges.push((*nx / 4, acc / 4));
            }
        }
        let n_wide = (acc / 4) as usize;

        // with threads, each takes an equal run of the contacts in contact order (which
        // follows the bodies' order: pairs are found and kept sorted) from every colour:
        // the lane each colour had reached at the contacts' quantiles (counted by the
        // colouring) is where it is cut, and where that thread's run starts laying out
        let threads = pool.map_or(1, Pool::threads);
        for counted in &mut self.cut_lanes {
            for (color, (lane, &start)) in counted.iter_mut().zip(&next).enumerate() {
                *lane = start + *lane * step(color);
            }
        }
        // where each contact goes, and which contact each lane holds: the layout below
        // writes every lane a contact takes, so only the lanes none takes are cleared
        // here (a colour's last wide constraint's spare lanes, an overflow constraint's
        // three), not the whole list
        self.slot.resize(contacts.len(), 0);
        let lanes = &mut self.lane_contact;
        lanes.resize(n_wide * 4, u32::MAX);
        // (at most three lanes at a time, written one by one: a `fill` of each is a call
        // to memset, and 65 of them a step were most of a small scene's step)
        for (color, (&start, &n)) in next.iter().zip(&counts).enumerate() {
            let (start, n) = (start as usize, n as usize);
            if n == 0 {
                continue;
            }
            if step(color) == 4 {
                for k in 0..n {
                    for lane in &mut lanes[start + 4 * k + 1..start + 4 * k + 4] {
                        *lane = u32::MAX;
                    }
                }
            } else {
                for lane in &mut lanes[start + n..start + n.div_ceil(4) * 4] {
                    *lane = u32::MAX;
                }
            }
        }
        {
            let (colors, cut_lanes) = (&self.colors[..], &self.cut_lanes[..]);
            let (slots, lanes) = (
                Disjoint::new(&mut self.slot[..]),
                Disjoint::new(&mut self.lane_contact[..]),
            );
            // run k of the contacts, from the lanes each colour had reached there
            let lay_out = |k: usize| {
                let run = parallel::split(contacts.len(), threads, k);
                let mut at = if k == 0 { next } else { cut_lanes[k - 1] };
                // SAFETY: the runs tile the contacts, and the lanes a run fills are its
                // own: from each colour's lane at the run's start to the next run's
                let slot = unsafe { slots.range(run.clone()) };
                for ((i, &color), out) in run.clone().zip(&colors[run]).zip(slot) {
                    let lane = &mut at[color as usize];
                    *out = *lane;
                    // SAFETY: as above
                    unsafe { lanes.set(*lane as usize, i as u32) };
                    *lane += step(color as usize);
                }
                0.0
            };
            match pool {
                Some(pool) if threads > 1 && contacts.len() >= PARALLEL_LAYOUT => {
                    parallel::blocks_max(pool, threads, &|_, k| lay_out(k));
                }
                _ => {
                    for k in 0..threads {
                        lay_out(k);
                    }
                }
            }
        }
        debug_assert!(
            (self.slot.iter().enumerate()).all(|(i, &l)| self.lane_contact[l as usize] == i as u32)
                && self.lane_contact.iter().filter(|&&c| c != u32::MAX).count() == contacts.len(),
            "each lane holds the contact laid out there, or none"
        );
        self.cut_colors(threads, &used, n_wide as u32);
        let hinge_bodies = self.lay_out_joints(joints, bodies, &used, h, s.warm_start, pool);
        self.cut_joints(threads);
        self.points = points;
        // rigid contacts soften to a quarter of the substep rate at most; against a body
        // that does not move, twice as stiff
        let hertz = s.contact_hertz.min(0.25 * self.inv_h);
        let soft_dynamic = Softness::new(hertz, s.contact_damping_ratio, h);
        self.find_direct(contacts, lopsided, deep);
        let soft_static = Softness::new(2.0 * hertz, s.contact_damping_ratio, h);
        let omega = 2.0 * std::f32::consts::PI * hertz;

        // every wide constraint is written whole below: old contents do not matter
        self.wide.resize(n_wide, WideConstraint::empty(rest, sink));
        self.cold.resize(n_wide, WideCold::default());
        let fill = Fill {
            contacts,
            lane_contact: &self.lane_contact,
            bodies: &self.bodies,
            inv_mass: &self.inv_mass,
            moves: &self.moves,
            soft_dynamic,
            soft_static,
            omega2_dynamic: omega * omega,
            omega2_static: 4.0 * omega * omega,
            load_scale: 1.0 / (h * s.slop.max(MIN_LOAD_DEPTH)),
            direct: &self.direct_contact,
            warm_start: s.warm_start,
            restitution_threshold: s.restitution_threshold,
            rest,
            sink,
        };
        // one pass over the contacts builds both halves of each wide constraint
        let fill_range = |offset: usize, wide: &mut [WideConstraint], cold: &mut [WideCold]| {
            let mut any = false;
            for (i, (w, c)) in wide.iter_mut().zip(cold.iter_mut()).enumerate() {
                fill.prefetch(offset + i + PREFETCH_AHEAD);
                fill.wide(offset + i, w);
                // (the flag comes from the lanes as they are written: reading the
                // four back as one vector would wait on the stores)
                let (cold, restitution) = fill.cold(offset + i);
                *c = cold;
                any |= restitution;
            }
            if any { 1.0 } else { 0.0 }
        };
        self.share_bodies.clear();
        let restitution = match pool {
            Some(pool) if threads > 1 && n_wide > WIDE_BLOCK => {
                // each thread fills its share of every colour: the constraints it solves
                let (wide, cold) = (Disjoint::new(&mut self.wide), Disjoint::new(&mut self.cold));
                let blocks = &self.fill_blocks;
                // the bodies each thread's share writes (the fill's blocks are laid out
                // thread by thread, as many for each), for the substeps' job to run ahead:
                // only with two threads (see `substeps_in_one_job`)
                let ranges = threads == 2;
                let per = blocks.len() / threads;
                let written = SharedMassRange::new();
                let r = parallel::blocks_max(pool, blocks.len(), &|_, b| {
                    let r = blocks[b].0 as usize..blocks[b].1 as usize;
                    if r.is_empty() {
                        return 0.0;
                    }
                    // SAFETY: the blocks' ranges do not overlap (see `cut_colors`)
                    let (w, c) = unsafe { (wide.range(r.clone()), cold.range(r.clone())) };
                    let any = fill_range(r.start, w, c);
                    if !ranges {
                        return any;
                    }
                    note_written(w, rest, &written.0[b / per]);
                    any
                });
                if ranges {
                    self.share_bodies
                        .extend(written.0[..threads].iter().map(ThreadMassRange::get));
                }
                r
            }
            _ => parallel::chunks_mut2(
                pool,
                &mut self.wide,
                &mut self.cold,
                WIDE_BLOCK,
                &|_, offset, wide, cold| fill_range(offset, wide, cold),
            ),
        };
        // the hinges' bodies too, where the contacts' are known (found by the fill, or
        // no colour has a contact)
        let colored = self.color_ranges.last().map_or(0, |r| r.1);
        if let Some(hinge_bodies) = hinge_bodies
            && (colored == 0 || !self.share_bodies.is_empty())
        {
            self.share_bodies.resize(hinge_bodies.len(), (u32::MAX, 0));
            for (s, h) in self.share_bodies.iter_mut().zip(hinge_bodies) {
                *s = (s.0.min(h.0), s.1.max(h.1));
            }
        }
        self.restitution = restitution > 0.0;
        self.build_direct(contacts);
    }

    /// Lays the joints out colour by colour: each used colour's joints that the lanes
    /// do not take (`joint_order`, in joint order, each colour's range in
    /// `joint_ranges`), then the overflow joints (`joint_rest`); and the colour's hinges
    /// four to a wide hinge (`hinges` and `hinge_rows`, the joint in each lane in
    /// `hinge_joints`, each colour's range in `hinge_ranges`). While the joints and which
    /// bodies move are as at the last step (`joints_kept`), the order is kept and the
    /// wide hinges only take the bodies' new geometry. `used`: constraints per colour;
    /// `h`: the substep. With two threads and some wide hinge, returns the least and the
    /// largest body each thread's share of the hinges writes (see `cut_joints`), for
    /// the substeps' job to run ahead.
    #[allow(clippy::too_many_arguments)]
    fn lay_out_joints(
        &mut self,
        joints: &[Joint],
        bodies: &[Body],
        used: &[u32; OVERFLOW + 1],
        h: f32,
        warm: bool,
        pool: Option<&Pool>,
    ) -> Option<[(u32, u32); 2]> {
        let kept = self.joints_kept;
        if !kept {
            self.order_joints();
        }
        // the used colours' ranges
        self.joint_ranges.clear();
        self.hinge_ranges.clear();
        for color in (0..OVERFLOW).filter(|&c| used[c] > 0) {
            self.joint_ranges.push(self.joint_spans[color]);
            let (a, b) = self.hinge_spans[color];
            self.hinge_ranges.push((a / 4, b / 4));
        }
        self.joint_rest = self.joint_spans[OVERFLOW];
        // the wide hinges: filled from the joints after a new layout, else their
        // geometry and masses taken anew (their lambdas are the last step's), split
        // between the threads
        let (rest, sink) = (self.moves.len() as u32, self.sink);
        let n_hinges = self.hinge_joints.len();
        if !kept {
            let empty = WideHinge::empty(rest, sink);
            self.hinges.resize(n_hinges, empty);
            self.hinge_rows.resize(n_hinges, HingeRows::default());
            self.hinge_frames.resize(n_hinges, HingeFrames::default());
        }
        // with threads, each takes its own share of every colour's hinges (as
        // `cut_joints` cuts them), so the hinges it solves are in its core's cache
        let threads = pool.map_or(1, Pool::threads);
        let ranges = &self.hinge_ranges;
        let shares = |t: usize| {
            ranges.iter().map(move |&(a, b)| {
                let r = parallel::split((b - a) as usize, threads, t);
                (a + r.start as u32, a + r.end as u32)
            })
        };
        share_blocks(&mut self.hinge_blocks, threads, shares, WIDE_BLOCK as u32);
        let (moves, inv_mass) = (&self.moves, &self.inv_mass);
        let joints_of = &self.hinge_joints;
        let (hinges, rows, frames) = (
            Disjoint::new(&mut self.hinges),
            Disjoint::new(&mut self.hinge_rows),
            Disjoint::new(&mut self.hinge_frames),
        );
        let blocks = &self.hinge_blocks;
        let per = blocks.len() / threads;
        let two = n_hinges > 0 && threads == 2;
        let written = SharedMassRange::new();
        let run = |b: usize| {
            let r = blocks[b].0 as usize..blocks[b].1 as usize;
            // SAFETY: the blocks' ranges do not overlap (they tile each colour's shares)
            let (hinges, rows, frames) = unsafe {
                (
                    hinges.range(r.clone()),
                    rows.range(r.clone()),
                    frames.range(r.clone()),
                )
            };
            for (k, ((c, r), f)) in hinges.iter_mut().zip(rows).zip(frames).enumerate() {
                if kept {
                    c.refresh(r, f, joints, bodies, inv_mass, h, warm);
                } else {
                    (*c, *r, *f) = WideHinge::fill(
                        &joints_of[blocks[b].0 as usize + k],
                        joints,
                        bodies,
                        moves,
                        inv_mass,
                        (rest, sink),
                        h,
                        warm,
                    );
                }
            }
            if two {
                // the bodies thread b / per's share writes
                note_written(hinges, rest, &written.0[b / per]);
            }
            0.0
        };
        match pool {
            Some(pool) if threads > 1 && n_hinges > WIDE_BLOCK => {
                parallel::blocks_max(pool, blocks.len(), &|_, b| run(b));
            }
            _ => {
                for b in 0..blocks.len() {
                    run(b);
                }
            }
        }
        two.then(|| [written.0[0].get(), written.0[1].get()])
    }

    /// Orders the joints colour by colour (a new layout): each colour's joints solved
    /// one by one (`joint_order`, in joint order, each colour's span in `joint_spans`,
    /// the overflow's last), and its hinges four to a wide hinge (the joint in each lane
    /// in `hinge_joints`, each colour's span of lanes in `hinge_spans`; each colour's
    /// start on a fresh wide hinge).
    fn order_joints(&mut self) {
        let laned = self.joints.lanes();
        let lanes = |i: usize| laned[i] && (self.joint_colors[i] as usize) < OVERFLOW;
        let (mut scalar, mut in_lanes) = ([0u32; OVERFLOW + 1], [0u32; OVERFLOW + 1]);
        for (i, &c) in self.joint_colors.iter().enumerate() {
            if lanes(i) {
                in_lanes[c as usize] += 1;
            } else {
                scalar[c as usize] += 1;
            }
        }
        let (mut next, mut next_lane) = ([0u32; OVERFLOW + 1], [0u32; OVERFLOW + 1]);
        let (mut acc, mut acc_lane) = (0u32, 0u32);
        self.joint_spans.clear();
        self.hinge_spans.clear();
        for color in 0..=OVERFLOW {
            next[color] = acc;
            acc += scalar[color];
            self.joint_spans.push((next[color], acc));
            next_lane[color] = acc_lane;
            acc_lane += in_lanes[color].div_ceil(4) * 4;
            self.hinge_spans.push((next_lane[color], acc_lane));
        }
        self.joint_order.clear();
        self.joint_order.resize(acc as usize, 0);
        self.hinge_joints.clear();
        self.hinge_joints
            .resize((acc_lane / 4) as usize, [u32::MAX; 4]);
        for (i, &color) in self.joint_colors.iter().enumerate() {
            let at = if lanes(i) {
                let at = &mut next_lane[color as usize];
                self.hinge_joints[(*at / 4) as usize][(*at % 4) as usize] = i as u32;
                at
            } else {
                let at = &mut next[color as usize];
                self.joint_order[*at as usize] = i as u32;
                at
            };
            *at += 1;
        }
    }

    /// Each used colour's items as its `threads` shares take them (`shares`): share j's
    /// joints one by one and its wide hinges (even parts of the colour's), then its wide
    /// constraints (where `cut_colors` cut them).
    fn cut_joints(&mut self, threads: usize) {
        self.shares.clear();
        let n = threads.max(1);
        for c in 0..self.joint_ranges.len() {
            let even = |(a, b): (u32, u32), j: usize| {
                let r = parallel::split((b - a) as usize, n, j);
                (a + r.start as u32, a + r.end as u32)
            };
            let mut first = 0u32;
            for j in 0..n {
                let contacts = self.contact_share(c, j);
                let share = ColorShare {
                    joints: even(self.joint_ranges[c], j),
                    hinges: even(self.hinge_ranges[c], j),
                    contacts: (contacts.start as u32, contacts.end as u32),
                    first,
                };
                first += share.len();
                self.shares.push(share);
            }
        }
    }

    /// Cuts each colour's wide constraints between `threads` threads where the contacts'
    /// quantiles fell (`cut_lanes`): the lane a colour had reached, rounded up to its
    /// wide constraint. Then lists the fill's blocks of the `n_wide` wide constraints.
    /// `counts`: constraints per colour (a colour is used where some).
    pub(super) fn cut_colors(&mut self, threads: usize, counts: &[u32; OVERFLOW + 1], n_wide: u32) {
        self.color_cuts.clear();
        self.cut_threads = threads;
        if threads < 2 {
            return;
        }
        // the ranges are the used colours, in order
        let used = (0..OVERFLOW).filter(|&c| counts[c] > 0);
        for (&(start, end), color) in self.color_ranges.iter().zip(used) {
            self.color_cuts.push(start);
            let len = end - start;
            for (k, lanes) in self.cut_lanes.iter().enumerate() {
                // no further than a quarter of the colour from an even cut: a colour
                // whose constraints bunch up (the last, small ones) is still shared. (A
                // tighter bound, a sixteenth, balanced the shares better but moved more
                // bodies between the cores from colour to colour: 1.02 of the time)
                let even = start + (len as usize * (k + 1) / threads) as u32;
                let slack = len / 4;
                let cut = lanes[color].div_ceil(4);
                let lo = even.saturating_sub(slack).max(start);
                let hi = (even + slack).min(end);
                self.color_cuts.push(cut.clamp(lo, hi));
            }
            self.color_cuts.push(end);
        }
        // the fill's blocks: thread t's share of each colour, a block at a time; the
        // overflow group (one constraint per wide constraint, after the colours) goes to
        // the first thread
        let done = self.color_ranges.last().map_or(0, |r| r.1);
        let cuts = &self.color_cuts;
        let shares = |t: usize| {
            let overflow = (t == 0).then_some((done, n_wide));
            cuts.chunks(threads + 1)
                .map(move |c| (c[t], c[t + 1]))
                .chain(overflow)
        };
        share_blocks(&mut self.fill_blocks, threads, shares, WIDE_BLOCK as u32);
    }
}

/// Folds into `slot` the least and the largest body the wide rows `rows` write, leaving
/// out the sinks (at `rest` or past it) that take what a body the solver does not move
/// would be given. (A thread's blocks may run on another thread: shared counters.)
fn note_written<W: super::schedule::Lanes>(rows: &[W], rest: u32, slot: &ThreadMassRange) {
    let (mut least, mut most) = (u32::MAX, 0);
    for c in rows {
        let (wa, wb) = c.written();
        for &i in wa.iter().chain(wb).filter(|&&i| i < rest) {
            (least, most) = (least.min(i), most.max(i));
        }
    }
    slot.0.fetch_min(least, Ordering::Relaxed);
    slot.1.fetch_max(most, Ordering::Relaxed);
}

/// Lists in `out` the blocks (of at most `block` items) of each of `threads` threads'
/// shares (`shares(t)`: ranges of items), thread after thread, each thread's padded with
/// empty blocks to as many as the most any thread has: run by `parallel::blocks_max`,
/// each thread first takes its own. Room is kept for a share grown by a block in each
/// range, so that a steady step allocates nothing.
fn share_blocks<I: Iterator<Item = (u32, u32)>>(
    out: &mut Vec<(u32, u32)>,
    threads: usize,
    shares: impl Fn(usize) -> I,
    block: u32,
) {
    let blocks_of = |(a, b): (u32, u32)| (b - a).div_ceil(block) as usize;
    let per = (0..threads)
        .map(|t| shares(t).map(blocks_of).sum::<usize>())
        .max()
        .unwrap_or(0)
        .max(1);
    out.clear();
    out.reserve(threads * (per + shares(0).count()));
    for t in 0..threads {
        let first = out.len();
        for (a, b) in shares(t) {
            let mut at = a;
            while at < b {
                let to = (at + block).min(b);
                out.push((at, to));
                at = to;
            }
        }
        out.extend(std::iter::repeat_n((0, 0), per - (out.len() - first)));
    }
}
