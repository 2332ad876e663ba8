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

/// The bodies whose kept box no longer holds their box (or whose filter or whether they
/// may move changed), as the caller found them in a pass over the bodies it makes
/// anyway ([`BroadPhase::kept_holds`], [`BroadPhase::kept_filter_holds`]).
#[derive(Clone, Copy, Debug)]
pub enum Left<'a> {
    /// The kept boxes are not for these bodies (or nobody looked): they are rebuilt.
    All,
    /// Exactly these, in increasing order (the kept boxes are for these bodies; none
    /// when every kept box holds).
    These(&'a [u32]),
}

/// How far a kept box reaches past a body's box (m), at most: a body is looked up again
/// only once its box leaves this. A quarter of the body's own extent where that is less,
/// so that small bodies keep few extra pairs.
const KEEP_MARGIN: f32 = 0.1;

/// At most this many bodies are looked up one by one against every box (about 2 ns a
/// box each) rather than through the grid (about 150 ns a box): the kept boxes that a
/// step's few movers leave, or the few awake bodies that look for sleepers. A big box
/// moving through a wall of sleeping boxes (Box2D's smash) then costs its own box and
/// a pass over the others, not a grid of them all.
const ONE_BY_ONE: usize = 32;

/// At most one body in this many of those that may move may leave its kept box for the
/// kept pairs to be updated for those bodies alone (a grid of their boxes that every
/// other box looks into) rather than rebuilt: a heap of small bodies jostling in one
/// place (Box2D's junkyard) then costs a pass over the boxes, not a grid of them all.
/// (A rebuild's grid holds the bodies that may move and the still ones they reach, so
/// the share is of the movers, not of every body.)
const SOME_SHARE: usize = 4;

/// A body's kept box: its box fattened by [`KEEP_MARGIN`], or a quarter of its extent
/// where that is less.
fn kept_box(b: &Aabb) -> Aabb {
    let extent = (b.max - b.min).max_element();
    b.fattened(KEEP_MARGIN.min(0.25 * extent))
}

/// Whether some two of `filters` (two entries, not one with itself) let their bodies
/// touch. Looks at the distinct filters only; with more than a few of them it answers
/// yes without looking further (then the grid decides, pair by pair).
fn any_pair_may_touch(filters: &[Filter]) -> bool {
    const FEW: usize = 8;
    // each distinct filter and whether it is there more than once
    let mut seen: [(Filter, bool); FEW] = [(Filter::default(), false); FEW];
    let mut n = 0;
    for f in filters {
        match seen[..n].iter_mut().find(|(g, _)| g == f) {
            Some((_, twice)) => *twice = true,
            None if n == FEW => return true,
            None => {
                seen[n] = (*f, false);
                n += 1;
            }
        }
    }
    let seen = &seen[..n];
    seen.iter().enumerate().any(|(i, (f, twice))| {
        (*twice && f.collides(f)) || seen[i + 1..].iter().any(|(g, _)| f.collides(g))
    })
}

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

    /// The pairs [`BroadPhase::find_pairs`] would find, found from last step's where
    /// that is enough: the pairs of the bodies' fattened boxes are kept, and while every
    /// box stays inside its fattened one (and no body starts being able to move while
    /// its pairs were kept as one that may not), this step's pairs are those kept pairs
    /// whose boxes overlap, a pass over the pairs instead of the grid. `may_move(i)` must
    /// hold wherever `moves[i]` does (an awake dynamic body may move; a static or
    /// sleeping one may not).
    ///
    /// The result is the same list, to the order, as `find_pairs` gives: two boxes that
    /// overlap lie inside fattened boxes that overlap, so the kept pairs hold every pair
    /// of this step, and both lists are sorted.
    #[cfg(test)]
    pub fn find_pairs_kept(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        may_move: impl Fn(usize) -> bool,
        can_collide: impl Fn(u32, u32) -> bool,
    ) {
        let listed: Option<Vec<u32>> = (self.kept_count() == aabbs.len()).then(|| {
            (0..aabbs.len())
                .filter(|&i| !self.kept_holds(i, &aabbs[i], may_move(i)))
                .map(|i| i as u32)
                .collect()
        });
        let left = listed.as_deref().map_or(Left::All, Left::These);
        self.find_pairs_kept_checked(aabbs, moves, left, may_move, None, can_collide, None);
    }

    /// Bodies the kept boxes are for (0 before the first [`BroadPhase::find_pairs_kept`]).
    pub fn kept_count(&self) -> usize {
        self.kept_boxes.len()
    }

    /// Whether body `i`'s kept box (`i` < [`BroadPhase::kept_count`]) still holds its box
    /// `b`, and its pairs were kept as a body that may move where it now may
    /// (`may_move`). A body that stopped moving (fell asleep) keeps its pairs as they
    /// are: they are more than it needs, and the next rebuild drops them. So falling
    /// asleep costs the kept pairs nothing, and waking only where a rebuild came between.
    #[inline]
    pub fn kept_holds(&self, i: usize, b: &Aabb, may_move: bool) -> bool {
        // filters that let no two bodies touch: no pair wherever the boxes go (while the
        // filters stay, which the caller checks with `kept_filter_holds`)
        self.no_pair_by_filters
            || (self.kept_boxes[i].contains(b) && (self.kept_moves[i] || !may_move))
    }

    /// Whether body `i`'s filter is the one the kept pairs were filtered with (always,
    /// when they were not filtered: they then hold every pair whatever the filters).
    #[inline]
    pub fn kept_filter_holds(&self, i: usize, filter: &Filter) -> bool {
        self.kept_filters.is_empty() || self.kept_filters[i] == *filter
    }

    /// [`BroadPhase::find_pairs_kept`] where the caller has checked whether the kept
    /// boxes hold, in a pass over the bodies it makes anyway: `left` says for which
    /// bodies [`BroadPhase::kept_holds`] or [`BroadPhase::kept_filter_holds`] fails.
    /// `filter_of`, as for [`BroadPhase::refresh_kept`].
    #[allow(clippy::too_many_arguments)]
    pub fn find_pairs_kept_checked(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        left: Left<'_>,
        may_move: impl Fn(usize) -> bool,
        filter_of: Option<&dyn Fn(usize) -> Filter>,
        can_collide: impl Fn(u32, u32) -> bool,
        pool: Option<&Pool>,
    ) {
        self.refresh_kept(aabbs, left, may_move, filter_of, pool);
        self.pairs.clear();
        for &(a, b) in &self.kept_pairs {
            if Self::kept_pair_holds(aabbs, moves, a, b) && can_collide(a, b) {
                self.pairs.push((a, b));
            }
        }
    }

    /// The first half of [`BroadPhase::find_pairs_kept_checked`]: rebuilds the kept
    /// boxes and pairs unless they hold (`left` empty, as for
    /// [`BroadPhase::find_pairs_kept_checked`]). The caller then filters
    /// [`BroadPhase::kept_pairs`] itself, with [`BroadPhase::kept_pair_holds`] and its
    /// own test, in a pass over the pairs it makes anyway (the narrow phase); `pairs`
    /// is left empty.
    ///
    /// With `filter_of` (each body's collision filter), a rebuild keeps only the pairs
    /// whose filters let them touch, and remembers the filters: while they stay the same
    /// ([`BroadPhase::kept_filter_holds`], which `left` must then include) the kept
    /// pairs still hold every pair of the step. Without it every pair of boxes is kept.
    pub fn refresh_kept(
        &mut self,
        aabbs: &[Aabb],
        left: Left<'_>,
        may_move: impl Fn(usize) -> bool,
        filter_of: Option<&dyn Fn(usize) -> Filter>,
        pool: Option<&Pool>,
    ) {
        let rebuild = match left {
            Left::All => true,
            Left::These(listed) => {
                !listed.is_empty() && !self.refresh_some(aabbs, listed, &may_move, filter_of, pool)
            }
        };
        if rebuild {
            let mut fat = std::mem::take(&mut self.kept_boxes);
            let mut fat_moves = std::mem::take(&mut self.kept_moves);
            fat.clear();
            fat.extend(aabbs.iter().map(kept_box));
            fat_moves.clear();
            fat_moves.extend((0..aabbs.len()).map(&may_move));
            self.kept_movers = fat_moves.iter().filter(|&&m| m).count();
            self.kept_bounds.clear();
            self.kept_bounds.extend(
                fat.chunks(AWAKE_BLOCK)
                    .map(|c| c.iter().copied().reduce(|a, b| a.union(&b))),
            );
            // the blocks none of whose bodies may move (static, or asleep): the grid
            // leaves out those that no mover's box reaches
            let mut still = std::mem::take(&mut self.still_bounds);
            still.clear();
            still.extend(
                fat_moves
                    .chunks(AWAKE_BLOCK)
                    .zip(&self.kept_bounds)
                    .map(|(m, b)| if m.contains(&true) { None } else { *b }),
            );
            let mut filters = std::mem::take(&mut self.kept_filters);
            self.no_pair_by_filters = false;
            match filter_of {
                Some(f) => {
                    match left {
                        // (every other body's filter is the one kept: only the bodies
                        // listed are read)
                        Left::These(listed) if filters.len() == aabbs.len() => {
                            for &i in listed {
                                filters[i as usize] = f(i as usize);
                            }
                        }
                        _ => {
                            filters.clear();
                            filters.extend((0..aabbs.len()).map(f));
                        }
                    }
                    debug_assert!((0..aabbs.len()).all(|i| filters[i] == f(i)));
                    if any_pair_may_touch(&filters) {
                        let can =
                            |a: u32, b: u32| filters[a as usize].collides(&filters[b as usize]);
                        self.find_pairs_sized(&fat, &fat_moves, &fat_moves, &still, can, pool);
                    } else {
                        // no two of the filters let their bodies touch (a grid whose
                        // bodies share a negative group): there is no pair to find
                        self.pairs.clear();
                        self.no_pair_by_filters = true;
                    }
                }
                None => {
                    filters.clear();
                    self.find_pairs_sized(&fat, &fat_moves, &fat_moves, &still, |_, _| true, pool);
                }
            }
            self.still_bounds = still;
            self.kept_filters = filters;
            // copied, not swapped: `pairs`, which the grid just filled, holds at least as
            // many as the filter below keeps, so neither buffer grows in a steady run
            self.kept_pairs.clear();
            self.kept_pairs.extend_from_slice(&self.pairs);
            (self.kept_boxes, self.kept_moves) = (fat, fat_moves);
            self.rebuilds += 1;
        }
        self.pairs.clear();
    }

    /// [`BroadPhase::refresh_kept`]'s update of the kept boxes and pairs when only some
    /// bodies (at most one in [`SOME_SHARE`]) have left their kept boxes (or changed
    /// whether they may move, or their filter): their boxes are kept anew and their
    /// pairs found again, their old pairs taken out; every other pair stands, its two
    /// boxes unchanged. Up to [`ONE_BY_ONE`] of them, each is looked up against the kept
    /// boxes of the blocks its box reaches (`kept_bounds`), for its old pairs and its new
    /// ones; more, their old pairs are those of the kept list with one of them, and their
    /// new ones are found through a grid of their boxes ([`pairs_of_some`]).
    /// The kept pairs are then every pair of kept boxes (that the filters let touch),
    /// sorted, as after a rebuild, and this step's pairs the same. `listed`: the bodies
    /// that left, in increasing order (as [`Left::These`]). Returns
    /// false where a rebuild is due (more bodies left, the body count changed, the
    /// filters refused every pair, or the bodies that left are spread too thin for
    /// their grid); it then changes nothing the rebuild does not set afresh.
    fn refresh_some(
        &mut self,
        aabbs: &[Aabb],
        listed: &[u32],
        may_move: &impl Fn(usize) -> bool,
        filter_of: Option<&dyn Fn(usize) -> Filter>,
        pool: Option<&Pool>,
    ) -> bool {
        let n = aabbs.len();
        let most = ONE_BY_ONE.max(self.kept_movers / SOME_SHARE);
        if self.kept_boxes.len() != n || self.no_pair_by_filters || listed.len() > most {
            return false;
        }
        let filter = |i: usize| filter_of.map_or(Filter::default(), |f| f(i));
        let filtered = !self.kept_filters.is_empty();
        debug_assert!(
            listed.windows(2).all(|w| w[0] < w[1])
                && (0..n)
                    .filter(|&i| {
                        !(self.kept_holds(i, &aabbs[i], may_move(i))
                            && self.kept_filter_holds(i, &filter(i)))
                    })
                    .eq(listed.iter().map(|&i| i as usize)),
            "the bodies listed as left are those that left, in order"
        );
        // more than a few: their pairs through a grid of their boxes
        let some = listed.len() > ONE_BY_ONE;
        self.redo.resize(n, false);
        for &i in listed {
            self.redo[i as usize] = true;
        }
        let Self {
            kept_boxes,
            kept_moves,
            kept_movers,
            kept_filters,
            kept_bounds,
            kept_pairs,
            redo,
            gone,
            pairs,
            pairs_tmp,
            some_grid,
            ..
        } = self;
        // as a rebuild's grid: one of the two may move, and their filters let them touch
        let touch = |moves: &[bool], filters: &[Filter], a: u32, b: u32| {
            let (a, b) = (a as usize, b as usize);
            (moves[a] || moves[b]) && (!filtered || filters[a].collides(&filters[b]))
        };
        // the few's pairs among the kept boxes as they stand, sorted: each of their kept
        // boxes against every kept box, passing over the blocks whose bounds it misses
        let marked = &*redo;
        let pairs_of = |boxes: &[Aabb],
                        moves: &[bool],
                        filters: &[Filter],
                        bounds: &[Option<Aabb>],
                        out: &mut Vec<Pair>| {
            out.clear();
            let accept = |a, b| touch(moves, filters, a, b);
            pairs_of_few(boxes, listed, marked, bounds, &accept, out);
            out.sort_unstable();
        };
        // their pairs as kept (every kept pair with one of them), then their new ones
        let with_some = |&&(a, b): &&Pair| marked[a as usize] || marked[b as usize];
        if some {
            gone.clear();
            gone.extend(kept_pairs.iter().filter(with_some));
        } else {
            pairs_of(kept_boxes, kept_moves, kept_filters, kept_bounds, gone);
            debug_assert!(
                kept_pairs.iter().filter(with_some).eq(gone.iter()),
                "the few's kept pairs are the pairs of their kept boxes"
            );
        }
        for &i in listed {
            let i = i as usize;
            let fat = kept_box(&aabbs[i]);
            kept_boxes[i] = fat;
            let moves = may_move(i);
            if moves != kept_moves[i] {
                *kept_movers = if moves {
                    *kept_movers + 1
                } else {
                    *kept_movers - 1
                };
            }
            kept_moves[i] = moves;
            if filtered {
                kept_filters[i] = filter(i);
            }
            // (a block's bounds grow to hold its new box)
            let bound = &mut kept_bounds[i / AWAKE_BLOCK];
            *bound = Some(bound.map_or(fat, |b| b.union(&fat)));
        }
        let found = if some {
            let accept = |a, b| touch(kept_moves, kept_filters, a, b);
            let found = pairs_of_some(
                kept_boxes,
                listed,
                marked,
                kept_bounds,
                &accept,
                some_grid,
                pairs,
                pool,
            );
            pairs.sort_unstable();
            found
        } else {
            pairs_of(kept_boxes, kept_moves, kept_filters, kept_bounds, pairs);
            true
        };
        for &i in listed {
            redo[i as usize] = false;
        }
        if !found {
            // (the rebuild sets every kept box, pair and bound afresh)
            return false;
        }
        splice_sorted(kept_pairs, gone, pairs, pairs_tmp);
        self.updates += 1;
        true
    }

    /// Every pair of kept boxes, sorted: this step's pairs are those among them for
    /// which [`BroadPhase::kept_pair_holds`] (and the caller's own test) holds.
    pub fn kept_pairs(&self) -> &[Pair] {
        &self.kept_pairs
    }

    /// Whether kept pair (a, b) is a pair this step: one of the bodies moves and their
    /// boxes overlap.
    #[inline]
    pub fn kept_pair_holds(aabbs: &[Aabb], moves: &[bool], a: u32, b: u32) -> bool {
        let (ia, ib) = (a as usize, b as usize);
        (moves[ia] || moves[ib]) && aabbs[ia].overlaps(&aabbs[ib])
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

/// Takes the pairs of `gone` out of `list` and puts those of `added` in, all three
/// sorted (`gone` a part of `list`; a pair may go and come back), `list` staying sorted.
/// Only the span of `list` from the first edit to the last is merged again, its runs
/// between two edits copied whole (`scratch` holds the merged span); the pairs after
/// it move only where the count changes.
fn splice_sorted(list: &mut Vec<Pair>, gone: &[Pair], added: &[Pair], scratch: &mut Vec<Pair>) {
    let first = gone.first().into_iter().chain(added.first()).min();
    let last = gone.last().into_iter().chain(added.last()).max();
    let (Some(&first), Some(&last)) = (first, last) else {
        return;
    };
    let lo = list.partition_point(|p| *p < first);
    let hi = lo + list[lo..].partition_point(|p| *p <= last);
    let span = &list[lo..hi];
    scratch.clear();
    let (mut at, mut g, mut a) = (0, 0, 0);
    loop {
        let edit = match (gone.get(g), added.get(a)) {
            (None, None) => break,
            (Some(&x), None) | (None, Some(&x)) => x,
            (Some(&x), Some(&y)) => x.min(y),
        };
        let to = at + gallop(&span[at..], |p| *p < edit);
        scratch.extend_from_slice(&span[at..to]);
        at = to;
        if gone.get(g) == Some(&edit) {
            debug_assert_eq!(span.get(at), Some(&edit), "a gone pair is in the list");
            at += 1;
            g += 1;
        }
        if added.get(a) == Some(&edit) {
            scratch.push(edit);
            a += 1;
        }
    }
    scratch.extend_from_slice(&span[at..]);
    list.splice(lo..hi, scratch.iter().copied());
}

/// Every pair of overlapping boxes with a body of `few` (listed in increasing order,
/// each with its `marked` entry set) where `accept` holds, into `out` (a < b, in no
/// particular order): each of them against every box, the pairs of two of them once.
/// A pair with no moving body (`marked` is `moves`) or of two unmarked bodies is never
/// reported. `blocks`, per awake block of boxes (empty, or shorter, for none): where
/// `Some`, bounds holding each box of the block; a block whose bounds a body's box
/// misses is passed over for that body.
fn pairs_of_few(
    aabbs: &[Aabb],
    few: &[u32],
    marked: &[bool],
    blocks: &[Option<Aabb>],
    accept: &impl Fn(u32, u32) -> bool,
    out: &mut Vec<Pair>,
) {
    let n = aabbs.len();
    for &i in few {
        let bi = aabbs[i as usize];
        let mut start = 0;
        while start < n {
            let (block, end) = if blocks.is_empty() {
                (None, n)
            } else {
                let end = (start + AWAKE_BLOCK).min(n);
                (blocks.get(start / AWAKE_BLOCK).copied().flatten(), end)
            };
            let run = start..end;
            start = end;
            if let Some(bounds) = block
                && !bi.overlaps(&bounds)
            {
                debug_assert!(
                    run.clone().all(|j| !bi.overlaps(&aabbs[j])),
                    "a block's bounds hold its boxes"
                );
                continue;
            }
            for (j, bj) in run.clone().zip(&aabbs[run]) {
                // a pair of two of the few is reported from its lower body
                if (marked[j] && j <= i as usize) || !bi.overlaps(bj) {
                    continue;
                }
                let j = j as u32;
                let p = if i < j { (i, j) } else { (j, i) };
                if accept(p.0, p.1) {
                    out.push(p);
                }
            }
        }
    }
}

/// The grid of [`pairs_of_some`]: where each cell's bodies start in `bodies` (a
/// counting sort), the cells each body in it covers, the bodies too large for it, and
/// the extents of the boxes.
#[derive(Clone, Default, Debug)]
struct SomeGrid {
    start: Vec<u32>,
    bodies: Vec<u32>,
    ranges: Vec<(u32, [i64; 4])>,
    large: Vec<u32>,
    sizes: Vec<f32>,
    /// The pairs each block of the threads' pass over the boxes found.
    outs: BlockScratch<Pair>,
}

/// Entries of the grid's cells (a body in each cell it covers) from which the threads
/// share the cells' pair tests (about 1,000 bodies: below it, the pass costs less than
/// sharing it).
const PARALLEL_CELL_ENTRIES: usize = 4096;

/// Pairs from which the threads share their sort.
const PARALLEL_SORT_PAIRS: usize = 8192;

/// Runs of the grid's cells a thread tests, on average, where the threads share them.
const RUNS_PER_THREAD: usize = 4;

/// Awake blocks of bodies a thread takes at a time in [`pairs_of_some`]'s pass over
/// the boxes (512 bodies).
const SCAN_BLOCKS: usize = 8;

/// [`pairs_of_few`] for more bodies (`some`, in increasing order, each with its `marked`
/// entry set): the same pairs, but found through a grid of their boxes, into which every
/// other box looks (passing over the blocks whose `blocks` bounds miss all of theirs),
/// a pass over the boxes rather than a pass for each of them. The boxes of `some` too
/// large for the grid are tested against every box. Returns false, with `out` left
/// as it may be, when their boxes are spread too thin for a dense grid (then a grid of
/// every box costs less). With a pool, the threads share the pass over the boxes, and
/// `out` holds the same pairs in another order.
#[allow(clippy::too_many_arguments)]
fn pairs_of_some(
    aabbs: &[Aabb],
    some: &[u32],
    marked: &[bool],
    blocks: &[Option<Aabb>],
    accept: &(impl Fn(u32, u32) -> bool + Sync),
    grid: &mut SomeGrid,
    out: &mut Vec<Pair>,
    pool: Option<&Pool>,
) -> bool {
    out.clear();
    let Some(&first) = some.first() else {
        return true;
    };
    let SomeGrid {
        start,
        bodies,
        ranges,
        large,
        sizes,
        outs,
    } = grid;
    sizes.clear();
    sizes.extend(some.iter().map(|&i| {
        let b = &aabbs[i as usize];
        (b.max - b.min).max_element()
    }));
    let inv = 1.0 / cell_size(sizes);
    let cells = |b: &Aabb| {
        let (x0, y0) = (floor_i64(b.min.x * inv), floor_i64(b.min.y * inv));
        let (x1, y1) = (floor_i64(b.max.x * inv), floor_i64(b.max.y * inv));
        let small = x1 - x0 < MAX_CELLS_PER_AXIS
            && y1 - y0 < MAX_CELLS_PER_AXIS
            && b.min.is_finite()
            && b.max.is_finite();
        small.then_some([x0, y0, x1, y1])
    };
    // each one's cells, the grid's bounds, and a box holding every box of `some`
    ranges.clear();
    large.clear();
    let mut reach = aabbs[first as usize];
    let (mut gx0, mut gy0, mut gx1, mut gy1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for &i in some {
        let b = &aabbs[i as usize];
        reach = reach.union(b);
        match cells(b) {
            Some(r @ [x0, y0, x1, y1]) => {
                ranges.push((i, r));
                (gx0, gy0, gx1, gy1) = (gx0.min(x0), gy0.min(y0), gx1.max(x1), gy1.max(y1));
            }
            None => large.push(i),
        }
    }
    let (w, h) = if ranges.is_empty() {
        (0, 0)
    } else {
        ((gx1 - gx0 + 1) as usize, (gy1 - gy0 + 1) as usize)
    };
    if w.saturating_mul(h) > (8 * ranges.len()).max(1 << 16) {
        return false;
    }
    // the counting sort: a cell's bodies in increasing order
    let cell_of = |ix: i64, iy: i64| (iy - gy0) as usize * w + (ix - gx0) as usize;
    start.clear();
    start.resize(w * h + 1, 0);
    let each_cell = |[x0, y0, x1, y1]: [i64; 4], f: &mut dyn FnMut(usize)| {
        for iy in y0..=y1 {
            for ix in x0..=x1 {
                f(cell_of(ix, iy));
            }
        }
    };
    for &(_, r) in ranges.iter() {
        each_cell(r, &mut |c| start[c + 1] += 1);
    }
    for c in 1..start.len() {
        start[c] += start[c - 1];
    }
    bodies.clear();
    bodies.resize(start[w * h] as usize, 0);
    for &(i, r) in ranges.iter() {
        // (start[c] runs over c's slots, ending at c + 1's first)
        each_cell(r, &mut |c| {
            bodies[start[c] as usize] = i;
            start[c] += 1;
        });
    }
    // back to where each cell starts
    for c in (1..start.len()).rev() {
        start[c] = start[c - 1];
    }
    start[0] = 0;
    let (start, bodies, ranges, large) = (&*start, &*bodies, &*ranges, &*large);
    // the pairs found looking from the boxes of some awake blocks
    let scan = |awake_blocks: Range<usize>, out: &mut Vec<Pair>| {
        // a pair with one of `some` is reported while looking from its other body, a
        // pair of two of them (both in the grid, or both too large for it) from the
        // lower one
        let mut report = |j: u32, i: u32| {
            let p = if i < j { (i, j) } else { (j, i) };
            if accept(p.0, p.1) {
                out.push(p);
            }
        };
        let n = aabbs.len();
        for k in awake_blocks {
            let from = k * AWAKE_BLOCK;
            if blocks
                .get(k)
                .copied()
                .flatten()
                .is_some_and(|b| !b.overlaps(&reach))
            {
                continue;
            }
            for j in from..(from + AWAKE_BLOCK).min(n) {
                let bj = &aabbs[j];
                if !bj.overlaps(&reach) {
                    continue;
                }
                let (j, j_marked, j_cells) = (j as u32, marked[j], cells(bj));
                // (one of them too large for the grid is one of `large`)
                let j_large = j_marked && j_cells.is_none();
                for &i in large.iter() {
                    if i != j && !(j_large && i < j) && bj.overlaps(&aabbs[i as usize]) {
                        report(j, i);
                    }
                }
                if ranges.is_empty() || j_large {
                    continue;
                }
                let Some([x0, y0, x1, y1]) = j_cells else {
                    // a large box not among them (a ground): against each in the grid
                    for &(i, _) in ranges.iter() {
                        if bj.overlaps(&aabbs[i as usize]) {
                            report(j, i);
                        }
                    }
                    continue;
                };
                // the cells of the grid the box covers
                let (x0, y0) = (x0.max(gx0), y0.max(gy0));
                let (x1, y1) = (x1.min(gx1), y1.min(gy1));
                for iy in y0..=y1 {
                    for ix in x0..=x1 {
                        let c = cell_of(ix, iy);
                        for &i in &bodies[start[c] as usize..start[c + 1] as usize] {
                            let bi = &aabbs[i as usize];
                            if (j_marked && i <= j) || !bj.overlaps(bi) {
                                continue;
                            }
                            // once: from the cell holding the overlap's lower-left corner
                            let corner = bj.min.max(bi.min);
                            if (floor_i64(corner.x * inv), floor_i64(corner.y * inv)) == (ix, iy) {
                                report(j, i);
                            }
                        }
                    }
                }
            }
        }
    };
    let awake_blocks = aabbs.len().div_ceil(AWAKE_BLOCK);
    match pool {
        Some(pool) if pool.threads() > 1 && awake_blocks > SCAN_BLOCKS => {
            let jobs = awake_blocks.div_ceil(SCAN_BLOCKS);
            let outs = outs.first(jobs, 0);
            parallel::ranges_max(Some(pool), awake_blocks, SCAN_BLOCKS, &|_, r| {
                let mut found = outs[r.start / SCAN_BLOCKS]
                    .lock()
                    .unwrap_or_else(|e| e.into_inner());
                found.clear();
                scan(r, &mut found);
                0.0
            });
            for found in outs.iter_mut() {
                out.extend_from_slice(found.get_mut().unwrap_or_else(|e| e.into_inner()));
            }
        }
        _ => scan(0..awake_blocks, out),
    }
    true
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_i64_is_the_clamped_floor() {
        const LIMIT: f64 = (1u64 << 40) as f64;
        let reference = |x: f32| -> i64 {
            if x.is_nan() {
                0
            } else {
                (x as f64).floor().clamp(-LIMIT, LIMIT) as i64
            }
        };
        let mut cases = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            1.5,
            -1.5,
            2.999_999_8,
            -2.999_999_8,
            1e10,
            -1e10,
            1.1e12,
            -1.1e12,
            1e30,
            -1e30,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            8_388_607.5,
            -8_388_607.5,
            16_777_217.0,
        ];
        // and a spread of bit patterns
        let mut bits = 0x1234_5678u32;
        for _ in 0..100_000 {
            bits = bits.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            cases.push(f32::from_bits(bits));
        }
        for x in cases {
            assert_eq!(floor_i64(x), reference(x), "floor of {x:e}");
        }
    }

    fn aabb(x0: f32, y0: f32, x1: f32, y1: f32) -> Aabb {
        Aabb {
            min: Vec2::new(x0, y0),
            max: Vec2::new(x1, y1),
        }
    }

    #[test]
    fn matches_all_pairs() {
        // A deterministic scatter of boxes of mixed sizes, plus one huge one.
        let mut boxes = vec![aabb(-100.0, -2.0, 100.0, 0.0)];
        let mut rnd = unit(lcg(12345));
        for _ in 0..300 {
            let x = rnd() * 40.0 - 20.0;
            let y = rnd() * 20.0 - 3.0;
            let s = 0.2 + rnd() * 2.0;
            boxes.push(aabb(x, y, x + s, y + s * rnd()));
        }
        // two more large boxes, moving, that overlap each other, the ground and many
        // small ones: each large-large pair is found once
        boxes.push(aabb(-30.0, -1.0, 30.0, 1.0));
        boxes.push(aabb(-10.0, -5.0, 10.0, 25.0));
        let moves: Vec<bool> = (0..boxes.len()).map(|i| i != 0).collect();
        let mut bp = BroadPhase::default();
        bp.find_pairs(&boxes, &moves, |_, _| true);
        let mut brute = Vec::new();
        for a in 0..boxes.len() {
            for b in a + 1..boxes.len() {
                if (moves[a] || moves[b]) && boxes[a].overlaps(&boxes[b]) {
                    brute.push((a as u32, b as u32));
                }
            }
        }
        assert!(brute.contains(&(301, 302)) && brute.contains(&(0, 301)));
        assert_eq!(bp.pairs, brute);
    }

    #[test]
    fn sparse_grid_matches_all_pairs() {
        // two clusters far apart: too many cells for the dense grid, so entries are sorted
        let mut boxes = Vec::new();
        for k in 0..40 {
            let x = (k % 8) as f32 * 0.7 + if k < 20 { 0.0 } else { 1.0e5 };
            let y = (k / 8) as f32 * 0.7;
            boxes.push(aabb(x, y, x + 1.0, y + 1.0));
        }
        let moves = vec![true; boxes.len()];
        let mut bp = BroadPhase::default();
        bp.find_pairs(&boxes, &moves, |_, _| true);
        let mut brute = Vec::new();
        for a in 0..boxes.len() {
            for b in a + 1..boxes.len() {
                if boxes[a].overlaps(&boxes[b]) {
                    brute.push((a as u32, b as u32));
                }
            }
        }
        assert!(!brute.is_empty());
        assert_eq!(bp.pairs, brute);
    }

    /// A ground, then `count` boxes in rows of `columns` at 1.1 m, each `smallest` to
    /// 1.25 m wide: a heap packed closely enough to touch.
    fn ground_and_heap(
        rnd: &mut impl FnMut() -> f32,
        count: usize,
        columns: usize,
        smallest: f32,
    ) -> Vec<Aabb> {
        let mut boxes = vec![aabb(-60.0, -2.0, 60.0, 0.0)];
        for k in 0..count {
            let (x, y) = (
                (k % columns) as f32 * 1.1 - 22.0,
                (k / columns) as f32 * 1.1,
            );
            let s = smallest + rnd() * (1.25 - smallest);
            boxes.push(aabb(x, y, x + s, y + s));
        }
        boxes
    }

    /// One step of the kept pairs against pairs found afresh: the same list, not
    /// empty, under a filter that changes every 50 steps.
    fn kept_against_fresh(
        kept: &mut BroadPhase,
        fresh: &mut BroadPhase,
        boxes: &[Aabb],
        moves: &[bool],
        may_move: &[bool],
        step: u32,
    ) {
        let phase = step / 50;
        let can = |a: u32, b: u32| !(a + b + phase).is_multiple_of(7);
        kept.find_pairs_kept(boxes, moves, |i| may_move[i], can);
        fresh.find_pairs(boxes, moves, can);
        assert!(!fresh.pairs.is_empty());
        assert_eq!(kept.pairs, fresh.pairs, "step {step}");
    }

    #[test]
    fn kept_pairs_are_the_pairs_found_afresh_every_step() {
        let mut rnd = unit(lcg(777));
        let mut boxes = ground_and_heap(&mut rnd, 400, 40, 0.05);
        let n = boxes.len();
        let mut may_move: Vec<bool> = (0..n).map(|i| i != 0).collect();
        let mut moves = may_move.clone();
        let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
        let steps = 300u32;
        for step in 0..steps {
            // small motions every step, now and then a jump, a body falling asleep or
            // waking, a body becoming static or dynamic
            for b in boxes.iter_mut().skip(1) {
                let d = Vec2::new(rnd() - 0.5, rnd() - 0.5) * 0.004;
                (b.min, b.max) = (b.min + d, b.max + d);
            }
            if step % 23 == 5 {
                let i = 1 + (rnd() * (n - 1) as f32) as usize % (n - 1);
                let d = Vec2::new(rnd() - 0.5, rnd() - 0.5) * 3.0;
                (boxes[i].min, boxes[i].max) = (boxes[i].min + d, boxes[i].max + d);
            }
            if step % 17 == 3 {
                let i = 1 + (rnd() * (n - 1) as f32) as usize % (n - 1);
                moves[i] = may_move[i] && !moves[i];
            }
            if step % 61 == 11 {
                let i = 1 + (rnd() * (n - 1) as f32) as usize % (n - 1);
                may_move[i] = !may_move[i];
                moves[i] = may_move[i];
            }
            kept_against_fresh(&mut kept, &mut fresh, &boxes, &moves, &may_move, step);
        }
        // the kept pairs were used (most steps move nothing out of its fattened box) and
        // renewed, body by body (the drift, the jumps and the changes of who may move
        // take a few bodies out of their kept boxes at a time)
        assert!(
            kept.updates > 5 && kept.rebuilds + kept.updates < u64::from(steps / 3),
            "{} rebuilds, {} updates",
            kept.rebuilds,
            kept.updates
        );
    }

    #[test]
    fn sleepers_keep_no_pairs_among_themselves_and_far_ones_stay_out_of_the_grid() {
        let mut rnd = unit(lcg(4242));
        // a ground, a heap of 300 bodies that move, and far off 640 sleepers in ten whole
        // blocks, packed so that each touches its neighbours
        let mut boxes = ground_and_heap(&mut rnd, 300, 30, 0.3);
        let far = boxes.len().next_multiple_of(AWAKE_BLOCK);
        while boxes.len() < far {
            let x = boxes.len() as f32 * 2.0;
            boxes.push(aabb(x, 50.0, x + 0.5, 50.5));
        }
        for k in 0..10 * AWAKE_BLOCK {
            let (x, y) = (1000.0 + (k % 32) as f32 * 0.9, (k / 32) as f32 * 0.9);
            boxes.push(aabb(x, y, x + 1.0, y + 1.0));
        }
        let n = boxes.len();
        // as the world has it: a body may move exactly while it is awake and dynamic
        let mut moves: Vec<bool> = (0..n).map(|i| i != 0 && i < far).collect();
        let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
        let steps = 400u32;
        let pick = |r: f32, lo: usize, hi: usize| lo + (r * (hi - lo) as f32) as usize % (hi - lo);
        // the far sleepers woken at some step
        let mut woken = Vec::new();
        for step in 0..steps {
            // the heap jostles; every 9th step most of it leaves its kept boxes (a rebuild)
            let jump = if step % 9 == 4 { 0.5 } else { 0.004 };
            for (b, _) in boxes.iter_mut().zip(&moves).filter(|(_, m)| **m) {
                let d = Vec2::new(rnd() - 0.5, rnd() - 0.5) * jump;
                (b.min, b.max) = (b.min + d, b.max + d);
            }
            // a body of the heap falls asleep or wakes; a far sleeper of the first far
            // block wakes, jostles, and may fall asleep again some steps later
            if step % 7 == 2 {
                let i = pick(rnd(), 1, 301);
                moves[i] = !moves[i];
            }
            if step % 13 == 6 {
                let i = pick(rnd(), far, far + AWAKE_BLOCK);
                moves[i] = !moves[i];
                woken.push(i);
            }
            kept_against_fresh(&mut kept, &mut fresh, &boxes, &moves, &moves, step);
            // a pair of two bodies kept as still ones is never kept
            assert!(
                kept.kept_pairs()
                    .iter()
                    .all(|&(a, b)| kept.kept_moves[a as usize] || kept.kept_moves[b as usize]),
                "step {step}"
            );
        }
        assert!(kept.rebuilds > 20, "{} rebuilds", kept.rebuilds);
        // the far sleepers kept no pair among themselves but those of the few ever woken
        // (each touches at most eight): not the 2,400 of all their touching neighbours
        woken.sort_unstable();
        woken.dedup();
        let far_pairs = kept
            .kept_pairs()
            .iter()
            .filter(|&&(a, _)| a as usize >= far)
            .count();
        assert!(
            far_pairs <= 8 * woken.len() && woken.len() < 40,
            "{far_pairs} pairs among the far sleepers, {} woken",
            woken.len()
        );
        // a rebuild's grid left the far blocks out: its last one held the heap's boxes
        // and the ground's, and at most the first two far blocks (the woken ones' and
        // the next, which their boxes may reach)
        assert!(kept.ranges.len() + kept.large.len() <= far + 2 * AWAKE_BLOCK);
        assert!(kept.left_out[far / AWAKE_BLOCK + 2..].iter().all(|&o| o));
    }

    #[test]
    fn filters_that_let_no_two_bodies_touch_are_seen_as_such() {
        let group = |g: i32| Filter {
            group: g,
            ..Filter::default()
        };
        let only = |category: u32, mask: u32| Filter {
            category,
            mask,
            ..Filter::default()
        };
        // one negative group: nothing; a body outside it touches them
        assert!(!any_pair_may_touch(&[group(-1); 5]));
        assert!(any_pair_may_touch(&[
            group(-1),
            group(-1),
            Filter::default()
        ]));
        // one default body alone touches nothing; two do
        assert!(!any_pair_may_touch(&[Filter::default()]));
        assert!(any_pair_may_touch(&[Filter::default(); 2]));
        // categories that leave each other out, and one that takes the other in
        assert!(!any_pair_may_touch(&[only(1, 2), only(4, 8), only(4, 8)]));
        assert!(!any_pair_may_touch(&[only(1, 2), only(2, 2)]));
        assert!(any_pair_may_touch(&[only(1, 2), only(2, 1)]));
        // a positive group always touches itself
        assert!(any_pair_may_touch(&[group(3), group(3)]));
        // many distinct filters: the grid decides
        let many: Vec<Filter> = (1..=12).map(|k| only(1 << k, 0)).collect();
        assert!(any_pair_may_touch(&many));
    }

    /// Bodies whose filters keep them apart cost no kept pairs however much their boxes
    /// overlap, and a filter changed between steps still gives the pairs found afresh.
    #[test]
    fn kept_pairs_leave_out_what_the_filters_refuse() {
        // a category that touches none
        let apart = Filter {
            category: 2,
            mask: 0,
            group: 0,
        };
        // 30 x 30 large boxes, every one overlapping every other
        let boxes: Vec<Aabb> = (0..900)
            .map(|k| {
                let (x, y) = ((k % 30) as f32 * 0.1, (k / 30) as f32 * 0.1);
                aabb(x, y, x + 100.0, y + 100.0)
            })
            .collect();
        let n = boxes.len();
        let moves = vec![true; n];
        let mut filters = vec![apart; n];
        let mut bp = BroadPhase::default();
        let step = |bp: &mut BroadPhase, filters: &[Filter]| {
            let left = left_of(bp, &boxes, &moves, filters);
            step_filtered(bp, &boxes, &moves, &left, filters, None);
        };
        step(&mut bp, &filters);
        assert!(bp.pairs.is_empty());
        assert!(
            bp.kept_pairs().is_empty(),
            "{} pairs kept that can never touch",
            bp.kept_pairs().len()
        );
        // two bodies that touch each other only: their pair is found, as afresh
        let pair = Filter {
            category: 4,
            mask: 4,
            group: 0,
        };
        (filters[10], filters[500]) = (pair, pair);
        step(&mut bp, &filters);
        assert_eq!(bp.pairs.len(), 1);
        assert_eq!(bp.pairs, vec![(10, 500)]);
        assert_eq!(bp.kept_pairs(), &[(10, 500)]);
        assert_eq!(bp.rebuilds, 2);
        // unfiltered, every pair of boxes is kept
        let mut all = BroadPhase::default();
        all.refresh_kept(&boxes, Left::All, |_| true, None, None);
        assert_eq!(all.kept_pairs().len(), n * (n - 1) / 2);
    }

    /// The bodies whose kept box or filter no longer holds, as the collide's pass lists
    /// them (`None` before the first rebuild: every body). [`Left`] of it by [`as_left`].
    fn left_of(
        bp: &BroadPhase,
        boxes: &[Aabb],
        moves: &[bool],
        filters: &[Filter],
    ) -> Option<Vec<u32>> {
        let n = boxes.len();
        (bp.kept_count() == n).then(|| {
            (0..n)
                .filter(|&i| leaves(bp, boxes, moves, filters, i))
                .map(|i| i as u32)
                .collect()
        })
    }

    /// One step of `bp`'s kept pairs under `filters`, the bodies that left as `left`
    /// lists them, with `moves` as whether each may move.
    fn step_filtered(
        bp: &mut BroadPhase,
        boxes: &[Aabb],
        moves: &[bool],
        left: &Option<Vec<u32>>,
        filters: &[Filter],
        pool: Option<&Pool>,
    ) {
        let of = |i: usize| filters[i];
        bp.find_pairs_kept_checked(
            boxes,
            moves,
            as_left(left),
            |i| moves[i],
            Some(&of),
            |a, b| filters[a as usize].collides(&filters[b as usize]),
            pool,
        );
    }

    fn as_left(listed: &Option<Vec<u32>>) -> Left<'_> {
        listed.as_deref().map_or(Left::All, Left::These)
    }

    /// Whether body `i` left its kept box (or changed whether it moves, or its filter).
    fn leaves(
        bp: &BroadPhase,
        boxes: &[Aabb],
        moves: &[bool],
        filters: &[Filter],
        i: usize,
    ) -> bool {
        !(bp.kept_holds(i, &boxes[i], moves[i]) && bp.kept_filter_holds(i, &filters[i]))
    }

    /// One of three filters by `k`: the third touches only the first.
    fn three_filters(k: usize) -> Filter {
        Filter {
            category: 1 << (k % 3),
            mask: if k % 3 == 2 { 1 } else { 0xffff },
            group: 0,
        }
    }

    /// A fixed scramble of numbers from `seed` (a linear congruential generator).
    fn lcg(mut seed: u32) -> impl FnMut() -> usize {
        move || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as usize
        }
    }

    /// The numbers of `next` (below 2^24, as [`lcg`]'s) scaled into [0, 1).
    fn unit(mut next: impl FnMut() -> usize) -> impl FnMut() -> f32 {
        move || next() as f32 / (1u32 << 24) as f32
    }

    /// Boxes scattered over a 40 x 20 m field, mixed sizes, one of them huge.
    fn scatter(seed: u32, count: usize) -> Vec<Aabb> {
        let mut rnd = unit(lcg(seed));
        let mut boxes = vec![aabb(-100.0, -2.0, 100.0, 0.0)];
        for _ in 0..count {
            let (x, y, s) = (rnd() * 40.0 - 20.0, rnd() * 20.0 - 3.0, 0.2 + rnd() * 2.0);
            boxes.push(aabb(x, y, x + s, y + s * rnd()));
        }
        boxes
    }

    #[test]
    fn threads_sharing_the_grid_and_the_sort_find_the_pairs_of_a_brute_force_scan() {
        // enough boxes, crowded enough, for the threads to share the cells' tests and
        // the pairs' sort; every third box still, some pairs refused
        let boxes = scatter(777, 3000);
        let n = boxes.len();
        let moves: Vec<bool> = (0..n).map(|i| !i.is_multiple_of(3)).collect();
        let can = |a: u32, b: u32| !(a + 3 * b).is_multiple_of(7);
        let mut brute = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                if (moves[a] || moves[b]) && boxes[a].overlaps(&boxes[b]) && can(a as u32, b as u32)
                {
                    brute.push((a as u32, b as u32));
                }
            }
        }
        let mut one = BroadPhase::default();
        one.find_pairs_sized(&boxes, &moves, &moves, &[], can, None);
        assert_eq!(one.pairs, brute, "one thread");
        assert!(
            one.pairs.len() >= PARALLEL_SORT_PAIRS,
            "{} pairs",
            one.pairs.len()
        );
        assert!(one.cell_bodies.len() >= PARALLEL_CELL_ENTRIES);
        for threads in [2, 3] {
            let pool = Pool::new(threads);
            let mut shared = BroadPhase::default();
            // twice: the second time on the buffers the first left
            for _ in 0..2 {
                shared.find_pairs_sized(&boxes, &moves, &moves, &[], can, Some(&pool));
                assert_eq!(shared.pairs, brute, "{threads} threads");
            }
        }
    }

    #[test]
    fn a_crowded_cell_and_boxes_that_only_touch_give_the_pairs_of_a_brute_force_scan() {
        // 300 unit boxes on a 0.25 m lattice: each cell holds far more than the 64 boxes
        // one body is tested against at a time, and many boxes meet only along an edge
        // or at a corner (which counts as overlapping); 60 small boxes spread around
        // them, every fourth box still
        let mut rnd = unit(lcg(99));
        let mut boxes = Vec::new();
        for k in 0..300 {
            let (x, y) = ((k % 20) as f32 * 0.25, (k / 20) as f32 * 0.25);
            boxes.push(aabb(x, y, x + 1.0, y + 1.0));
        }
        for _ in 0..60 {
            let (x, y) = (rnd() * 8.0 - 2.0, rnd() * 8.0 - 2.0);
            boxes.push(aabb(x, y, x + 0.1, y + 0.1));
        }
        let n = boxes.len();
        let moves: Vec<bool> = (0..n).map(|i| !i.is_multiple_of(4)).collect();
        let mut brute = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                if (moves[a] || moves[b]) && boxes[a].overlaps(&boxes[b]) {
                    brute.push((a as u32, b as u32));
                }
            }
        }
        let mut one = BroadPhase::default();
        one.find_pairs(&boxes, &moves, |_, _| true);
        assert_eq!(one.pairs, brute, "one thread");
        let cells = one.cell_start.windows(2).map(|w| w[1] - w[0]);
        assert!(
            cells.max().unwrap_or(0) > 2 * 64,
            "a cell holds over 128 boxes"
        );
        let touching = |a: &Aabb, b: &Aabb| a.max.x == b.min.x || a.max.y == b.min.y;
        assert!(
            brute
                .iter()
                .any(|&(a, b)| touching(&boxes[a as usize], &boxes[b as usize])),
            "some pairs only touch"
        );
        let pool = Pool::new(2);
        let mut shared = BroadPhase::default();
        shared.find_pairs_sized(&boxes, &moves, &moves, &[], |_, _| true, Some(&pool));
        assert_eq!(shared.pairs, brute, "two threads");
    }

    #[test]
    fn a_few_movers_find_the_pairs_of_a_brute_force_scan() {
        let boxes = scatter(4242, 400);
        let n = boxes.len();
        // movers: none, the huge box, a handful, as many as are looked up one by one,
        // and one more (the grid's side of the line)
        for count in [0, 1, 7, ONE_BY_ONE, ONE_BY_ONE + 1] {
            let mut moves = vec![false; n];
            for k in 0..count {
                moves[(k * 37) % n] = true;
            }
            let can = |a: u32, b: u32| !(a + 2 * b).is_multiple_of(5);
            let mut bp = BroadPhase::default();
            bp.find_pairs(&boxes, &moves, can);
            let mut brute = Vec::new();
            for a in 0..n {
                for b in a + 1..n {
                    if (moves[a] || moves[b])
                        && boxes[a].overlaps(&boxes[b])
                        && can(a as u32, b as u32)
                    {
                        brute.push((a as u32, b as u32));
                    }
                }
            }
            assert!(count < 2 || !brute.is_empty(), "{count} movers");
            assert_eq!(bp.pairs, brute, "{count} movers");
        }
    }

    #[test]
    fn a_few_movers_pass_over_the_blocks_their_boxes_miss_and_find_the_same_pairs() {
        // four blocks of boxes: the first holds the movers; the second lies beside them
        // (its bounds reached), the third far off (missed), the fourth far off too but
        // with one box reaching back to the movers (its bounds reached again)
        let b = AWAKE_BLOCK;
        let mut boxes = scatter(31, 4 * b - 1);
        for (i, bx) in boxes.iter_mut().enumerate() {
            if i >= 2 * b {
                bx.min.x += 1000.0;
                bx.max.x += 1000.0;
            }
        }
        boxes[3 * b + 9] = aabb(-5.0, -5.0, 5.0, 5.0);
        let n = boxes.len();
        let mut moves = vec![false; n];
        for k in 0..9 {
            moves[k * 7 + 1] = true;
        }
        let bounds: Vec<Option<Aabb>> = (0..4)
            .map(|k| {
                let run = &boxes[k * b..((k + 1) * b).min(n)];
                (k > 0).then(|| run.iter().copied().reduce(|x, y| x.union(&y)).unwrap())
            })
            .collect();
        let can = |a: u32, b: u32| !(a + b).is_multiple_of(7);
        let mut plain = BroadPhase::default();
        plain.find_pairs(&boxes, &moves, can);
        let mut bounded = BroadPhase::default();
        bounded.find_pairs_sized(&boxes, &moves, &moves, &bounds, can, None);
        let mut brute = Vec::new();
        for a in 0..n {
            for c in a + 1..n {
                if (moves[a] || moves[c]) && boxes[a].overlaps(&boxes[c]) && can(a as u32, c as u32)
                {
                    brute.push((a as u32, c as u32));
                }
            }
        }
        assert!(brute.iter().any(|&(_, c)| c as usize == 3 * b + 9));
        assert!(
            brute
                .iter()
                .any(|&(_, c)| (b..2 * b).contains(&(c as usize)))
        );
        assert!(!boxes[..b].iter().any(|x| x.overlaps(&bounds[2].unwrap())));
        assert_eq!(plain.pairs, brute);
        assert_eq!(bounded.pairs, brute);
    }

    #[test]
    fn splice_sorted_edits_a_sorted_list_as_a_set() {
        // lists of pairs from a fixed scramble; each edit takes a random part out and
        // puts random pairs in (some of them pairs it took out): the result is the set
        // difference and union, sorted
        let mut next = lcg(3);
        let mut rnd = move |m: u32| next() as u32 % m;
        let mut scratch = Vec::new();
        for round in 0..200 {
            let mut list: Vec<Pair> = (0..rnd(60)).map(|_| (rnd(20), rnd(20))).collect();
            list.sort_unstable();
            list.dedup();
            let gone: Vec<Pair> = list.iter().copied().filter(|_| rnd(4) == 0).collect();
            let mut added: Vec<Pair> = (0..rnd(8)).map(|_| (rnd(20), rnd(20))).collect();
            added.extend(gone.iter().copied().filter(|_| rnd(2) == 0));
            added.sort_unstable();
            added.dedup();
            added.retain(|p| gone.contains(p) || !list.contains(p));
            let mut want: Vec<Pair> = list
                .iter()
                .copied()
                .filter(|p| !gone.contains(p))
                .chain(added.iter().copied())
                .collect();
            want.sort_unstable();
            splice_sorted(&mut list, &gone, &added, &mut scratch);
            assert_eq!(list, want, "round {round}");
        }
    }

    #[test]
    fn a_few_bodies_wandering_through_a_grid_keep_the_pairs_a_rebuild_finds() {
        // 40 rows of 16 boxes in row order, so each awake block of 64 is four rows and
        // a few movers' kept boxes miss most blocks' bounds; three of them wander
        // through the grid, jumping up to two rows a step: the kept pairs stay every
        // pair of kept boxes (the pairs a rebuild finds) and the step's pairs those
        // found afresh
        let (rows, cols) = (40usize, 16usize);
        let mut boxes: Vec<Aabb> = (0..rows * cols)
            .map(|i| {
                let (x, y) = ((i % cols) as f32, (i / cols) as f32);
                aabb(x, y, x + 0.9, y + 0.9)
            })
            .collect();
        let n = boxes.len();
        let moves = vec![true; n];
        let filters = vec![Filter::default(); n];
        let mut rnd = unit(lcg(17));
        let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
        for step in 0..300 {
            for i in [5, 300, 630] {
                let d = Vec2::new(rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0);
                let c = (boxes[i].min + d).clamp(Vec2::ZERO, Vec2::new(15.0, 39.0));
                (boxes[i].min, boxes[i].max) = (c, c + Vec2::splat(0.9));
            }
            let left = left_of(&kept, &boxes, &moves, &filters);
            kept.find_pairs_kept_checked(
                &boxes,
                &moves,
                as_left(&left),
                |i| moves[i],
                None,
                |_, _| true,
                None,
            );
            fresh.find_pairs(&boxes, &moves, |_, _| true);
            assert_eq!(kept.pairs, fresh.pairs, "step {step}");
            let fat: Vec<Aabb> = kept.kept_boxes.clone();
            let mut rebuilt = BroadPhase::default();
            rebuilt.find_pairs(&fat, &moves, |_, _| true);
            assert_eq!(kept.kept_pairs(), &rebuilt.pairs[..], "step {step}");
        }
        assert_eq!(kept.rebuilds, 1, "only the first step rebuilds");
        assert!(kept.updates > 250, "{} updates", kept.updates);
    }

    #[test]
    fn some_bodies_jumping_about_keep_the_pairs_a_rebuild_finds() {
        // 600 boxes of mixed sizes over a ground, under filters; each step 40 to 140 of
        // them (more than are looked up one by one, at most a quarter) jump, now and then
        // one of them swelling past the grid's cells or a filter changing: the kept
        // pairs stay every pair of kept boxes the filters let touch, and the step's
        // pairs those found afresh; on one thread or two, the kept pairs are the same
        let mut boxes = scatter(7, 599);
        let n = boxes.len();
        let moves: Vec<bool> = (0..n).map(|i| i != 0).collect();
        let mut filters: Vec<Filter> = (0..n).map(three_filters).collect();
        let mut rnd = lcg(11);
        let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
        // (the second shares its pass over the boxes between two threads)
        let (mut listed, pool) = (BroadPhase::default(), Pool::new(2));
        let mut some_steps = 0;
        for step in 0..150 {
            let count = 40 + rnd() % 100;
            for _ in 0..count {
                let i = 1 + rnd() % (n - 1);
                let d = Vec2::new(
                    (rnd() % 100) as f32 * 0.04 - 2.0,
                    (rnd() % 100) as f32 * 0.04 - 2.0,
                );
                (boxes[i].min, boxes[i].max) = (boxes[i].min + d, boxes[i].max + d);
                if rnd().is_multiple_of(50) {
                    boxes[i].max = boxes[i].min + Vec2::new(15.0, 12.0);
                }
            }
            if step % 4 == 0 {
                filters[1 + rnd() % (n - 1)] = three_filters(rnd());
            }
            let left = left_of(&kept, &boxes, &moves, &filters);
            let these = left_of(&listed, &boxes, &moves, &filters);
            let count = these.as_ref().map_or(0, Vec::len);
            some_steps += usize::from(count > ONE_BY_ONE && count <= n / SOME_SHARE);
            let can = |a: u32, b: u32| filters[a as usize].collides(&filters[b as usize]);
            step_filtered(&mut kept, &boxes, &moves, &left, &filters, None);
            step_filtered(&mut listed, &boxes, &moves, &these, &filters, Some(&pool));
            fresh.find_pairs(&boxes, &moves, can);
            assert_eq!(kept.pairs, fresh.pairs, "step {step}");
            assert_eq!(listed.pairs, fresh.pairs, "step {step}");
            assert_eq!(listed.kept_pairs(), kept.kept_pairs(), "step {step}");
            let fat = kept.kept_boxes.clone();
            let mut rebuilt = BroadPhase::default();
            rebuilt.find_pairs(&fat, &kept.kept_moves.clone(), |a, b| {
                kept.kept_filters[a as usize].collides(&kept.kept_filters[b as usize])
            });
            assert_eq!(kept.kept_pairs(), &rebuilt.pairs[..], "step {step}");
        }
        assert!(
            some_steps > 100,
            "{some_steps} steps with some bodies leaving"
        );
        assert_eq!(kept.rebuilds, 1, "only the first step rebuilds");
        assert_eq!(
            (listed.rebuilds, listed.updates),
            (kept.rebuilds, kept.updates)
        );
    }

    #[test]
    fn kept_pairs_redone_body_by_body_under_filters_are_the_pairs_found_afresh() {
        let mut boxes = scatter(99, 300);
        let n = boxes.len();
        let moves: Vec<bool> = (0..n).map(|i| i != 0).collect();
        let mut filters: Vec<Filter> = (0..n).map(three_filters).collect();
        let mut rnd = lcg(5);
        let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
        for step in 0..200 {
            // one body jumps, and now and then another takes a new filter
            let i = 1 + rnd() % (n - 1);
            let d = Vec2::new(
                (rnd() % 100) as f32 * 0.05 - 2.5,
                (rnd() % 100) as f32 * 0.05,
            );
            (boxes[i].min, boxes[i].max) = (boxes[i].min + d, boxes[i].max + d);
            if step % 3 == 0 {
                filters[1 + rnd() % (n - 1)] = three_filters(rnd());
            }
            let left = left_of(&kept, &boxes, &moves, &filters);
            let can = |a: u32, b: u32| filters[a as usize].collides(&filters[b as usize]);
            step_filtered(&mut kept, &boxes, &moves, &left, &filters, None);
            fresh.find_pairs(&boxes, &moves, can);
            assert!(!fresh.pairs.is_empty());
            assert_eq!(kept.pairs, fresh.pairs, "step {step}");
            // the kept pairs are every pair of kept boxes the filters let touch, sorted
            assert!(kept.kept_pairs().windows(2).all(|w| w[0] < w[1]));
        }
        assert_eq!(kept.rebuilds, 1, "only the first step rebuilds");
        assert!(kept.updates > 100, "{} updates", kept.updates);
    }
}
