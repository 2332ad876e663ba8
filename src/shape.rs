//! Collision shapes in a body's local frame (origin at the centre of mass), their mass
//! properties and bounding boxes.

use crate::defs::ShapeDef;
use crate::math::{Aabb, Transform, Vec2, cross};

/// The most vertices a polygon may have (after the convex hull is taken).
pub const MAX_POLYGON_VERTICES: usize = 16;

/// Points closer than this (m) are welded into one when the hull is built.
const WELD_DISTANCE: f32 = 1e-4;

/// A convex polygon, counter-clockwise, with its outward edge normals.
/// Edge i runs from vertex i to vertex i + 1.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(into = "PolygonRepr", try_from = "PolygonRepr")]
pub struct Polygon {
    pub vertices: [Vec2; MAX_POLYGON_VERTICES],
    pub normals: [Vec2; MAX_POLYGON_VERTICES],
    pub count: usize,
}

/// A polygon as a saved state holds it: only the vertices and normals in use.
#[derive(serde::Serialize, serde::Deserialize)]
struct PolygonRepr {
    vertices: Vec<Vec2>,
    normals: Vec<Vec2>,
}

impl From<Polygon> for PolygonRepr {
    fn from(p: Polygon) -> Self {
        PolygonRepr {
            vertices: p.verts().to_vec(),
            normals: p.normals[..p.count].to_vec(),
        }
    }
}

impl TryFrom<PolygonRepr> for Polygon {
    type Error = String;

    fn try_from(r: PolygonRepr) -> Result<Self, String> {
        let n = r.vertices.len();
        if !(3..=MAX_POLYGON_VERTICES).contains(&n) || r.normals.len() != n {
            return Err(format!(
                "a polygon needs 3 to {MAX_POLYGON_VERTICES} vertices and as many normals, got {n} and {}",
                r.normals.len()
            ));
        }
        let mut p = Polygon {
            vertices: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            normals: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            count: n,
        };
        p.vertices[..n].copy_from_slice(&r.vertices);
        p.normals[..n].copy_from_slice(&r.normals);
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

    /// From counter-clockwise convex points (at most [`MAX_POLYGON_VERTICES`]).
    fn from_ccw(points: &[Vec2]) -> Polygon {
        let mut p = Polygon {
            vertices: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            normals: [Vec2::ZERO; MAX_POLYGON_VERTICES],
            count: points.len(),
        };
        for (i, &v) in points.iter().enumerate() {
            p.vertices[i] = v;
        }
        for i in 0..p.count {
            let e = p.vertices[(i + 1) % p.count] - p.vertices[i];
            // outward normal of a CCW edge: e rotated by -90 degrees
            p.normals[i] = Vec2::new(e.y, -e.x).normalize();
        }
        p
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

/// Why a shape could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    #[error("polygon has fewer than 3 distinct points or no area")]
    Degenerate,
    #[error("polygon hull has {0} vertices; at most {MAX_POLYGON_VERTICES} are supported")]
    TooManyVertices(usize),
    #[error("{0} must be > 0, got {1}")]
    NotPositive(&'static str, f32),
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

/// A collision shape in the body frame, centred so the body origin is the centre of mass.
// Kept inline (Copy, no box): a polygon is the common case and the solvers read it hot.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Shape {
    Circle { radius: f32 },
    Polygon(Polygon),
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
    pub fn from_def(def: &ShapeDef) -> Result<(Shape, Vec2), ShapeError> {
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
        }
    }

    /// The area (m^2).
    pub fn area(&self) -> f32 {
        match self {
            Shape::Circle { radius } => std::f32::consts::PI * radius * radius,
            Shape::Polygon(p) => p.area_centroid_inertia().0,
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
                let (area, c, j) = p.area_centroid_inertia();
                MassData {
                    mass: density * area,
                    center: c,
                    inertia: density * j,
                }
            }
        }
    }

    /// Whether the point `p`, in the shape's frame, lies inside the shape or on its
    /// boundary.
    pub fn contains_local(&self, p: Vec2) -> bool {
        match self {
            Shape::Circle { radius } => p.length_squared() <= radius * radius,
            Shape::Polygon(poly) => poly
                .verts()
                .iter()
                .zip(&poly.normals[..poly.count])
                .all(|(v, n)| n.dot(p - *v) <= 0.0),
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
            Shape::Circle { radius } => Aabb {
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
                b
            }
        }
    }

    /// The shape's width across the unit direction `dir` (world frame), for drag.
    pub fn extent_across(&self, xf: &Transform, dir: Vec2) -> f32 {
        match self {
            Shape::Circle { radius } => 2.0 * radius,
            Shape::Polygon(p) => {
                let perp = Vec2::new(-dir.y, dir.x);
                let local = xf.q.inv_rotate(perp);
                let (mut lo, mut hi) = (f32::MAX, f32::MIN);
                for &v in p.verts() {
                    let d = v.dot(local);
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
                hi - lo
            }
        }
    }

    /// The largest distance from the centre of mass to any point of the shape.
    pub fn radius(&self) -> f32 {
        match self {
            Shape::Circle { radius } => *radius,
            Shape::Polygon(p) => p.verts().iter().fold(0.0f32, |m, v| m.max(v.length())),
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
}
