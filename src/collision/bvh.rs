//! A bounding volume hierarchy over boxes, built top down by median splits: what the
//! world's queries walk instead of every body (see `crate::world::query`).
//!
//! The tree is flat: node `i`'s left child is `i + 1` and its right child is stored in
//! the node, so a walk touches memory in order. Leaves hold up to [`LEAF_SIZE`] items.
//! Building sorts nothing it does not need: each split only partitions its items about
//! the median centre on the longer axis (`select_nth_unstable`), O(n log n) in all.

use crate::math::{Aabb, Vec2};

/// Most items in a leaf.
const LEAF_SIZE: usize = 4;

/// A walk's stack: a tree of median splits over n items is about log2(n / 4) deep, so
/// this holds any tree of up to 2^60 items.
const STACK: usize = 64;

#[derive(Clone, Copy, Debug)]
struct Node {
    aabb: Aabb,
    /// A leaf: the first of its items in `items`. An inner node: its right child.
    start: u32,
    /// A leaf: how many items (1 to LEAF_SIZE). An inner node: 0.
    count: u32,
}

/// A tree over the items given to [`Bvh::build`], by their boxes.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bvh {
    nodes: Vec<Node>,
    items: Vec<u32>,
    /// Scratch of the build: each item's box centre.
    centres: Vec<Vec2>,
}

impl Bvh {
    /// Builds the tree over the items `i` for which `keep(i)` holds, each by `boxes[i]`,
    /// reusing the buffers.
    pub(crate) fn build(&mut self, boxes: &[Aabb], keep: impl Fn(usize) -> bool) {
        self.nodes.clear();
        self.items.clear();
        self.items
            .extend((0..boxes.len() as u32).filter(|&i| keep(i as usize)));
        self.centres.clear();
        self.centres
            .extend(boxes.iter().map(|b| (b.min + b.max) * 0.5));
        if !self.items.is_empty() {
            self.split(boxes, 0, self.items.len());
        }
    }

    /// Lays out the subtree over `items[first..first + n]` from the next free node on
    /// (depth first: a node's left child follows it) and returns its root.
    fn split(&mut self, boxes: &[Aabb], first: usize, n: usize) -> u32 {
        let node = self.nodes.len();
        self.nodes.push(leaf_over(boxes, &self.items, first, n));
        if n <= LEAF_SIZE {
            return node as u32;
        }
        // split at the median centre along the longer side of the centres' box
        let items = &mut self.items[first..first + n];
        let centres = &self.centres;
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        for &i in items.iter() {
            lo = lo.min(centres[i as usize]);
            hi = hi.max(centres[i as usize]);
        }
        let axis = usize::from(hi.y - lo.y > hi.x - lo.x);
        let half = n / 2;
        items.select_nth_unstable_by(half, |&a, &b| {
            centres[a as usize][axis]
                .total_cmp(&centres[b as usize][axis])
                .then(a.cmp(&b))
        });
        self.split(boxes, first, half);
        let right = self.split(boxes, first + half, n - half);
        self.nodes[node].count = 0;
        self.nodes[node].start = right;
        node as u32
    }

    /// Calls `f(item)` for each item whose box overlaps `aabb` (touching counts) until
    /// `f` returns false; returns whether the walk ran to the end.
    pub(crate) fn query(
        &self,
        boxes: &[Aabb],
        aabb: &Aabb,
        mut f: impl FnMut(u32) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return true;
        }
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            if !node.aabb.overlaps(aabb) {
                continue;
            }
            if node.count > 0 {
                let s = node.start as usize;
                for &i in &self.items[s..s + node.count as usize] {
                    if boxes[i as usize].overlaps(aabb) && !f(i) {
                        return false;
                    }
                }
            } else {
                stack[top] = node.start;
                stack[top + 1] = index + 1;
                top += 2;
            }
        }
        true
    }

    /// Walks the items whose box the segment `origin + t d`, t in [0, max], meets,
    /// nearer boxes' subtrees first; `f(item, max)` returns the new `max` (a hit's `t` to
    /// clip the segment, `max` to go on, a negative value to stop). Returns whether the
    /// walk ran to the end.
    pub(crate) fn ray(
        &self,
        boxes: &[Aabb],
        origin: Vec2,
        d: Vec2,
        mut max: f32,
        mut f: impl FnMut(u32, f32) -> f32,
    ) -> bool {
        if self.nodes.is_empty() {
            return true;
        }
        let inv = Vec2::new(1.0 / d.x, 1.0 / d.y);
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            if ray_enters(&node.aabb, origin, d, inv, max).is_none() {
                continue;
            }
            if node.count > 0 {
                let s = node.start as usize;
                for &i in &self.items[s..s + node.count as usize] {
                    if ray_enters(&boxes[i as usize], origin, d, inv, max).is_some() {
                        let m = f(i, max);
                        if m < 0.0 {
                            return false;
                        }
                        max = max.min(m);
                    }
                }
            } else {
                let (l, r) = (index + 1, node.start);
                let tl = ray_enters(&self.nodes[l as usize].aabb, origin, d, inv, max);
                let tr = ray_enters(&self.nodes[r as usize].aabb, origin, d, inv, max);
                // the nearer child on top, so that it is walked first and clips the other
                let (near, far) = match (tl, tr) {
                    (Some(a), Some(b)) if b < a => (r, l),
                    _ => (l, r),
                };
                stack[top] = far;
                stack[top + 1] = near;
                top += 2;
            }
        }
        true
    }

    /// Items in the tree.
    pub(crate) fn len(&self) -> usize {
        self.items.len()
    }
}

/// A leaf over `items[first..first + n]`: the union of their boxes.
fn leaf_over(boxes: &[Aabb], items: &[u32], first: usize, n: usize) -> Node {
    let mut aabb = boxes[items[first] as usize];
    for &i in &items[first + 1..first + n] {
        aabb = aabb.union(&boxes[i as usize]);
    }
    Node {
        aabb,
        start: first as u32,
        count: n.min(u32::MAX as usize) as u32,
    }
}

/// Where the segment `origin + t d`, t in [0, max], enters `b` (0 if it starts inside),
/// or None if it misses. `inv` is 1 / d per axis (infinite where d is 0).
#[inline]
fn ray_enters(b: &Aabb, origin: Vec2, d: Vec2, inv: Vec2, max: f32) -> Option<f32> {
    let (mut t0, mut t1) = (0.0f32, max);
    for k in 0..2 {
        if d[k] == 0.0 {
            if origin[k] < b.min[k] || origin[k] > b.max[k] {
                return None;
            }
        } else {
            let a = (b.min[k] - origin[k]) * inv[k];
            let c = (b.max[k] - origin[k]) * inv[k];
            let (near, far) = if a < c { (a, c) } else { (c, a) };
            t0 = t0.max(near);
            t1 = t1.min(far);
            if t0 > t1 {
                return None;
            }
        }
    }
    Some(t0)
}
