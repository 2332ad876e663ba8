//! Awake blocks: which blocks of bodies a step's body passes visit.
//!
//! The bodies are cut into blocks of [`AWAKE_BLOCK`] in creation order. A block all
//! of whose bodies sleep holds nothing a body pass of the solve changes: a sleeper is
//! still, has no force (the wake pass wakes one that has), and is in no constraint (its
//! contacts are kept aside and its joints parked). The collide's pass over the bodies
//! marks the blocks that hold a body that is not asleep ([`AwakeMarks`]); the solver's
//! passes after it (load, force increments, integration, the end of the step) visit only
//! those ([`each_awake`]), and so does the sleep pass's timers. A block the marks found
//! asleep, still asleep at the next step, is a rest block ([`RestBlocks`]): its entries
//! in the collide's arrays hold, so the next step's wake pass and broad phase skip it
//! too, and a world that is mostly asleep pays for its sleeping blocks in no pass of the
//! step.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use crate::body::Body;
use crate::math::{AWAKE_BLOCK, Aabb};

/// The blocks the collide's pass found awake this step, marked from the pass's threads.
#[derive(Debug, Default)]
pub(crate) struct AwakeMarks {
    marks: Vec<AtomicBool>,
    /// This step's marks, one flag per block, once the pass is over (empty until then:
    /// every block counts as awake).
    blocks: Vec<bool>,
}

impl Clone for AwakeMarks {
    /// A copy has found nothing: its next step's collide marks afresh.
    fn clone(&self) -> Self {
        AwakeMarks::default()
    }
}

impl AwakeMarks {
    /// Forgets the marks (until [`AwakeMarks::start`] and [`AwakeMarks::finish`]).
    pub(crate) fn forget(&mut self) {
        self.blocks.clear();
    }

    /// Clears the marks of `bodies` bodies' blocks for a pass to mark.
    pub(crate) fn start(&mut self, bodies: usize) {
        self.blocks.clear();
        let blocks = bodies.div_ceil(AWAKE_BLOCK);
        self.marks.truncate(blocks);
        for m in &mut self.marks {
            *m.get_mut() = false;
        }
        self.marks.resize_with(blocks, || AtomicBool::new(false));
    }

    /// Marks body `i`'s block awake (from any thread of the pass).
    #[inline(always)]
    pub(crate) fn mark(&self, i: usize) {
        self.marks[i / AWAKE_BLOCK].store(true, Ordering::Relaxed);
    }

    /// The pass is over: the marks are this step's.
    pub(crate) fn finish(&mut self) {
        self.blocks.clear();
        self.blocks
            .extend(self.marks.iter_mut().map(|m| *m.get_mut()));
    }

    /// Whether body `i`'s block holds a body that is not asleep (every block does when
    /// the marks are not this step's).
    #[inline]
    pub(crate) fn is_awake(&self, i: usize) -> bool {
        self.blocks.get(i / AWAKE_BLOCK).is_none_or(|&m| m)
    }

    /// The first body at or after `i` whose block holds a body that is not asleep
    /// (`usize::MAX` when there is none): a pass that meets a sleeping block goes on
    /// from there, past every sleeping block after it too.
    pub(crate) fn next_awake(&self, i: usize) -> usize {
        let k = i / AWAKE_BLOCK;
        if self.is_awake(i) {
            return i;
        }
        next_block(&self.blocks, k + 1, true).map_or(usize::MAX, |j| j * AWAKE_BLOCK)
    }

    /// Whether this step's pass found every body of block `k` asleep (false when the
    /// marks are not this step's: then no block is known to sleep).
    fn sleeps(&self, k: usize) -> bool {
        self.blocks.get(k) == Some(&false)
    }

    /// This step's marks, one flag per block; empty (every block visited) when they are
    /// not this step's (for [`each_awake`]).
    pub(crate) fn blocks(&self) -> &[bool] {
        &self.blocks
    }

    /// Copies this step's marks into `out`, one flag per block; empty (every block
    /// visited) when they are not this step's.
    pub(crate) fn copy_into(&self, out: &mut Vec<bool>) {
        out.clone_from(&self.blocks);
    }
}

/// Rest blocks: the blocks where every body slept through the last step, whose entries
/// in the collide's arrays (swept box, reach, flags, whether it sizes the wake pass's
/// grid) still hold from then. Their bodies are still and unchanged (anything that
/// moves, pushes or reshapes a sleeper wakes its island first, which takes its block
/// off), so the wake pass and the broad phase skip them and a world that is mostly
/// asleep pays for its sleeping blocks in no pass of the step. Known only for the same
/// bodies (count and order: adding, removing or restoring bodies forgets them) and the
/// same step and margin the boxes were swept for; debug builds check every skipped
/// entry against a fresh one.
#[derive(Debug, Default)]
pub(crate) struct RestBlocks {
    /// Per block: every body in it sleeps and its entries hold.
    blocks: Vec<bool>,
    /// Per block: the broad phase's filter and sensor flags of its bodies, as its last
    /// visit found them.
    flags: Vec<AtomicU32>,
    /// Per block: while it rests, the bounds of its bodies' swept boxes, once the wake
    /// pass has found them (`None` before, and for a block that does not rest).
    bounds: Vec<Option<Aabb>>,
    /// The bounds of the sleepers of each block that does not rest, where it holds
    /// some (scratch of the wake pass).
    pub(crate) loose: Vec<Aabb>,
    /// The body count and the step and margin (bits) of the boxes.
    seen: (usize, u32, u32),
    /// The world's count of edits to its bodies (added, removed, reshaped, restored)
    /// when the blocks were found.
    edits: u64,
}

impl Clone for RestBlocks {
    /// A copy knows no rest block: its next step visits every body.
    fn clone(&self) -> Self {
        RestBlocks::default()
    }
}

impl RestBlocks {
    /// Each body's `f` into `out` (a step's start, for what its end compares with).
    /// Where `out` already holds an entry for every body, the rest blocks' entries are
    /// left as they are: a rest block's bodies have not moved or changed since the step
    /// before it came to rest, whose start wrote them. Debug builds check them.
    pub(crate) fn copy_but_rest<T: Copy + Default + PartialEq + std::fmt::Debug>(
        &self,
        bodies: &[Body],
        out: &mut Vec<T>,
        f: impl Fn(&Body) -> T,
    ) {
        let known = out.len() == bodies.len();
        out.resize(bodies.len(), T::default());
        for (k, (bodies, out)) in bodies
            .chunks(AWAKE_BLOCK)
            .zip(out.chunks_mut(AWAKE_BLOCK))
            .enumerate()
        {
            if known && self.is_rest(k) {
                debug_assert!(
                    bodies.iter().zip(out.iter()).all(|(b, o)| f(b) == *o),
                    "a rest block's entries hold"
                );
                continue;
            }
            for (b, o) in bodies.iter().zip(out) {
                *o = f(b);
            }
        }
    }

    /// Knows no rest block (until a step's end finds them again).
    pub(crate) fn forget(&mut self) {
        self.blocks.clear();
        self.bounds.clear();
    }

    /// A step's start in a world whose bodies have been edited `edits` times: forgets
    /// the rest blocks if they were edited since they were found.
    pub(crate) fn since_edits(&mut self, edits: u64) {
        if edits != self.edits {
            self.forget();
            self.edits = edits;
        }
    }

    /// A collide's start for `bodies` bodies and boxes swept over `h` with `margin`:
    /// forgets the rest blocks unless the boxes were found for the same.
    pub(crate) fn begin(&mut self, bodies: usize, h: f32, margin: f32) {
        let seen = (bodies, h.to_bits(), margin.to_bits());
        if seen != self.seen {
            self.forget();
            self.seen = seen;
        }
        let blocks = bodies.div_ceil(AWAKE_BLOCK);
        self.flags.truncate(blocks);
        self.flags.resize_with(blocks, || AtomicU32::new(0));
    }

    /// Whether block `k`'s bodies all sleep with their entries as the last visit left
    /// them.
    #[inline]
    pub(crate) fn is_rest(&self, k: usize) -> bool {
        self.blocks.get(k).copied().unwrap_or(false)
    }

    /// Body `i` wakes (or changes): its block is visited again.
    #[inline]
    pub(crate) fn wake(&mut self, i: usize) {
        let k = i / AWAKE_BLOCK;
        if let Some(b) = self.blocks.get_mut(k) {
            *b = false;
        }
        if let Some(b) = self.bounds.get_mut(k) {
            *b = None;
        }
    }

    /// Per block, where it rests and its bounds are known, the bounds of its bodies'
    /// swept boxes (see [`RestBlocks::bound`]); `None` elsewhere.
    pub(crate) fn bounds(&self) -> &[Option<Aabb>] {
        &self.bounds
    }

    /// Rest block `k`'s bounds, from its bodies' swept boxes `boxes` (its entries, which
    /// hold while it rests): found once, on the first wake pass it rests through.
    pub(crate) fn bound(&mut self, k: usize, boxes: &[Aabb]) {
        debug_assert!(self.is_rest(k));
        // (`keep` sizes the bounds with the blocks)
        let bounds = &mut self.bounds[k];
        if bounds.is_none() {
            *bounds = boxes.iter().copied().reduce(|a, b| a.union(&b));
        }
    }

    /// The flags block `k`'s visit found (see [`RestBlocks::is_rest`]).
    #[inline]
    pub(crate) fn flags(&self, k: usize) -> u32 {
        self.flags[k].load(Ordering::Relaxed)
    }

    /// Records block `k`'s flags from its visit (from any thread of the pass).
    #[inline]
    pub(crate) fn set_flags(&self, k: usize, f: u32) {
        self.flags[k].store(f, Ordering::Relaxed);
    }

    /// A step's end, before anything falls asleep or wakes: the rest blocks of the next
    /// step are the blocks this step's pass found asleep (`marks`; a block that falls
    /// asleep now has its boxes swept with its last velocities, so it waits a step).
    pub(crate) fn keep(&mut self, marks: &AwakeMarks) {
        if marks.blocks.is_empty() {
            self.forget();
            return;
        }
        let blocks = self.seen.0.div_ceil(AWAKE_BLOCK);
        self.blocks.resize(blocks, false);
        self.bounds.resize(blocks, None);
        for (k, (rests, bounds)) in self.blocks.iter_mut().zip(&mut self.bounds).enumerate() {
            let now = marks.sleeps(k);
            // a block's bounds hold while it rests on
            if !(now && *rests) {
                *bounds = None;
            }
            *rests = now;
        }
    }
}

/// The first index of `flags` that is `want` (as `position`, but a run of 32 flags at a
/// time, with no early exit inside a run, so the scan is a few vector compares a run:
/// a world of thousands of sleeping blocks scans their flags in every pass).
fn first_flag(flags: &[bool], want: bool) -> Option<usize> {
    const RUN: usize = 32;
    let mut runs = flags.chunks_exact(RUN);
    for (k, run) in runs.by_ref().enumerate() {
        if run.iter().fold(false, |any, &m| any | (m == want)) {
            return run.iter().position(|&m| m == want).map(|i| k * RUN + i);
        }
    }
    let tail = runs.remainder();
    tail.iter()
        .position(|&m| m == want)
        .map(|i| flags.len() - tail.len() + i)
}

/// The first block from `k` on whose flag is `want`, if any.
fn next_block(flags: &[bool], k: usize, want: bool) -> Option<usize> {
    first_flag(flags.get(k..)?, want).map(|d| k + d)
}

/// Calls `f` on the parts of `r` (body indices) that lie in awake blocks, each run of
/// consecutive awake blocks as one part, in order. `awake` holds a flag per block; an
/// empty `awake`, or an index past its blocks (the solver's own slots after the
/// bodies), counts as awake.
#[inline]
pub(crate) fn each_awake(awake: &[bool], r: Range<usize>, mut f: impl FnMut(Range<usize>)) {
    if awake.is_empty() {
        if !r.is_empty() {
            f(r);
        }
        return;
    }
    // (a run of blocks of one kind is found by a scan of the flags, so a world of
    // sleeping blocks costs a pass a few bytes a block)
    let blocks = awake.len();
    let mut at = r.start;
    while at < r.end {
        let k = at / AWAKE_BLOCK;
        if awake.get(k).copied().unwrap_or(true) {
            // to the next sleeping block (past the flags, every block is awake)
            let end = next_block(awake, k, false).map_or(r.end, |j| (j * AWAKE_BLOCK).min(r.end));
            f(at..end);
            at = end;
        } else {
            // to the next awake block
            at = next_block(awake, k, true).map_or(blocks * AWAKE_BLOCK, |j| j * AWAKE_BLOCK);
        }
    }
}

/// [`each_awake`] over the `len` bodies from `offset` (a pass's block of them), each part
/// given relative to `offset`.
#[inline]
pub(crate) fn each_awake_in(
    awake: &[bool],
    offset: usize,
    len: usize,
    mut f: impl FnMut(Range<usize>),
) {
    each_awake(awake, offset..offset + len, |r| {
        f(r.start - offset..r.end - offset)
    });
}

#[cfg(test)]
mod tests {
    use super::{AwakeMarks, RestBlocks, each_awake, each_awake_in, first_flag};
    use crate::math::{AWAKE_BLOCK, Aabb, Vec2};

    /// The indices `each_awake` visits, one by one.
    fn visited(awake: &[bool], r: std::ops::Range<usize>) -> Vec<usize> {
        let mut out = Vec::new();
        let mut last_end = None;
        each_awake(awake, r, |p| {
            assert!(!p.is_empty(), "an empty part");
            if let Some(e) = last_end {
                assert!(p.start > e, "parts in order, runs merged: {p:?} after {e}");
            }
            last_end = Some(p.end);
            out.extend(p);
        });
        out
    }

    #[test]
    fn each_awake_visits_exactly_the_indices_of_awake_blocks() {
        let b = AWAKE_BLOCK;
        // every pattern of five blocks, and ranges cut anywhere
        for pattern in 0..32u32 {
            let awake: Vec<bool> = (0..5).map(|k| pattern & (1 << k) != 0).collect();
            for (start, end) in [
                (0, 5 * b),
                (3, 4 * b + 7),
                (b - 1, 2 * b + 1),
                (2 * b, 2 * b),
                (b + 5, 7 * b),
            ] {
                let want: Vec<usize> = (start..end)
                    .filter(|&i| awake.get(i / b).copied().unwrap_or(true))
                    .collect();
                assert_eq!(
                    visited(&awake, start..end),
                    want,
                    "{awake:?} {start}..{end}"
                );
            }
        }
        // no marks: everything
        assert_eq!(visited(&[], 5..9), vec![5, 6, 7, 8]);
        // from an offset, the parts relative to it
        let mut parts = Vec::new();
        each_awake_in(&[true, false, true], b - 2, 2 * b + 4, |r| parts.push(r));
        assert_eq!(parts, vec![0..2, b + 2..2 * b + 4]);
    }

    #[test]
    fn first_flag_finds_what_position_finds() {
        // every length past a few runs of 32, flags from a fixed scramble, and runs of
        // one flag with the other at each place
        let mut seed = 7u32;
        for len in 0..140usize {
            let mixed: Vec<bool> = (0..len)
                .map(|_| {
                    seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                    seed >> 28 == 0
                })
                .collect();
            for want in [false, true] {
                assert_eq!(
                    first_flag(&mixed, want),
                    mixed.iter().position(|&m| m == want),
                    "len {len}"
                );
                for at in 0..len {
                    let mut one = vec![!want; len];
                    one[at] = want;
                    assert_eq!(first_flag(&one, want), Some(at), "len {len} at {at}");
                }
                assert_eq!(first_flag(&vec![!want; len], want), None);
            }
        }
    }

    #[test]
    fn next_awake_is_the_first_body_on_in_an_awake_block() {
        let b = AWAKE_BLOCK;
        let mut m = AwakeMarks::default();
        // marks not found: every body counts as awake
        assert_eq!(m.next_awake(b + 3), b + 3);
        // blocks 0 and 3 of five awake
        m.start(5 * b);
        m.mark(5);
        m.mark(3 * b + 9);
        m.finish();
        for i in 0..5 * b {
            let want = (i..5 * b).find(|&j| m.is_awake(j)).unwrap_or(usize::MAX);
            assert_eq!(m.next_awake(i), want, "from {i}");
        }
        assert_eq!(m.next_awake(b), 3 * b);
        assert_eq!(m.next_awake(4 * b + 1), usize::MAX);
    }

    #[test]
    fn rest_blocks_are_the_blocks_found_asleep_until_a_wake_or_a_change() {
        let b = AWAKE_BLOCK;
        let rest = |r: &RestBlocks| (0..4).map(|k| r.is_rest(k)).collect::<Vec<_>>();
        let mut m = AwakeMarks::default();
        let mut r = RestBlocks::default();
        r.since_edits(0);
        r.begin(3 * b + 1, 0.25, 0.1);
        // marks not found (no pass, or none asleep): nothing rests
        m.start(3 * b + 1);
        m.mark(b);
        r.keep(&m);
        assert_eq!(rest(&r), [false; 4]);
        // found: the blocks with no mark rest (the last, short one too)
        m.finish();
        r.keep(&m);
        assert_eq!(rest(&r), [true, false, true, true]);
        // the same bodies, step and margin keep them; a wake takes one block off
        r.begin(3 * b + 1, 0.25, 0.1);
        r.wake(2 * b + 7);
        assert_eq!(rest(&r), [true, false, false, true]);
        // another count, step or margin, or an edit, forgets them all
        for change in 0..4 {
            r.keep(&m);
            assert_eq!(rest(&r), [true, false, true, true]);
            match change {
                0 => r.begin(3 * b + 2, 0.25, 0.1),
                1 => r.begin(3 * b + 1, 0.5, 0.1),
                2 => r.begin(3 * b + 1, 0.25, 0.2),
                _ => r.since_edits(1),
            }
            assert_eq!(rest(&r), [false; 4], "change {change}");
            // (back to the first settings)
            r.begin(3 * b + 1, 0.25, 0.1);
        }
        // the same edit count keeps them; a copy knows none
        r.keep(&m);
        r.since_edits(1);
        assert_eq!(rest(&r), [true, false, true, true]);
        assert_eq!(rest(&r.clone()), [false; 4]);
        // flags as the last visit found them
        r.set_flags(2, 6);
        assert_eq!(r.flags(2), 6);
    }

    #[test]
    fn a_rest_blocks_bounds_hold_its_boxes_while_it_rests_on() {
        let b = AWAKE_BLOCK;
        let boxes: Vec<Aabb> = (0..3 * b)
            .map(|i| {
                let min = Vec2::new(i as f32, -(i as f32) * 0.5);
                Aabb {
                    min,
                    max: min + Vec2::splat(1.0),
                }
            })
            .collect();
        let bounds = |r: &RestBlocks| {
            (0..3)
                .map(|k| r.bounds().get(k).copied().flatten())
                .collect::<Vec<_>>()
        };
        let mut m = AwakeMarks::default();
        let mut r = RestBlocks::default();
        r.since_edits(0);
        r.begin(3 * b, 0.25, 0.1);
        m.start(3 * b);
        m.mark(b + 5);
        m.finish();
        r.keep(&m);
        // resting, but not found yet by a wake pass
        assert_eq!(bounds(&r), [None; 3]);
        for k in [0, 2] {
            r.bound(k, &boxes[k * b..(k + 1) * b]);
        }
        let want = |k: usize| {
            let run = &boxes[k * b..(k + 1) * b];
            Some(Aabb {
                min: Vec2::new(run[0].min.x, run[b - 1].min.y),
                max: Vec2::new(run[b - 1].max.x, run[0].max.y),
            })
        };
        assert_eq!(bounds(&r), [want(0), None, want(2)]);
        // kept while the block rests on (a later visit does not find them again)
        r.keep(&m);
        r.bound(0, &boxes[..1]);
        assert_eq!(bounds(&r), [want(0), None, want(2)]);
        // a wake drops its block's; a block that wakes in a pass loses them too
        r.wake(2 * b + 1);
        assert_eq!(bounds(&r), [want(0), None, None]);
        m.start(3 * b);
        m.mark(3);
        m.finish();
        r.keep(&m);
        assert_eq!(bounds(&r), [None; 3]);
        // a change forgets them with the blocks
        m.start(3 * b);
        m.finish();
        r.keep(&m);
        r.keep(&m);
        r.bound(1, &boxes[b..2 * b]);
        assert!(bounds(&r)[1].is_some());
        r.since_edits(1);
        assert_eq!(bounds(&r), [None; 3]);
    }

    #[test]
    fn marks_count_only_when_the_pass_finished() {
        let mut m = AwakeMarks::default();
        let mut out = vec![true];
        m.start(3 * AWAKE_BLOCK + 1);
        m.mark(AWAKE_BLOCK + 3);
        m.copy_into(&mut out);
        assert!(out.is_empty(), "not found yet: visit every block");
        m.finish();
        m.copy_into(&mut out);
        assert_eq!(out, vec![false, true, false, false]);
        let awake: Vec<usize> = (0..5 * AWAKE_BLOCK).filter(|&i| m.is_awake(i)).collect();
        // (past the marked blocks counts as awake)
        let want: Vec<usize> = (AWAKE_BLOCK..2 * AWAKE_BLOCK)
            .chain(4 * AWAKE_BLOCK..5 * AWAKE_BLOCK)
            .collect();
        assert_eq!(awake, want);
        // a new pass starts from nothing marked
        m.start(2 * AWAKE_BLOCK);
        m.finish();
        m.copy_into(&mut out);
        assert_eq!(out, vec![false, false]);
        m.forget();
        m.copy_into(&mut out);
        assert!(out.is_empty());
        assert!(m.is_awake(0));
        assert!(m.clone().marks.is_empty());
    }
}
