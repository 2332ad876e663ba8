//! Building a world: bodies (mass, inertia and centre of mass from the shape, every
//! derived value checked to be finite), joints (checked, then anchored where the bodies
//! are), constant point forces, and a whole world from its description.

use super::{BodyKey, EditError, JointKey, PointForce, World};
use crate::body::{Body, BodyId};
use crate::defs::{
    BodyDef, BodyModel, BodyType, ForceDef, JointDef, ShapeDef, SolverSettings, WorldDef,
};
use crate::joint::{Joint, JointId};
use crate::math::{Rot, Vec2};
use crate::shape::{Shape, ShapeError};

/// Why a world could not be built from its description. Names are quoted with escapes
/// (as Rust's `{:?}` writes them), so a name cannot break a message over lines.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A body's shape (or a compound's part) could not be built.
    #[error("body {name:?}: {source}")]
    Shape {
        /// The body's name.
        name: String,
        /// What is wrong with the shape.
        source: ShapeError,
    },
    /// A particle body (named here) has a shape other than a circle.
    #[error("body {0:?}: a particle must have a circle shape")]
    ParticleShape(String),
    /// A body's mass or density is not above 0, or its damping or sleep threshold is
    /// negative.
    #[error("body {name:?}: {what} must be > 0, got {value}")]
    NotPositive {
        /// The body's name.
        name: String,
        /// Which value (`"mass"`, `"density"`, `"linear_damping"`, ...).
        what: &'static str,
        /// The value given.
        value: f32,
    },
    /// A body's given value (position, angle, velocity, friction, ...) or a force on it
    /// is NaN or infinite.
    #[error("body {name:?}: {what} is not a finite number")]
    NotFinite {
        /// The body's name.
        name: String,
        /// Which value (`"position"`, `"velocity"`, `"force"`, ...).
        what: &'static str,
    },
    /// A quantity the world derives from the description (mass, inertia, centre of
    /// mass, energy) is not finite or not usable; `input` says which given value made it.
    #[error("body {name:?}: {what}")]
    Derived {
        /// The body's name.
        name: String,
        /// The given value to change.
        input: BodyInput,
        /// What is wrong, in words.
        what: String,
    },
    /// A body of this name is already in the world (names are unique).
    #[error("duplicate body name {0:?}")]
    DuplicateName(String),
    /// A joint, force, motion or spawned joint names a body index that does not exist.
    #[error("{what} names body #{index}, but the world has {count} bodies")]
    NoSuchBody {
        /// What names it (`"joint"`, `"force"`, `"motion"`, `"spawned joint"`).
        what: &'static str,
        /// The index given.
        index: usize,
        /// How many bodies there are to name (the world's, or the spawn group's).
        count: usize,
    },
    /// The joint of this index (the one being added) is not valid: why, in words.
    #[error("joint #{0}: {1}")]
    Joint(usize, String),
    /// The solver settings (or a spawn table's `every`) are out of range: what is wrong.
    #[error("solver: {0}")]
    Settings(String),
}

/// Which value of a [`BodyDef`] a [`BuildError::Derived`] comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyInput {
    /// The shape (its size gives the mass and inertia).
    Shape,
    /// `density` or `mass`.
    Mass,
    /// `position` (its centre of mass or potential energy is not finite).
    Position,
    /// `velocity` (its kinetic energy is not finite), or a kinematic body's path.
    Velocity,
    /// `angular_velocity`.
    AngularVelocity,
}

impl World {
    /// Builds the world a description asks for, with these solver settings.
    pub fn from_def(def: &WorldDef, settings: SolverSettings) -> Result<World, BuildError> {
        settings.check().map_err(BuildError::Settings)?;
        let mut w = World::new(def.gravity, settings);
        w.drag = def.drag;
        w.origin = def.origin;
        for b in &def.bodies {
            w.add_body(b)?;
        }
        for f in &def.forces {
            w.add_force(f)?;
        }
        for j in &def.joints {
            w.add_joint(j)?;
        }
        for m in &def.motions {
            w.add_motion(m)?;
        }
        for s in &def.spawns {
            w.add_spawn(s)?;
        }
        Ok(w)
    }

    /// Adds a joint of `def` between the bodies of keys `a` and `b` (its `a` and `b`;
    /// `def.bodies` is not read), anchored where the bodies are now. A stale key is
    /// refused ([`EditError::NoSuchBody`]), and so is a definition the world cannot make
    /// a joint of ([`EditError::Build`]); either way the world is unchanged.
    pub fn create_joint(
        &mut self,
        a: BodyKey,
        b: BodyKey,
        def: &JointDef,
    ) -> Result<JointKey, EditError> {
        self.sync_keys();
        let ia = self.body_of_key(a).ok_or(EditError::NoSuchBody)?;
        let ib = self.body_of_key(b).ok_or(EditError::NoSuchBody)?;
        let def = JointDef {
            bodies: [ia, ib],
            ..def.clone()
        };
        let i = self.add_joint_index(&def)?;
        Ok(self.joint_key(i).expect("a joint just added has a key"))
    }

    /// Adds a body (its mass and inertia from the shape and density, or the given mass)
    /// and returns its key. A name another body has is refused.
    pub fn create_body(&mut self, def: &BodyDef) -> Result<BodyKey, BuildError> {
        let i = self.add_body(def)?;
        self.sync_keys();
        Ok(self.body_key(i).expect("a body just added has a key"))
    }

    /// Adds a joint between two existing, distinct bodies named by their places in
    /// creation order (`def.bodies`, as a [`crate::WorldDef`] names them), anchored where
    /// the bodies are now, and returns its key. The program builds a scene's joints so;
    /// a library user names bodies by key ([`World::create_joint`]).
    #[doc(hidden)]
    pub fn add_joint(&mut self, def: &JointDef) -> Result<JointKey, BuildError> {
        let i = self.add_joint_index(def)?;
        self.sync_keys();
        Ok(self.joint_key(i).expect("a joint just added has a key"))
    }

    /// [`World::add_joint`], returning the joint's index.
    pub(crate) fn add_joint_index(&mut self, def: &JointDef) -> Result<JointId, BuildError> {
        let id = self.joints.len();
        let count = self.bodies.len();
        for &i in &def.bodies {
            if i >= count {
                return Err(BuildError::NoSuchBody {
                    what: "joint",
                    index: i,
                    count,
                });
            }
        }
        let bad = |m: String| Err(BuildError::Joint(id, m));
        let [a, b] = def.bodies;
        if a == b {
            return bad(format!("joins body {:?} to itself", self.bodies[a].name));
        }
        if let Err(why) = Joint::check_def(def) {
            return bad(why);
        }
        let joint = Joint::from_def(def, &self.bodies);
        if let Some(what) = joint.not_finite() {
            return bad(format!(
                "its {what} is not finite (the bodies {:?} and {:?} are too far apart for f32)",
                self.bodies[a].name, self.bodies[b].name
            ));
        }
        self.may_break |= joint.breakable();
        self.joints.push(joint);
        self.sync_keys();
        if !def.collide_connected {
            let pair = (a.min(b) as u32, a.max(b) as u32);
            if let Err(at) = self.collider.no_collide.binary_search(&pair) {
                self.collider.no_collide.insert(at, pair);
            }
        }
        let (ia, ib) = (self.bodies[a].island, self.bodies[b].island);
        if self.bodies[a].asleep && self.bodies[b].asleep {
            // a joint between two sleepers (bodies made asleep) joins their islands:
            // they sleep on, and wake together
            if ia != ib {
                for body in &mut self.bodies {
                    if body.asleep && body.island == ib {
                        body.island = ia;
                    }
                }
            }
        } else {
            self.wake_index(a);
            self.wake_index(b);
        }
        Ok(id)
    }

    /// Adds a body; its mass and inertia come from the shape and density (or the given mass).
    pub(crate) fn add_body(&mut self, def: &BodyDef) -> Result<BodyId, BuildError> {
        if self.bodies.iter().any(|b| b.name == def.name) {
            return Err(BuildError::DuplicateName(def.name.clone()));
        }
        let body = World::make_body(def, self.gravity)?;
        Ok(self.add_made_index(body, def.awake))
    }

    /// Adds a body made by [`World::make_body`] without checking that its name is new
    /// (the caller has: a loader with a set of names), asleep on an island of its own if
    /// not `awake` and dynamic ([`BodyDef::awake`]). Returns its key.
    pub fn add_made_body(&mut self, body: Body, awake: bool) -> BodyKey {
        let i = self.add_made_index(body, awake);
        self.body_keys.body(i)
    }

    /// [`World::add_made_body`], returning the body's index.
    pub(crate) fn add_made_index(&mut self, mut body: Body, awake: bool) -> BodyId {
        self.damped |= body.linear_damping != 0.0 || body.angular_damping != 0.0;
        if !awake && body.is_dynamic() {
            // an island's label is the index of one of its bodies: its own
            body.asleep = true;
            body.island = self.bodies.len() as u32;
        }
        if body.has_sensor() {
            // a sensor is there to be heard: its scene records events
            self.collider.has_sensors = true;
            self.record_events = true;
        }
        self.bodies.push(body);
        self.sync_keys();
        self.edits += 1;
        self.bodies.len() - 1
    }

    /// The body a description makes, as [`World::create_body`] would add it to a world with
    /// this gravity, without adding it: every value it derives (centre of mass, mass,
    /// inertia and their inverses, kinetic and potential energy) is checked to be finite.
    pub fn make_body(def: &BodyDef, gravity: Option<Vec2>) -> Result<Body, BuildError> {
        let name = def.name.clone();
        let finite = |what: &'static str, ok: bool| {
            if ok {
                Ok(())
            } else {
                Err(BuildError::NotFinite {
                    name: name.clone(),
                    what,
                })
            }
        };
        finite("position", def.position.is_finite())?;
        finite("angle", def.angle.is_finite())?;
        finite("velocity", def.velocity.is_finite())?;
        finite("angular_velocity", def.angular_velocity.is_finite())?;
        finite("friction", def.friction.is_finite())?;
        finite("restitution", def.restitution.is_finite())?;
        for (what, v) in [
            ("linear_damping", def.linear_damping),
            ("angular_damping", def.angular_damping),
            ("sleep_threshold", def.sleep_threshold),
        ] {
            finite(what, v.is_finite())?;
            if v < 0.0 {
                return Err(BuildError::NotPositive {
                    name: name.clone(),
                    what,
                    value: v,
                });
            }
        }
        let shape_error = |source| BuildError::Shape {
            name: name.clone(),
            source,
        };
        // a compound's parts, and their mass data at the body's density
        let compound = match &def.shape {
            ShapeDef::Compound { parts } => Some(
                crate::compound::build(
                    parts,
                    def.density,
                    def.friction,
                    def.restitution,
                    def.filter,
                )
                .map_err(shape_error)?,
            ),
            _ => None,
        };
        let (shape, centroid) = match &compound {
            Some((parts, md)) => (
                Shape::Compound {
                    radius: crate::compound::bounding_radius(parts),
                },
                md.center,
            ),
            None => Shape::from_def(&def.shape).map_err(shape_error)?,
        };
        let particle = def.model == BodyModel::Particle;
        if particle && !matches!(shape, Shape::Circle { .. }) {
            return Err(BuildError::ParticleShape(name));
        }
        let derived = |input: BodyInput, what: String| BuildError::Derived {
            name: def.name.clone(),
            input,
            what,
        };
        let dynamic = def.body_type == BodyType::Dynamic;
        let (mut mass, mut inertia) = (0.0, 0.0);
        if dynamic {
            // Which value to blame for a mass that is not usable: the given mass, else the
            // shape when its area is what under- or overflows, else the density.
            let unit = match &compound {
                // the parts' own densities, scaled so the body's is 1
                Some((_, md)) => crate::shape::MassData {
                    mass: md.mass / def.density,
                    center: md.center,
                    inertia: md.inertia / def.density,
                },
                None => shape.mass_data(1.0),
            };
            let area_ok = unit.mass.is_finite() && unit.mass > 0.0 && unit.inertia.is_finite();
            let md = match def.mass {
                Some(m) => {
                    if !(m > 0.0) || !m.is_finite() {
                        return Err(BuildError::NotPositive {
                            name,
                            what: "mass",
                            value: m,
                        });
                    }
                    // scale the unit-density inertia to the given mass
                    crate::shape::MassData {
                        mass: m,
                        center: unit.center,
                        inertia: unit.inertia * m / unit.mass,
                    }
                }
                None => {
                    if !(def.density > 0.0) || !def.density.is_finite() {
                        return Err(BuildError::NotPositive {
                            name,
                            what: "density",
                            value: def.density,
                        });
                    }
                    match &compound {
                        Some((_, md)) => *md,
                        None => shape.mass_data(def.density),
                    }
                }
            };
            let blame = if area_ok {
                BodyInput::Mass
            } else {
                BodyInput::Shape
            };
            if !(md.mass.is_finite() && md.mass > 0.0 && (1.0 / md.mass).is_finite()) {
                return Err(derived(
                    blame,
                    format!(
                        "its mass is {} (area {} m^2): too large or too small to simulate",
                        md.mass, unit.mass
                    ),
                ));
            }
            if !(particle
                || (md.inertia.is_finite() && md.inertia > 0.0 && (1.0 / md.inertia).is_finite()))
            {
                return Err(derived(
                    blame,
                    format!(
                        "its rotational inertia is {} kg m^2: too large or too small to simulate",
                        md.inertia
                    ),
                ));
            }
            mass = md.mass;
            inertia = if particle { 0.0 } else { md.inertia };
        }
        let angle = if particle { 0.0 } else { def.angle };
        let rot = Rot::from_angle(angle);
        let position = def.position + rot.rotate(centroid);
        if !position.is_finite() {
            return Err(derived(
                BodyInput::Position,
                "its centre of mass is not finite (the position is too large for f32)".into(),
            ));
        }
        let body = Body {
            name,
            body_type: def.body_type,
            model: def.model,
            shape,
            origin_offset: -centroid,
            position,
            angle,
            rot,
            velocity: def.velocity,
            angular_velocity: if particle { 0.0 } else { def.angular_velocity },
            mass,
            inv_mass: if mass > 0.0 { 1.0 / mass } else { 0.0 },
            inertia,
            inv_inertia: if inertia > 0.0 { 1.0 / inertia } else { 0.0 },
            friction: def.friction,
            restitution: def.restitution,
            color: def.color,
            // a compound's parts filter pair by pair in the narrow phase; the broad phase
            // sees their common filter, or lets every pair through when they differ
            filter: match &compound {
                Some((parts, _)) if parts.iter().any(|p| p.filter != parts[0].filter) => {
                    crate::defs::Filter::default()
                }
                Some((parts, _)) => parts[0].filter,
                None => def.filter,
            },
            sensor: def.sensor,
            force: Vec2::ZERO,
            torque: 0.0,
            correction: Vec2::ZERO,
            correction_angle: 0.0,
            asleep: false,
            sleep_time: 0.0,
            island: 0,
            next_part_id: compound.as_ref().map_or(1, |(parts, _)| parts.len() as u32),
            parts: compound
                .map(|(mut parts, md)| {
                    // a given mass scales every part's density alike
                    if dynamic && md.mass > 0.0 {
                        for p in &mut parts {
                            p.density *= mass / md.mass;
                        }
                    }
                    parts
                })
                .unwrap_or_default(),
            linear_damping: def.linear_damping,
            angular_damping: def.angular_damping,
            sleep_threshold: def.sleep_threshold,
            rest_box: None,
        };
        if dynamic && let Some((input, what)) = energy_problem(&body, gravity) {
            return Err(derived(input, what));
        }
        Ok(body)
    }

    /// Adds a constant force, every step, at a point of the body of `key` (the point
    /// in the body's shape frame; `def.body` is not read). A stale key is refused
    /// ([`EditError::NoSuchBody`]), and so is a force or point that is not finite
    /// ([`EditError::Build`]); either way the world is unchanged.
    pub fn create_force(&mut self, key: BodyKey, def: &ForceDef) -> Result<(), EditError> {
        let body = self.body_of_key(key).ok_or(EditError::NoSuchBody)?;
        self.add_force(&ForceDef { body, ..*def })?;
        Ok(())
    }

    /// Adds a constant force at a point of the body at place `f.body` in creation order
    /// (as a [`crate::WorldDef`] names it; the point is in the body's shape frame). The
    /// program builds a scene's forces so; a library user names the body by key
    /// ([`World::create_force`]).
    #[doc(hidden)]
    pub fn add_force(&mut self, f: &ForceDef) -> Result<(), BuildError> {
        let Some(b) = self.bodies.get(f.body) else {
            return Err(BuildError::NoSuchBody {
                what: "force",
                index: f.body,
                count: self.bodies.len(),
            });
        };
        if !f.force.is_finite() || !f.point.is_finite() {
            return Err(BuildError::NotFinite {
                name: b.name.clone(),
                what: "force",
            });
        }
        let local = f.point + b.origin_offset;
        self.forces.push(PointForce {
            body: f.body,
            force: f.force,
            local,
        });
        Ok(())
    }
}

/// Why a dynamic body's energy could not be summed ([`World::energy`]'s terms in the
/// same precision): the value to blame and what went wrong; `None` when every term is
/// finite.
pub(super) fn energy_problem(body: &Body, gravity: Option<Vec2>) -> Option<(BodyInput, String)> {
    let linear = 0.5 * body.mass * body.velocity.length_squared();
    if !linear.is_finite() {
        return Some((
            BodyInput::Velocity,
            format!(
                "its kinetic energy is not finite (mass {} kg, velocity {:?})",
                body.mass, body.velocity
            ),
        ));
    }
    let angular = 0.5 * body.inertia * body.angular_velocity * body.angular_velocity;
    if !angular.is_finite() || !(linear + angular).is_finite() {
        return Some((
            BodyInput::AngularVelocity,
            format!(
                "its rotational kinetic energy is not finite (inertia {} kg m^2, angular_velocity {})",
                body.inertia, body.angular_velocity
            ),
        ));
    }
    let g = gravity.unwrap_or(Vec2::ZERO);
    if !(body.mass * g.dot(body.position)).is_finite() {
        return Some((
            BodyInput::Position,
            format!(
                "its potential energy is not finite (mass {} kg at {:?} under gravity {:?})",
                body.mass, body.position, g
            ),
        ));
    }
    None
}
