//! Questions about the world between steps: which bodies hold a point, which overlap a
//! box or a shape, what a ray or a moving shape hits. They walk a tree over the bodies'
//! boxes ([`crate::collision::bvh`]), not every body: a query on 20,000 bodies looks at
//! the few near it. None changes the world.
//!
//! The tree is made at the first query (a world that asks nothing pays nothing for it)
//! and from then on kept by the step: each body's box is fattened by [`QUERY_MARGIN`]
//! when it enters the tree, and a body whose box leaves its fattened box goes to a short
//! list tested one by one, until the list is long enough that the tree is built again.
//! Adding, removing and moving bodies through the world's methods is seen; a position
//! the crate writes straight into the body list (the window's drag) is seen at the
//! next step.
//!
//! A query's [`Filter`] is one-sided, as in Box2D: a body takes part when its category
//! is in the filter's mask (`Filter::default()` takes every body). The bodies' own masks
//! and groups decide what they touch, not what a query sees.
//!
//! Each query comes in two forms: one that calls a closure per result, allocating
//! nothing (`for_each_*`, [`World::ray_cast`]), and one that returns a `Vec` in a
//! fixed order (creation order, or nearest first).
//!
//! Results name bodies by [`BodyKey`]; a body has its key from the moment it is added.

use std::sync::{Arc, Mutex};

use super::{BodyKey, World};
use crate::body::Body;
use crate::collision::bvh::Bvh;
use crate::defs::{Filter, ShapeDef};
use crate::math::{Aabb, Rot, Transform, Vec2};
use crate::shape::{Shape, ShapeError};

/// How far (m) a body's box is fattened when it enters the queries' tree: it stays in
/// its place in the tree while its box moves less than this.
pub const QUERY_MARGIN: f32 = 0.1;

/// Where a ray met a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// The body hit.
    pub body: BodyKey,
    /// The world point where the ray enters the body's shape.
    pub point: Vec2,
    /// The shape's outward unit normal there (world frame).
    pub normal: Vec2,
    /// How far along the ray: `point = origin + fraction * translation`, in [0, 1].
    pub fraction: f32,
}

/// Where a moving shape ([`World::cast_shape`]) first touches a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeCastHit {
    /// The body touched.
    pub body: BodyKey,
    /// How far along the translation the shape gets before it touches (the time of
    /// impact, in [0, 1]): the shape at `position + fraction * translation` is within
    /// [`SHAPE_CAST_TOLERANCE`] of the body.
    pub fraction: f32,
    /// Where they touch (world frame), on the body's surface.
    pub point: Vec2,
    /// The unit normal there, from the moving shape towards the body.
    pub normal: Vec2,
}

/// How close (m) a shape cast brings its shape to what it hits before it reports it.
pub const SHAPE_CAST_TOLERANCE: f32 = 5.0e-4;

/// A convex shape to query with ([`World::for_each_overlapping`], [`World::cast_shape`]),
/// checked and made once so that queries with it allocate nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryShape {
    shape: Shape,
    /// Where the definition's origin lies from the shape's centre (the shape is kept
    /// centred on its centroid, as a body's is).
    offset: Vec2,
}

impl QueryShape {
    /// The shape of `def`: a circle, box, polygon, capsule or rounded one. Segments,
    /// chain segments and compounds are refused (they have no inside to overlap with).
    pub fn new(def: &ShapeDef) -> Result<QueryShape, ShapeError> {
        if matches!(
            def,
            ShapeDef::Segment { .. } | ShapeDef::ChainSegment { .. } | ShapeDef::Compound { .. }
        ) {
            return Err(ShapeError::Invalid(
                "a query shape is a circle, box, polygon or capsule: segments, chain \
                 segments and compounds have no inside"
                    .into(),
            ));
        }
        let (shape, centroid) = Shape::from_def(def)?;
        Ok(QueryShape {
            shape,
            offset: -centroid,
        })
    }

    /// The shape placed with its definition's origin at `position`, turned by `angle`.
    fn placed(&self, position: Vec2, angle: f32) -> Transform {
        let q = Rot::from_angle(angle);
        Transform {
            p: position - q.rotate(self.offset),
            q,
        }
    }
}

/// Whether a query with `filter` sees `body`.
#[inline]
fn sees(filter: &Filter, body: &Body) -> bool {
    filter.mask & body.filter.category != 0
}

/// What a query index was made for: (bodies, edits, moves, steps) of its world.
type Stamp = (usize, u64, u64, u64);

/// The queries' tree over the bodies, and what it was made for.
#[derive(Clone, Debug, Default)]
pub(crate) struct QueryIndex {
    bvh: Bvh,
    /// Each body's fattened box, as the tree holds it.
    fat: Vec<Aabb>,
    /// Bodies whose box left their fattened box since the tree was built.
    moved: Vec<u32>,
    is_moved: Vec<bool>,
    /// What the index was made for.
    stamp: Stamp,
}

impl QueryIndex {
    /// The tree over every body, afresh.
    fn build(&mut self, bodies: &[Body], stamp: Stamp) {
        self.fat.clear();
        self.fat.extend(bodies.iter().map(fat_box));
        self.bvh.build(&self.fat, |_| true);
        self.moved.clear();
        self.is_moved.clear();
        self.is_moved.resize(bodies.len(), false);
        self.stamp = stamp;
    }

    /// After a step: bodies that may have moved (awake, not static) whose box left their
    /// fattened one join the moved list; a long list builds the tree again.
    fn refresh(&mut self, bodies: &[Body], stamp: Stamp) {
        // made for the world before this step, or made again
        if (self.stamp.0, self.stamp.1, self.stamp.2, self.stamp.3 + 1) != stamp {
            return self.build(bodies, stamp);
        }
        for (i, b) in bodies.iter().enumerate() {
            if b.asleep || b.body_type == crate::defs::BodyType::Static || self.is_moved[i] {
                continue;
            }
            if !self.fat[i].contains(&b.aabb()) {
                self.is_moved[i] = true;
                self.moved.push(i as u32);
            }
        }
        if self.moved.len() > 16 + bodies.len() / 16 {
            return self.build(bodies, stamp);
        }
        self.stamp = stamp;
    }

    /// Calls `f(body)` for each body whose box may overlap `aabb` (each once: the tree's,
    /// then the moved ones by their box now) until `f` returns false.
    fn candidates(&self, bodies: &[Body], aabb: &Aabb, mut f: impl FnMut(usize) -> bool) {
        let go_on = self.bvh.query(&self.fat, aabb, |i| {
            self.is_moved[i as usize] || f(i as usize)
        });
        if go_on {
            for &i in &self.moved {
                if bodies[i as usize].aabb().overlaps(aabb) && !f(i as usize) {
                    return;
                }
            }
        }
    }
}

/// A body's box, fattened for the tree.
fn fat_box(b: &Body) -> Aabb {
    b.aabb().fattened(QUERY_MARGIN)
}

/// The world's query index: made at the first query, shared by clones of the world
/// until one of them steps, kept by the step after that.
#[derive(Default)]
pub(crate) struct QueryCache(Mutex<Option<Arc<QueryIndex>>>);

impl Clone for QueryCache {
    fn clone(&self) -> QueryCache {
        QueryCache(Mutex::new(self.lock().clone()))
    }
}

impl std::fmt::Debug for QueryCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let bodies = self.lock().as_ref().map(|x| x.bvh.len());
        f.debug_struct("QueryCache")
            .field("bodies", &bodies)
            .finish()
    }
}

impl QueryCache {
    fn lock(&self) -> std::sync::MutexGuard<'_, Option<Arc<QueryIndex>>> {
        // a panic while the lock was held left at worst a stale index: rebuilt below
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl World {
    /// What the query index must have been made for to answer for this world.
    fn query_stamp(&self) -> Stamp {
        (self.bodies.len(), self.edits, self.moves, self.step_count)
    }

    /// The query index for the world as it is (made or brought up to date here).
    fn query_index(&self) -> Arc<QueryIndex> {
        let stamp = self.query_stamp();
        let mut cache = self.queries.lock();
        match cache.as_mut() {
            Some(index) if index.stamp == stamp => {}
            Some(index) => Arc::make_mut(index).build(&self.bodies, stamp),
            None => {
                let mut index = QueryIndex::default();
                index.build(&self.bodies, stamp);
                *cache = Some(Arc::new(index));
            }
        }
        Arc::clone(cache.as_ref().expect("made above"))
    }

    /// The step's part: brings an existing query index up to the bodies' new places.
    pub(crate) fn refresh_queries(&mut self) {
        let stamp = self.query_stamp();
        let cache = self.queries.0.get_mut().unwrap_or_else(|e| e.into_inner());
        if let Some(index) = cache.as_mut() {
            Arc::make_mut(index).refresh(&self.bodies, stamp);
        }
    }

    /// Calls `f(body)` for each body whose shape holds the world point `p` (boundary
    /// included) among those `filter` sees, until `f` returns false. Allocates nothing.
    pub fn for_each_at_point(&self, p: Vec2, filter: &Filter, mut f: impl FnMut(BodyKey) -> bool) {
        self.at_point(p, filter, |i| self.body_key(i).is_none_or(&mut f));
    }

    /// [`World::for_each_at_point`] by body index.
    fn at_point(&self, p: Vec2, filter: &Filter, mut f: impl FnMut(usize) -> bool) {
        let index = self.query_index();
        let at = Aabb { min: p, max: p };
        index.candidates(&self.bodies, &at, |i| {
            let b = &self.bodies[i];
            if sees(filter, b) && b.contains_local(b.transform().inv_apply(p)) {
                return f(i);
            }
            true
        });
    }

    /// The bodies whose shape holds the world point `p` (boundary included), in
    /// creation order, among those `filter` sees.
    pub fn query_point(&self, p: Vec2, filter: &Filter) -> Vec<BodyKey> {
        let mut out = Vec::new();
        self.at_point(p, filter, |i| {
            out.push(i);
            true
        });
        self.keys_in_order(out)
    }

    /// The keys of bodies `found` (indices), in creation order.
    fn keys_in_order(&self, mut found: Vec<usize>) -> Vec<BodyKey> {
        found.sort_unstable();
        found.into_iter().filter_map(|i| self.body_key(i)).collect()
    }

    /// Calls `f(body)` for each body whose bounding box overlaps `aabb` (touching
    /// counts) among those `filter` sees, until `f` returns false. Allocates nothing.
    pub fn for_each_in_aabb(
        &self,
        aabb: &Aabb,
        filter: &Filter,
        mut f: impl FnMut(BodyKey) -> bool,
    ) {
        self.in_aabb(aabb, filter, |i| self.body_key(i).is_none_or(&mut f));
    }

    /// [`World::for_each_in_aabb`] by body index.
    fn in_aabb(&self, aabb: &Aabb, filter: &Filter, mut f: impl FnMut(usize) -> bool) {
        let index = self.query_index();
        index.candidates(&self.bodies, aabb, |i| {
            let b = &self.bodies[i];
            if sees(filter, b) && b.aabb().overlaps(aabb) {
                return f(i);
            }
            true
        });
    }

    /// The bodies whose bounding box overlaps `aabb` (touching counts), in creation
    /// order, among those `filter` sees.
    pub fn query_aabb(&self, aabb: &Aabb, filter: &Filter) -> Vec<BodyKey> {
        let mut out = Vec::new();
        self.in_aabb(aabb, filter, |i| {
            out.push(i);
            true
        });
        self.keys_in_order(out)
    }

    /// Calls `f(body)` for each body the shape, placed at `position` and turned by
    /// `angle`, overlaps (touching counts; a compound body when one of its parts does)
    /// among those `filter` sees, until `f` returns false. Allocates nothing.
    pub fn for_each_overlapping(
        &self,
        shape: &QueryShape,
        position: Vec2,
        angle: f32,
        filter: &Filter,
        mut f: impl FnMut(BodyKey) -> bool,
    ) {
        self.overlapping(shape, position, angle, filter, |i| {
            self.body_key(i).is_none_or(&mut f)
        });
    }

    /// [`World::for_each_overlapping`] by body index.
    fn overlapping(
        &self,
        shape: &QueryShape,
        position: Vec2,
        angle: f32,
        filter: &Filter,
        mut f: impl FnMut(usize) -> bool,
    ) {
        let xf = shape.placed(position, angle);
        let aabb = shape.shape.aabb(&xf);
        let index = self.query_index();
        index.candidates(&self.bodies, &aabb, |i| {
            let b = &self.bodies[i];
            if sees(filter, b)
                && b.aabb().overlaps(&aabb)
                && distance_below(&shape.shape, &xf, b, 0.0).is_some()
            {
                return f(i);
            }
            true
        });
    }

    /// The bodies the shape overlaps ([`World::for_each_overlapping`]), in creation order.
    pub fn query_shape(
        &self,
        shape: &QueryShape,
        position: Vec2,
        angle: f32,
        filter: &Filter,
    ) -> Vec<BodyKey> {
        let mut out = Vec::new();
        self.overlapping(shape, position, angle, filter, |i| {
            out.push(i);
            true
        });
        self.keys_in_order(out)
    }

    /// Casts the segment from `origin` to `origin + translation` among the bodies
    /// `filter` sees, calling `f(hit)` for each body it enters (a body it starts inside
    /// is not reported), nearer ones mostly first. `f` returns how far the ray goes on,
    /// as a fraction: `hit.fraction` to look only for nearer hits, `1.0` to see every
    /// hit, a negative value to stop. Allocates nothing.
    pub fn ray_cast(
        &self,
        origin: Vec2,
        translation: Vec2,
        filter: &Filter,
        mut f: impl FnMut(&RayHit) -> f32,
    ) {
        let index = self.query_index();
        let bodies = &self.bodies;
        let hit_of = |i: usize, max: f32| -> Option<RayHit> {
            let b = &bodies[i];
            if !sees(filter, b) {
                return None;
            }
            let xf = b.transform();
            // in the body's frame; the direction is only turned
            let o = xf.inv_apply(origin);
            let d = xf.q.inv_rotate(translation);
            let (t, n) = b.ray_cast_local(o, d)?;
            if t > max {
                return None;
            }
            Some(RayHit {
                body: self.body_key(i)?,
                point: origin + translation * t,
                normal: xf.q.rotate(n),
                fraction: t,
            })
        };
        let go_on = index
            .bvh
            .ray(&index.fat, origin, translation, 1.0, |i, max| {
                if index.is_moved[i as usize] {
                    return max;
                }
                match hit_of(i as usize, max) {
                    Some(hit) => f(&hit),
                    None => max,
                }
            });
        if go_on {
            let mut max = 1.0f32;
            for &i in &index.moved {
                if let Some(hit) = hit_of(i as usize, max) {
                    let m = f(&hit);
                    if m < 0.0 {
                        return;
                    }
                    max = max.min(m);
                }
            }
        }
    }

    /// Every body the segment from `origin` to `origin + translation` enters, nearest
    /// first (ties in creation order), among those `filter` sees. A body the
    /// segment starts inside is not reported.
    pub fn ray_cast_all(&self, origin: Vec2, translation: Vec2, filter: &Filter) -> Vec<RayHit> {
        let mut hits = Vec::new();
        self.ray_cast(origin, translation, filter, |h| {
            hits.push(*h);
            1.0
        });
        hits.sort_by(|a, b| {
            a.fraction
                .total_cmp(&b.fraction)
                .then_with(|| self.body_of_key(a.body).cmp(&self.body_of_key(b.body)))
        });
        hits
    }

    /// The nearest body the segment enters (ties: the first created), as
    /// [`World::ray_cast_all`]'s first. Allocates nothing.
    pub fn ray_cast_closest(
        &self,
        origin: Vec2,
        translation: Vec2,
        filter: &Filter,
    ) -> Option<RayHit> {
        let mut best: Option<RayHit> = None;
        self.ray_cast(origin, translation, filter, |h| {
            let order = |h: &RayHit| (h.fraction, self.body_of_key(h.body));
            if best.is_none_or(|b| order(h) < order(&b)) {
                best = Some(*h);
            }
            h.fraction
        });
        best
    }

    /// Moves the shape, placed at `position` and turned by `angle`, along `translation`
    /// (not turning) and finds the first body among those `filter` sees that it touches:
    /// the time of impact as a fraction of the translation, the point and the normal
    /// (ties: the first created). A body the shape overlaps where it starts is hit at
    /// fraction 0. Allocates nothing.
    pub fn cast_shape(
        &self,
        shape: &QueryShape,
        position: Vec2,
        angle: f32,
        translation: Vec2,
        filter: &Filter,
    ) -> Option<ShapeCastHit> {
        let xf = shape.placed(position, angle);
        let start = shape.shape.aabb(&xf);
        let end = Aabb {
            min: start.min + translation,
            max: start.max + translation,
        };
        let swept = start.union(&end);
        let index = self.query_index();
        // (index, hit)
        let mut best: Option<(usize, ShapeCastHit)> = None;
        index.candidates(&self.bodies, &swept, |i| {
            let b = &self.bodies[i];
            if !sees(filter, b) || !b.aabb().overlaps(&swept) {
                return true;
            }
            let Some(key) = self.body_key(i) else {
                return true;
            };
            let limit = best.map_or(1.0, |(_, h)| h.fraction);
            if let Some(hit) = time_of_impact(&shape.shape, &xf, translation, b, limit)
                && best.is_none_or(|(j, h)| (hit.0, i) < (h.fraction, j))
            {
                let (fraction, point, normal) = hit;
                best = Some((
                    i,
                    ShapeCastHit {
                        body: key,
                        fraction,
                        point,
                        normal,
                    },
                ));
            }
            true
        });
        best.map(|(_, h)| h)
    }
}

/// The least separation (m) between `shape` placed by `xf` and any part of `body`, and
/// the normal (from the shape to the body) and point of it, where it is below `margin`
/// (a negative separation: they overlap). For polygons it is the separating axis'
/// separation, never more than the true distance; for circles and capsules the
/// distance.
fn distance_below(
    shape: &Shape,
    xf: &Transform,
    body: &Body,
    margin: f32,
) -> Option<(f32, Vec2, Vec2)> {
    let mut best: Option<(f32, Vec2, Vec2)> = None;
    crate::compound::for_each_collider(body, |_, c| {
        let m = crate::collision::sat::collide(shape, xf, &c.shape, &c.xf, margin);
        for p in m.points() {
            if p.separation <= margin && best.is_none_or(|b| p.separation < b.0) {
                best = Some((p.separation, m.normal, p.point));
            }
        }
    });
    best
}

/// Conservative advancement: the shape moves along `translation` from `xf`, each time
/// by the separation over the distance travelled (it cannot close more than that), until
/// it is within [`SHAPE_CAST_TOLERANCE`] of the body. (fraction, point, normal), or None
/// if it does not get there before `limit`.
fn time_of_impact(
    shape: &Shape,
    xf: &Transform,
    translation: Vec2,
    body: &Body,
    limit: f32,
) -> Option<(f32, Vec2, Vec2)> {
    let length = translation.length();
    let mut t = 0.0f32;
    // a separation above this cannot close within the rest of the translation
    for _ in 0..64 {
        let at = Transform {
            p: xf.p + translation * t,
            q: xf.q,
        };
        let reach = length * (limit - t) + SHAPE_CAST_TOLERANCE;
        let (separation, normal, point) = distance_below(shape, &at, body, reach)?;
        if separation <= SHAPE_CAST_TOLERANCE {
            return Some((t, point, normal));
        }
        if length == 0.0 {
            return None;
        }
        // to within half the tolerance: the next look finds it inside the tolerance
        t += (separation - 0.5 * SHAPE_CAST_TOLERANCE) / length;
        if t > limit {
            return None;
        }
    }
    None
}
