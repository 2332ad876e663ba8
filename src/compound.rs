//! Compound bodies: several convex parts fixed in one rigid frame.
//!
//! A compound body's [`Body::shape`] is the marker [`Shape::Compound`] (its bounding
//! radius); its parts are [`Body::parts`], each a shape placed in the body frame (whose
//! origin is the centre of mass of all the parts) with its own friction, restitution and
//! filter. Mass, centre of mass and inertia come from the parts: each part's mass
//! `density * area` at its centroid, and the inertia about the common centre of mass by
//! the parallel axis theorem, `I = sum(I_i + m_i |c_i - c|^2)`.
//!
//! Each pair of parts collides on its own and makes its own manifold; a pair of bodies
//! may so have several contacts, one per pair of touching parts, told apart by the part
//! indices in their feature ids ([`part_feature_bits`]).

use crate::body::Body;
use crate::collision::{Manifold, sat};
use crate::defs::{Filter, MAX_PARTS, PartDef, ShapeDef};
use crate::math::{Aabb, Rot, Transform, Vec2};
use crate::shape::{MassData, Shape, ShapeError};

/// One part of a compound body, in the body frame.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Part {
    /// Centred on the part's own centroid.
    pub shape: Shape,
    /// Where the part's centroid lies in the body frame (from the centre of mass, m).
    pub offset: Vec2,
    /// The part's rotation in the body frame.
    pub rot: Rot,
    /// The part's Coulomb friction coefficient (its own, or the body's).
    pub friction: f32,
    /// The part's coefficient of restitution (its own, or the body's).
    pub restitution: f32,
    /// Which other bodies' parts this part may touch (its own, or the body's).
    pub filter: Filter,
    /// A sensor part: its overlaps are heard ([`crate::World::events`]), never resolved.
    #[serde(default)]
    pub sensor: bool,
    /// How far the shape reaches from its centroid ([`Shape::radius`]), kept for the
    /// narrow phase's cull; 0 where not worked out (a restored state): then
    /// [`Part::reach`] works it out.
    #[serde(skip)]
    pub reach: f32,
    /// The part's density (kg/m^2), for working out the body's mass again when a
    /// part is added or removed ([`crate::World::add_shape`]).
    #[serde(default)]
    pub density: f32,
    /// The part's number in its body, for its [`crate::ShapeKey`]: never used again
    /// in that body once the part is removed.
    #[serde(default)]
    pub id: u32,
}

/// Two parts are equal when what they are is (the kept reach is worked out from it).
impl PartialEq for Part {
    fn eq(&self, o: &Part) -> bool {
        (
            &self.shape,
            self.offset,
            self.rot,
            self.friction,
            self.restitution,
            self.filter,
            self.sensor,
        ) == (
            &o.shape,
            o.offset,
            o.rot,
            o.friction,
            o.restitution,
            o.filter,
            o.sensor,
        )
    }
}

impl Part {
    /// How far the part's shape reaches from its centroid (m).
    #[inline]
    pub fn reach(&self) -> f32 {
        if self.reach > 0.0 {
            self.reach
        } else {
            self.shape.radius()
        }
    }

    /// The part's frame in the body frame.
    #[inline]
    pub fn local(&self) -> Transform {
        Transform {
            p: self.offset,
            q: self.rot,
        }
    }
}

/// The parts a description makes, placed about their common centre of mass, with the
/// mass data (`center`: the centre of mass in the description's frame) for `density`
/// where a part gives none. The body's friction, restitution and filter fill what a
/// part leaves out.
pub fn build(
    parts: &[PartDef],
    density: f32,
    friction: f32,
    restitution: f32,
    filter: Filter,
) -> Result<(Vec<Part>, MassData), ShapeError> {
    if parts.is_empty() {
        return Err(ShapeError::Invalid(
            "a compound needs at least one part".into(),
        ));
    }
    if parts.len() > MAX_PARTS {
        return Err(ShapeError::Invalid(format!(
            "a compound has at most {MAX_PARTS} parts, got {}",
            parts.len()
        )));
    }
    let mut out = Vec::with_capacity(parts.len());
    let mut masses = Vec::with_capacity(parts.len());
    for (i, p) in parts.iter().enumerate() {
        if matches!(
            p.shape,
            ShapeDef::Segment { .. } | ShapeDef::ChainSegment { .. } | ShapeDef::Compound { .. }
        ) {
            return Err(ShapeError::Invalid(format!(
                "part {} of a compound must be a circle, box, polygon or capsule",
                i + 1
            )));
        }
        if !(p.offset.is_finite() && p.angle.is_finite()) {
            return Err(ShapeError::Invalid(format!(
                "part {} has a position or angle that is not finite",
                i + 1
            )));
        }
        let (shape, c) = Shape::from_def(&p.shape)?;
        let rot = Rot::from_angle(p.angle);
        let d = p.density.unwrap_or(density);
        // a sensor part may be massless (a zone that hears); a solid one needs mass
        if !(d.is_finite() && (d > 0.0 || (d == 0.0 && p.sensor))) {
            return Err(ShapeError::Invalid(format!(
                "part {} has density {d}: it must be finite and > 0 (or 0 on a sensor part)",
                i + 1
            )));
        }
        masses.push(shape.mass_data(d));
        out.push(Part {
            shape,
            // the part's centroid in the description frame, until the centre is known
            offset: p.offset + rot.rotate(c),
            rot,
            friction: p.friction.unwrap_or(friction),
            restitution: p.restitution.unwrap_or(restitution),
            filter: p.filter.unwrap_or(filter),
            sensor: p.sensor,
            reach: shape.radius(),
            density: d,
            id: i as u32,
        });
    }
    let mass: f32 = masses.iter().map(|m| m.mass).sum();
    // the centre of mass; with no mass (a density of 0 on a static body), the centroid
    // of the areas
    let weights: Vec<f32> = if mass > 0.0 && mass.is_finite() {
        masses.iter().map(|m| m.mass).collect()
    } else {
        out.iter().map(|p| p.shape.area()).collect()
    };
    let total: f32 = weights.iter().sum();
    let center = out
        .iter()
        .zip(&weights)
        .fold(Vec2::ZERO, |s, (p, w)| s + p.offset * *w)
        / total;
    let mut inertia = 0.0;
    for (p, m) in out.iter_mut().zip(&masses) {
        p.offset -= center;
        // parallel axis theorem
        inertia += m.inertia + m.mass * p.offset.length_squared();
    }
    Ok((
        out,
        MassData {
            mass,
            center,
            inertia,
        },
    ))
}

/// The largest distance from the centre of mass to any point of the parts (m).
pub fn bounding_radius(parts: &[Part]) -> f32 {
    parts
        .iter()
        .map(|p| p.offset.length() + p.shape.radius())
        .fold(0.0, f32::max)
}

/// The bits a contact point's feature id gains from the parts that made it: part `i`
/// of body A in bits 16..22, part `j` of body B in bits 22..28 (the SAT ids use bits
/// 0..16 and 29..32).
#[inline]
pub fn part_feature_bits(i: usize, j: usize) -> u32 {
    ((i as u32) << 16) | ((j as u32) << 22)
}

/// What a body collides with: its one shape placed by its transform, or each of its
/// parts, with the material of each.
pub struct Collider {
    /// The shape, centred on its own frame's origin.
    pub shape: Shape,
    /// Where that frame lies in the world: the body's transform, composed with the
    /// part's place in the body for a compound.
    pub xf: Transform,
    /// Coulomb friction coefficient (the body's, or the part's).
    pub friction: f32,
    /// Coefficient of restitution (the body's, or the part's).
    pub restitution: f32,
    /// The collision filter (the body's, or the part's).
    pub filter: Filter,
    /// The body is a sensor, or this part is.
    pub sensor: bool,
}

/// Calls `f(index, collider)` for each part of `body` (its one shape: index 0).
#[inline]
pub fn for_each_collider(body: &Body, mut f: impl FnMut(usize, Collider)) {
    let xf = body.transform();
    if body.parts.is_empty() {
        f(
            0,
            Collider {
                shape: body.shape,
                xf,
                friction: body.friction,
                restitution: body.restitution,
                filter: body.filter,
                sensor: body.sensor,
            },
        );
    } else {
        for (i, p) in body.parts.iter().enumerate() {
            f(
                i,
                Collider {
                    shape: p.shape,
                    xf: xf.compose(&p.local()),
                    friction: p.friction,
                    restitution: p.restitution,
                    filter: p.filter,
                    sensor: body.sensor || p.sensor,
                },
            );
        }
    }
}

/// The manifolds between two bodies of which one at least is a compound: one per pair
/// of parts that touch (within `margin`) and whose filters let them, each with its
/// mixed friction and restitution. Sensor parts make none (they are heard, see
/// [`senses`]). Anchors are from each body's centre of mass; the feature ids carry the
/// part indices.
///
/// A pair of parts further apart than the margin (and a centimetre), by their bounding
/// circles, is not tested: no point of either can be within the margin of the other, so
/// the test would find none (a drum of 40 parts around 8,000 boxes tests each box
/// against the parts near it only).
pub fn collide_bodies(ba: &Body, bb: &Body, margin: f32, mut out: impl FnMut(Manifold, f32, f32)) {
    if ba.sensor || bb.sensor {
        // a sensor body is heard, never touched
        return;
    }
    // the gap beyond which two shapes cannot keep a point: the margin, and a cushion
    // far above the rounding of the points' clipping
    let reach = margin + 0.01;
    let (xa, xb) = (ba.transform(), bb.transform());
    // b's centre in a's frame, and how far b reaches from it
    let b_in_a = ba.rot.inv_rotate(bb.position - ba.position);
    let rb = bb.shape.radius();
    // the parts are read in place, and culled before anything is placed
    for i in 0..ba.parts.len().max(1) {
        let (shape_a, xf_a, ra, friction_a, restitution_a, filter_a) = match ba.parts.get(i) {
            Some(p) => {
                let r = p.reach() + rb + reach;
                if p.sensor || (b_in_a - p.offset).length_squared() > r * r {
                    continue;
                }
                (
                    &p.shape,
                    xa.compose(&p.local()),
                    p.reach(),
                    p.friction,
                    p.restitution,
                    p.filter,
                )
            }
            None => (
                &ba.shape,
                xa,
                ba.shape.radius(),
                ba.friction,
                ba.restitution,
                ba.filter,
            ),
        };
        for j in 0..bb.parts.len().max(1) {
            let (shape_b, xf_b, friction_b, restitution_b) = match bb.parts.get(j) {
                Some(p) => {
                    if p.sensor || !filter_a.collides(&p.filter) {
                        continue;
                    }
                    let xf = xb.compose(&p.local());
                    let r = ra + p.reach() + reach;
                    if (xf.p - xf_a.p).length_squared() > r * r {
                        continue;
                    }
                    (&p.shape, xf, p.friction, p.restitution)
                }
                None => {
                    if !filter_a.collides(&bb.filter) {
                        continue;
                    }
                    (&bb.shape, xb, bb.friction, bb.restitution)
                }
            };
            let mut m = sat::collide(shape_a, &xf_a, shape_b, &xf_b, margin);
            if m.count == 0 {
                continue;
            }
            let bits = part_feature_bits(i, j);
            for p in &mut m.points[..m.count] {
                p.anchor_a = p.point - ba.position;
                p.anchor_b = p.point - bb.position;
                p.id |= bits;
            }
            // mu = sqrt(mu_a mu_b), e = max(e_a, e_b), as for single shapes
            out(
                m,
                (friction_a * friction_b).sqrt(),
                restitution_a.max(restitution_b),
            );
        }
    }
}

/// Whether a sensor of one body (the whole body, or a sensor part) overlaps a solid
/// part of the other, at their present positions. A sensor hears moving bodies only:
/// never a static body, nor a whole sensor body, nor another sensor part; part filters
/// apply as they do to contacts.
pub fn senses(ba: &Body, bb: &Body) -> bool {
    fn one_way(s: &Body, o: &Body) -> bool {
        if o.sensor || o.body_type == crate::defs::BodyType::Static || !s.has_sensor() {
            return false;
        }
        let mut hit = false;
        for_each_collider(s, |_, cs| {
            if hit || !cs.sensor {
                return;
            }
            for_each_collider(o, |_, co| {
                if hit || co.sensor || !cs.filter.collides(&co.filter) {
                    return;
                }
                let m = sat::collide(&cs.shape, &cs.xf, &co.shape, &co.xf, 0.0);
                hit = m.points().iter().any(|p| p.separation <= 0.0);
            });
        });
        hit
    }
    one_way(ba, bb) || one_way(bb, ba)
}

impl Body {
    /// Whether the body hears overlaps: it is a sensor, or one of its parts is.
    #[inline]
    pub fn has_sensor(&self) -> bool {
        self.sensor || self.parts.iter().any(|p| p.sensor)
    }

    /// The world box around the body's shape or all of its parts.
    pub fn aabb(&self) -> Aabb {
        let xf = self.transform();
        if self.parts.is_empty() {
            return self.shape.aabb(&xf);
        }
        let mut bb: Option<Aabb> = None;
        for p in &self.parts {
            let b = p.shape.aabb(&xf.compose(&p.local()));
            bb = Some(bb.map_or(b, |a| a.union(&b)));
        }
        bb.unwrap_or_else(|| self.shape.aabb(&xf))
    }

    /// Whether the body-frame point `p` is inside the shape or one of the parts.
    pub fn contains_local(&self, p: Vec2) -> bool {
        if self.parts.is_empty() {
            return self.shape.contains_local(p);
        }
        self.parts
            .iter()
            .any(|part| part.shape.contains_local(part.local().inv_apply(p)))
    }

    /// Where a body-frame ray `origin + t d`, t in [0, 1], first enters the shape or
    /// one of the parts: (t, outward normal in the body frame).
    pub fn ray_cast_local(&self, origin: Vec2, d: Vec2) -> Option<(f32, Vec2)> {
        if self.parts.is_empty() {
            return self.shape.ray_cast_local(origin, d);
        }
        let mut best: Option<(f32, Vec2)> = None;
        for part in &self.parts {
            let xf = part.local();
            let hit = part
                .shape
                .ray_cast_local(xf.inv_apply(origin), xf.q.inv_rotate(d));
            if let Some((t, n)) = hit
                && best.is_none_or(|(bt, _)| t < bt)
            {
                best = Some((t, xf.q.rotate(n)));
            }
        }
        best
    }
}
