//! The kept pairs: the pairs of the bodies' fattened (kept) boxes, kept from step to
//! step and updated for the bodies that leave their kept boxes, or rebuilt.

use super::*;

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
pub(super) const ONE_BY_ONE: usize = 32;

/// At most one body in this many of those that may move may leave its kept box for the
/// kept pairs to be updated for those bodies alone (a grid of their boxes that every
/// other box looks into) rather than rebuilt: a heap of small bodies jostling in one
/// place (Box2D's junkyard) then costs a pass over the boxes, not a grid of them all.
/// (A rebuild's grid holds the bodies that may move and the still ones they reach, so
/// the share is of the movers, not of every body.)
pub(super) const SOME_SHARE: usize = 4;

/// The most steps of its motion a body's kept box reaches ahead of its box.
const AHEAD_MOST: u8 = 8;

/// How many steps of its motion a body's kept box reaches ahead, its last one having
/// reached `ahead` steps and held for `held` refreshes before the body left it: twice
/// as many (one from none, at most [`AHEAD_MOST`]) where the body went on as it went
/// (it left the box near its far end), half as many where it turned, hit something or
/// stopped. So a falling or thrown body leaves its kept box up to [`AHEAD_MOST`] times
/// less often, and one jostled in a heap reaches no further than its margin: the kept
/// pairs grow only along paths that bodies keep to.
pub(super) fn next_ahead(ahead: u8, held: u32) -> u8 {
    if held > u32::from(ahead) {
        (2 * ahead).clamp(1, AHEAD_MOST)
    } else {
        ahead / 2
    }
}

/// How far body `i`'s kept box reaches ahead of its box: `ahead` steps of its `motion`
/// (which is not asked for where that is none).
fn reach(motion: &dyn Fn(usize) -> Vec2, i: usize, ahead: u8) -> Vec2 {
    if ahead == 0 {
        Vec2::ZERO
    } else {
        motion(i) * f32::from(ahead)
    }
}

/// A body's kept box: its box `b` stretched by `ahead` (where its motion takes it in the
/// steps its kept box reaches ahead), fattened by [`KEEP_MARGIN`], or a quarter of its
/// extent where that is less.
fn kept_box(b: &Aabb, ahead: Vec2) -> Aabb {
    let extent = (b.max - b.min).max_element();
    b.swept(ahead).fattened(KEEP_MARGIN.min(0.25 * extent))
}

/// Whether some two of `filters` (two entries, not one with itself) let their bodies
/// touch. Looks at the distinct filters only; with more than a few of them it answers
/// yes without looking further (then the grid decides, pair by pair).
pub(super) fn any_pair_may_touch(filters: &[Filter]) -> bool {
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

impl BroadPhase {
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
        motion: impl Fn(usize) -> Vec2,
        can_collide: impl Fn(u32, u32) -> bool,
    ) {
        let listed: Option<Vec<u32>> = (self.kept_count() == aabbs.len()).then(|| {
            (0..aabbs.len())
                .filter(|&i| !self.kept_holds(i, &aabbs[i], may_move(i)))
                .map(|i| i as u32)
                .collect()
        });
        let left = listed.as_deref().map_or(Left::All, Left::These);
        self.find_pairs_kept_checked(
            aabbs,
            moves,
            left,
            may_move,
            &motion,
            None,
            can_collide,
            None,
        );
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
        motion: &dyn Fn(usize) -> Vec2,
        filter_of: Option<&dyn Fn(usize) -> Filter>,
        can_collide: impl Fn(u32, u32) -> bool,
        pool: Option<&Pool>,
    ) {
        self.refresh_kept(aabbs, left, may_move, motion, filter_of, pool);
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
    ///
    /// `motion(i)`: how far body i moves in a step as it moves now (zero where its path
    /// is not to be trusted). A kept box made anew reaches that far ahead for as many
    /// steps as the body's last one held before it left ([`next_ahead`]), so that a body
    /// in flight is looked up again every few steps, not every step. A kept box holds
    /// the kept pairs' promise whatever its shape: the pairs of the step stay the same.
    pub fn refresh_kept(
        &mut self,
        aabbs: &[Aabb],
        left: Left<'_>,
        may_move: impl Fn(usize) -> bool,
        motion: &dyn Fn(usize) -> Vec2,
        filter_of: Option<&dyn Fn(usize) -> Filter>,
        pool: Option<&Pool>,
    ) {
        // how far the kept boxes of the bodies that left reach ahead, by how long their
        // last ones held
        self.refreshes = self.refreshes.wrapping_add(1);
        let now = self.refreshes;
        let known = self.kept_ahead.len() == aabbs.len();
        if let (Left::These(listed), true) = (left, known) {
            for &i in listed {
                let i = i as usize;
                let held = now.wrapping_sub(self.kept_made[i]);
                self.kept_ahead[i] = next_ahead(self.kept_ahead[i], held);
                self.kept_made[i] = now;
            }
        }
        let rebuild = match left {
            Left::All => true,
            Left::These(listed) => {
                !listed.is_empty()
                    && !self.refresh_some(aabbs, listed, &may_move, motion, filter_of, pool)
            }
        };
        if rebuild {
            let mut fat = std::mem::take(&mut self.kept_boxes);
            let mut fat_moves = std::mem::take(&mut self.kept_moves);
            fat.clear();
            if !known || matches!(left, Left::All) {
                self.kept_ahead.clear();
                self.kept_ahead.resize(aabbs.len(), 0);
            }
            self.kept_made.clear();
            self.kept_made.resize(aabbs.len(), now);
            let ahead = &self.kept_ahead;
            fat.extend(
                aabbs
                    .iter()
                    .zip(ahead)
                    .enumerate()
                    .map(|(i, (b, &k))| kept_box(b, reach(motion, i, k))),
            );
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
        motion: &dyn Fn(usize) -> Vec2,
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
            kept_ahead,
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
            let fat = kept_box(&aabbs[i], reach(motion, i, kept_ahead[i]));
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
}

/// Takes the pairs of `gone` out of `list` and puts those of `added` in, all three
/// sorted (`gone` a part of `list`; a pair may go and come back), `list` staying sorted.
/// Only the span of `list` from the first edit to the last is merged again, its runs
/// between two edits copied whole (`scratch` holds the merged span); the pairs after
/// it move only where the count changes.
pub(super) fn splice_sorted(
    list: &mut Vec<Pair>,
    gone: &[Pair],
    added: &[Pair],
    scratch: &mut Vec<Pair>,
) {
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
