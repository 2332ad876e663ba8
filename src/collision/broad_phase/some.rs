//! The pairs of a few or some bodies against every box: one by one, or through a grid
//! of their boxes alone into which the other boxes look.

use super::*;

/// Every pair of overlapping boxes with a body of `few` (listed in increasing order,
/// each with its `marked` entry set) where `accept` holds, into `out` (a < b, in no
/// particular order): each of them against every box, the pairs of two of them once.
/// A pair with no moving body (`marked` is `moves`) or of two unmarked bodies is never
/// reported. `blocks`, per awake block of boxes (empty, or shorter, for none): where
/// `Some`, bounds holding each box of the block; a block whose bounds a body's box
/// misses is passed over for that body.
pub(super) fn pairs_of_few(
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
pub(super) struct SomeGrid {
    start: Vec<u32>,
    bodies: Vec<u32>,
    ranges: Vec<(u32, [i64; 4])>,
    large: Vec<u32>,
    sizes: Vec<f32>,
    /// The pairs each block of the threads' pass over the boxes found.
    outs: BlockScratch<Pair>,
}

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
pub(super) fn pairs_of_some(
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
