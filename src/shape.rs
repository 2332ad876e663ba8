//! Collision shapes in a body's local frame (origin at the centre of mass), their mass
//! properties and bounding boxes.

use crate::defs::ShapeDef;
use crate::math::{Aabb, Transform, Vec2, cross};

/// The most vertices a polygon may have (after the convex hull is taken).
pub const MAX_POLYGON_VERTICES: usize = 16;

/// Points closer than this (m) are welded into one when the hull is built.
const WELD_DISTANCE: f32 = 1e-4;

/// A convex polygon, counter-clockwise, with its outward edge normals, and a rounding
/// radius: the shape is every point within `radius` of the polygon (its core). Edge i
/// runs from vertex i to vertex i + 1.
///
/// Two vertices make a segment (normals on both sides): with a radius, a capsule; with
/// none, a segment of no thickness (static or kinematic bodies only: it has no area).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(into = "PolygonRepr", try_from = "PolygonRepr")]
pub struct Polygon {
    /// The core's vertices (m), counter-clockwise; the first `count` are used.
    pub vertices: [Vec2; MAX_POLYGON_VERTICES],
    /// Unit outward normal of edge i (vertex i to vertex i + 1); the first `count`
    /// are used.
    pub normals: [Vec2; MAX_POLYGON_VERTICES],
    /// How many vertices are used: 2 (a segment or capsule) to
    /// [`MAX_POLYGON_VERTICES`].
    pub count: usize,
    /// Rounding radius (m); 0 for sharp corners.
    pub radius: f32,
    /// Whether each edge normalised is its normal turned back, to the bit (see
    /// [`Polygon::edges_match_normals`]): the SAT's clipping then takes the edge's
    /// direction from the normal, without a square root. True for a polygon made from
    /// points; worked out again when one is moved or restored.
    pub exact_edges: bool,
}

/// A polygon as a saved state holds it: only the vertices and normals in use.
#[derive(serde::Serialize, serde::Deserialize)]
struct PolygonRepr {
    vertices: Vec<Vec2>,
    normals: Vec<Vec2>,
    #[serde(default)]
    radius: f32,
}

impl From<Polygon> for PolygonRepr {
    fn from(p: Polygon) -> Self {
        PolygonRepr {
            vertices: p.verts().to_vec(),
            normals: p.normals[..p.count].to_vec(),
            radius: p.radius,
        }
    }
}

impl TryFrom<PolygonRepr> for Polygon {
    type Error = String;

    fn try_from(r: PolygonRepr) -> Result<Self, String> {
        let n = r.vertices.len();
        if !(2..=MAX_POLYGON_VERTICES).contains(&n) || r.normals.len() != n {
            return Err(format!(
                "a polygon needs 2 to {MAX_POLYGON_VERTICES} vertices and as many normals, got {n} and {}",
                r.normals.len()
            ));
        }
        if !(r.radius >= 0.0 && r.radius.is_finite()) {
            return Err(format!(
                "a polygon's radius must be finite and >= 0, got {}",
                r.radius
            ));
        }
        let mut p = Polygon {
            vertices: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            normals: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            count: n,
            radius: r.radius,
            exact_edges: false,
        };
        p.vertices[..n].copy_from_slice(&r.vertices);
        p.normals[..n].copy_from_slice(&r.normals);
        p.exact_edges = p.edges_match_normals();
        Ok(p)
    }
}

impl Polygon {
    /// The vertices in use.
    pub fn verts(&self) -> &[Vec2] {
        &self.vertices[..self.count]
    }

    /// A box of full width `w` and height `h` centred on the origin.
    pub fn new_box(w: f32, h: f32) -> Polygon {
        let (hx, hy) = (0.5 * w, 0.5 * h);
        Polygon::from_ccw(&[
            Vec2::new(-hx, -hy),
            Vec2::new(hx, -hy),
            Vec2::new(hx, hy),
            Vec2::new(-hx, hy),
        ])
    }

    /// The segment from `a` to `b` rounded by `radius` (0: a bare segment): two
    /// vertices, edge 0 from `a` to `b` with its normal on the right of `b - a`, edge 1
    /// back with the opposite normal.
    pub fn segment(a: Vec2, b: Vec2, radius: f32) -> Polygon {
        Polygon {
            radius,
            ..Polygon::from_ccw(&[a, b])
        }
    }

    /// The polygon with its corners rounded by `radius` (the outline moves out by it).
    pub fn rounded(&self, radius: f32) -> Polygon {
        Polygon { radius, ..*self }
    }

    /// From counter-clockwise convex points (at most [`MAX_POLYGON_VERTICES`]).
    fn from_ccw(points: &[Vec2]) -> Polygon {
        let mut p = Polygon {
            vertices: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            normals: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            count: points.len(),
            radius: 0.0,
            exact_edges: false,
        };
        for (i, &v) in points.iter().enumerate() {
            p.vertices[i] = v;
        }
        for i in 0..p.count {
            let e = p.vertices[(i + 1) % p.count] - p.vertices[i];
            // outward normal of a CCW edge: e rotated by -90 degrees
            p.normals[i] = Vec2::new(e.y, -e.x).normalize();
        }
        // (e.y, -e.x) normalised and e normalised take the same squares, summed in the
        // other order (which rounds the same), and the same reciprocal: so this holds
        p.exact_edges = p.edges_match_normals();
        p
    }

    /// Whether every edge, normalised, is its normal turned back by 90 degrees to the
    /// bit: `(v[i+1] - v[i]) / |v[i+1] - v[i]| == (-n.y, n.x)`.
    pub fn edges_match_normals(&self) -> bool {
        let v = self.verts();
        self.normals[..self.count].iter().enumerate().all(|(i, n)| {
            let t = (v[(i + 1) % v.len()] - v[i]).normalize();
            t.x.to_bits() == (-n.y).to_bits() && t.y.to_bits() == n.x.to_bits()
        })
    }

    /// The convex hull of `points`, or a reason it does not exist.
    pub fn hull(points: &[Vec2]) -> Result<Polygon, ShapeError> {
        let hull = convex_hull(points);
        if hull.len() < 3 {
            return Err(ShapeError::Degenerate);
        }
        if hull.len() > MAX_POLYGON_VERTICES {
            return Err(ShapeError::TooManyVertices(hull.len()));
        }
        Ok(Polygon::from_ccw(&hull))
    }

    /// The polygon moved by `d`.
    pub fn translated(&self, d: Vec2) -> Polygon {
        let mut p = *self;
        for v in &mut p.vertices[..p.count] {
            *v += d;
        }
        // a moved edge can round differently from the normal made before
        p.exact_edges = p.edges_match_normals();
        p
    }

    /// Area, centroid and second moment about the centroid per unit density.
    fn area_centroid_inertia(&self) -> (f32, Vec2, f32) {
        // Triangle fan from the first vertex (shifts reduce round-off).
        let origin = self.vertices[0];
        let mut area = 0.0;
        let mut center = Vec2::ZERO;
        let mut inertia = 0.0; // about `origin`
        for i in 1..self.count - 1 {
            let e1 = self.vertices[i] - origin;
            let e2 = self.vertices[i + 1] - origin;
            let d = cross(e1, e2);
            let tri_area = 0.5 * d;
            area += tri_area;
            // centroid of the triangle (origin, e1, e2) = (e1 + e2) / 3
            center += tri_area * (e1 + e2) / 3.0;
            // J_origin = d/12 * (|e1|^2 + e1.e2 + |e2|^2) for a triangle with a vertex at the origin
            inertia += d / 12.0 * (e1.dot(e1) + e1.dot(e2) + e2.dot(e2));
        }
        let c = center / area;
        // parallel axis: J_c = J_origin - A |c|^2
        let j = inertia - area * c.dot(c);
        (area, c + origin, j)
    }
}

impl Polygon {
    /// Area, centroid and second moment about the centroid per unit density, of the
    /// whole shape: the core polygon, a band of width `radius` outside each edge, and a
    /// circular sector at each vertex (the sectors' angles add up to a full turn).
    fn rounded_area_centroid_inertia(&self) -> (f32, Vec2, f32) {
        let r = self.radius;
        if r == 0.0 {
            if self.count < 3 {
                return (0.0, Vec2::ZERO, 0.0); // a bare segment
            }
            return self.area_centroid_inertia();
        }
        // sums over the parts: mass, first moment and second moment about the origin
        let (mut mass, mut first, mut second) = (0.0f32, Vec2::ZERO, 0.0f32);
        let mut add = |m: f32, c: Vec2, j_c: f32| {
            mass += m;
            first += m * c;
            second += j_c + m * c.length_squared();
        };
        if self.count >= 3 {
            let (a, c, j) = self.area_centroid_inertia();
            add(a, c, j);
        }
        let n = self.count;
        for i in 0..n {
            let (v1, v2) = (self.vertices[i], self.vertices[(i + 1) % n]);
            let normal = self.normals[i];
            // the band outside edge i: a rectangle l x r
            let l = v1.distance(v2);
            add(
                l * r,
                0.5 * (v1 + v2) + 0.5 * r * normal,
                l * r * (l * l + r * r) / 12.0,
            );
            // the sector at v2, from this edge's normal to the next one's (counter-clockwise)
            let next = self.normals[(i + 1) % n];
            let mut angle = cross(normal, next).atan2(normal.dot(next));
            if angle < 0.0 {
                angle += std::f32::consts::TAU; // a half turn met as -pi (a capsule's end)
            }
            if angle <= 0.0 {
                continue;
            }
            let half = 0.5 * angle;
            let area = half * r * r;
            // centroid 4 r sin(half) / (3 angle) from the apex along the bisector
            let d = 4.0 * r * half.sin() / (3.0 * angle);
            let (s, c) = half.sin_cos();
            let bisector = Vec2::new(c * normal.x - s * normal.y, s * normal.x + c * normal.y);
            // polar moment about the apex: area r^2 / 2
            let j_apex = 0.5 * area * r * r;
            add(area, v2 + d * bisector, j_apex - area * d * d);
        }
        let c = first / mass;
        (mass, c, second - mass * c.length_squared())
    }

    /// The closest point of the core polygon to `p` (all in the polygon's frame), and
    /// whether `p` lies inside the core.
    fn closest_core_point(&self, p: Vec2) -> (Vec2, bool) {
        let n = self.count;
        let inside = n >= 3
            && self
                .verts()
                .iter()
                .zip(&self.normals[..n])
                .all(|(v, nn)| nn.dot(p - *v) <= 0.0);
        if inside {
            return (p, true);
        }
        let mut best = self.vertices[0];
        let mut best_d = f32::MAX;
        for i in 0..n {
            let q = closest_on_segment(self.vertices[i], self.vertices[(i + 1) % n], p).0;
            let d = q.distance_squared(p);
            if d < best_d {
                best_d = d;
                best = q;
            }
        }
        (best, false)
    }
}

/// The point of the segment `a`-`b` closest to `p`, and its parameter in [0, 1].
#[inline]
pub fn closest_on_segment(a: Vec2, b: Vec2, p: Vec2) -> (Vec2, f32) {
    let e = b - a;
    let ee = e.dot(e);
    let t = if ee > 0.0 {
        ((p - a).dot(e) / ee).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + t * e, t)
}

/// Where the segment `origin + t d`, t in [0, 1], first meets the segment `a`-`b`
/// coming from the side `normal` points to: `t`.
fn ray_segment(origin: Vec2, d: Vec2, a: Vec2, b: Vec2, normal: Vec2) -> Option<f32> {
    let den = normal.dot(d);
    if den >= 0.0 {
        return None; // parallel or leaving
    }
    let t = normal.dot(a - origin) / den;
    if !(0.0..=1.0).contains(&t) {
        return None;
    }
    let e = b - a;
    let u = (origin + t * d - a).dot(e);
    (0.0..=e.dot(e)).contains(&u).then_some(t)
}

/// Where the segment `origin + t d`, t in [0, 1], enters the circle at `center`.
fn ray_circle(origin: Vec2, d: Vec2, center: Vec2, radius: f32) -> Option<f32> {
    let o = origin - center;
    let dd = d.dot(d);
    let c = o.dot(o) - radius * radius;
    if dd <= 0.0 || c <= 0.0 {
        return None;
    }
    let b = o.dot(d);
    let disc = b * b - dd * c;
    if b >= 0.0 || disc < 0.0 {
        return None;
    }
    let t = c / (-b + disc.sqrt());
    (0.0..=1.0).contains(&t).then_some(t)
}

/// Why a shape could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A polygon's points have fewer than 3 distinct points or enclose no area.
    #[error("polygon has fewer than 3 distinct points or no area")]
    Degenerate,
    /// A polygon's convex hull has this many vertices, more than
    /// [`MAX_POLYGON_VERTICES`].
    #[error("polygon hull has {0} vertices; at most {MAX_POLYGON_VERTICES} are supported")]
    TooManyVertices(usize),
    /// A size that must be above 0 is not: which one (e.g. `"circle radius"`) and its
    /// value.
    #[error("{0} must be > 0, got {1}")]
    NotPositive(&'static str, f32),
    /// Any other problem (a capsule too short for its radius, a segment with equal
    /// ends, a compound with no parts or too many, ...), said in full.
    #[error("{0}")]
    Invalid(String),
}

/// Andrew's monotone chain; returns the hull counter-clockwise without collinear points.
fn convex_hull(points: &[Vec2]) -> Vec<Vec2> {
    let mut pts: Vec<Vec2> = Vec::with_capacity(points.len());
    for &p in points {
        if !pts.iter().any(|q| q.distance(p) < WELD_DISTANCE) {
            pts.push(p);
        }
    }
    if pts.len() < 3 {
        return pts;
    }
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let mut hull: Vec<Vec2> = Vec::with_capacity(2 * pts.len());
    // Drop a point unless it makes a strict left turn (area tolerance removes near-collinear points).
    let turn = |o: Vec2, a: Vec2, b: Vec2| cross(a - o, b - o);
    let eps = 1e-9_f32.max(1e-7 * pts.iter().fold(0.0f32, |m, p| m.max(p.length_squared())));
    for &p in &pts {
        while hull.len() >= 2 && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= eps {
            hull.pop();
        }
        hull.push(p);
    }
    let lower = hull.len() + 1;
    for &p in pts.iter().rev().skip(1) {
        while hull.len() >= lower && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= eps {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop();
    hull
}

/// One segment of a polyline, in its body's frame: the segment `a`-`b` and its
/// neighbours' far ends (ghost vertices), which decide which contact normals are real.
/// At a flat or concave joint only this segment's face normal is, so a box sliding
/// across the joint is not caught by the next segment's end; at a convex joint normals
/// between the two faces' are, and the joint's contact belongs to the segment before it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChainSegment {
    /// The segment's start, in the body's frame (m).
    pub a: Vec2,
    /// The segment's end, in the body's frame (m).
    pub b: Vec2,
    /// The previous segment's start (`None`: `a` is an open end).
    pub prev: Option<Vec2>,
    /// The next segment's end (`None`: `b` is an open end).
    pub next: Option<Vec2>,
    /// Only the side left of `a` -> `b` collides.
    pub one_sided: bool,
}

impl ChainSegment {
    /// The unit normal on the left of `a` -> `b` (the solid side is on the right).
    pub fn left_normal(&self) -> Vec2 {
        (self.b - self.a).perp().normalize()
    }
}

/// A collision shape in the body frame, centred so the body origin is the centre of mass.
// Kept inline (Copy, no box): a polygon is the common case and the solvers read it hot.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Shape {
    /// A circle centred on the centre of mass.
    Circle {
        /// Radius (m).
        radius: f32,
    },
    /// A convex polygon, possibly rounded: boxes, polygons, capsules, segments.
    Polygon(Polygon),
    /// One segment of a polyline, with its neighbours' ends.
    Chain(ChainSegment),
    /// A compound body's marker: the parts are [`crate::Body::parts`]; `radius` bounds
    /// them all about the centre of mass. The shape's own queries answer for that disk
    /// (a box, an extent) or for nothing (area, mass, containment, rays); the body's
    /// ([`crate::Body::aabb`], `contains_local`, `ray_cast_local`) look at the parts.
    Compound {
        /// Radius (m) of a disk about the centre of mass that holds every part.
        radius: f32,
    },
}

/// Mass, centroid and rotational inertia of a shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassData {
    /// kg
    pub mass: f32,
    /// Centre of mass in the shape's frame (m).
    pub center: Vec2,
    /// kg m^2, about the centre of mass.
    pub inertia: f32,
}

impl Shape {
    /// Builds the shape from its description, and returns where its centroid lies in the
    /// description's frame. The shape itself is re-centred on that centroid.
    ///
    /// A shape whose derived numbers do not fit f32 (a box so thin that an edge's
    /// normal cannot be worked out, a segment so long that its length overflows) is
    /// refused here, so that every shape a world holds can be saved and read back.
    pub fn from_def(def: &ShapeDef) -> Result<(Shape, Vec2), ShapeError> {
        let (shape, c) = Self::from_def_unchecked(def)?;
        if let Err(why) = shape.check_sound() {
            return Err(ShapeError::Invalid(format!(
                "the shape does not fit f32 ({why}): too small or too large to simulate"
            )));
        }
        if !c.is_finite() {
            return Err(ShapeError::Invalid(
                "the shape's centroid is not finite: too large to simulate".into(),
            ));
        }
        Ok((shape, c))
    }

    /// Whether every number of the shape is finite and consistent: radii finite and
    /// positive, vertices finite, each edge normal a unit vector, a polyline segment of
    /// finite, non-zero length. `Err` says what is wrong, in a few words. What
    /// [`Shape::from_def`] makes passes; a shape read from a damaged state may not.
    pub fn check_sound(&self) -> Result<(), String> {
        match self {
            Shape::Circle { radius } | Shape::Compound { radius } => {
                if !(radius.is_finite() && *radius > 0.0) {
                    return Err(format!("radius {radius}"));
                }
            }
            Shape::Polygon(p) => {
                if !(2..=MAX_POLYGON_VERTICES).contains(&p.count) {
                    return Err(format!("{} vertices", p.count));
                }
                if !(p.radius.is_finite() && p.radius >= 0.0) {
                    return Err(format!("rounding radius {}", p.radius));
                }
                for i in 0..p.count {
                    let (v, n) = (p.vertices[i], p.normals[i]);
                    if !v.is_finite() {
                        return Err(format!("vertex {i} is {v}"));
                    }
                    if !(n.is_finite() && (n.length_squared() - 1.0).abs() < 1e-3) {
                        return Err(format!("the normal of edge {i} is {n}, not a unit vector"));
                    }
                    let e = p.vertices[(i + 1) % p.count] - v;
                    if !e.length_squared().is_finite() {
                        return Err(format!("edge {i}'s length is not finite"));
                    }
                }
            }
            Shape::Chain(c) => {
                let ends = [Some(c.a), Some(c.b), c.prev, c.next];
                if let Some(v) = ends.iter().flatten().find(|v| !v.is_finite()) {
                    return Err(format!("a point is {v}"));
                }
                let l = (c.b - c.a).length_squared();
                if !(l.is_finite() && l > 0.0) {
                    return Err("the segment's length is zero or not finite".into());
                }
            }
        }
        Ok(())
    }

    fn from_def_unchecked(def: &ShapeDef) -> Result<(Shape, Vec2), ShapeError> {
        match def {
            ShapeDef::Circle { radius } => {
                if !(*radius > 0.0) {
                    return Err(ShapeError::NotPositive("circle radius", *radius));
                }
                Ok((Shape::Circle { radius: *radius }, Vec2::ZERO))
            }
            ShapeDef::Box { width, height } => {
                if !(*width > 0.0) {
                    return Err(ShapeError::NotPositive("box width", *width));
                }
                if !(*height > 0.0) {
                    return Err(ShapeError::NotPositive("box height", *height));
                }
                Ok((
                    Shape::Polygon(Polygon::new_box(*width, *height)),
                    Vec2::ZERO,
                ))
            }
            ShapeDef::Polygon { points } => {
                let poly = Polygon::hull(points)?;
                let (area, c, _) = poly.area_centroid_inertia();
                if !(area > 1e-12) {
                    return Err(ShapeError::Degenerate);
                }
                Ok((Shape::Polygon(poly.translated(-c)), c))
            }
            ShapeDef::Capsule { length, radius } => {
                if !(*radius > 0.0 && radius.is_finite()) {
                    return Err(ShapeError::NotPositive("capsule radius", *radius));
                }
                if !(*length > 2.0 * radius && length.is_finite()) {
                    return Err(ShapeError::Invalid(format!(
                        "capsule length must be more than twice its radius ({}), got {length}",
                        2.0 * radius
                    )));
                }
                let half = 0.5 * length - radius;
                Ok((
                    Shape::Polygon(Polygon::segment(
                        Vec2::new(-half, 0.0),
                        Vec2::new(half, 0.0),
                        *radius,
                    )),
                    Vec2::ZERO,
                ))
            }
            ShapeDef::RoundedBox {
                width,
                height,
                radius,
            } => {
                let (sharp, c) = Shape::from_def(&ShapeDef::Box {
                    width: *width,
                    height: *height,
                })?;
                if *radius == 0.0 {
                    return Ok((sharp, c));
                }
                if !(*radius > 0.0 && 2.0 * radius < width.min(*height)) {
                    return Err(ShapeError::Invalid(format!(
                        "box radius must be >= 0 and less than half the smaller side ({}), got {radius}",
                        0.5 * width.min(*height)
                    )));
                }
                let core = Polygon::new_box(width - 2.0 * radius, height - 2.0 * radius);
                Ok((Shape::Polygon(core.rounded(*radius)), Vec2::ZERO))
            }
            ShapeDef::RoundedPolygon { points, radius } => {
                if !(*radius >= 0.0 && radius.is_finite()) {
                    return Err(ShapeError::Invalid(format!(
                        "polygon radius must be finite and >= 0, got {radius}"
                    )));
                }
                let (sharp, c) = Shape::from_def(&ShapeDef::Polygon {
                    points: points.clone(),
                })?;
                let Shape::Polygon(core) = sharp else {
                    unreachable!("a polygon def builds a polygon")
                };
                let rounded = core.rounded(*radius);
                // the bands and sectors shift the centroid a little off the core's
                let (_, dc, _) = rounded.rounded_area_centroid_inertia();
                Ok((Shape::Polygon(rounded.translated(-dc)), c + dc))
            }
            ShapeDef::Segment { a, b } => {
                if !(a.is_finite() && b.is_finite()) || a.distance(*b) < WELD_DISTANCE {
                    return Err(ShapeError::Invalid(format!(
                        "segment needs two distinct finite ends, got {a} and {b}"
                    )));
                }
                let mid = 0.5 * (*a + *b);
                Ok((
                    Shape::Polygon(Polygon::segment(*a - mid, *b - mid, 0.0)),
                    mid,
                ))
            }
            ShapeDef::ChainSegment {
                a,
                b,
                prev,
                next,
                one_sided,
            } => {
                let apart = |p: &Vec2, q: Vec2| p.is_finite() && p.distance(q) >= WELD_DISTANCE;
                let ghosts_ok = prev.as_ref().is_none_or(|p| apart(p, *a))
                    && next.as_ref().is_none_or(|p| apart(p, *b));
                if !(a.is_finite() && apart(b, *a) && ghosts_ok) {
                    return Err(ShapeError::Invalid(format!(
                        "polyline segment needs distinct finite points, got {a} and {b} (neighbours {prev:?}, {next:?})"
                    )));
                }
                let mid = 0.5 * (*a + *b);
                Ok((
                    Shape::Chain(ChainSegment {
                        a: *a - mid,
                        b: *b - mid,
                        prev: prev.map(|p| p - mid),
                        next: next.map(|p| p - mid),
                        one_sided: *one_sided,
                    }),
                    mid,
                ))
            }
            ShapeDef::Compound { .. } => Err(ShapeError::Invalid(
                "a compound's parts are built with its body (World::make_body)".into(),
            )),
        }
    }

    /// The area (m^2).
    pub fn area(&self) -> f32 {
        match self {
            Shape::Circle { radius } => std::f32::consts::PI * radius * radius,
            Shape::Polygon(p) => p.rounded_area_centroid_inertia().0,
            Shape::Chain(_) | Shape::Compound { .. } => 0.0,
        }
    }

    /// Mass properties for a uniform density (kg/m^2).
    pub fn mass_data(&self, density: f32) -> MassData {
        match self {
            Shape::Circle { radius } => {
                let m = density * std::f32::consts::PI * radius * radius;
                // I = m r^2 / 2
                MassData {
                    mass: m,
                    center: Vec2::ZERO,
                    inertia: 0.5 * m * radius * radius,
                }
            }
            Shape::Polygon(p) => {
                let (area, c, j) = p.rounded_area_centroid_inertia();
                MassData {
                    mass: density * area,
                    center: c,
                    inertia: density * j,
                }
            }
            Shape::Chain(_) | Shape::Compound { .. } => MassData {
                mass: 0.0,
                center: Vec2::ZERO,
                inertia: 0.0,
            },
        }
    }

    /// Whether the point `p`, in the shape's frame, lies inside the shape or on its
    /// boundary.
    pub fn contains_local(&self, p: Vec2) -> bool {
        match self {
            Shape::Circle { radius } => p.length_squared() <= radius * radius,
            Shape::Polygon(poly) if poly.radius == 0.0 && poly.count >= 3 => poly
                .verts()
                .iter()
                .zip(&poly.normals[..poly.count])
                .all(|(v, n)| n.dot(p - *v) <= 0.0),
            Shape::Polygon(poly) => {
                let (q, inside) = poly.closest_core_point(p);
                inside || q.distance_squared(p) <= poly.radius * poly.radius
            }
            Shape::Chain(_) | Shape::Compound { .. } => false,
        }
    }

    /// Where the segment `origin + t d`, t in [0, 1], first enters the shape, all in
    /// the shape's frame: `(t, outward normal)`. A segment that starts inside (or on the
    /// boundary heading in) reports nothing, as in Box2D: a ray finds the surfaces it
    /// crosses from outside.
    pub fn ray_cast_local(&self, origin: Vec2, d: Vec2) -> Option<(f32, Vec2)> {
        match self {
            Shape::Circle { radius } => {
                // |o + t d|^2 = r^2: t^2 dd + 2 t (o.d) + (o.o - r^2) = 0, the smaller root
                let dd = d.dot(d);
                let c = origin.dot(origin) - radius * radius;
                if dd <= 0.0 || c <= 0.0 {
                    return None;
                }
                let b = origin.dot(d);
                let disc = b * b - dd * c;
                if b >= 0.0 || disc < 0.0 {
                    return None;
                }
                // the smaller root without cancellation: c / (-b + sqrt(disc)) = t dd / dd
                let t = c / (-b + disc.sqrt());
                if !(0.0..=1.0).contains(&t) {
                    return None;
                }
                let n = (origin + d * t).normalize_or_zero();
                Some((t, n))
            }
            Shape::Compound { .. } => None,
            Shape::Chain(c) => {
                // the face the ray comes from (only the left one when one-sided)
                let n = c.left_normal();
                let faces: &[(Vec2, Vec2, Vec2)] = &[(c.a, c.b, n), (c.b, c.a, -n)];
                let faces = if c.one_sided { &faces[..1] } else { faces };
                faces
                    .iter()
                    .find_map(|&(a, b, n)| ray_segment(origin, d, a, b, n).map(|t| (t, n)))
            }
            Shape::Polygon(poly) if poly.radius > 0.0 || poly.count < 3 => {
                // The shape is the union of the core, a band outside each edge and a
                // disk at each vertex: the ray enters it where it first enters one of
                // the bands' outer sides or one of the disks.
                if poly.radius > 0.0 && self.contains_local(origin) {
                    return None;
                }
                let r = poly.radius;
                let mut best: Option<(f32, Vec2)> = None;
                let mut keep = |t: f32, n: Vec2| {
                    if best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, n));
                    }
                };
                let n = poly.count;
                for i in 0..n {
                    let (a, b, nn) = (
                        poly.vertices[i],
                        poly.vertices[(i + 1) % n],
                        poly.normals[i],
                    );
                    if let Some(t) = ray_segment(origin, d, a + r * nn, b + r * nn, nn) {
                        keep(t, nn);
                    }
                    if r > 0.0
                        && let Some(t) = ray_circle(origin, d, a, r)
                    {
                        keep(t, (origin + t * d - a).normalize_or_zero());
                    }
                }
                best
            }
            Shape::Polygon(poly) => {
                // Cyrus-Beck: clip [0, 1] by each edge's half-plane n.(x - v) <= 0
                let (mut lower, mut upper) = (0.0f32, 1.0f32);
                let mut entered: Option<usize> = None;
                for i in 0..poly.count {
                    let n = poly.normals[i];
                    let num = n.dot(poly.vertices[i] - origin);
                    let den = n.dot(d);
                    if den == 0.0 {
                        if num < 0.0 {
                            return None; // parallel and outside this edge
                        }
                    } else if den < 0.0 && num < lower * den {
                        // entering through this edge, later than any before
                        lower = num / den;
                        entered = Some(i);
                    } else if den > 0.0 && num < upper * den {
                        upper = num / den;
                    }
                    if upper < lower {
                        return None;
                    }
                }
                entered.map(|i| (lower, poly.normals[i]))
            }
        }
    }

    /// The bounding box of the shape placed by `xf`.
    #[inline]
    pub fn aabb(&self, xf: &Transform) -> Aabb {
        match self {
            Shape::Circle { radius } | Shape::Compound { radius } => Aabb {
                min: xf.p - Vec2::splat(*radius),
                max: xf.p + Vec2::splat(*radius),
            },
            Shape::Polygon(p) => {
                let v0 = xf.apply(p.vertices[0]);
                let mut b = Aabb { min: v0, max: v0 };
                for &v in &p.vertices[1..p.count] {
                    let w = xf.apply(v);
                    b.min = b.min.min(w);
                    b.max = b.max.max(w);
                }
                if p.radius > 0.0 {
                    b.min -= Vec2::splat(p.radius);
                    b.max += Vec2::splat(p.radius);
                }
                b
            }
            Shape::Chain(c) => {
                let (a, b) = (xf.apply(c.a), xf.apply(c.b));
                Aabb {
                    min: a.min(b),
                    max: a.max(b),
                }
            }
        }
    }

    /// The shape's width across the unit direction `dir` (world frame), for drag.
    pub fn extent_across(&self, xf: &Transform, dir: Vec2) -> f32 {
        match self {
            Shape::Circle { radius } | Shape::Compound { radius } => 2.0 * radius,
            Shape::Polygon(p) => {
                let perp = Vec2::new(-dir.y, dir.x);
                let local = xf.q.inv_rotate(perp);
                let (mut lo, mut hi) = (f32::MAX, f32::MIN);
                for &v in p.verts() {
                    let d = v.dot(local);
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
                hi - lo + 2.0 * p.radius
            }
            Shape::Chain(c) => {
                let perp = xf.q.inv_rotate(Vec2::new(-dir.y, dir.x));
                (c.b - c.a).dot(perp).abs()
            }
        }
    }

    /// The largest distance from the centre of mass to any point of the shape.
    pub fn radius(&self) -> f32 {
        match self {
            Shape::Circle { radius } | Shape::Compound { radius } => *radius,
            Shape::Polygon(p) => p.verts().iter().fold(0.0f32, |m, v| m.max(v.length())) + p.radius,
            Shape::Chain(c) => c.a.length().max(c.b.length()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, rel: f32) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-12)
    }

    #[test]
    fn circle_mass_and_inertia() {
        let (s, _) = Shape::from_def(&ShapeDef::Circle { radius: 0.5 }).unwrap();
        let md = s.mass_data(2.0);
        let m = 2.0 * std::f32::consts::PI * 0.25;
        assert!(close(md.mass, m, 1e-6));
        assert!(close(md.inertia, 0.5 * m * 0.25, 1e-6)); // I = m r^2 / 2
    }

    #[test]
    fn box_mass_and_inertia() {
        let (s, _) = Shape::from_def(&ShapeDef::Box {
            width: 2.0,
            height: 0.5,
        })
        .unwrap();
        let md = s.mass_data(3.0);
        let m = 3.0 * 2.0 * 0.5;
        assert!(close(md.mass, m, 1e-6));
        assert!(close(md.inertia, m * (4.0 + 0.25) / 12.0, 1e-5)); // I = m (w^2 + h^2) / 12
        assert!(md.center.length() < 1e-6);
    }

    #[test]
    fn triangle_mass_centroid_and_inertia() {
        // Right triangle with legs a, b: area ab/2, centroid (a/3, b/3),
        // polar moment about the centroid m (a^2 + b^2) / 18.
        let (a, b) = (3.0f32, 2.0f32);
        let pts = vec![Vec2::ZERO, Vec2::new(a, 0.0), Vec2::new(0.0, b)];
        let (s, c) = Shape::from_def(&ShapeDef::Polygon { points: pts }).unwrap();
        assert!((c - Vec2::new(a / 3.0, b / 3.0)).length() < 1e-5);
        let md = s.mass_data(1.0);
        let m = a * b / 2.0;
        assert!(close(md.mass, m, 1e-5));
        assert!(close(md.inertia, m * (a * a + b * b) / 18.0, 1e-4));
        assert!(md.center.length() < 1e-5, "re-centred on the centroid");
    }

    #[test]
    fn hull_drops_interior_and_collinear_points() {
        let pts = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(2.0, 0.0), // collinear
            Vec2::new(2.0, 2.0),
            Vec2::new(1.0, 1.0), // interior
            Vec2::new(0.0, 2.0),
            Vec2::new(0.0, 2.0), // duplicate
        ];
        let p = Polygon::hull(&pts).unwrap();
        assert_eq!(p.count, 4);
        // counter-clockwise: every cross product of consecutive edges positive
        for i in 0..p.count {
            let e1 = p.vertices[(i + 1) % 4] - p.vertices[i];
            let e2 = p.vertices[(i + 2) % 4] - p.vertices[(i + 1) % 4];
            assert!(cross(e1, e2) > 0.0);
        }
    }

    #[test]
    fn degenerate_polygons_refused() {
        let line = vec![Vec2::ZERO, Vec2::new(1.0, 1.0), Vec2::new(2.0, 2.0)];
        assert_eq!(
            Shape::from_def(&ShapeDef::Polygon { points: line }),
            Err(ShapeError::Degenerate)
        );
        let two = vec![Vec2::ZERO, Vec2::X, Vec2::X];
        assert_eq!(
            Shape::from_def(&ShapeDef::Polygon { points: two }),
            Err(ShapeError::Degenerate)
        );
        assert!(Shape::from_def(&ShapeDef::Circle { radius: 0.0 }).is_err());
        assert!(Shape::from_def(&ShapeDef::Circle { radius: f32::NAN }).is_err());
    }

    /// Mass, centroid and polar moment by sampling the shape on a fine grid (an
    /// integration independent of the closed forms).
    fn sampled(shape: &Shape, half: f32, n: usize) -> (f32, Vec2, f32) {
        let cell = 2.0 * half / n as f32;
        let (mut m, mut first, mut second) = (0.0f64, [0.0f64; 2], 0.0f64);
        for i in 0..n {
            for j in 0..n {
                let p = Vec2::new(
                    -half + (i as f32 + 0.5) * cell,
                    -half + (j as f32 + 0.5) * cell,
                );
                if shape.contains_local(p) {
                    let a = (cell * cell) as f64;
                    m += a;
                    first[0] += a * p.x as f64;
                    first[1] += a * p.y as f64;
                    second += a * p.length_squared() as f64;
                }
            }
        }
        let c = Vec2::new((first[0] / m) as f32, (first[1] / m) as f32);
        (m as f32, c, (second - m * c.length_squared() as f64) as f32)
    }

    #[test]
    fn capsule_mass_and_inertia_against_the_closed_form() {
        // a rectangle L x 2r and two half disks whose centroids sit 4r / (3 pi) past
        // the segment's ends
        let (length, r) = (3.0f32, 0.4f32);
        let (s, c) = Shape::from_def(&ShapeDef::Capsule { length, radius: r }).unwrap();
        assert_eq!(c, Vec2::ZERO);
        let l = length - 2.0 * r; // the straight part
        let pi = std::f32::consts::PI;
        let (m_rect, m_disk) = (l * 2.0 * r, pi * r * r);
        let d = 4.0 * r / (3.0 * pi);
        let inertia =
            m_rect * (l * l + 4.0 * r * r) / 12.0 + m_disk * (0.5 * r * r + 0.25 * l * l + l * d);
        let md = s.mass_data(1.0);
        assert!(close(md.mass, m_rect + m_disk, 1e-5), "{}", md.mass);
        assert!(
            close(md.inertia, inertia, 1e-4),
            "{} vs {inertia}",
            md.inertia
        );
        assert!(md.center.length() < 1e-5);
        assert!(close(s.area(), m_rect + m_disk, 1e-5));
        assert!(close(s.radius(), 0.5 * length, 1e-6));
    }

    #[test]
    fn rounded_box_and_polygon_mass_properties_match_a_sampled_integral() {
        // a rounded box: area w h - (4 - pi) r^2
        let (w, h, r) = (2.0f32, 1.0f32, 0.25f32);
        let (s, _) = Shape::from_def(&ShapeDef::RoundedBox {
            width: w,
            height: h,
            radius: r,
        })
        .unwrap();
        let area = w * h - (4.0 - std::f32::consts::PI) * r * r;
        let md = s.mass_data(1.0);
        assert!(close(md.mass, area, 1e-5), "{} vs {area}", md.mass);
        let (m, c, j) = sampled(&s, 1.2, 1200);
        assert!(close(md.mass, m, 2e-3), "{} vs sampled {m}", md.mass);
        assert!(c.length() < 1e-3 && md.center.length() < 1e-5);
        assert!(close(md.inertia, j, 3e-3), "{} vs sampled {j}", md.inertia);
        // a rounded right triangle: its centroid moves off the core's, and the shape is
        // re-centred on it
        let pts = vec![Vec2::ZERO, Vec2::new(2.0, 0.0), Vec2::new(0.0, 1.0)];
        let (s, origin) = Shape::from_def(&ShapeDef::RoundedPolygon {
            points: pts,
            radius: 0.2,
        })
        .unwrap();
        let md = s.mass_data(1.0);
        let (m, c, j) = sampled(&s, 2.0, 1600);
        assert!(close(md.mass, m, 2e-3), "{} vs sampled {m}", md.mass);
        assert!(
            c.length() < 2e-3,
            "sampled centroid {c} should be the body origin"
        );
        assert!(close(md.inertia, j, 3e-3), "{} vs sampled {j}", md.inertia);
        // area = core + perimeter r + pi r^2
        let perimeter = 3.0 + 5f32.sqrt();
        let area = 1.0 + perimeter * 0.2 + std::f32::consts::PI * 0.04;
        assert!(close(md.mass, area, 1e-5));
        // the core's centroid was (2/3, 1/3); the rounding pulls it towards the long sides
        assert!((origin - Vec2::new(2.0 / 3.0, 1.0 / 3.0)).length() < 0.1);
    }

    #[test]
    fn rounded_shapes_refuse_bad_sizes_and_a_segment_has_no_mass() {
        let capsule = |length, radius| Shape::from_def(&ShapeDef::Capsule { length, radius });
        assert!(
            capsule(1.0, 0.5).is_err(),
            "a capsule must be longer than 2r"
        );
        assert!(capsule(1.0, 0.0).is_err());
        assert!(capsule(f32::NAN, 0.1).is_err());
        let rounded = |radius| {
            Shape::from_def(&ShapeDef::RoundedBox {
                width: 1.0,
                height: 0.4,
                radius,
            })
        };
        assert!(
            rounded(0.2).is_err(),
            "radius must be under half the smaller side"
        );
        assert!(rounded(-0.1).is_err());
        assert_eq!(
            rounded(0.0).unwrap().0,
            Shape::Polygon(Polygon::new_box(1.0, 0.4))
        );
        let seg = ShapeDef::Segment {
            a: Vec2::new(1.0, 1.0),
            b: Vec2::new(3.0, 1.0),
        };
        let (s, c) = Shape::from_def(&seg).unwrap();
        assert_eq!(c, Vec2::new(2.0, 1.0));
        assert_eq!(s.mass_data(1.0).mass, 0.0);
        assert!(
            Shape::from_def(&ShapeDef::Segment {
                a: Vec2::ONE,
                b: Vec2::ONE
            })
            .is_err()
        );
    }

    #[test]
    fn rays_enter_capsules_and_segments_where_the_outline_is() {
        let (s, _) = Shape::from_def(&ShapeDef::Capsule {
            length: 2.0,
            radius: 0.5,
        })
        .unwrap();
        // straight down onto the flat side: y = 0.5
        let (t, n) = s
            .ray_cast_local(Vec2::new(0.2, 3.0), Vec2::new(0.0, -5.0))
            .unwrap();
        assert!((t - 0.5).abs() < 1e-6 && (n - Vec2::Y).length() < 1e-6);
        // along the axis onto the end cap: x = 1
        let (t, n) = s
            .ray_cast_local(Vec2::new(-5.0, 0.0), Vec2::new(10.0, 0.0))
            .unwrap();
        assert!((t - 0.4).abs() < 1e-6 && (n + Vec2::X).length() < 1e-6);
        // at height 0.3 onto the cap: x = 0.5 + sqrt(0.25 - 0.09) = 0.9
        let (t, n) = s
            .ray_cast_local(Vec2::new(5.0, 0.3), Vec2::new(-10.0, 0.0))
            .unwrap();
        assert!((t - 0.41).abs() < 1e-5, "{t}");
        assert!((n - Vec2::new(0.8, 0.6)).length() < 1e-5, "{n}");
        // passing beside the cap, or from inside: nothing
        assert!(
            s.ray_cast_local(Vec2::new(5.0, 0.55), Vec2::new(-10.0, 0.0))
                .is_none()
        );
        assert!(s.ray_cast_local(Vec2::ZERO, Vec2::new(3.0, 0.0)).is_none());
        assert!(s.contains_local(Vec2::new(0.95, 0.2)));
        assert!(!s.contains_local(Vec2::new(0.95, 0.4)));
        // a bare segment is hit from either side, never beside its ends
        let (seg, _) = Shape::from_def(&ShapeDef::Segment {
            a: Vec2::new(-1.0, 0.0),
            b: Vec2::new(1.0, 0.0),
        })
        .unwrap();
        for (o, d, want) in [
            (
                Vec2::new(0.5, 2.0),
                Vec2::new(0.0, -4.0),
                Some((0.5, Vec2::Y)),
            ),
            (
                Vec2::new(0.5, -1.0),
                Vec2::new(0.0, 4.0),
                Some((0.25, -Vec2::Y)),
            ),
            (Vec2::new(1.5, 2.0), Vec2::new(0.0, -4.0), None),
        ] {
            let got = seg.ray_cast_local(o, d);
            match (got, want) {
                (Some((t, n)), Some((wt, wn))) => {
                    assert!((t - wt).abs() < 1e-6 && (n - wn).length() < 1e-6, "{got:?}")
                }
                (None, None) => {}
                _ => panic!("{o} + {d}: {got:?}, want {want:?}"),
            }
        }
    }
}
