//! The narrow phase by the separating axis theorem: polygon-polygon (reference and
//! incident faces, clipping, up to 2 points), circle-polygon and circle-circle.
//! Rounded polygons and capsules (a polygon with a radius) collide through their
//! cores, with the closest features deciding the normal where the cores are apart.
//!
//! Points are kept while their separation is below `margin` (speculative contacts), so a
//! resting contact survives tiny bounces and its cached lambdas keep warm-starting.

use super::{ContactPoint, FeatureId, Manifold};
use crate::math::cross;
use crate::math::{Rot, Transform, Vec2};
use crate::shape::{ChainSegment, MAX_POLYGON_VERTICES, Polygon, Shape};
use glam::Vec4;

/// A reference face of B is chosen over A's only when it separates better by this much (m),
/// so the choice does not flicker between nearly equal faces.
const FACE_SWITCH_TOLERANCE: f32 = 0.0005;

/// The manifold between two shapes placed by their transforms, normal from A to B.
pub fn collide(sa: &Shape, xa: &Transform, sb: &Shape, xb: &Transform, margin: f32) -> Manifold {
    match (sa, sb) {
        // compounds collide part by part (crate::compound::collide_bodies)
        (Shape::Compound { .. }, _) | (_, Shape::Compound { .. }) => Manifold::default(),
        (Shape::Chain(_), Shape::Chain(_)) => Manifold::default(),
        (Shape::Chain(c), other) => collide_chain(c, xa, other, xb, margin),
        (other, Shape::Chain(c)) => {
            let mut m = collide_chain(c, xb, other, xa, margin);
            flip(&mut m, xa, xb);
            m
        }
        (Shape::Polygon(pa), Shape::Polygon(pb))
            if pa.radius == 0.0 && pb.radius == 0.0 && pa.count >= 3 && pb.count >= 3 =>
        {
            collide_polygons(pa, xa, pb, xb, margin)
        }
        (Shape::Polygon(pa), Shape::Polygon(pb)) => collide_rounded(pa, xa, pb, xb, margin),
        (Shape::Polygon(pa), Shape::Circle { radius }) => {
            collide_polygon_circle(pa, xa, xb.p, *radius, margin)
        }
        (Shape::Circle { radius }, Shape::Polygon(pb)) => {
            let mut m = collide_polygon_circle(pb, xb, xa.p, *radius, margin);
            flip(&mut m, xa, xb);
            m
        }
        (Shape::Circle { radius: ra }, Shape::Circle { radius: rb }) => {
            collide_circles(xa.p, *ra, xb.p, *rb, margin)
        }
    }
}

/// Swaps the roles of A and B in a manifold computed with them exchanged.
fn flip(m: &mut Manifold, xa: &Transform, xb: &Transform) {
    m.normal = -m.normal;
    for p in &mut m.points[..m.count] {
        p.anchor_a = p.point - xa.p;
        p.anchor_b = p.point - xb.p;
    }
}

fn point(
    world: Vec2,
    xa: &Transform,
    xb: &Transform,
    separation: f32,
    id: FeatureId,
) -> ContactPoint {
    ContactPoint {
        point: world,
        anchor_a: world - xa.p,
        anchor_b: world - xb.p,
        separation,
        id,
        normal_impulse: 0.0,
        tangent_impulse: 0.0,
    }
}

/// Circle against circle: one point, feature id 0.
pub fn collide_circles(ca: Vec2, ra: f32, cb: Vec2, rb: f32, margin: f32) -> Manifold {
    let d = cb - ca;
    let dist = d.length();
    let sep = dist - ra - rb;
    let mut m = Manifold::default();
    if sep > margin {
        return m;
    }
    let n = if dist > 1e-9 { d / dist } else { Vec2::Y };
    // midway between the two surfaces
    let p = ca + n * (ra + 0.5 * sep);
    m.normal = n;
    m.points[0] = ContactPoint {
        point: p,
        anchor_a: p - ca,
        anchor_b: p - cb,
        separation: sep,
        id: 0,
        normal_impulse: 0.0,
        tangent_impulse: 0.0,
    };
    m.count = 1;
    m
}

/// Polygon (A) against circle (B, centre `c_world`): one point, normal from A to B.
/// Feature id: face index, or 0x100 | vertex index in a vertex region.
pub fn collide_polygon_circle(
    pa: &Polygon,
    xa: &Transform,
    c_world: Vec2,
    radius: f32,
    margin: f32,
) -> Manifold {
    let mut m = Manifold::default();
    let c = xa.inv_apply(c_world);
    let n = pa.count;
    let mut best = 0;
    let mut best_sep = f32::MIN;
    for i in 0..n {
        let s = pa.normals[i].dot(c - pa.vertices[i]);
        if s > best_sep {
            best_sep = s;
            best = i;
        }
    }
    let rp = pa.radius;
    if best_sep > radius + rp + margin {
        return m;
    }
    let v1 = pa.vertices[best];
    let v2 = pa.vertices[(best + 1) % n];
    let (normal, dist, id) = if best_sep > 0.0 && (c - v1).dot(v2 - v1) < 0.0 {
        let d = c - v1;
        let len = d.length();
        (d / len, len, 0x100 | best as u32)
    } else if best_sep > 0.0 && (c - v2).dot(v1 - v2) < 0.0 {
        let d = c - v2;
        let len = d.length();
        (d / len, len, 0x100 | ((best + 1) % n) as u32)
    } else {
        (pa.normals[best], best_sep, best as u32)
    };
    let sep = if rp == 0.0 {
        dist - radius
    } else {
        dist - radius - rp
    };
    if sep > margin {
        return m;
    }
    // midpoint between the polygon surface (c - n (dist - rp)) and the circle surface
    // (c - n r)
    let local = if rp == 0.0 {
        c - normal * (0.5 * (dist + radius))
    } else {
        c - normal * (0.5 * (dist - rp + radius))
    };
    let nw = xa.q.rotate(normal);
    let pw = xa.apply(local);
    m.normal = nw;
    let xb = Transform {
        p: c_world,
        q: xa.q,
    };
    m.points[0] = point(pw, xa, &xb, sep, id);
    m.count = 1;
    m
}

/// The edge of `v1/n1` that best separates the points `v2`: (edge, separation).
#[inline]
fn max_separation(v1: &[Vec2], n1: &[Vec2], v2: &[Vec2]) -> (usize, f32) {
    let mut best = 0;
    let mut best_sep = f32::MIN;
    for i in 0..v1.len() {
        let n = n1[i];
        let o = v1[i];
        let mut si = f32::MAX;
        for &w in v2 {
            si = si.min(n.dot(w - o));
        }
        if si > best_sep {
            best_sep = si;
            best = i;
        }
    }
    (best, best_sep)
}

/// Four points or directions by coordinate: lane i holds the i-th (a box's vertices or
/// normals, for the SAT of two boxes four at a time).
#[derive(Clone, Copy)]
struct Quad {
    x: Vec4,
    y: Vec4,
}

impl Quad {
    /// The first four of `v`.
    #[inline(always)]
    fn load(v: &[Vec2]) -> Quad {
        Quad {
            x: Vec4::new(v[0].x, v[1].x, v[2].x, v[3].x),
            y: Vec4::new(v[0].y, v[1].y, v[2].y, v[3].y),
        }
    }

    /// Each lane turned by `q`, as `Rot::rotate` does it.
    #[inline(always)]
    fn rotate(self, q: Rot) -> Quad {
        let (c, s) = (Vec4::splat(q.c), Vec4::splat(q.s));
        Quad {
            x: c * self.x - s * self.y,
            y: s * self.x + c * self.y,
        }
    }

    /// Each lane placed by `xf`, as `Transform::apply` does it.
    #[inline(always)]
    fn apply(self, xf: &Transform) -> Quad {
        let r = self.rotate(xf.q);
        Quad {
            x: r.x + Vec4::splat(xf.p.x),
            y: r.y + Vec4::splat(xf.p.y),
        }
    }

    #[inline(always)]
    fn store(self, out: &mut [Vec2]) {
        let (x, y) = (self.x.to_array(), self.y.to_array());
        for i in 0..4 {
            out[i] = Vec2::new(x[i], y[i]);
        }
    }
}

/// [`max_separation`] of four edges against four points: the same arithmetic for each
/// edge and point, so the same separations. Lane i holds edge i: the separations of
/// all four edges from point j come at once, their minimum over the points is each
/// edge's separation, and the first edge of the greatest wins, as in the scalar loop.
#[inline(always)]
fn max_separation4(v1: &Quad, n1: &Quad, v2: &Quad) -> (usize, f32) {
    let (wx, wy) = (v2.x.to_array(), v2.y.to_array());
    // n_i . (w_j - o_i), lane i, for point j
    let d = |j: usize| n1.x * (Vec4::splat(wx[j]) - v1.x) + n1.y * (Vec4::splat(wy[j]) - v1.y);
    let sep = d(0).min(d(1)).min(d(2)).min(d(3));
    let best_sep = sep.max_element();
    // the first edge whose separation is the greatest (no lane matches only where a
    // separation is NaN: then edge 0)
    let mask = sep.cmpeq(Vec4::splat(best_sep)).bitmask();
    let best = if mask == 0 {
        0
    } else {
        mask.trailing_zeros() as usize
    };
    (best, best_sep)
}

/// Polygon against polygon. Works in A's frame; the reference face is the face of
/// greatest separation, the incident edge the most anti-parallel edge of the other
/// polygon, clipped to the reference face's side planes.
pub fn collide_polygons(
    pa: &Polygon,
    xa: &Transform,
    pb: &Polygon,
    xb: &Transform,
    margin: f32,
) -> Manifold {
    if pa.count == 4 && pb.count == 4 {
        // boxes: the same code with the counts known, so every loop unrolls
        collide_polygons_n::<4>(pa, 4, xa, pb, 4, xb, margin)
    } else {
        collide_polygons_n::<MAX_POLYGON_VERTICES>(pa, pa.count, xa, pb, pb.count, xb, margin)
    }
}

/// [`collide_polygons`] for polygons of `na` and `nb` vertices, B's at most `CAP`.
#[inline(always)]
fn collide_polygons_n<const CAP: usize>(
    pa: &Polygon,
    na_count: usize,
    xa: &Transform,
    pb: &Polygon,
    nb_count: usize,
    xb: &Transform,
    margin: f32,
) -> Manifold {
    let mut m = Manifold::default();
    let rel = xa.inv_mul(xb);
    let mut vb = [Vec2::ZERO; CAP];
    let mut nb = [Vec2::ZERO; CAP];
    let va = &pa.vertices[..na_count];
    let na = &pa.normals[..na_count];
    let (edge_a, sep_a, edge_b, sep_b);
    if CAP == 4 {
        // two boxes: four vertices at a time
        let (qbv, qbn) = (
            Quad::load(&pb.vertices).apply(&rel),
            Quad::load(&pb.normals).rotate(rel.q),
        );
        qbv.store(&mut vb);
        qbn.store(&mut nb);
        let qav = Quad::load(va);
        (edge_a, sep_a) = max_separation4(&qav, &Quad::load(na), &qbv);
        if sep_a > margin {
            return m;
        }
        (edge_b, sep_b) = max_separation4(&qbv, &qbn, &qav);
        if sep_b > margin {
            return m;
        }
    } else {
        for i in 0..nb_count {
            vb[i] = rel.apply(pb.vertices[i]);
            nb[i] = rel.q.rotate(pb.normals[i]);
        }
        (edge_a, sep_a) = max_separation(va, na, &vb[..nb_count]);
        if sep_a > margin {
            return m;
        }
        (edge_b, sep_b) = max_separation(&vb[..nb_count], &nb[..nb_count], va);
        if sep_b > margin {
            return m;
        }
    }
    let vb = &vb[..nb_count];
    let nb = &nb[..nb_count];

    let flipped = sep_b > sep_a + FACE_SWITCH_TOLERANCE;
    let (rv, rn, iv, inn, ref_edge) = if flipped {
        (vb, nb, va, na, edge_b)
    } else {
        (va, na, vb, nb, edge_a)
    };

    let n = rn[ref_edge];
    // incident edge: the one whose normal is most anti-parallel to the reference normal
    let mut inc = 0;
    let mut min_dot = f32::MAX;
    for (i, &ni) in inn.iter().enumerate() {
        let d = n.dot(ni);
        if d < min_dot {
            min_dot = d;
            inc = i;
        }
    }
    let inc2 = (inc + 1) % iv.len();
    let r1 = rv[ref_edge];
    let ref2 = (ref_edge + 1) % rv.len();
    let r2 = rv[ref2];
    // the reference edge's direction, normalised. On A (not flipped) the edge and its
    // normal are A's own: where A's normals are its edges turned and normalised to the
    // bit (`Polygon::exact_edges`), the direction is the normal turned back, without the
    // square root and division. B's edge was moved into A's frame: normalised here.
    let t = if !flipped && pa.exact_edges {
        Vec2::new(-n.y, n.x)
    } else {
        (r2 - r1).normalize()
    };

    // The incident segment with a feature id per end (see `face_ids`). An end keeps
    // its id when it is clipped: in an aligned stack the incident vertices sit on the
    // side planes, and an id that changed with clipping flipped on 1e-7 m of jitter and
    // lost the cached lambdas.
    let (id1, id2) = face_ids(flipped, (ref_edge, ref2), (inc, inc2));
    let mut seg = [(iv[inc], id1), (iv[inc2], id2)];

    // clip against the side plane through r1 (keep t.(p - r1) >= 0)
    if !clip(&mut seg, -t, -t.dot(r1)) {
        return m;
    }
    // and through r2 (keep t.(p - r2) <= 0)
    if !clip(&mut seg, t, t.dot(r2)) {
        return m;
    }

    let normal_local = if flipped { -n } else { n };
    m.normal = xa.q.rotate(normal_local);
    for &(p, id) in &seg {
        let sep = n.dot(p - r1);
        if sep > margin {
            continue;
        }
        // midway between the incident point and the reference face
        let mid = p - n * (0.5 * sep);
        let pw = xa.apply(mid);
        m.points[m.count] = point(pw, xa, xb, sep, id);
        m.count += 1;
    }
    m
}

/// A point's id between two polygons: the vertex of A and the vertex of B it lies
/// between, whichever of them gave the reference face. In a pile the reference face
/// switches between the two boxes whenever their tilts cross (a few milliradians at
/// their edges exceed `FACE_SWITCH_TOLERANCE`); an id that named the reference side
/// lost the cached lambdas at each switch, and a pyramid whose load-bearing points
/// started cold a few at a time never came to rest.
fn pair_id(flipped: bool, ref_vertex: usize, inc_vertex: usize) -> FeatureId {
    let (a, b) = if flipped {
        (inc_vertex, ref_vertex)
    } else {
        (ref_vertex, inc_vertex)
    };
    ((a as u32) << 8) | b as u32
}

/// The ids of a face contact's two ends, the one from incident vertex `inc` and the one
/// from `inc2`: the incident edge runs against the reference edge (`ref_edge` to
/// `ref2`), so its start lies across from the reference edge's end and its end across
/// from the start.
fn face_ids(
    flipped: bool,
    (ref_edge, ref2): (usize, usize),
    (inc, inc2): (usize, usize),
) -> (FeatureId, FeatureId) {
    (
        pair_id(flipped, ref2, inc),
        pair_id(flipped, ref_edge, inc2),
    )
}

/// Cores closer than this (m) are treated as touching: the closest-feature direction is
/// not used (it could not be normalised safely).
const CORE_TOUCH: f32 = 1e-5;

/// The closest-feature normal replaces the reference face's when they differ by more
/// than about 2.6 degrees (cosine below this).
const FACE_COS: f32 = 0.999;

/// The closest points of the segments `p1`-`q1` and `p2`-`q2`: (s, t, point on the
/// first, point on the second), s and t in [0, 1].
fn closest_segments(p1: Vec2, q1: Vec2, p2: Vec2, q2: Vec2) -> (f32, f32, Vec2, Vec2) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    let (s, t);
    if a <= 1e-12 && e <= 1e-12 {
        (s, t) = (0.0, 0.0);
    } else if a <= 1e-12 {
        (s, t) = (0.0, (f / e).clamp(0.0, 1.0));
    } else {
        let c = d1.dot(r);
        if e <= 1e-12 {
            (s, t) = ((-c / a).clamp(0.0, 1.0), 0.0);
        } else {
            let b = d1.dot(d2);
            let den = a * e - b * b;
            // parallel segments: any s will do; take the middle of the overlap below
            let s0 = if den > 1e-12 * a * e {
                ((b * f - c * e) / den).clamp(0.0, 1.0)
            } else {
                0.5
            };
            let t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                (s, t) = ((-c / a).clamp(0.0, 1.0), 0.0);
            } else if t0 > 1.0 {
                (s, t) = (((b - c) / a).clamp(0.0, 1.0), 1.0);
            } else {
                (s, t) = (s0, t0);
            }
        }
    }
    (s, t, p1 + s * d1, p2 + t * d2)
}

/// Two polygons where either is rounded or is a segment (capsules, rounded boxes,
/// terrain segments). Works in A's frame on the cores: the reference and incident
/// faces are chosen as for sharp polygons, then, when the cores are apart, the closest
/// points of those two edges decide: along the reference normal the incident edge is
/// clipped as usual (up to 2 points, each `radius` sum less separated); in any other
/// direction (a corner or a capsule's end meeting the other shape's rounded corner) one
/// point along the line between the closest points.
pub fn collide_rounded(
    pa: &Polygon,
    xa: &Transform,
    pb: &Polygon,
    xb: &Transform,
    margin: f32,
) -> Manifold {
    let mut m = Manifold::default();
    let radius = pa.radius + pb.radius;
    let rel = xa.inv_mul(xb);
    let mut vb = [Vec2::ZERO; MAX_POLYGON_VERTICES];
    let mut nb = [Vec2::ZERO; MAX_POLYGON_VERTICES];
    for i in 0..pb.count {
        vb[i] = rel.apply(pb.vertices[i]);
        nb[i] = rel.q.rotate(pb.normals[i]);
    }
    let va = pa.verts();
    let na = &pa.normals[..pa.count];
    let vb = &vb[..pb.count];
    let nb = &nb[..pb.count];

    let (edge_a, sep_a) = max_separation(va, na, vb);
    if sep_a > radius + margin {
        return m;
    }
    let (edge_b, sep_b) = max_separation(vb, nb, va);
    if sep_b > radius + margin {
        return m;
    }
    let flipped = sep_b > sep_a + FACE_SWITCH_TOLERANCE;
    let (rv, rn, iv, inn, ref_edge, r_ref, r_inc) = if flipped {
        (vb, nb, va, na, edge_b, pb.radius, pa.radius)
    } else {
        (va, na, vb, nb, edge_a, pa.radius, pb.radius)
    };
    let n = rn[ref_edge];
    let mut inc = 0;
    let mut min_dot = f32::MAX;
    for (i, &ni) in inn.iter().enumerate() {
        let d = n.dot(ni);
        if d < min_dot {
            min_dot = d;
            inc = i;
        }
    }
    let inc2 = (inc + 1) % iv.len();
    let ref2 = (ref_edge + 1) % rv.len();
    let (r1, r2) = (rv[ref_edge], rv[ref2]);
    // A's frame -> world, with the normal turned to point from A to B
    let sign = if flipped { -1.0 } else { 1.0 };

    // the closest features when the cores are apart
    let mut single = None;
    if radius > 0.0 && sep_a.max(sep_b) > -CORE_TOUCH {
        let (s, t, p, q) = closest_segments(r1, r2, iv[inc], iv[inc2]);
        let d = q - p;
        let dist = d.length();
        if dist > radius + margin {
            return m;
        }
        if dist > CORE_TOUCH {
            let dir = d / dist;
            let vertex = |u: f32, lo: usize, hi: usize| if u < 0.5 { lo } else { hi };
            let id = (1 << 30) | pair_id(flipped, vertex(s, ref_edge, ref2), vertex(t, inc, inc2));
            single = Some((p, q, dir, dist, id));
            if dir.dot(n) < FACE_COS {
                let (p, q, dir, dist, id) = single.take().unwrap();
                push_single(
                    &mut m,
                    xa,
                    xb,
                    p,
                    q,
                    dir * sign,
                    dist - radius,
                    r_ref,
                    r_inc,
                    id,
                );
                return m;
            }
        }
    }

    let t = (r2 - r1).normalize();
    let (id1, id2) = face_ids(flipped, (ref_edge, ref2), (inc, inc2));
    let mut seg = [(iv[inc], id1), (iv[inc2], id2)];
    let clipped = clip(&mut seg, -t, -t.dot(r1)) && clip(&mut seg, t, t.dot(r2));
    if !clipped {
        // the incident edge lies past the reference edge's ends: a capsule end to end
        // with another, or a corner past a face
        if let Some((p, q, dir, dist, id)) = single {
            push_single(
                &mut m,
                xa,
                xb,
                p,
                q,
                dir * sign,
                dist - radius,
                r_ref,
                r_inc,
                id,
            );
        }
        return m;
    }
    m.normal = xa.q.rotate(n * sign);
    for &(p, id) in &seg {
        let core_sep = n.dot(p - r1);
        let sep = core_sep - radius;
        if sep > margin {
            continue;
        }
        // midway between the incident surface (p - n r_inc) and the reference surface
        // (p - n core_sep + n r_ref)
        let mid = p - n * (0.5 * (core_sep - r_ref + r_inc));
        let pw = xa.apply(mid);
        m.points[m.count] = point(pw, xa, xb, sep, id);
        m.count += 1;
    }
    m
}

/// One contact point between the closest core points `p` (reference) and `q`
/// (incident), in A's frame, `dir` from the reference to the incident core, `normal`
/// from A to B.
#[allow(clippy::too_many_arguments)]
fn push_single(
    m: &mut Manifold,
    xa: &Transform,
    xb: &Transform,
    p: Vec2,
    q: Vec2,
    normal: Vec2,
    sep: f32,
    r_ref: f32,
    r_inc: f32,
    id: FeatureId,
) {
    let dir = (q - p).normalize_or_zero();
    let mid = 0.5 * ((p + dir * r_ref) + (q - dir * r_inc));
    m.normal = xa.q.rotate(normal);
    m.points[0] = point(xa.apply(mid), xa, xb, sep, id);
    m.count = 1;
}

/// A shape against one segment of a polyline (A), normal from the segment to the
/// shape. The plain segment's manifold is kept when its normal is the segment's face
/// normal, or lies between the two faces' normals at a convex joint (the joint's
/// contact then belongs to the segment before it). Any other normal at a joint is a
/// ghost: at a flat or concave joint the shape is met along the face normal only (so a
/// box sliding across the joint is not stopped by the next segment's end), and past the
/// neighbour's normal the neighbour holds the shape. A one-sided segment ignores a shape
/// whose centre is behind it.
pub fn collide_chain(
    c: &ChainSegment,
    xa: &Transform,
    other: &Shape,
    xb: &Transform,
    margin: f32,
) -> Manifold {
    let seg = Shape::Polygon(Polygon::segment(c.a, c.b, 0.0));
    let left = c.left_normal();
    let center = xa.inv_apply(xb.p);
    let behind = left.dot(center - c.a) < 0.0;
    if c.one_sided && behind {
        return Manifold::default();
    }
    let m = collide(&seg, xa, other, xb, margin);
    if m.count == 0 {
        return m;
    }
    let front = if behind { -left } else { left };
    let n = xa.q.inv_rotate(m.normal);
    if n.dot(front) >= FACE_COS {
        return m;
    }
    let e = c.b - c.a;
    let at_a = n.dot(e) < 0.0;
    let (before, after) = if at_a {
        let Some(g) = c.prev else { return m };
        (c.a - g, e)
    } else {
        let Some(g) = c.next else { return m };
        (e, g - c.b)
    };
    // the neighbour's face normal on the same side, and the joint's turn seen from it
    let neighbour = if at_a { before } else { after };
    let n_nb = neighbour.perp().normalize() * if behind { -1.0 } else { 1.0 };
    let turn = cross(before, after) * if behind { -1.0 } else { 1.0 };
    let convex = turn < -1e-6 * before.length() * after.length();
    if convex {
        // inside the cone from this face's normal to the neighbour's?
        let span = cross(front, n_nb);
        let inside = cross(front, n) * span >= 0.0 && cross(n, n_nb) * span >= 0.0;
        if inside && !at_a {
            return m;
        }
        return Manifold::default();
    }
    face_contact(c.a, c.b, front, xa, other, xb, margin)
}

/// `other` met along the segment `a`-`b`'s face normal `front` only (A's frame): a
/// circle whose centre lies over the segment, or a polygon's incident edge clipped to
/// the segment's ends.
fn face_contact(
    a: Vec2,
    b: Vec2,
    front: Vec2,
    xa: &Transform,
    other: &Shape,
    xb: &Transform,
    margin: f32,
) -> Manifold {
    let mut m = Manifold::default();
    match other {
        Shape::Compound { .. } => {}
        Shape::Circle { radius } => {
            let c = xa.inv_apply(xb.p);
            let e = b - a;
            let u = (c - a).dot(e);
            if !(0.0..=e.dot(e)).contains(&u) {
                return m;
            }
            let d = front.dot(c - a);
            let sep = d - radius;
            if sep > margin {
                return m;
            }
            m.normal = xa.q.rotate(front);
            let p = xa.apply(c - front * (0.5 * (d + radius)));
            m.points[0] = point(p, xa, xb, sep, 1 << 29);
            m.count = 1;
        }
        Shape::Polygon(poly) => {
            let rel = xa.inv_mul(xb);
            let mut inc = 0;
            let mut min_dot = f32::MAX;
            for i in 0..poly.count {
                let d = front.dot(rel.q.rotate(poly.normals[i]));
                if d < min_dot {
                    min_dot = d;
                    inc = i;
                }
            }
            let inc2 = (inc + 1) % poly.count;
            let t = (b - a).normalize();
            let id = |v: usize| (1u32 << 29) | v as u32;
            let mut seg = [
                (rel.apply(poly.vertices[inc]), id(inc)),
                (rel.apply(poly.vertices[inc2]), id(inc2)),
            ];
            if !(clip(&mut seg, -t, -t.dot(a)) && clip(&mut seg, t, t.dot(b))) {
                return m;
            }
            m.normal = xa.q.rotate(front);
            for &(p, id) in &seg {
                let core_sep = front.dot(p - a);
                let sep = core_sep - poly.radius;
                if sep > margin {
                    continue;
                }
                let mid = p - front * (0.5 * (core_sep + poly.radius));
                m.points[m.count] = point(xa.apply(mid), xa, xb, sep, id);
                m.count += 1;
            }
        }
        Shape::Chain(_) => {}
    }
    m
}

/// Clips a segment to the half-plane normal.p <= offset; a clipped end keeps its id.
/// Returns false when nothing is left.
#[inline]
fn clip(seg: &mut [(Vec2, FeatureId); 2], normal: Vec2, offset: f32) -> bool {
    let d0 = normal.dot(seg[0].0) - offset;
    let d1 = normal.dot(seg[1].0) - offset;
    if d0 <= 0.0 && d1 <= 0.0 {
        return true;
    }
    if d0 > 0.0 && d1 > 0.0 {
        return false;
    }
    let t = d0 / (d0 - d1);
    let p = seg[0].0 + t * (seg[1].0 - seg[0].0);
    if d0 > 0.0 {
        seg[0].0 = p;
    } else {
        seg[1].0 = p;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::defs::ShapeDef;
    use crate::math::Rot;

    fn shape(def: ShapeDef) -> Shape {
        Shape::from_def(&def).unwrap().0
    }

    fn at(x: f32, y: f32, angle: f32) -> Transform {
        Transform {
            p: Vec2::new(x, y),
            q: Rot::from_angle(angle),
        }
    }

    fn capsule(length: f32, radius: f32) -> Shape {
        shape(ShapeDef::Capsule { length, radius })
    }

    /// A box resting half on the box below, as in a pyramid: as their tilts cross,
    /// the reference face passes from the lower box to the upper one and back.
    #[test]
    fn a_point_keeps_its_id_when_the_reference_face_passes_to_the_other_box() {
        let unit = || {
            shape(ShapeDef::Box {
                width: 1.0,
                height: 1.0,
            })
        };
        let (lower, upper) = (unit(), unit());
        let mut seen = vec![];
        for tilt in [-0.004f32, -0.002, 0.0, 0.002, 0.004] {
            // the upper box turns one way, the lower the other: which face separates
            // better (and so is the reference face) switches at zero
            let xa = at(0.0, 0.0, -tilt);
            let xb = at(0.5, 0.999, tilt);
            let m = collide(&lower, &xa, &upper, &xb, 0.004);
            assert_eq!(m.count, 2, "tilt {tilt}");
            let mut by_x: Vec<(f32, FeatureId)> =
                m.points().iter().map(|p| (p.point.x, p.id)).collect();
            by_x.sort_by(|a, b| a.0.total_cmp(&b.0));
            seen.push((tilt, by_x));
        }
        // the left point (x near 0) and the right one (x near 0.5) keep their ids
        let first = (seen[0].1[0].1, seen[0].1[1].1);
        assert_ne!(first.0, first.1);
        for (tilt, pts) in &seen {
            assert!(pts[0].0 < 0.1 && pts[1].0 > 0.4, "tilt {tilt}: {pts:?}");
            assert_eq!((pts[0].1, pts[1].1), first, "tilt {tilt}: {pts:?}");
        }
    }

    #[test]
    fn a_capsule_lying_on_a_box_touches_at_two_points_a_gap_apart() {
        let ground = shape(ShapeDef::Box {
            width: 10.0,
            height: 1.0,
        });
        let cap = capsule(2.0, 0.25);
        let gap = 0.01;
        // box top at y = 0.5; capsule centre 0.25 + gap above it
        let m = collide(
            &ground,
            &at(0.0, 0.0, 0.0),
            &cap,
            &at(0.3, 0.75 + gap, 0.0),
            0.05,
        );
        assert_eq!(m.count, 2);
        assert!((m.normal - Vec2::Y).length() < 1e-6);
        let mut xs = vec![];
        for p in m.points() {
            assert!((p.separation - gap).abs() < 1e-5, "{}", p.separation);
            assert!((p.point.y - (0.5 + 0.5 * gap)).abs() < 1e-5);
            xs.push(p.point.x);
        }
        xs.sort_by(f32::total_cmp);
        // under the ends of the straight part: 0.3 -+ 0.75
        assert!(
            (xs[0] + 0.45).abs() < 1e-5 && (xs[1] - 1.05).abs() < 1e-5,
            "{xs:?}"
        );
        // the same the other way round: normal from the capsule to the box
        let m = collide(
            &cap,
            &at(0.3, 0.75 + gap, 0.0),
            &ground,
            &at(0.0, 0.0, 0.0),
            0.05,
        );
        assert_eq!(m.count, 2);
        assert!((m.normal + Vec2::Y).length() < 1e-6);
        // out of reach: nothing
        let far = collide(&ground, &at(0.0, 0.0, 0.0), &cap, &at(0.3, 0.9, 0.0), 0.05);
        assert_eq!(far.count, 0);
    }

    #[test]
    fn capsules_end_to_end_and_a_capsule_end_on_a_circle_touch_along_the_centre_line() {
        let cap = capsule(2.0, 0.25);
        // in line along x: caps' tips at x = 1 and x = 1 + gap
        for gap in [0.02f32, -0.01] {
            let m = collide(
                &cap,
                &at(0.0, 0.0, 0.0),
                &cap,
                &at(2.0 + gap, 0.0, 0.0),
                0.05,
            );
            assert_eq!(m.count, 1, "gap {gap}");
            assert!((m.normal - Vec2::X).length() < 1e-5, "{}", m.normal);
            assert!((m.points[0].separation - gap).abs() < 1e-5);
            assert!((m.points[0].point - Vec2::new(1.0 + 0.5 * gap, 0.0)).length() < 1e-5);
        }
        // a capsule tilted by 90 degrees, its lower cap 0.03 above a circle
        let ball = Shape::Circle { radius: 0.5 };
        let m = collide(
            &cap,
            &at(0.0, 1.53, std::f32::consts::FRAC_PI_2),
            &ball,
            &at(0.0, 0.0, 0.0),
            0.05,
        );
        assert_eq!(m.count, 1);
        assert!((m.normal + Vec2::Y).length() < 1e-5);
        assert!((m.points[0].separation - 0.03).abs() < 1e-5);
    }

    #[test]
    fn rounded_corners_meet_along_the_line_between_their_centres() {
        let rb = shape(ShapeDef::RoundedBox {
            width: 1.0,
            height: 1.0,
            radius: 0.2,
        });
        // corner centres at (0.3, 0.3) and (1.3, 0.3 + d) - ... : place B diagonal so its
        // (-0.3, -0.3) corner centre is at (0.3 + a, 0.3 + a) from A's
        let a = 0.3f32;
        let m = collide(
            &rb,
            &at(0.0, 0.0, 0.0),
            &rb,
            &at(0.6 + a, 0.6 + a, 0.0),
            0.1,
        );
        assert_eq!(m.count, 1);
        let dir = Vec2::new(1.0, 1.0).normalize();
        assert!((m.normal - dir).length() < 1e-5, "{}", m.normal);
        let want = a * 2f32.sqrt() - 0.4;
        assert!((m.points[0].separation - want).abs() < 1e-5);
        // face to face a sharp box's way: two points, separation = the gap
        let m = collide(&rb, &at(0.0, 0.0, 0.0), &rb, &at(0.2, 1.01, 0.0), 0.1);
        assert_eq!(m.count, 2);
        for p in m.points() {
            assert!((p.separation - 0.01).abs() < 1e-5);
        }
    }

    #[test]
    fn a_box_on_a_segment_touches_at_its_two_bottom_corners() {
        let seg = shape(ShapeDef::Segment {
            a: Vec2::new(-3.0, 0.0),
            b: Vec2::new(3.0, 0.0),
        });
        let b = shape(ShapeDef::Box {
            width: 1.0,
            height: 1.0,
        });
        for (y, n) in [(0.49f32, Vec2::Y), (-0.49, -Vec2::Y)] {
            let m = collide(&seg, &at(0.0, 0.0, 0.0), &b, &at(1.0, y, 0.0), 0.05);
            assert_eq!(m.count, 2, "box at y = {y}");
            assert!((m.normal - n).length() < 1e-6);
            for p in m.points() {
                assert!((p.separation + 0.01).abs() < 1e-5);
            }
        }
        // past the segment's end: nothing
        let m = collide(&seg, &at(0.0, 0.0, 0.0), &b, &at(3.6, 0.49, 0.0), 0.05);
        assert_eq!(m.count, 0);
    }

    proptest::proptest! {
        /// Two boxes take the four-lane SAT; the general polygon path must give the same
        /// manifold to the bit (the large pyramid's state hash depends on it).
        #[test]
        fn the_four_lane_box_path_gives_the_general_paths_bits(
            wa in 0.05f32..4.0, ha in 0.05f32..4.0, wb in 0.05f32..4.0, hb in 0.05f32..4.0,
            xa in -50.0f32..50.0, ya in -50.0f32..50.0, aa in -7.0f32..7.0,
            dx in -3.0f32..3.0, dy in -3.0f32..3.0, ab in -7.0f32..7.0,
            margin in 0.0f32..0.2,
        ) {
            let (Shape::Polygon(pa), Shape::Polygon(pb)) = (
                shape(ShapeDef::Box { width: wa, height: ha }),
                shape(ShapeDef::Box { width: wb, height: hb }),
            ) else {
                panic!("a box is a polygon");
            };
            let (ta, tb) = (at(xa, ya, aa), at(xa + dx, ya + dy, ab));
            let four = collide_polygons_n::<4>(&pa, 4, &ta, &pb, 4, &tb, margin);
            let general = collide_polygons_n::<MAX_POLYGON_VERTICES>(&pa, 4, &ta, &pb, 4, &tb, margin);
            proptest::prop_assert_eq!(format!("{four:?}"), format!("{general:?}"));
        }

        /// A polygon made from points (a box, a hull) has exact edges; a moved one
        /// says whether it still has; and where a polygon says so, the SAT's clipping
        /// gives the bits of the path that normalises the edge.
        #[test]
        fn the_edge_from_the_normal_gives_the_normalised_edges_bits(
            w in 0.01f32..40.0, h in 0.01f32..40.0,
            pts in proptest::collection::vec((-20.0f32..20.0, -20.0f32..20.0), 3..12),
            d in (-3.0f32..3.0, -3.0f32..3.0),
            xb in (-3.0f32..3.0, -3.0f32..3.0, -7.0f32..7.0),
            margin in 0.0f32..0.2,
        ) {
            use crate::shape::Polygon;
            let hull = Polygon::hull(&pts.iter().map(|&(x, y)| Vec2::new(x, y)).collect::<Vec<_>>()).ok();
            let made = std::iter::once(Polygon::new_box(w, h)).chain(hull);
            for p in made {
                proptest::prop_assert!(p.exact_edges && p.edges_match_normals());
                let moved = p.translated(Vec2::new(d.0, d.1));
                proptest::prop_assert_eq!(moved.exact_edges, moved.edges_match_normals());
                for a in [p, moved] {
                    let b = Polygon::new_box(w, h);
                    let (ta, tb) = (at(0.0, 0.0, 0.0), at(xb.0, xb.1, xb.2));
                    let plain = Polygon { exact_edges: false, ..a };
                    let fast = collide_polygons(&a, &ta, &b, &tb, margin);
                    let slow = collide_polygons(&plain, &ta, &b, &tb, margin);
                    proptest::prop_assert_eq!(format!("{fast:?}"), format!("{slow:?}"));
                }
            }
        }
    }
}
