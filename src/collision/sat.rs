//! The narrow phase by the separating axis theorem: polygon-polygon (reference and
//! incident faces, clipping, up to 2 points), circle-polygon and circle-circle.
//!
//! Points are kept while their separation is below `margin` (speculative contacts), so a
//! resting contact survives tiny bounces and its cached lambdas keep warm-starting.

use super::{ContactPoint, FeatureId, Manifold};
use crate::math::{Transform, Vec2};
use crate::shape::{MAX_POLYGON_VERTICES, Polygon, Shape};

/// A reference face of B is chosen over A's only when it separates better by this much (m),
/// so the choice does not flicker between nearly equal faces.
const FACE_SWITCH_TOLERANCE: f32 = 0.0005;

/// The manifold between two shapes placed by their transforms, normal from A to B.
pub fn collide(sa: &Shape, xa: &Transform, sb: &Shape, xb: &Transform, margin: f32) -> Manifold {
    match (sa, sb) {
        (Shape::Polygon(pa), Shape::Polygon(pb)) => collide_polygons(pa, xa, pb, xb, margin),
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
    if best_sep > radius + margin {
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
    let sep = dist - radius;
    if sep > margin {
        return m;
    }
    // midpoint between the polygon surface (c - n dist) and the circle surface (c - n r)
    let local = c - normal * (0.5 * (dist + radius));
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
    for i in 0..nb_count {
        vb[i] = rel.apply(pb.vertices[i]);
        nb[i] = rel.q.rotate(pb.normals[i]);
    }
    let va = &pa.vertices[..na_count];
    let na = &pa.normals[..na_count];
    let vb = &vb[..nb_count];
    let nb = &nb[..nb_count];

    let (edge_a, sep_a) = max_separation(va, na, vb);
    if sep_a > margin {
        return m;
    }
    let (edge_b, sep_b) = max_separation(vb, nb, va);
    if sep_b > margin {
        return m;
    }

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
    let r2 = rv[(ref_edge + 1) % rv.len()];
    let t = (r2 - r1).normalize();

    // The incident segment with a feature id per end: the reference edge and the
    // incident vertex that end starts from. An end keeps its id when it is clipped: in
    // an aligned stack the incident vertices sit on the side planes, and an id that
    // changed with clipping flipped on 1e-7 m of jitter and lost the cached lambdas.
    let flip_bit: u32 = if flipped { 1 << 31 } else { 0 };
    let vertex_id = |v: usize| flip_bit | ((ref_edge as u32) << 8) | v as u32;
    let mut seg = [(iv[inc], vertex_id(inc)), (iv[inc2], vertex_id(inc2))];

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
