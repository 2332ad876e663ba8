//! Lopsided contacts (masses `direct::MASS_RATIO` apart or more): finding them, and the
//! small islands they join, which are solved exactly after each sweep (`direct`).

#[allow(unused_imports)]
use super::*;

/// Whether a contact between two moving bodies of inverse masses `ia` and `ib` joins
/// masses `direct::MASS_RATIO` apart or more.
#[inline(always)]
pub(super) fn is_lopsided(ia: f32, ib: f32) -> bool {
    // max(ia / ib, ib / ia) is the larger over the smaller (division rounds monotonically)
    ia > 0.0 && ib > 0.0 && ia.max(ib) / ia.min(ib) >= direct::MASS_RATIO
}

/// Whether contact `c` joins two moving bodies (`moves`) whose masses (`inv_mass`) are
/// lopsided.
pub(super) fn is_lopsided_contact(c: &Contact, moves: &[bool], inv_mass: &[(f32, f32)]) -> bool {
    let (a, b) = (c.a as usize, c.b as usize);
    moves[a] && moves[b] && is_lopsided(inv_mass[a].0, inv_mass[b].0)
}

/// The least and the largest positive 1/m of the moving bodies in one block of a pass
/// over the bodies, as f32 bits (positive floats order as their bits).
#[derive(Clone, Copy)]
pub(super) struct MassRange {
    pub(super) least: u32,
    pub(super) most: u32,
}

impl Default for MassRange {
    fn default() -> Self {
        MassRange {
            least: u32::MAX,
            most: 0,
        }
    }
}

impl MassRange {
    #[inline(always)]
    pub(super) fn add(&mut self, moves: bool, inv_mass: f32) {
        if moves && inv_mass > 0.0 {
            let bits = inv_mass.to_bits();
            self.least = self.least.min(bits);
            self.most = self.most.max(bits);
        }
    }

    /// Folds this block's range into the pass's, as thread `t` of the pass's job (the
    /// blocks of one thread run one after another).
    pub(super) fn publish(self, to: &SharedMassRange, t: usize) {
        if self.least <= self.most {
            let slot = &to.0[t];
            let (least, most) = (
                slot.0.load(Ordering::Relaxed),
                slot.1.load(Ordering::Relaxed),
            );
            slot.0.store(least.min(self.least), Ordering::Relaxed);
            slot.1.store(most.max(self.most), Ordering::Relaxed);
        }
    }
}

/// Whether some contact between moving bodies whose positive 1/m lie in `range` (as
/// [`SharedMassRange::get`] gives it) may be lopsided: the larger over the smaller of two
/// such masses is at most the largest over the least (division rounds monotonically).
pub(super) fn may_be_lopsided((least, most): (u32, u32)) -> bool {
    least <= most && f32::from_bits(most) / f32::from_bits(least) >= direct::MASS_RATIO
}

/// A pass's [`MassRange`], folded from its blocks: per thread of the pass's job, each on
/// a cache line of its own that only that thread writes (one shared pair of counters,
/// folded into with an atomic min and max per block, moved its line between the cores
/// some twenty times a pass).
pub(super) struct SharedMassRange(pub(super) [ThreadMassRange; MAX_THREADS]);

/// One thread's least and largest 1/m bits (or, for the build's passes, the least and
/// the largest body its share writes: see `build::note_written`).
#[repr(align(64))]
pub(super) struct ThreadMassRange(pub(super) AtomicU32, pub(super) AtomicU32);

impl SharedMassRange {
    pub(super) fn new() -> Self {
        SharedMassRange(std::array::from_fn(|_| {
            ThreadMassRange(AtomicU32::new(u32::MAX), AtomicU32::new(0))
        }))
    }

    /// (least, most); least > most where no moving body has a positive 1/m.
    pub(super) fn get(&self) -> (u32, u32) {
        self.0
            .iter()
            .map(ThreadMassRange::get)
            .fold((u32::MAX, 0), |(least, most), (l, m)| {
                (least.min(l), most.max(m))
            })
    }
}

impl ThreadMassRange {
    /// (least, most) of one thread.
    pub(super) fn get(&self) -> (u32, u32) {
        (
            self.0.load(Ordering::Relaxed),
            self.1.load(Ordering::Relaxed),
        )
    }
}

impl SoftSolver {
    /// Marks the contacts of islands to solve exactly (`direct`): bodies joined by
    /// contacts between moving bodies, with some contact joining masses
    /// `direct::MASS_RATIO` apart or more, and at most `direct::MAX_POINTS` points.
    /// `any_lopsided`: whether some contact is lopsided (found by the colouring pass).
    /// `deep`: where some contact between moving bodies overlaps deeper than
    /// [`direct::deep_overlap`], that depth; an island with such a contact is a
    /// candidate too.
    pub(super) fn find_direct(
        &mut self,
        contacts: &[Contact],
        any_lopsided: bool,
        deep: Option<f32>,
    ) {
        self.direct_contact.clear();
        self.direct.clear();
        if !any_lopsided && deep.is_none() {
            return;
        }
        let (moves, inv_mass) = (&self.moves, &self.inv_mass);
        let below = -deep.unwrap_or(f32::INFINITY);
        let candidate = |c: &Contact| {
            is_lopsided_contact(c, moves, inv_mass)
                || (moves[c.a as usize]
                    && moves[c.b as usize]
                    && c.manifold.points().iter().any(|p| p.separation < below))
        };
        let nb = self.moves.len();
        let parent = &mut self.parent;
        parent.clear();
        parent.extend(0..nb as u32);
        // per island root: points, and whether some contact is a candidate, kept at the
        // root as the islands join (one pass over the contacts)
        let (points, flagged) = (&mut self.root_points, &mut self.root_flagged);
        points.clear();
        points.resize(nb, 0);
        flagged.clear();
        flagged.resize(nb, false);
        for c in contacts {
            let (a, b) = (c.a, c.b);
            let (ma, mb) = (moves[a as usize], moves[b as usize]);
            let mut r = uf_root(parent, if ma { a } else { b });
            if ma && mb {
                // (joined as `uf_union` joins them: the smaller root stays)
                let rb = uf_root(parent, b);
                if r != rb {
                    let (kept, gone) = (r.min(rb) as usize, r.max(rb) as usize);
                    parent[gone] = kept as u32;
                    points[kept] += points[gone];
                    flagged[kept] |= flagged[gone];
                    r = kept as u32;
                }
            }
            points[r as usize] += c.manifold.count as u32;
            flagged[r as usize] |= candidate(c);
        }
        let solved = |r: usize| flagged[r] && points[r] as usize <= direct::MAX_POINTS;
        // (most steps no island qualifies: a pile is one island far over the points
        // allowed; then the contacts need no second pass)
        if !(0..nb).any(|i| parent[i] == i as u32 && solved(i)) {
            return;
        }
        self.roots.clear();
        for c in contacts {
            let body = if moves[c.a as usize] { c.a } else { c.b };
            self.roots.push(uf_root(parent, body));
        }
        self.direct_contact
            .extend(self.roots.iter().map(|&r| solved(r as usize)));
    }

    /// Builds the exactly solved islands from the filled wide constraints.
    pub(super) fn build_direct(&mut self, contacts: &[Contact]) {
        if !self.direct_contact.iter().any(|&d| d) {
            return;
        }
        // islands in order of their first contact; lanes in contact order
        let island_of = &mut self.root_points;
        island_of.fill(u32::MAX);
        let mut lanes: Vec<Vec<(u32, u8, u8)>> = Vec::new();
        for (i, c) in contacts.iter().enumerate() {
            if !self.direct_contact[i] {
                continue;
            }
            let r = self.roots[i] as usize;
            let at = self.slot[i];
            let lane = (at / 4, (at % 4) as u8, c.manifold.count as u8);
            if island_of[r] == u32::MAX {
                island_of[r] = lanes.len() as u32;
                lanes.push(Vec::new());
            }
            lanes[island_of[r] as usize].push(lane);
        }
        for l in &lanes {
            self.direct.add_island(l, &self.wide, &self.moves);
        }
    }
}
