//! The broad phase: a uniform grid, run again only when a body's box leaves the fattened
//! box it had at the last run (see [`BroadPhase::find_pairs_kept`]). Every body's box is
//! written into the cells it covers, the (cell, body) entries are sorted, and bodies
//! sharing a cell are tested. A pair is reported only from the cell that holds the
//! lower-left corner of the overlap of the two boxes, so it is found once. Bodies whose
//! boxes span many cells (the ground) go to a short list tested against everyone. The
//! output is sorted by (a, b), so the step order does not depend on the grid.

use crate::defs::Filter;
use crate::math::{AWAKE_BLOCK, Aabb, Vec2, gallop};
use crate::parallel::{self, BlockScratch, Disjoint, Pool, Scratch};
use std::ops::Range;
use std::sync::Mutex;

/// A candidate pair of body indices, a < b.
pub type Pair = (u32, u32);

/// Reusable buffers of the grid broad phase.
#[derive(Clone, Default, Debug)]
pub struct BroadPhase {
    entries: Vec<(u64, u32)>,
    /// (body, [x0, y0, x1, y1]): the cells each body that is not large covers.
    ranges: Vec<(u32, [i64; 4])>,
    /// Per body: its lowest cell [x0, y0] (meaningful for bodies in `ranges`).
    lowest: Vec<[i64; 2]>,
    /// Dense grid: where each cell's bodies start in `cell_bodies` (counting sort).
    cell_start: Vec<u32>,
    cell_fill: Vec<u32>,
    cell_bodies: Vec<u32>,
    /// Counting sort of the pairs by their first body.
    pair_start: Vec<u32>,
    /// Per run of the pairs (one a thread): its count of each first body, then where
    /// the run's pairs of each go.
    pair_counts: Vec<u32>,
    pairs_tmp: Vec<Pair>,
    large: Vec<u32>,
    /// Per body: its index in `large`, or u32::MAX (scratch).
    large_rank: Vec<u32>,
    sizes: Vec<f32>,
    /// [`BroadPhase::find_pairs_kept`]: each body's fattened box, whether it may move
    /// (awake and dynamic, at the last rebuild or since), and every pair of those boxes
    /// with one that may move. A sleeper kept as one that may not costs no pair with the
    /// sleepers and static bodies around it, and a rebuild's grid leaves out the blocks
    /// of such bodies that no mover reaches (`still_bounds`).
    kept_boxes: Vec<Aabb>,
    /// Per body: how many steps of its motion its kept box reaches ahead, and the
    /// refresh of the kept pairs (`refreshes`) that made it.
    kept_ahead: Vec<u8>,
    kept_made: Vec<u32>,
    /// Refreshes of the kept pairs so far (wrapping).
    refreshes: u32,
    kept_moves: Vec<bool>,
    /// Each body's collision filter at the last rebuild, when the kept pairs were
    /// filtered by them (empty when they were not: then they hold every pair of boxes).
    /// A pair the filters refuse is not kept, so bodies that overlap without touching
    /// (a filtered grid of large circles) cost no memory for their pairs.
    kept_filters: Vec<Filter>,
    kept_pairs: Vec<Pair>,
    /// Per awake block of bodies ([`AWAKE_BLOCK`]): a box holding each of its kept boxes
    /// (found at the rebuild, grown as some bodies' are redone), so that their search
    /// for pairs passes over the blocks their boxes miss.
    kept_bounds: Vec<Option<Aabb>>,
    /// How many kept boxes may move (`kept_moves` set).
    kept_movers: usize,
    /// Per awake block: its kept bounds where none of its bodies may move, else `None`
    /// (scratch of a rebuild).
    still_bounds: Vec<Option<Aabb>>,
    /// Per awake block: whether the grid leaves it out (scratch of
    /// [`BroadPhase::each_pair`]).
    left_out: Vec<bool>,
    /// The bounds of each block's movers (scratch of [`BroadPhase::each_pair`]).
    mover_bounds: Vec<Aabb>,
    /// The kept pairs an update for some bodies takes out (scratch of
    /// [`BroadPhase::refresh_some`]).
    gone: Vec<Pair>,
    /// The last rebuild's filters let no two bodies touch: the kept pairs (none) hold
    /// while the filters do.
    no_pair_by_filters: bool,
    /// Per body: whether it is one of those whose kept box is being redone (scratch
    /// of [`BroadPhase::refresh_some`], all false between calls).
    redo: Vec<bool>,
    /// A few bodies that look for pairs (scratch).
    few: Vec<u32>,
    /// The pairs each block of cells found, where the threads share the grid's cells
    /// (scratch of [`BroadPhase::pairs_dense`]).
    cell_outs: BlockScratch<Pair>,
    /// Per run of cells, the boxes of the cell it scans (scratch of
    /// [`BroadPhase::pairs_dense`]).
    cell_boxes: Scratch<Mutex<CellBoxes>>,
    /// The grid of [`pairs_of_some`] (scratch).
    some_grid: SomeGrid,
    /// Rebuilds of the kept pairs so far.
    pub rebuilds: u64,
    /// Updates of the kept pairs for some bodies ([`BroadPhase::refresh_some`]) so far.
    pub updates: u64,
    /// Candidate pairs from the last [`BroadPhase::find_pairs`], sorted.
    pub pairs: Vec<Pair>,
}

mod kept;
mod some;
#[cfg(test)]
mod tests;

pub use kept::Left;
use kept::ONE_BY_ONE;
use some::{SomeGrid, pairs_of_few, pairs_of_some};

/// A box spanning more cells than this per axis is tested against all bodies instead.
const MAX_CELLS_PER_AXIS: i64 = 4;

/// A grid's cell: twice the median of the box extents `sizes` (not empty; reordered),
/// rounded up to 1, 1.25, 1.5 or 1.75 times a power of two (the float's mantissa cut to
/// two bits): the grid keeps its shape, and its buffers their size, while the median
/// wavers.
fn cell_size(sizes: &mut [f32]) -> f32 {
    let mid = sizes.len() / 2;
    let (_, m, _) = sizes.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    const LOW: u32 = (1 << 21) - 1;
    f32::from_bits(((2.0 * *m).max(1e-3).to_bits() + LOW) & !LOW)
}

#[inline]
fn cell_key(ix: i64, iy: i64) -> u64 {
    // 32 bits each, offset so negative cells sort before positive ones
    (((ix + (1 << 31)) as u64) << 32) | ((iy + (1 << 31)) as u64 & 0xffff_ffff)
}

impl BroadPhase {
    /// Finds every pair of overlapping boxes where `can_collide(a, b)` holds (a < b).
    /// `aabbs[i]` is body i's (fattened) box; `moves[i]` is false for static bodies, and
    /// two bodies that both do not move are never paired.
    #[cfg(test)]
    pub fn find_pairs(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        can_collide: impl Fn(u32, u32) -> bool + Sync,
    ) {
        self.find_pairs_sized(aabbs, moves, moves, &[], can_collide, None);
    }

    /// [`BroadPhase::find_pairs`] with the grid's cells sized by the boxes `sized` marks
    /// rather than by the moving ones: the pairs are the same (the grid only decides how
    /// fast they are found). Waking uses it: there the few awake bodies move, and a
    /// grid sized by one large mover would put thousands of small sleepers in a cell.
    ///
    /// `blocks`, per awake block of [`AWAKE_BLOCK`] bodies (empty, or shorter, for none):
    /// `Some(bounds)` where no body of the block moves and each one's box lies inside
    /// `bounds`. While a few bodies move (each then tested against every box), a block
    /// whose bounds a mover's box misses is passed over whole: a world of sleeping
    /// blocks pays for one box a block, not one a body.
    ///
    /// With a pool, the threads share the grid's cells; the pairs are the same, in the
    /// same order.
    pub fn find_pairs_sized(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        sized: &[bool],
        blocks: &[Option<Aabb>],
        can_collide: impl Fn(u32, u32) -> bool + Sync,
        pool: Option<&Pool>,
    ) {
        let mut pairs = std::mem::take(&mut self.pairs);
        pairs.clear();
        let mut few = std::mem::take(&mut self.few);
        few.clear();
        'find: for (k, start) in (0..moves.len()).step_by(AWAKE_BLOCK).enumerate() {
            if matches!(blocks.get(k), Some(Some(_))) {
                // (none of its bodies moves)
                continue;
            }
            let end = (start + AWAKE_BLOCK).min(moves.len());
            for (i, _) in moves[start..end].iter().enumerate().filter(|(_, m)| **m) {
                if few.len() > ONE_BY_ONE {
                    break 'find;
                }
                few.push((start + i) as u32);
            }
        }
        if few.len() <= ONE_BY_ONE {
            // a few movers: each against every box, no grid
            pairs_of_few(aabbs, &few, moves, blocks, &can_collide, &mut pairs);
        } else {
            self.each_pair(aabbs, moves, sized, blocks, &can_collide, pool, &mut pairs);
        }
        self.few = few;
        self.pairs = pairs;
        self.sort_pairs(aabbs.len(), pool);
        debug_assert!(
            self.pairs.windows(2).all(|w| w[0] < w[1]),
            "the grid finds each pair once"
        );
    }

    /// The pairs of overlapping boxes with one of `some` (in increasing order; `marked`
    /// holds for them and no other) where `can_collide(a, b)` holds (a < b), sorted:
    /// found through a grid of their boxes alone, into which every other box looks
    /// (passing over the blocks whose `blocks` bounds miss all of theirs), where they
    /// are few. Returns false, with the pairs unset, where their boxes are spread too
    /// thin for that grid. With a pool, the threads share the pass over the boxes.
    pub fn find_pairs_of_some(
        &mut self,
        aabbs: &[Aabb],
        some: &[u32],
        marked: &[bool],
        blocks: &[Option<Aabb>],
        can_collide: impl Fn(u32, u32) -> bool + Sync,
        pool: Option<&Pool>,
    ) -> bool {
        let mut pairs = std::mem::take(&mut self.pairs);
        let found = pairs_of_some(
            aabbs,
            some,
            marked,
            blocks,
            &can_collide,
            &mut self.some_grid,
            &mut pairs,
            pool,
        );
        self.pairs = pairs;
        if found {
            self.sort_pairs(aabbs.len(), pool);
        }
        found
    }

    /// Counts the pairs [`BroadPhase::find_pairs`] would find, without keeping them, up
    /// to `limit`: `Ok(count)`, or `Err(pair)` with the pair that went past `limit`.
    /// Memory grows with the bodies, not with the pairs, so a scene whose bodies overlap
    /// by the million can be measured before anything is allocated for its pairs.
    pub fn count_pairs(
        aabbs: &[Aabb],
        moves: &[bool],
        can_collide: impl Fn(u32, u32) -> bool + Sync,
        limit: u64,
    ) -> Result<u64, Pair> {
        let mut counted = Counted {
            count: 0,
            limit,
            over: None,
        };
        BroadPhase::default().each_pair(aabbs, moves, moves, &[], &can_collide, None, &mut counted);
        match counted.over {
            Some(p) => Err(p),
            None => Ok(counted.count),
        }
    }

    /// Gives `emit` each pair of overlapping boxes where `can_collide` holds, once and in
    /// no particular order; stops once `emit` refuses one. The grid's cells are sized by
    /// the boxes `sized` marks. `blocks`, as for [`BroadPhase::find_pairs_sized`]: a
    /// block with bounds that miss the bounds of every block's movers stays out of the
    /// grid (none of its boxes meets a mover's), so a world of sleeping blocks far from
    /// its few thousand movers pays for theirs.
    #[allow(clippy::too_many_arguments)]
    fn each_pair(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        sized: &[bool],
        blocks: &[Option<Aabb>],
        can_collide: &(impl Fn(u32, u32) -> bool + Sync),
        pool: Option<&Pool>,
        emit: &mut dyn PairSink,
    ) {
        self.entries.clear();
        self.large.clear();
        if aabbs.len() < 2 {
            return;
        }
        // the blocks left out: each with bounds (none of its bodies moves) that miss
        // the bounds of every block's movers
        let mut left_out = std::mem::take(&mut self.left_out);
        left_out.clear();
        if blocks.iter().any(Option::is_some) {
            let mut movers = std::mem::take(&mut self.mover_bounds);
            movers.clear();
            for (k, (boxes, moving)) in aabbs
                .chunks(AWAKE_BLOCK)
                .zip(moves.chunks(AWAKE_BLOCK))
                .enumerate()
            {
                if matches!(blocks.get(k), Some(Some(_))) {
                    continue;
                }
                let moving = boxes
                    .iter()
                    .zip(moving)
                    .filter(|(_, m)| **m)
                    .map(|(b, _)| *b);
                movers.extend(moving.reduce(|a, b| a.union(&b)));
            }
            // (the box holding them all first: most blocks far from every mover miss it)
            let reach = movers.iter().copied().reduce(|a, b| a.union(&b));
            left_out.extend(blocks.iter().map(|b| {
                b.is_some_and(|b| {
                    reach.is_none_or(|r| !r.overlaps(&b) || !movers.iter().any(|m| m.overlaps(&b)))
                })
            }));
            self.mover_bounds = movers;
        }
        self.grid_pairs(
            aabbs,
            moves,
            sized,
            blocks,
            &left_out,
            can_collide,
            pool,
            emit,
        );
        self.left_out = left_out;
    }

    /// [`BroadPhase::each_pair`] with the blocks `left_out` marks (per block; none past
    /// its end) left out of the grid.
    #[allow(clippy::too_many_arguments)]
    fn grid_pairs(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        sized: &[bool],
        blocks: &[Option<Aabb>],
        left_out: &[bool],
        can_collide: &(impl Fn(u32, u32) -> bool + Sync),
        pool: Option<&Pool>,
        emit: &mut dyn PairSink,
    ) {
        let out = |k: usize| left_out.get(k).copied().unwrap_or(false);
        // the blocks of bodies in the grid
        let n = aabbs.len();
        let runs = || {
            (0..n)
                .step_by(AWAKE_BLOCK)
                .enumerate()
                .filter(move |&(k, _)| !out(k))
                .map(move |(k, from)| (k, from..(from + AWAKE_BLOCK).min(n)))
        };
        // Cell size: twice the median extent of the moving bodies' boxes.
        let cell = {
            let sizes = &mut self.sizes;
            sizes.clear();
            for (_, run) in runs() {
                sizes.extend(
                    aabbs[run.clone()]
                        .iter()
                        .zip(&sized[run])
                        .filter(|(_, m)| **m)
                        .map(|(b, _)| (b.max - b.min).max_element()),
                );
            }
            if sizes.is_empty() || (!std::ptr::eq(sized, moves) && !moves.contains(&true)) {
                return;
            }
            cell_size(sizes)
        };
        let inv = 1.0 / cell;
        let to_cell = |v: Vec2| (floor_i64(v.x * inv), floor_i64(v.y * inv));
        // each body's cell range; the grid's bounds
        self.ranges.clear();
        // every body in `ranges` writes its entry below; the others' are never read
        self.lowest.resize(aabbs.len(), [0; 2]);
        let (mut gx0, mut gy0, mut gx1, mut gy1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
        for (i, b) in runs().flat_map(|(_, run)| run.clone().zip(&aabbs[run])) {
            let (x0, y0) = to_cell(b.min);
            let (x1, y1) = to_cell(b.max);
            if x1 - x0 >= MAX_CELLS_PER_AXIS
                || y1 - y0 >= MAX_CELLS_PER_AXIS
                || !b.min.is_finite()
                || !b.max.is_finite()
            {
                self.large.push(i as u32);
                continue;
            }
            self.ranges.push((i as u32, [x0, y0, x1, y1]));
            self.lowest[i] = [x0, y0];
            (gx0, gy0, gx1, gy1) = (gx0.min(x0), gy0.min(y0), gx1.max(x1), gy1.max(y1));
        }
        // saturating: with no ranges the bounds are still (MAX, MIN)
        let (w, h) = (
            gx1.saturating_sub(gx0).saturating_add(1),
            gy1.saturating_sub(gy0).saturating_add(1),
        );
        let dense = !self.ranges.is_empty()
            && w > 0
            && h > 0
            && w.saturating_mul(h) <= (8 * self.ranges.len() as i64).max(1 << 16);
        let more = if dense {
            self.pairs_dense(
                aabbs,
                moves,
                can_collide,
                [gx0, gy0],
                w as usize,
                h as usize,
                pool,
                emit,
            )
        } else {
            self.pairs_sorted(aabbs, moves, can_collide, inv, emit)
        };
        if !more {
            return;
        }

        // per body: its place in `large` (u32::MAX if it is not large)
        self.large_rank.clear();
        if !self.large.is_empty() {
            self.large_rank.resize(aabbs.len(), u32::MAX);
            for (k, &l) in self.large.iter().enumerate() {
                self.large_rank[l as usize] = k as u32;
            }
        }
        for (k, &l) in self.large.iter().enumerate() {
            let bl = &aabbs[l as usize];
            let l_moves = moves[l as usize];
            for (block, run) in runs() {
                // (a block none of whose bodies moves: only a mover's pairs with it)
                if let Some(Some(bounds)) = blocks.get(block)
                    && !(l_moves && bounds.overlaps(bl))
                {
                    continue;
                }
                for (i, b) in run.clone().zip(&aabbs[run]) {
                    // a large-large pair is tested once, from the earlier large body (and
                    // a body not with itself): skip the large bodies up to this one
                    if self.large_rank[i] <= k as u32 {
                        continue;
                    }
                    let i = i as u32;
                    if !(l_moves || moves[i as usize]) || !bl.overlaps(b) {
                        continue;
                    }
                    let p = if l < i { (l, i) } else { (i, l) };
                    if can_collide(p.0, p.1) && !emit.pair(p) {
                        return;
                    }
                }
            }
        }
    }

    /// Sorts the pairs by (a, b): a counting sort by a, then each (short) run of equal a
    /// by insertion. The same order as `sort_unstable`, in linear time; a few pairs
    /// among many bodies (waking) by `sort_unstable` itself, which visits no body.
    ///
    /// From [`PARALLEL_SORT_PAIRS`] pairs the threads share it: each counts its run of
    /// the pairs by first body, the counts are summed to where each run's pairs of each
    /// first body go (run after run, so the sort stays stable and the order is the one
    /// thread's), each places its run, and each sorts the runs of equal first body in its
    /// share of the bodies. One thread does the same over one run.
    fn sort_pairs(&mut self, bodies: usize, pool: Option<&Pool>) {
        let n = self.pairs.len();
        if n * 16 < bodies {
            self.pairs.sort_unstable();
            return;
        }
        let pool = pool.filter(|p| p.threads() > 1 && n >= PARALLEL_SORT_PAIRS);
        let runs = pool.map_or(1, Pool::threads);
        // f(k) for each run k: a block each on the pool, or in turn here
        let each_run = |f: &(dyn Fn(usize) + Sync)| match pool {
            Some(pool) => {
                parallel::blocks_max(pool, runs, &|_, k| {
                    f(k);
                    0.0
                });
            }
            None => (0..runs).for_each(f),
        };
        let stride = bodies + 1;
        let counts = &mut self.pair_counts;
        counts.clear();
        counts.resize(runs * stride, 0);
        let pairs = &self.pairs[..];
        // run k of the pairs, and its counts (then its next slots)
        let run = |k: usize| &pairs[parallel::split(n, runs, k)];
        let per_run = Disjoint::new(counts);
        each_run(&|k| {
            // SAFETY: run k takes only its own counts
            let counts = unsafe { per_run.range(k * stride..(k + 1) * stride) };
            for &(a, _) in run(k) {
                counts[a as usize] += 1;
            }
        });
        // each run's first slot for each first body; `pair_start`, where each first
        // body's pairs start
        let start = &mut self.pair_start;
        start.clear();
        start.resize(stride, 0);
        let mut at = 0u32;
        for (a, first) in start[..bodies].iter_mut().enumerate() {
            *first = at;
            for k in 0..runs {
                let c = &mut counts[k * stride + a];
                (*c, at) = (at, at + *c);
            }
        }
        start[bodies] = at;
        self.pairs_tmp.clear();
        self.pairs_tmp.resize(n, (0, 0));
        let placed = Disjoint::new(&mut self.pairs_tmp);
        let per_run = Disjoint::new(counts);
        each_run(&|k| {
            // SAFETY: run k takes only its own slots
            let next = unsafe { per_run.range(k * stride..(k + 1) * stride) };
            for &p in run(k) {
                let slot = &mut next[p.0 as usize];
                // SAFETY: each run's slots for each first body are its own (the sums
                // above), and each slot is taken once
                unsafe { placed.set(*slot as usize, p) };
                *slot += 1;
            }
        });
        // the runs of equal first body, each share of the bodies holding about as many
        // pairs
        let start = &self.pair_start[..];
        let share = |k: usize| start.partition_point(|&s| (s as usize) < n * k / runs);
        each_run(&|k| {
            let (lo, hi) = (share(k), share(k + 1).min(bodies));
            if lo >= hi {
                return;
            }
            let base = start[lo] as usize;
            // SAFETY: the shares' first bodies, and so their pairs, do not overlap
            let mine = unsafe { placed.range(base..start[hi] as usize) };
            for a in lo..hi {
                insertion_sort(&mut mine[start[a] as usize - base..start[a + 1] as usize - base]);
            }
        });
        std::mem::swap(&mut self.pairs, &mut self.pairs_tmp);
    }
}

/// The boxes of one grid cell side by side, a coordinate to a row (the lower x of every
/// box, then the lower y, the upper x, the upper y), so that one box is tested against
/// the rest with no branch on the compares (scratch of the grid's scan).
#[derive(Debug, Default)]
struct CellBoxes {
    rows: Vec<f32>,
}

impl CellBoxes {
    /// Takes the boxes of the bodies `here`.
    fn gather(&mut self, here: impl ExactSizeIterator<Item = u32>, aabbs: &[Aabb]) {
        let n = here.len();
        self.rows.resize(4 * n, 0.0);
        let (x0, rest) = self.rows.split_at_mut(n);
        let (y0, rest) = rest.split_at_mut(n);
        let (x1, y1) = rest.split_at_mut(n);
        for (i, b) in here.enumerate() {
            let bb = &aabbs[b as usize];
            (x0[i], y0[i], x1[i], y1[i]) = (bb.min.x, bb.min.y, bb.max.x, bb.max.y);
        }
    }

    /// Calls `f(j)` for each box j after box `k` (in the order gathered) that overlaps
    /// it, in order, testing 64 at a time ([`CellBoxes::overlapping`]); stops and
    /// returns false once `f` does.
    fn each_overlap(&self, k: usize, mut f: impl FnMut(usize) -> bool) -> bool {
        let n = self.rows.len() / 4;
        for from in (k + 1..n).step_by(64) {
            let mut hits = self.overlapping(k, from..(from + 64).min(n));
            while hits != 0 {
                let j = from + hits.trailing_zeros() as usize;
                hits &= hits - 1;
                if !f(j) {
                    return false;
                }
            }
        }
        true
    }

    /// Which of the boxes `after` (in the order gathered; at most 64, all after box `k`)
    /// overlap box `k` ([`Aabb::overlaps`]): a bit each, the first box's the lowest.
    fn overlapping(&self, k: usize, after: Range<usize>) -> u64 {
        debug_assert!(k < after.start && after.len() <= 64);
        let n = self.rows.len() / 4;
        let (x0, rest) = self.rows.split_at(n);
        let (y0, rest) = rest.split_at(n);
        let (x1, y1) = rest.split_at(n);
        let (ax0, ay0, ax1, ay1) = (x0[k], y0[k], x1[k], y1[k]);
        let rows = x0[after.clone()]
            .iter()
            .zip(&y0[after.clone()])
            .zip(x1[after.clone()].iter().zip(&y1[after]));
        let mut hits = 0u64;
        for (bit, ((&bx0, &by0), (&bx1, &by1))) in rows.enumerate() {
            let hit = (ax0 <= bx1) & (bx0 <= ax1) & (ay0 <= by1) & (by0 <= ay1);
            hits |= (hit as u64) << bit;
        }
        hits
    }
}

/// Where the grid's pairs go: one by one, or a list found by one thread at once.
trait PairSink {
    /// Takes a pair; false to stop.
    fn pair(&mut self, p: Pair) -> bool;

    /// Takes the pairs in order; false to stop.
    fn pairs(&mut self, pairs: &[Pair]) -> bool {
        pairs.iter().all(|&p| self.pair(p))
    }
}

/// The pairs kept in a list (a found list copied whole).
impl PairSink for Vec<Pair> {
    fn pair(&mut self, p: Pair) -> bool {
        self.push(p);
        true
    }

    fn pairs(&mut self, pairs: &[Pair]) -> bool {
        self.extend_from_slice(pairs);
        true
    }
}

/// The pairs counted up to a limit: the pair past it stops the count.
struct Counted {
    count: u64,
    limit: u64,
    over: Option<Pair>,
}

impl PairSink for Counted {
    fn pair(&mut self, p: Pair) -> bool {
        self.count += 1;
        if self.count > self.limit {
            self.over = Some(p);
        }
        self.over.is_none()
    }
}

/// Sorts a short run of pairs in place by insertion.
fn insertion_sort(run: &mut [Pair]) {
    for i in 1..run.len() {
        let x = run[i];
        let mut j = i;
        while j > 0 && run[j - 1] > x {
            run[j] = run[j - 1];
            j -= 1;
        }
        run[j] = x;
    }
}

impl BroadPhase {
    /// The cells of a bounded grid (w x h cells from `origin`) hold the bodies, placed by
    /// a counting sort: within a cell in body order, cells in row order. The pairs are
    /// emitted cell by cell; with a pool, the threads test runs of the cells, each into
    /// its own list, and the lists are emitted in the cells' order (the same pairs in
    /// the same order). Returns false when `emit` asked to stop.
    #[allow(clippy::too_many_arguments)]
    fn pairs_dense(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        can_collide: &(impl Fn(u32, u32) -> bool + Sync),
        origin: [i64; 2],
        w: usize,
        h: usize,
        pool: Option<&Pool>,
        emit: &mut dyn PairSink,
    ) -> bool {
        let cell_of = |ix: i64, iy: i64| (iy - origin[1]) as usize * w + (ix - origin[0]) as usize;
        self.cell_start.clear();
        self.cell_start.resize(w * h + 1, 0);
        for &(_, [x0, y0, x1, y1]) in &self.ranges {
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    self.cell_start[cell_of(ix, iy) + 1] += 1;
                }
            }
        }
        for c in 1..self.cell_start.len() {
            self.cell_start[c] += self.cell_start[c - 1];
        }
        let total = self.cell_start[w * h] as usize;
        self.cell_bodies.clear();
        self.cell_bodies.resize(total, 0);
        // fill: cell_fill[c] runs from cell_start[c]
        self.cell_fill.clear();
        self.cell_fill.extend_from_slice(&self.cell_start[..w * h]);
        for &(i, [x0, y0, x1, y1]) in &self.ranges {
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    let c = cell_of(ix, iy);
                    self.cell_bodies[self.cell_fill[c] as usize] = i;
                    self.cell_fill[c] += 1;
                }
            }
        }
        let (cell_start, cell_bodies, lowest) = (&self.cell_start, &self.cell_bodies, &self.lowest);
        // the pairs of the cells `cells`, each emitted; `scratch` holds a cell's boxes
        // side by side (see [`CellBoxes`]): each body is tested against the rest of its
        // cell a bit a box, with no branch, and only the boxes that overlap go on to the
        // other tests
        let scan = |cells: Range<usize>, scratch: &mut CellBoxes, emit: &mut dyn PairSink| {
            for c in cells {
                let (start, end) = (cell_start[c] as usize, cell_start[c + 1] as usize);
                if end - start < 2 {
                    continue;
                }
                let (cx, cy) = ((c % w) as i64 + origin[0], (c / w) as i64 + origin[1]);
                let here = &cell_bodies[start..end];
                scratch.gather(here.iter().copied(), aabbs);
                for (k, &a) in here.iter().enumerate() {
                    let each = scratch.each_overlap(k, |j| {
                        let b = here[j];
                        if !(moves[a as usize] || moves[b as usize]) {
                            return true;
                        }
                        // report only from the cell holding the overlap's lower-left
                        // corner, max(a.min, b.min): the cell is monotone in the point,
                        // so the corner's cell is the larger of the two bodies' lowest
                        let (la, lb) = (lowest[a as usize], lowest[b as usize]);
                        if (la[0].max(lb[0]), la[1].max(lb[1])) != (cx, cy) {
                            return true;
                        }
                        // a < b: bodies lie in a cell in increasing order
                        !can_collide(a, b) || emit.pair((a, b))
                    });
                    if !each {
                        return false;
                    }
                }
            }
            true
        };
        let threads = pool.map_or(1, Pool::threads);
        let (cells, total) = (w * h, cell_bodies.len());
        let Some(pool) = pool.filter(|_| threads > 1 && total >= PARALLEL_CELL_ENTRIES) else {
            let scratch = self.cell_boxes.first_with(1, CellBoxes::default);
            return scan(
                0..cells,
                scratch[0].get_mut().unwrap_or_else(|e| e.into_inner()),
                emit,
            );
        };
        // runs of cells of about equal entries, a few per thread (a crowded run costs
        // more than its entries say, and the other threads take what is left)
        let runs = RUNS_PER_THREAD * threads;
        let run = |k: usize| {
            let at = |k: usize| cell_start.partition_point(|&s| (s as usize) < total * k / runs);
            at(k).min(cells)..at(k + 1).min(cells)
        };
        let outs = self.cell_outs.first(runs, 0);
        let scratch = &*self.cell_boxes.first_with(runs, CellBoxes::default);
        parallel::blocks_max(pool, runs, &|_, k| {
            let mut found = outs[k].lock().unwrap_or_else(|e| e.into_inner());
            found.clear();
            let mut scratch = scratch[k].lock().unwrap_or_else(|e| e.into_inner());
            scan(run(k), &mut scratch, &mut *found);
            0.0
        });
        for found in outs.iter_mut() {
            let found = found.get_mut().unwrap_or_else(|e| e.into_inner());
            if !emit.pairs(found) {
                return false;
            }
        }
        true
    }

    /// The sparse case: (cell key, body) entries sorted. Returns false when `emit`
    /// asked to stop.
    fn pairs_sorted(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        can_collide: &impl Fn(u32, u32) -> bool,
        inv: f32,
        emit: &mut dyn PairSink,
    ) -> bool {
        let to_cell = |v: Vec2| (floor_i64(v.x * inv), floor_i64(v.y * inv));
        for &(i, [x0, y0, x1, y1]) in &self.ranges {
            for ix in x0..=x1 {
                for iy in y0..=y1 {
                    self.entries.push((cell_key(ix, iy), i));
                }
            }
        }
        self.entries.sort_unstable();

        let entries = &self.entries;
        // a cell's boxes side by side, as the dense grid tests them
        let scratch = self.cell_boxes.first_with(1, CellBoxes::default);
        let scratch = scratch[0].get_mut().unwrap_or_else(|e| e.into_inner());
        let mut start = 0;
        while start < entries.len() {
            let key = entries[start].0;
            let mut end = start + 1;
            while end < entries.len() && entries[end].0 == key {
                end += 1;
            }
            let here = &entries[start..end];
            scratch.gather(here.iter().map(|e| e.1), aabbs);
            for (k, &(_, a)) in here.iter().enumerate() {
                let each = scratch.each_overlap(k, |j| {
                    let (ba, b) = (&aabbs[a as usize], here[j].1);
                    if !(moves[a as usize] || moves[b as usize]) {
                        return true;
                    }
                    // report only from the cell holding the overlap's lower-left corner
                    let corner = ba.min.max(aabbs[b as usize].min);
                    let (cx, cy) = to_cell(corner);
                    if cell_key(cx, cy) != key {
                        return true;
                    }
                    let p = if a < b { (a, b) } else { (b, a) };
                    !can_collide(p.0, p.1) || emit.pair(p)
                });
                if !each {
                    return false;
                }
            }
            start = end;
        }
        true
    }
}

/// Entries of the grid's cells (a body in each cell it covers) from which the threads
/// share the cells' pair tests (about 1,000 bodies: below it, the pass costs less than
/// sharing it).
const PARALLEL_CELL_ENTRIES: usize = 4096;

/// Pairs from which the threads share their sort.
const PARALLEL_SORT_PAIRS: usize = 8192;

/// Runs of the grid's cells a thread tests, on average, where the threads share them.
const RUNS_PER_THREAD: usize = 4;

/// floor(x) as an integer, without a libm call: truncate, then step down below zero.
/// Clamped to +-2^40 cells, so that differences and sums of cells never overflow (a body
/// far beyond that lands in the edge cell; the narrow phase sorts it out); NaN is cell 0.
///
/// Clamped as a float first, so the conversion needs none of `as`'s saturation fix-ups:
/// this runs four times a body a step, and the saturating form cost about 40
/// instructions a call (0.8 M a step on the large pyramid, 2% of the step).
#[inline(always)]
fn floor_i64(x: f32) -> i64 {
    const LIMIT: f32 = (1u64 << 40) as f32;
    let x = if x.is_nan() {
        0.0
    } else {
        x.clamp(-LIMIT, LIMIT)
    };
    // SAFETY: x is finite and within +-2^40, which i64 holds exactly
    let i = unsafe { x.to_int_unchecked::<i64>() };
    i - ((i as f32) > x) as i64
}
