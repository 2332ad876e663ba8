//! Awake blocks: which blocks of bodies a step's body passes visit.
//!
//! The bodies are cut into blocks of [`BODY_PASS_BLOCK`] in creation order. A block all
//! of whose bodies sleep holds nothing a body pass of the solve changes: a sleeper is
//! still, has no force (the wake pass wakes one that has), and is in no constraint (its
//! contacts are kept aside and its joints parked). The collide's pass over the bodies
//! marks the blocks that hold a body that is not asleep ([`AwakeMarks`]); the solver's
//! passes after it (load, force increments, integration, the end of the step) visit only
//! those ([`each_awake`]), so a world that is mostly asleep pays for its sleeping blocks
//! in the collide's pass and not again in every pass of every substep.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::math::BODY_PASS_BLOCK;

/// The blocks the collide's pass found awake this step, marked from the pass's threads.
#[derive(Debug, Default)]
pub(crate) struct AwakeMarks {
    marks: Vec<AtomicBool>,
    /// Whether `marks` are this step's (the collide's pass ran).
    found: bool,
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
        self.found = false;
    }

    /// Clears the marks of `bodies` bodies' blocks for a pass to mark.
    pub(crate) fn start(&mut self, bodies: usize) {
        self.found = false;
        let blocks = bodies.div_ceil(BODY_PASS_BLOCK);
        self.marks.truncate(blocks);
        for m in &mut self.marks {
            *m.get_mut() = false;
        }
        self.marks.resize_with(blocks, || AtomicBool::new(false));
    }

    /// Marks body `i`'s block awake (from any thread of the pass).
    #[inline(always)]
    pub(crate) fn mark(&self, i: usize) {
        self.marks[i / BODY_PASS_BLOCK].store(true, Ordering::Relaxed);
    }

    /// The pass is over: the marks are this step's.
    pub(crate) fn finish(&mut self) {
        self.found = true;
    }

    /// Whether body `i`'s block holds a body that is not asleep (every block does when
    /// the marks are not this step's).
    #[inline]
    pub(crate) fn is_awake(&self, i: usize) -> bool {
        !self.found
            || self
                .marks
                .get(i / BODY_PASS_BLOCK)
                .is_none_or(|m| m.load(Ordering::Relaxed))
    }

    /// Copies this step's marks into `out`, one flag per block; empty (every block
    /// visited) when they are not this step's.
    pub(crate) fn copy_into(&self, out: &mut Vec<bool>) {
        out.clear();
        if self.found {
            out.extend(self.marks.iter().map(|m| m.load(Ordering::Relaxed)));
        }
    }
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
    let mut at = r.start;
    while at < r.end {
        let block = at / BODY_PASS_BLOCK;
        let block_end = ((block + 1) * BODY_PASS_BLOCK).min(r.end);
        if awake.get(block).copied().unwrap_or(true) {
            // extend over the following awake blocks
            let mut end = block_end;
            while end < r.end && awake.get(end / BODY_PASS_BLOCK).copied().unwrap_or(true) {
                end = ((end / BODY_PASS_BLOCK + 1) * BODY_PASS_BLOCK).min(r.end);
            }
            f(at..end);
            at = end;
        } else {
            at = block_end;
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
    use super::{AwakeMarks, each_awake, each_awake_in};
    use crate::math::BODY_PASS_BLOCK;

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
        let b = BODY_PASS_BLOCK;
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
    fn marks_count_only_when_the_pass_finished() {
        let mut m = AwakeMarks::default();
        let mut out = vec![true];
        m.start(3 * BODY_PASS_BLOCK + 1);
        m.mark(BODY_PASS_BLOCK + 3);
        m.copy_into(&mut out);
        assert!(out.is_empty(), "not found yet: visit every block");
        m.finish();
        m.copy_into(&mut out);
        assert_eq!(out, vec![false, true, false, false]);
        let awake: Vec<usize> = (0..5 * BODY_PASS_BLOCK)
            .filter(|&i| m.is_awake(i))
            .collect();
        // (past the marked blocks counts as awake)
        let want: Vec<usize> = (BODY_PASS_BLOCK..2 * BODY_PASS_BLOCK)
            .chain(4 * BODY_PASS_BLOCK..5 * BODY_PASS_BLOCK)
            .collect();
        assert_eq!(awake, want);
        // a new pass starts from nothing marked
        m.start(2 * BODY_PASS_BLOCK);
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
