//! The broad phase: a uniform grid rebuilt each step. Every body's box is written into
//! the cells it covers, the (cell, body) entries are sorted, and bodies sharing a cell
//! are tested. A pair is reported only from the cell that holds the lower-left corner of
//! the overlap of the two boxes, so it is found once. Bodies whose boxes span many cells
//! (the ground) go to a short list tested against everyone. The output is sorted by
//! (a, b), so the step order does not depend on the grid.

use crate::math::{Aabb, Vec2};

/// A candidate pair of body indices, a < b.
pub type Pair = (u32, u32);

/// Reusable buffers of the grid broad phase.
#[derive(Clone, Default, Debug)]
pub struct BroadPhase {
    entries: Vec<(u64, u32)>,
    large: Vec<u32>,
    sizes: Vec<f32>,
    /// Candidate pairs from the last [`BroadPhase::find_pairs`], sorted.
    pub pairs: Vec<Pair>,
}

/// A box spanning more cells than this per axis is tested against all bodies instead.
const MAX_CELLS_PER_AXIS: i64 = 4;

#[inline]
fn cell_key(ix: i64, iy: i64) -> u64 {
    // 32 bits each, offset so negative cells sort before positive ones
    (((ix + (1 << 31)) as u64) << 32) | ((iy + (1 << 31)) as u64 & 0xffff_ffff)
}

impl BroadPhase {
    /// Finds every pair of overlapping boxes where `can_collide(a, b)` holds (a < b).
    /// `aabbs[i]` is body i's (fattened) box; `moves[i]` is false for static bodies, and
    /// two bodies that both do not move are never paired.
    pub fn find_pairs(
        &mut self,
        aabbs: &[Aabb],
        moves: &[bool],
        can_collide: impl Fn(u32, u32) -> bool,
    ) {
        self.entries.clear();
        self.large.clear();
        self.pairs.clear();
        if aabbs.len() < 2 {
            return;
        }
        // Cell size: twice the median extent of the moving bodies' boxes.
        let cell = {
            let sizes = &mut self.sizes;
            sizes.clear();
            sizes.extend(
                aabbs
                    .iter()
                    .zip(moves)
                    .filter(|(_, m)| **m)
                    .map(|(b, _)| (b.max - b.min).max_element()),
            );
            if sizes.is_empty() {
                return;
            }
            let mid = sizes.len() / 2;
            let (_, m, _) = sizes.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
            (2.0 * *m).max(1e-3)
        };
        let inv = 1.0 / cell;
        let to_cell = |v: Vec2| ((v.x * inv).floor() as i64, (v.y * inv).floor() as i64);
        for (i, b) in aabbs.iter().enumerate() {
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
            for ix in x0..=x1 {
                for iy in y0..=y1 {
                    self.entries.push((cell_key(ix, iy), i as u32));
                }
            }
        }
        self.entries.sort_unstable();

        let entries = &self.entries;
        let mut start = 0;
        while start < entries.len() {
            let key = entries[start].0;
            let mut end = start + 1;
            while end < entries.len() && entries[end].0 == key {
                end += 1;
            }
            for i in start..end {
                let a = entries[i].1;
                let ba = &aabbs[a as usize];
                for &(_, b) in &entries[i + 1..end] {
                    let bb = &aabbs[b as usize];
                    if !(moves[a as usize] || moves[b as usize]) || !ba.overlaps(bb) {
                        continue;
                    }
                    // report only from the cell holding the overlap's lower-left corner
                    let corner = ba.min.max(bb.min);
                    let (cx, cy) = to_cell(corner);
                    if cell_key(cx, cy) != key {
                        continue;
                    }
                    let p = if a < b { (a, b) } else { (b, a) };
                    if can_collide(p.0, p.1) {
                        self.pairs.push(p);
                    }
                }
            }
            start = end;
        }

        for (k, &l) in self.large.iter().enumerate() {
            let bl = &aabbs[l as usize];
            for (i, b) in aabbs.iter().enumerate() {
                let i = i as u32;
                // a large-large pair is tested once, from the earlier large body
                if i == l || (self.large[..=k].contains(&i)) {
                    continue;
                }
                if !(moves[l as usize] || moves[i as usize]) || !bl.overlaps(b) {
                    continue;
                }
                let p = if l < i { (l, i) } else { (i, l) };
                if can_collide(p.0, p.1) {
                    self.pairs.push(p);
                }
            }
        }
        self.pairs.sort_unstable();
        self.pairs.dedup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut seed = 12345u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        for _ in 0..300 {
            let x = rnd() * 40.0 - 20.0;
            let y = rnd() * 20.0 - 3.0;
            let s = 0.2 + rnd() * 2.0;
            boxes.push(aabb(x, y, x + s, y + s * rnd()));
        }
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
        assert_eq!(bp.pairs, brute);
    }
}
