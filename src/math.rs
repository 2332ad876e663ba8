//! Small 2D math on top of glam: rotations stored as (cos, sin), rigid transforms and
//! the 2D cross products the solver needs.

pub use glam::Vec2;

/// A rotation stored as its cosine and sine, so rotating a vector costs four multiplies.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct Rot {
    /// cos(angle).
    pub c: f32,
    /// sin(angle).
    pub s: f32,
}

impl Rot {
    /// No rotation.
    pub const IDENTITY: Rot = Rot { c: 1.0, s: 0.0 };

    /// The rotation by `angle` radians, counter-clockwise.
    #[inline]
    pub fn from_angle(angle: f32) -> Rot {
        let (s, c) = angle.sin_cos();
        Rot { c, s }
    }

    /// R v
    #[inline]
    pub fn rotate(self, v: Vec2) -> Vec2 {
        Vec2::new(self.c * v.x - self.s * v.y, self.s * v.x + self.c * v.y)
    }

    /// R^T v
    #[inline]
    pub fn inv_rotate(self, v: Vec2) -> Vec2 {
        Vec2::new(self.c * v.x + self.s * v.y, -self.s * v.x + self.c * v.y)
    }

    /// R_self R_other: `other` applied first, then `self`.
    #[inline]
    pub fn then_rot(self, other: Rot) -> Rot {
        Rot {
            c: self.c * other.c - self.s * other.s,
            s: self.s * other.c + self.c * other.s,
        }
    }

    /// R_self^T R_other: the rotation of `other` seen from `self`'s frame.
    #[inline]
    pub fn inv_mul(self, other: Rot) -> Rot {
        Rot {
            c: self.c * other.c + self.s * other.s,
            s: self.c * other.s - self.s * other.c,
        }
    }
}

/// A rigid transform: x -> R x + p.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The translation (m): where the frame's origin lies.
    pub p: Vec2,
    /// The rotation.
    pub q: Rot,
}

impl Transform {
    /// The identity transform.
    pub const IDENTITY: Transform = Transform {
        p: Vec2::ZERO,
        q: Rot::IDENTITY,
    };

    /// R v + p
    #[inline]
    pub fn apply(&self, v: Vec2) -> Vec2 {
        self.q.rotate(v) + self.p
    }

    /// R^T (v - p)
    #[inline]
    pub fn inv_apply(&self, v: Vec2) -> Vec2 {
        self.q.inv_rotate(v - self.p)
    }

    /// self * other: a frame given in `self`'s frame, placed in the world.
    #[inline]
    pub fn compose(&self, other: &Transform) -> Transform {
        Transform {
            p: self.apply(other.p),
            q: self.q.then_rot(other.q),
        }
    }

    /// self^-1 * other: `other` expressed in `self`'s frame.
    #[inline]
    pub fn inv_mul(&self, other: &Transform) -> Transform {
        Transform {
            p: self.q.inv_rotate(other.p - self.p),
            q: self.q.inv_mul(other.q),
        }
    }
}

/// a x b = a.x b.y - a.y b.x (the z of the 3D cross product).
#[inline]
pub fn cross(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

/// w x r for a scalar (z-axis) w: (-w r.y, w r.x).
#[inline]
pub fn cross_sv(w: f32, r: Vec2) -> Vec2 {
    Vec2::new(-w * r.y, w * r.x)
}

/// v x s for a scalar s: (s v.y, -s v.x).
#[inline]
pub fn cross_vs(v: Vec2, s: f32) -> Vec2 {
    Vec2::new(s * v.y, -s * v.x)
}

/// An axis-aligned bounding box (the default: a point at the origin).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Aabb {
    /// The lower-left corner (smallest x and y, m).
    pub min: Vec2,
    /// The upper-right corner (largest x and y, m).
    pub max: Vec2,
}

impl Aabb {
    /// Whether the two boxes overlap (touching counts).
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.x <= o.max.x
            && o.min.x <= self.max.x
            && self.min.y <= o.max.y
            && o.min.y <= self.max.y
    }

    /// Whether `o` lies wholly inside this box (touching counts; false where either is
    /// NaN).
    #[inline]
    pub fn contains(&self, o: &Aabb) -> bool {
        self.min.x <= o.min.x
            && self.min.y <= o.min.y
            && o.max.x <= self.max.x
            && o.max.y <= self.max.y
    }

    /// The box grown by `m` on every side.
    #[inline]
    pub fn fattened(&self, m: f32) -> Aabb {
        Aabb {
            min: self.min - Vec2::splat(m),
            max: self.max + Vec2::splat(m),
        }
    }

    /// The box stretched along `d`: it holds the box and the box moved by `d`.
    #[inline]
    pub fn swept(&self, d: Vec2) -> Aabb {
        Aabb {
            min: self.min + d.min(Vec2::ZERO),
            max: self.max + d.max(Vec2::ZERO),
        }
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
}

/// Union-find over indices (`parent[i] == i` at a root), with path halving: the root of
/// `i`'s set.
pub(crate) fn uf_root(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

/// Joins the sets of `a` and `b`; the smaller root becomes the root, so the sets and
/// their roots do not depend on the order of the joins.
pub(crate) fn uf_union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (uf_root(parent, a), uf_root(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}

/// The first index of sorted `items` where `before` fails (as `partition_point`), found
/// by probing 1, 2, 4, ... items from the start and then searching the last span: the
/// cost grows with the answer's distance from the start, not with the slice (a walk
/// that skips ahead along a long sorted list reads only the items near its place).
pub(crate) fn gallop<T>(items: &[T], before: impl Fn(&T) -> bool) -> usize {
    // every item before `at` is before; the answer is at most `at + step - 1` once the
    // probe fails
    let (mut at, mut step) = (0, 1);
    while at + step <= items.len() && before(&items[at + step - 1]) {
        at += step;
        step *= 2;
    }
    let end = (at + step).min(items.len());
    at + items[at..end].partition_point(before)
}

/// How many items ahead the passes over the bodies ask for the next ones: a body is
/// hundreds of bytes, and the passes read its first cache line only.
pub(crate) const BODY_AHEAD: usize = 8;

/// Bodies per block of a parallel pass over the bodies.
pub(crate) const BODY_PASS_BLOCK: usize = 256;

/// Bodies per awake block (see [`crate::awake`]): the grain at which the step's passes
/// leave sleeping bodies out. Small, so an awake body among sleepers costs the passes a
/// few of its neighbours, not a pass block of them; a pass block holds whole ones.
pub(crate) const AWAKE_BLOCK: usize = 64;
const _: () = assert!(BODY_PASS_BLOCK.is_multiple_of(AWAKE_BLOCK));

/// Asks the cache for the first `bytes` bytes of `items[i]` (all of it for
/// `usize::MAX`; nothing past the slice's end). A hint only: no result depends on it.
#[inline(always)]
pub(crate) fn prefetch<T>(items: &[T], i: usize, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(x) = items.get(i) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let p = (x as *const T).cast::<i8>();
        let end = bytes.min(std::mem::size_of::<T>());
        // addresses less than a line apart, and the last byte: every line the bytes
        // span is asked for, wherever the item starts in its line
        let mut at = 0;
        while at < end {
            // SAFETY: prefetching has no effect on memory and cannot fault, and the
            // address lies inside the item.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.add(at)) };
            at += 56;
        }
        if end > 0 {
            // SAFETY: as above (end <= the item's size).
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.add(end - 1)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (items, i, bytes);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_round_trip() {
        let q = Rot::from_angle(0.7);
        let v = Vec2::new(1.5, -2.0);
        let back = q.inv_rotate(q.rotate(v));
        assert!((back - v).length() < 1e-6);
        // A quarter turn takes x to y.
        let r = Rot::from_angle(std::f32::consts::FRAC_PI_2).rotate(Vec2::X);
        assert!((r - Vec2::Y).length() < 1e-6);
    }

    #[test]
    fn cross_products_agree_with_3d() {
        let r = Vec2::new(2.0, 3.0);
        // (0,0,w) x (r,0) = (-w r.y, w r.x, 0)
        assert_eq!(cross_sv(2.0, r), Vec2::new(-6.0, 4.0));
        assert_eq!(cross(Vec2::X, Vec2::Y), 1.0);
        assert_eq!(cross_vs(Vec2::X, 1.0), Vec2::new(0.0, -1.0));
    }

    #[test]
    fn transform_inverse() {
        let a = Transform {
            p: Vec2::new(1.0, 2.0),
            q: Rot::from_angle(0.3),
        };
        let b = Transform {
            p: Vec2::new(-3.0, 0.5),
            q: Rot::from_angle(-1.1),
        };
        let rel = a.inv_mul(&b);
        let v = Vec2::new(0.25, 0.75);
        let direct = b.apply(v);
        let via = a.apply(rel.apply(v));
        assert!((direct - via).length() < 1e-5);
    }

    #[test]
    fn gallop_finds_where_partition_point_does() {
        // every length to past a few doublings, every answer in each
        for len in 0..70usize {
            let items: Vec<usize> = (0..len).collect();
            for cut in 0..=len {
                assert_eq!(gallop(&items, |&x| x < cut), cut, "len {len}, cut {cut}");
            }
        }
        // runs of equal items
        let items = [1, 1, 2, 2, 2, 2, 2, 3, 9, 9];
        for cut in 0..11 {
            assert_eq!(
                gallop(&items, |&x| x < cut),
                items.partition_point(|&x| x < cut)
            );
        }
    }
}
