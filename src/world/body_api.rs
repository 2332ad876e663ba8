//! A body through its key: reading it, moving it, setting its velocity, pushing it.
//! Each change is checked (a key of a removed body, a value that is not finite, a
//! velocity for a static body, a turn for a particle are refused, and the body is left
//! as it was) and wakes the body's island, as Box2D's setters do.

use super::edit::Keys;
use super::{BodyKey, JointKey, World};
use crate::body::Body;
use crate::defs::{BodyModel, BodyType};
use crate::joint::Joint;
use crate::math::{Rot, Vec2, cross};

/// What a change to a body refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    /// The key is stale or from another world.
    #[error("the key names no body of this world (removed, or from another world)")]
    NoSuchBody,
    /// The joint key is stale (the joint was removed or broke) or from another world.
    #[error("the key names no joint of this world (removed, broken, or from another world)")]
    NoSuchJoint,
    /// The shape key is stale (the shape or its body was removed) or from another world.
    #[error("the key names no shape of this world (removed, or from another world)")]
    NoSuchShape,
    /// A shape given to [`World::add_shape`] cannot be built.
    #[error("body {name:?}: the shape cannot be added: {why}")]
    BadShape {
        /// The body's name.
        name: String,
        /// Why not.
        why: String,
    },
    /// The definition could not make a body or joint (why, as the builder says).
    #[error(transparent)]
    Build(#[from] super::BuildError),
    /// A joint's value is out of its range.
    #[error("joint: the {what} must be {must}, got {value}")]
    BadJointValue {
        /// Which value.
        what: &'static str,
        /// What it must be.
        must: &'static str,
        /// It, as written.
        value: String,
    },
    /// A value given is NaN or infinite.
    #[error("body {name:?}: the {what} must be finite, got {value}")]
    NotFinite {
        /// The body's name.
        name: String,
        /// Which value.
        what: &'static str,
        /// It, as written.
        value: String,
    },
    /// The change does not apply to this kind of body.
    #[error("body {name:?}: {why}")]
    NotApplicable {
        /// The body's name.
        name: String,
        /// Why not.
        why: &'static str,
    },
}

/// The world's bodies or joints with their keys, in creation order: [`World::bodies`],
/// [`World::joints`]. An exact-size, double-ended iterator.
#[derive(Clone, Debug)]
pub struct Keyed<'a, K, T> {
    items: &'a [T],
    keys: &'a Keys,
    key: fn(&Keys, usize) -> K,
    range: std::ops::Range<usize>,
}

/// [`World::bodies`]: `(BodyKey, &Body)` in creation order.
pub type Bodies<'a> = Keyed<'a, BodyKey, Body>;

/// [`World::joints`]: `(JointKey, &Joint)` in creation order.
pub type Joints<'a> = Keyed<'a, JointKey, Joint>;

impl<'a, K, T> Keyed<'a, K, T> {
    fn at(&self, i: usize) -> (K, &'a T) {
        ((self.key)(self.keys, i), &self.items[i])
    }
}

impl<'a, K, T> Iterator for Keyed<'a, K, T> {
    type Item = (K, &'a T);

    fn next(&mut self) -> Option<Self::Item> {
        let i = self.range.next()?;
        Some(self.at(i))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.range.size_hint()
    }

    fn nth(&mut self, n: usize) -> Option<Self::Item> {
        let i = self.range.nth(n)?;
        Some(self.at(i))
    }
}

impl<K, T> DoubleEndedIterator for Keyed<'_, K, T> {
    fn next_back(&mut self) -> Option<Self::Item> {
        let i = self.range.next_back()?;
        Some(self.at(i))
    }

    fn nth_back(&mut self, n: usize) -> Option<Self::Item> {
        let i = self.range.nth_back(n)?;
        Some(self.at(i))
    }
}

impl<K, T> ExactSizeIterator for Keyed<'_, K, T> {}

impl<K, T> std::iter::FusedIterator for Keyed<'_, K, T> {}

impl World {
    /// The body of `key`, or None if it was removed.
    pub fn body(&self, key: BodyKey) -> Option<&Body> {
        self.bodies.get(self.body_of_key(key)?)
    }

    /// Every body with its key, in creation order (a removed body leaves the order of
    /// the rest as it was). Reading a body changes nothing; to change one, name it by
    /// its key to a setter ([`World::set_transform`], [`World::set_velocity`],
    /// [`World::apply_impulse`], [`World::apply_force_at`], ...).
    pub fn bodies(&self) -> Bodies<'_> {
        let n = self.bodies.len().min(self.body_keys.len());
        Keyed {
            items: &self.bodies,
            keys: &self.body_keys,
            key: Keys::body,
            range: 0..n,
        }
    }

    /// Every joint with its key, in creation order (a removed or broken joint leaves
    /// the order of the rest as it was). [`World::joint_bodies`] gives a joint's bodies'
    /// keys.
    pub fn joints(&self) -> Joints<'_> {
        let n = self.joints.len().min(self.joint_keys.len());
        Keyed {
            items: &self.joints,
            keys: &self.joint_keys,
            key: Keys::joint,
            range: 0..n,
        }
    }

    /// How many joints the world has.
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// The world positions of the joint's two anchors (m): for most joints the points
    /// it holds together, on its first body then its second; a motor joint's are the
    /// second body's target point and the point of it driven there; a pulley's its
    /// bodies' anchors. None for a stale key.
    pub fn joint_anchors(&self, key: JointKey) -> Option<(Vec2, Vec2)> {
        Some(self.joint(key)?.world_anchors(&self.bodies))
    }

    /// How far the joint is from holding (m), as [`World::joint_error`] measures each
    /// joint: the anchor separation of a hinge or weld, the length error (or range
    /// violation) of a distance joint, the off-axis offset plus the range violation of
    /// a prismatic or wheel joint, the stretch of a pulley past its length; 0 for a
    /// motor joint. None for a stale key.
    pub fn joint_position_error(&self, key: JointKey) -> Option<f32> {
        Some(self.joint(key)?.position_error(&self.bodies))
    }

    /// How far the joint's angle is outside a hinge's limits, or off a weld or
    /// prismatic joint's rest angle (rad). None for a stale key.
    pub fn joint_angle_error(&self, key: JointKey) -> Option<f32> {
        Some(self.joint(key)?.angle_error(&self.bodies))
    }

    /// How many bodies the world has.
    pub fn body_count(&self) -> usize {
        self.bodies.len()
    }

    /// The index of `key`'s body, checking `values` are finite.
    fn edit_index(&self, key: BodyKey, values: &[(&'static str, f32)]) -> Result<usize, EditError> {
        let i = self.body_of_key(key).ok_or(EditError::NoSuchBody)?;
        if let Some((what, v)) = values.iter().find(|(_, v)| !v.is_finite()) {
            return Err(EditError::NotFinite {
                name: self.bodies[i].name.clone(),
                what,
                value: v.to_string(),
            });
        }
        Ok(i)
    }

    fn not_applicable(&self, i: usize, why: &'static str) -> EditError {
        EditError::NotApplicable {
            name: self.bodies[i].name.clone(),
            why,
        }
    }

    /// Puts the body's origin (the point its definition's `position` names) at
    /// `position`, turned by `angle` (rad), and wakes it. Its velocities are kept. A
    /// particle refuses an angle other than 0.
    pub fn set_transform(
        &mut self,
        key: BodyKey,
        position: Vec2,
        angle: f32,
    ) -> Result<(), EditError> {
        let i = self.edit_index(
            key,
            &[
                ("position x", position.x),
                ("position y", position.y),
                ("angle", angle),
            ],
        )?;
        if self.bodies[i].model == BodyModel::Particle && angle != 0.0 {
            return Err(self.not_applicable(i, "a particle has no angle"));
        }
        let b = &mut self.bodies[i];
        b.angle = angle;
        b.rot = Rot::from_angle(angle);
        b.position = position - b.rot.rotate(b.origin_offset);
        self.moves += 1;
        self.wake_index(i);
        Ok(())
    }

    /// Sets the body's velocity (m/s, of its centre of mass) and angular velocity
    /// (rad/s), and wakes it. A static body refuses; a particle refuses a spin.
    pub fn set_velocity(
        &mut self,
        key: BodyKey,
        velocity: Vec2,
        angular_velocity: f32,
    ) -> Result<(), EditError> {
        let i = self.edit_index(
            key,
            &[
                ("velocity x", velocity.x),
                ("velocity y", velocity.y),
                ("angular velocity", angular_velocity),
            ],
        )?;
        let b = &self.bodies[i];
        if b.body_type == BodyType::Static {
            return Err(self.not_applicable(i, "a static body does not move"));
        }
        if b.model == BodyModel::Particle && angular_velocity != 0.0 {
            return Err(self.not_applicable(i, "a particle does not turn"));
        }
        let b = &mut self.bodies[i];
        b.velocity = velocity;
        b.angular_velocity = angular_velocity;
        self.wake_index(i);
        Ok(())
    }

    /// Applies an impulse (N s) at a world point: the velocity changes at once by
    /// impulse / m, the spin by (r x impulse) / I. Wakes the body. Only a dynamic body
    /// takes one.
    pub fn apply_impulse(
        &mut self,
        key: BodyKey,
        impulse: Vec2,
        world_point: Vec2,
    ) -> Result<(), EditError> {
        let i = self.edit_index(
            key,
            &[
                ("impulse x", impulse.x),
                ("impulse y", impulse.y),
                ("point x", world_point.x),
                ("point y", world_point.y),
            ],
        )?;
        if !self.bodies[i].is_dynamic() {
            return Err(self.not_applicable(i, "only a dynamic body takes an impulse"));
        }
        let b = &mut self.bodies[i];
        b.velocity += impulse * b.inv_mass;
        b.angular_velocity += cross(world_point - b.position, impulse) * b.inv_inertia;
        self.wake_index(i);
        Ok(())
    }

    /// Adds a force (N) at a world point and a torque (N m) for the next step only, and
    /// wakes the body. Only a dynamic body takes them.
    pub fn apply_force_at(
        &mut self,
        key: BodyKey,
        force: Vec2,
        world_point: Vec2,
        torque: f32,
    ) -> Result<(), EditError> {
        let i = self.edit_index(
            key,
            &[
                ("force x", force.x),
                ("force y", force.y),
                ("point x", world_point.x),
                ("point y", world_point.y),
                ("torque", torque),
            ],
        )?;
        if !self.bodies[i].is_dynamic() {
            return Err(self.not_applicable(i, "only a dynamic body takes a force"));
        }
        let b = &mut self.bodies[i];
        b.add_force_at(force, world_point, torque);
        self.wake_index(i);
        Ok(())
    }

    /// Sets the force (N) and torque (N m) past which the joint breaks after a step
    /// (`None`: never on that count); see [`crate::JointDef::break_force`]. Each given
    /// must be > 0 and finite; a stale key or a bad value changes nothing. Wakes the
    /// joint's bodies.
    pub fn set_joint_break(
        &mut self,
        key: JointKey,
        force: Option<f32>,
        torque: Option<f32>,
    ) -> Result<(), EditError> {
        let i = self.joint_of_key(key).ok_or(EditError::NoSuchJoint)?;
        for (what, v) in [("break force", force), ("break torque", torque)] {
            if let Some(v) = v
                && !(v > 0.0 && v.is_finite())
            {
                return Err(EditError::BadJointValue {
                    what,
                    must: "> 0 and finite",
                    value: v.to_string(),
                });
            }
        }
        let j = &mut self.joints[i];
        j.break_force = force;
        j.break_torque = torque;
        self.may_break |= j.breakable();
        // a sleeping island's joints carry no load the step looks at: wake it
        let (a, b) = (j.a, j.b);
        self.wake_index(a);
        self.wake_index(b);
        Ok(())
    }
}
