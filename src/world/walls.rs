//! One-sided walls that hold what meets them from the front however fast it comes: the
//! static one-sided segments in a grid, and the pass after the step that puts back a
//! centre the step carried behind one.

use super::World;
use crate::body::Body;
use crate::math::{AWAKE_BLOCK, Aabb, BODY_PASS_BLOCK, Transform, Vec2};
use crate::parallel;
use crate::shape::{ChainSegment, Shape};

impl World {
    /// A one-sided segment holds what meets it from the front however fast it comes: a
    /// dynamic body whose centre this step carried across the line of a static one-sided
    /// segment, from the front to behind and within the segment, is put back onto the
    /// segment's line and its speed into the segment taken away; the contact pushes it
    /// out from there. Without it a body driven hard along a curved wall (the spinner's
    /// bodies at 100 m/s) sinks in a little each step until its centre slips behind the
    /// wall and it is gone; Box2D's continuous step stops such a centre too.
    pub(super) fn keep_in_front(&mut self) {
        // (the walls are static: their places are read once, before the threads share
        // the bodies, each body on its own)
        self.walls.place(&self.bodies);
        let pool = self.pool();
        let (walls, rest, start) = (&self.walls, &self.sleep.rest, &self.step_start);
        parallel::chunks_mut(
            pool.as_deref(),
            &mut self.bodies,
            BODY_PASS_BLOCK,
            &|_, offset, bodies| {
                for (k, from) in (0..bodies.len()).step_by(AWAKE_BLOCK).enumerate() {
                    // (a rest block's bodies all sleep: none of them moved)
                    if rest.is_rest(offset / AWAKE_BLOCK + k) {
                        continue;
                    }
                    let to = (from + AWAKE_BLOCK).min(bodies.len());
                    for (b, &start) in bodies[from..to].iter_mut().zip(&start[offset + from..]) {
                        keep_body_in_front(walls, b, start);
                    }
                }
                0.0
            },
        );
    }

    /// Whether a static body is a one-sided segment (worked out again, with the grid of
    /// them, when the body count changes).
    pub(super) fn has_one_sided(&mut self) -> bool {
        let n = self.bodies.len();
        if self.one_sided.0 != n {
            self.walls = WallGrid::of(&self.bodies);
            self.one_sided = (n, !self.walls.cells.is_empty());
        }
        self.one_sided.1
    }
}

/// [`World::keep_in_front`] for one body, `b`, whose centre was at `start` when the
/// step began.
fn keep_body_in_front(walls: &WallGrid, b: &mut Body, start: Vec2) {
    if !b.is_dynamic() || b.asleep || b.position == start {
        return;
    }
    // A centre put back onto one wall's line past that wall's end lies behind the next
    // wall (at a vertex of a loop seen from inside); the path from the start to the
    // corrected place then crosses the next wall, which the next pass finds. Two passes
    // settle a centre near a vertex; a path metres past the wall (10,000 g in a test)
    // takes a few more.
    for _ in 0..8 {
        if !push_in_front(walls, b, start) {
            break;
        }
    }
}

/// One pass of [`World::keep_in_front`] for body `b`, whose centre was at `start` when
/// the step began: each static one-sided segment whose line the path from `start` to
/// the body's centre crosses from the front, within the segment, puts the centre back a
/// tenth of a millimetre in front of its line and takes away its speed into it.
/// Whether it moved the body.
fn push_in_front(walls: &WallGrid, b: &mut Body, start: Vec2) -> bool {
    let position = b.position;
    let (c0, c1) = (
        walls.cell(start.min(position)),
        walls.cell(start.max(position)),
    );
    // a path over many cells (a body thrown far in one step) looks at every wall
    let cells = (c1.0 as i64 - c0.0 as i64 + 1) * (c1.1 as i64 - c0.1 as i64 + 1);
    let (c0, c1) = if cells > 64 {
        ((0, 0), (0, 0))
    } else {
        (c0, c1)
    };
    let mut pushed = false;
    for cx in c0.0..=c1.0 {
        for cy in c0.1..=c1.1 {
            let list = if cells > 64 {
                &walls.every
            } else {
                match walls.cells.get(&(cx, cy)) {
                    Some(list) => list,
                    None => continue,
                }
            };
            for &wall in list {
                // (a wall's body that is no longer a segment: nothing to cross)
                let Some((seg, xf)) = &walls.placed[wall as usize] else {
                    continue;
                };
                let end = xf.inv_apply(b.position);
                let from = xf.inv_apply(start);
                let left = seg.left_normal();
                let (before, after) = (left.dot(from - seg.a), left.dot(end - seg.a));
                if before < 0.0 || after >= 0.0 {
                    continue;
                }
                // where the path crosses the line, along the segment
                let cross = from + (end - from) * (before / (before - after));
                let e = seg.b - seg.a;
                let t = e.dot(cross - seg.a) / e.length_squared();
                if !(0.0..=1.0).contains(&t) {
                    continue;
                }
                let normal = xf.q.rotate(left);
                // a tenth of a millimetre in front: on the line, rounding could leave
                // it behind
                b.position += normal * (1.0e-4 - after);
                let into = b.velocity.dot(normal);
                if into < 0.0 {
                    b.velocity -= normal * into;
                }
                pushed = true;
            }
        }
    }
    pushed
}

/// The static one-sided segments in a grid of square cells, each segment in every cell
/// its box touches: where a body's path through the step may cross one.
#[derive(Clone, Debug, Default)]
pub(super) struct WallGrid {
    /// The cells' side (m): twice the longest segment's box, at least 1 m.
    side: f32,
    /// Per cell, the walls in it (indices into `bodies` and `placed`).
    cells: std::collections::HashMap<(i32, i32), Vec<u32>>,
    /// Every wall's body.
    bodies: Vec<u32>,
    /// 0, 1, 2...: every wall, for a path over many cells.
    every: Vec<u32>,
    /// Each wall's segment and its body's transform, if the body is still a segment
    /// ([`WallGrid::place`]).
    placed: Vec<Option<(ChainSegment, Transform)>>,
}

impl WallGrid {
    fn of(bodies: &[Body]) -> WallGrid {
        let walls: Vec<(usize, Aabb)> = bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| !b.is_dynamic() && matches!(b.shape, Shape::Chain(c) if c.one_sided))
            .map(|(i, b)| (i, b.aabb()))
            .collect();
        let longest = walls
            .iter()
            .map(|(_, bb)| (bb.max - bb.min).max_element())
            .fold(0.0f32, f32::max);
        let mut grid = WallGrid {
            side: (2.0 * longest).max(1.0),
            cells: Default::default(),
            bodies: walls.iter().map(|&(i, _)| i as u32).collect(),
            every: (0..walls.len() as u32).collect(),
            placed: Vec::with_capacity(walls.len()),
        };
        for (k, (_, bb)) in walls.into_iter().enumerate() {
            let (c0, c1) = (grid.cell(bb.min), grid.cell(bb.max));
            for cx in c0.0..=c1.0 {
                for cy in c0.1..=c1.1 {
                    grid.cells.entry((cx, cy)).or_default().push(k as u32);
                }
            }
        }
        grid
    }

    /// Reads each wall's segment and place from its body.
    fn place(&mut self, bodies: &[Body]) {
        self.placed.clear();
        self.placed.extend(self.bodies.iter().map(|&i| {
            let b = &bodies[i as usize];
            match b.shape {
                Shape::Chain(seg) => Some((seg, b.transform())),
                _ => None,
            }
        }));
    }

    fn cell(&self, p: Vec2) -> (i32, i32) {
        let c = |x: f32| (x / self.side).floor().clamp(-1e9, 1e9) as i32;
        (c(p.x), c(p.y))
    }
}
