//! Shapes added to and removed from a body at run time. A body with more than its one
//! shape is a compound ([`crate::compound`]): its first added shape turns its own shape
//! into part 0. Each part keeps its density, so the body's mass, centre of mass and
//! inertia (parallel axis theorem) are worked out again after each change; the body
//! keeps its place in the world (its origin), its centre of mass moves, and what is
//! anchored in its frame (joints, constant forces, the mouse joint) stays where it was
//! on the body.

use super::{BodyKey, EditError, World};
use crate::compound::{self, Part};
use crate::defs::{BodyModel, BodyType, MAX_PARTS, PartDef, ShapeDef};
use crate::math::{Vec2, cross_sv};
use crate::shape::Shape;

/// One shape of a body for the world's life: [`World::add_shape`],
/// [`World::shape_keys`]. A removed shape's key (or one of a removed body) names
/// nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct ShapeKey {
    /// The body the shape is on.
    pub body: BodyKey,
    id: u32,
}

impl World {
    /// The keys of the body's shapes, in part order (a body of one shape: one key).
    pub fn shape_keys(&self, body: BodyKey) -> Option<Vec<ShapeKey>> {
        let b = self.body(body)?;
        Some(if b.parts.is_empty() {
            vec![ShapeKey { body, id: 0 }]
        } else {
            b.parts
                .iter()
                .map(|p| ShapeKey { body, id: p.id })
                .collect()
        })
    }

    /// Adds the shape `part` to the body of `body`: placed in the frame of the body's
    /// definition (its origin, [`World::set_transform`]'s), with its own density
    /// (`None`: the density of the body's mass as it is now), friction, restitution,
    /// filter and sensor flag. The mass, centre of mass and inertia are worked out
    /// again from every part's density; the body's velocity becomes that of its new
    /// centre of mass (the same rigid motion), and it wakes. Refused, changing nothing:
    /// a stale key, a particle, a body whose shape is a segment or polyline, more than
    /// [`MAX_PARTS`] parts, or a part that cannot be built.
    pub fn add_shape(&mut self, body: BodyKey, part: &PartDef) -> Result<ShapeKey, EditError> {
        let i = self.body_of_key(body).ok_or(EditError::NoSuchBody)?;
        let b = &self.bodies[i];
        let refuse = |why: &'static str| EditError::NotApplicable {
            name: b.name.clone(),
            why,
        };
        if b.model == BodyModel::Particle {
            return Err(refuse("a particle has one circle"));
        }
        if lacks_density(b) {
            return Err(refuse(NO_DENSITY));
        }
        let mut parts = match b.parts.is_empty() {
            true => vec![self.own_shape_as_part(i)?],
            false => b.parts.clone(),
        };
        if parts.len() >= MAX_PARTS {
            return Err(refuse("a body has at most 64 shapes"));
        }
        // the part built alone, in the definition's frame; the density is the body's
        // (mass over area) where the part gives none
        let density = part.density.unwrap_or_else(|| body_density(b, &parts));
        let def = PartDef {
            density: Some(density),
            ..part.clone()
        };
        let (mut built, _) = compound::build(
            std::slice::from_ref(&def),
            density,
            b.friction,
            b.restitution,
            b.filter,
        )
        .map_err(|e| EditError::BadShape {
            name: b.name.clone(),
            why: e.to_string(),
        })?;
        let mut new = built.remove(0);
        // build() placed the part's centroid about itself; put it back in the body frame
        new.offset = b.origin_offset + def.offset + new.rot.rotate(centroid_of(&def.shape));
        let id = b
            .next_part_id
            .max(parts.iter().map(|p| p.id + 1).max().unwrap_or(0));
        new.id = id;
        parts.push(new);
        self.set_parts(i, parts)?;
        self.bodies[i].next_part_id = id + 1;
        Ok(ShapeKey { body, id })
    }

    /// Removes a shape from its body; the mass, centre and inertia are worked out
    /// again from the parts left (see [`World::add_shape`]) and the body wakes. A body
    /// keeps at least one shape; a stale key is refused. Either way a refusal changes
    /// nothing.
    pub fn remove_shape(&mut self, key: ShapeKey) -> Result<(), EditError> {
        let i = self.body_of_key(key.body).ok_or(EditError::NoSuchShape)?;
        let b = &self.bodies[i];
        let at = b
            .parts
            .iter()
            .position(|p| p.id == key.id)
            .ok_or(EditError::NoSuchShape)?;
        if b.parts.len() == 1 || lacks_density(b) {
            return Err(EditError::NotApplicable {
                name: b.name.clone(),
                why: if b.parts.len() == 1 {
                    "a body keeps at least one shape"
                } else {
                    NO_DENSITY
                },
            });
        }
        let mut parts = b.parts.clone();
        parts.remove(at);
        self.set_parts(i, parts)
    }

    /// The body's own (single) shape as a compound part, in the body frame.
    fn own_shape_as_part(&self, i: usize) -> Result<Part, EditError> {
        let b = &self.bodies[i];
        if matches!(b.shape, Shape::Chain(_) | Shape::Compound { .. }) || b.shape.area() <= 0.0 {
            return Err(EditError::NotApplicable {
                name: b.name.clone(),
                why: "only a body of a circle, box, polygon or capsule takes more shapes",
            });
        }
        let area = b.shape.area();
        Ok(Part {
            shape: b.shape,
            offset: Vec2::ZERO,
            rot: crate::math::Rot::IDENTITY,
            friction: b.friction,
            restitution: b.restitution,
            filter: b.filter,
            sensor: b.sensor,
            reach: b.shape.radius(),
            density: if b.mass > 0.0 { b.mass / area } else { 1.0 },
            id: 0,
        })
    }

    /// Gives body `i` these parts (in its frame about its old centre of mass): its
    /// mass data again, its centre of mass moved, what is anchored on it kept in place.
    fn set_parts(&mut self, i: usize, mut parts: Vec<Part>) -> Result<(), EditError> {
        let b = &self.bodies[i];
        let dynamic = b.body_type == BodyType::Dynamic;
        let md: Vec<crate::shape::MassData> =
            parts.iter().map(|p| p.shape.mass_data(p.density)).collect();
        let mass: f32 = md.iter().map(|m| m.mass).sum();
        // a body that does not move keeps its frame; a dynamic one's centre moves to the
        // parts' centre of mass
        let c = if dynamic {
            parts
                .iter()
                .zip(&md)
                .fold(Vec2::ZERO, |s, (p, m)| s + p.offset * m.mass)
                / mass
        } else {
            Vec2::ZERO
        };
        let mut inertia = 0.0;
        for (p, m) in parts.iter_mut().zip(&md) {
            p.offset -= c;
            inertia += m.inertia + m.mass * p.offset.length_squared();
        }
        if dynamic
            && !(mass > 0.0
                && (1.0 / mass).is_finite()
                && inertia > 0.0
                && (1.0 / inertia).is_finite()
                && c.is_finite())
        {
            return Err(EditError::NotApplicable {
                name: b.name.clone(),
                why: "the shapes' mass or inertia would be too large or too small to simulate",
            });
        }
        let b = &mut self.bodies[i];
        let shift = b.rot.rotate(c);
        // the same rigid motion: the new centre's velocity is v + w x (c_new - c_old)
        b.velocity += cross_sv(b.angular_velocity, shift);
        b.position += shift;
        b.origin_offset -= c;
        b.filter = match parts.iter().any(|p| p.filter != parts[0].filter) {
            true => crate::defs::Filter::default(),
            false => parts[0].filter,
        };
        b.shape = Shape::Compound {
            radius: compound::bounding_radius(&parts),
        };
        b.parts = parts;
        if dynamic {
            b.mass = mass;
            b.inv_mass = 1.0 / mass;
            b.inertia = inertia;
            b.inv_inertia = 1.0 / inertia;
        }
        // what is anchored in the body's frame stays on the same material point: a
        // joint's anchors, and a motor joint's target (on a) and the point it drives
        // (on b, its centre of mass when the joint was made), so a motor holds the body
        // where it held it
        for j in &mut self.joints {
            if j.a == i {
                j.local_a -= c;
            }
            if j.b == i {
                j.local_b -= c;
            }
        }
        for f in self.forces.iter_mut().filter(|f| f.body == i) {
            f.local -= c;
        }
        if let Some(m) = &mut self.mouse
            && m.body == i
        {
            m.local -= c;
        }
        // its contacts are found again (part indices name their feature ids)
        let g = i as u32;
        for list in [
            &mut self.contacts,
            &mut self.collider.old_contacts,
            &mut self.sleep.contacts,
        ] {
            list.retain(|c| c.a != g && c.b != g);
        }
        self.edits += 1;
        self.wake_index(i);
        Ok(())
    }
}

/// Why a body whose parts carry no density takes no shape and gives none up.
const NO_DENSITY: &str =
    "its shapes carry no density (a state saved before shapes kept theirs): build it again";

/// Whether a dynamic body's parts all have density 0: restored from a state saved
/// before parts kept their density, so its mass cannot be worked out again from them.
fn lacks_density(b: &crate::body::Body) -> bool {
    b.body_type == BodyType::Dynamic
        && !b.parts.is_empty()
        && b.parts.iter().all(|p| p.density == 0.0)
}

/// The density of a body's mass over its parts' area (1 where it has none: a static
/// or kinematic body).
fn body_density(b: &crate::body::Body, parts: &[Part]) -> f32 {
    let area: f32 = parts.iter().map(|p| p.shape.area()).sum();
    if b.mass > 0.0 && area > 0.0 {
        b.mass / area
    } else {
        1.0
    }
}

/// Where a shape description's centroid lies in its own frame.
fn centroid_of(shape: &ShapeDef) -> Vec2 {
    Shape::from_def(shape).map_or(Vec2::ZERO, |(_, c)| c)
}
