//! Questions about the world between steps: which bodies hold a point, which overlap a
//! box, what a ray hits. Each looks at every body once (O(n)); none changes the world.
//!
//! A query's [`Filter`] is one-sided, as in Box2D: a body takes part when its category
//! is in the filter's mask (`Filter::default()` takes every body). The bodies' own masks
//! and groups decide what they touch, not what a query sees.

use super::World;
use crate::body::BodyId;
use crate::defs::Filter;
use crate::math::{Aabb, Vec2};

/// Where a ray met a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    pub body: BodyId,
    /// The world point where the ray enters the body's shape.
    pub point: Vec2,
    /// The shape's outward unit normal there (world frame).
    pub normal: Vec2,
    /// How far along the ray: `point = origin + fraction * translation`, in [0, 1].
    pub fraction: f32,
}

/// Whether a query with `filter` sees `body`.
#[inline]
fn sees(filter: &Filter, body: &crate::body::Body) -> bool {
    filter.mask & body.filter.category != 0
}

impl World {
    /// The bodies whose shape holds the world point `p` (boundary included), in
    /// creation order, among those `filter` sees.
    pub fn query_point(&self, p: Vec2, filter: &Filter) -> Vec<BodyId> {
        self.bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| sees(filter, b))
            .filter(|(_, b)| b.contains_local(b.transform().inv_apply(p)))
            .map(|(i, _)| i)
            .collect()
    }

    /// The bodies whose bounding box overlaps `aabb` (touching counts), in creation
    /// order, among those `filter` sees.
    pub fn query_aabb(&self, aabb: &Aabb, filter: &Filter) -> Vec<BodyId> {
        self.bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| sees(filter, b))
            .filter(|(_, b)| b.aabb().overlaps(aabb))
            .map(|(i, _)| i)
            .collect()
    }

    /// Every body the segment from `origin` to `origin + translation` enters, nearest
    /// first (ties in creation order), among those `filter` sees. A body the
    /// segment starts inside is not reported.
    pub fn ray_cast_all(&self, origin: Vec2, translation: Vec2, filter: &Filter) -> Vec<RayHit> {
        let mut hits: Vec<RayHit> = self
            .bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| sees(filter, b))
            .filter_map(|(i, b)| {
                let xf = b.transform();
                // in the body's frame; the direction is only turned
                let o = xf.inv_apply(origin);
                let d = xf.q.inv_rotate(translation);
                let (t, n) = b.ray_cast_local(o, d)?;
                Some(RayHit {
                    body: i,
                    point: origin + translation * t,
                    normal: xf.q.rotate(n),
                    fraction: t,
                })
            })
            .collect();
        hits.sort_by(|a, b| a.fraction.total_cmp(&b.fraction).then(a.body.cmp(&b.body)));
        hits
    }

    /// The nearest body the segment enters (see [`World::ray_cast_all`]).
    pub fn ray_cast_closest(
        &self,
        origin: Vec2,
        translation: Vec2,
        filter: &Filter,
    ) -> Option<RayHit> {
        self.ray_cast_all(origin, translation, filter)
            .into_iter()
            .next()
    }
}
