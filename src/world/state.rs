//! Saving and restoring a world: [`World::snapshot`] takes a [`WorldState`], and
//! [`World::restore`] (or [`World::from_state`]) puts one back, so that the world goes
//! on bit for bit as if it had never stopped.
//!
//! A state holds everything a step reads that the world carries from one step to the
//! next: the bodies whole (pose, velocities, the forces queued for the next step, mass
//! and shape), the joints with their warm-start impulses and drives, the constant point
//! forces, the contact cache (this step's manifolds with their feature ids and
//! impulses, which the next step matches its points against), the mouse joint, the
//! event bookkeeping (pairs touching and sensed), the step count, the time, gravity,
//! drag and the solver settings. The steppers keep no state from one step to the next
//! (their buffers are rebuilt from the world at the start of each step: the joints' and
//! contacts' impulses live in the world), so a restored world starts with a fresh one;
//! `tests/state.rs` checks for each solver that this continues bit-identically. There is
//! no sleeping yet, so there is no sleep state to keep.
//!
//! The file format is JSON (serde_json with `float_roundtrip`: every finite f32 and f64
//! is written in the shortest form that reads back to the same bits). It is not meant
//! to be edited; it carries `"format": "sandbox2d-state"` and a `"version"`, and a
//! reader refuses a version it does not know. A state read from a file is checked
//! before it is used (every body index in range, shapes and manifolds well formed), so
//! a damaged file is refused rather than panicking a step.

use serde::{Deserialize, Serialize};

use super::spawn::{MotionState, SpawnProgress};
use super::{PointForce, World};
use crate::body::Body;
use crate::collision::Contact;
use crate::defs::{DragDef, SolverSettings};
use crate::joint::{Joint, MouseJoint};
use crate::math::Vec2;
use crate::shape::{MAX_POLYGON_VERTICES, Shape};
use crate::step::StepStats;

/// The `format` field of a state file.
pub const STATE_FORMAT: &str = "sandbox2d-state";

/// The version of the state format this build writes and reads.
pub const STATE_VERSION: u32 = 1;

/// Everything a world carries from one step to the next (see the module docs).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct WorldState {
    /// Always [`STATE_FORMAT`].
    pub format: String,
    /// [`STATE_VERSION`] when written by this build.
    pub version: u32,
    /// Steps taken.
    pub step_count: u64,
    /// Simulated time (s).
    pub time: f64,
    /// The world's gravity (m/s^2); `None` = no gravity pass.
    pub gravity: Option<Vec2>,
    /// The world's fluid drag; `None` = vacuum.
    pub drag: Option<DragDef>,
    /// The solver settings the world stepped with.
    pub settings: SolverSettings,
    /// The bodies, whole, in creation order.
    pub bodies: Vec<Body>,
    /// The joints with their warm-start impulses.
    pub joints: Vec<Joint>,
    /// The contact cache: the last step's contacts, sorted by pair, with their impulses.
    pub contacts: Vec<Contact>,
    /// The contacts of sleeping islands, with their impulses.
    #[serde(default)]
    pub sleeping_contacts: Vec<Contact>,
    /// The mouse joint, if a body is held.
    pub mouse: Option<MouseJoint>,
    /// Whether events are recorded.
    pub record_events: bool,
    /// Where the world's (0, 0) is ([`World::origin`]); (0, 0) when absent.
    #[serde(default)]
    pub origin: glam::DVec2,
    forces: Vec<PointForce>,
    no_collide: Vec<(u32, u32)>,
    touching: Vec<(u32, u32)>,
    sensed: Vec<(u32, u32)>,
    /// Kinematic bodies on a path ([`crate::defs::MotionDef`]), by body index.
    #[serde(default)]
    motions: Vec<MotionState>,
    /// Each spawn table's progress: copies made, and the live copies' bodies.
    #[serde(default)]
    spawns: Vec<SpawnProgress>,
}

/// Why a state could not be read or restored. Each message is one line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateError {
    /// Not JSON, cut short, or not of the state's shape.
    #[error("not a sandbox2d state file: {0}")]
    Parse(String),
    /// Written by a build with another format version.
    #[error("state format version {0} is not supported (this build reads version {STATE_VERSION})")]
    Version(u32),
    /// Well formed, but its parts do not fit together (a body index out of range...).
    #[error("the state is damaged: {0}")]
    Invalid(String),
    /// Saved from a world with other bodies than the one it is restored against.
    #[error("saved from a different scene: {0}")]
    Mismatch(String),
    /// The world holds a number that is not finite (it cannot be written).
    #[error("the world cannot be saved: {0}")]
    NotFinite(String),
}

/// The fields read first, to name the file's kind and version before the rest is parsed.
#[derive(Deserialize)]
struct Header {
    format: Option<String>,
    version: Option<u32>,
}

impl WorldState {
    /// About the bytes this state takes in memory (what a timeline counts against its
    /// bound; see [`World::state_bytes`]).
    pub fn heap_bytes(&self) -> usize {
        state_size(
            &self.bodies,
            self.joints.len(),
            self.contacts.len() + self.sleeping_contacts.len(),
            self.forces.len(),
            self.no_collide.len() + self.touching.len() + self.sensed.len(),
        )
    }

    /// The state as JSON bytes (one line). Refused when a body's state is not finite
    /// (JSON has no NaN; a world that blew up is not worth keeping), or when the state
    /// would not load back ([`WorldState::check`]: a finite velocity whose kinetic
    /// energy is not, a speed past the limits a loaded state is held to): what is saved
    /// always loads.
    pub fn to_json(&self) -> Result<Vec<u8>, StateError> {
        for (i, b) in self.bodies.iter().enumerate() {
            let ok = b.position.is_finite()
                && b.angle.is_finite()
                && b.velocity.is_finite()
                && b.angular_velocity.is_finite();
            if !ok {
                return Err(StateError::NotFinite(format!(
                    "body {:?} (#{i}) has a state that is not finite",
                    b.name
                )));
            }
        }
        if !self.time.is_finite() {
            return Err(StateError::NotFinite("the time is not finite".into()));
        }
        if let Err(e) = self.check() {
            let why = match e {
                StateError::Invalid(m) | StateError::NotFinite(m) => m,
                other => other.to_string(),
            };
            return Err(StateError::NotFinite(format!(
                "it would not load back: {why}"
            )));
        }
        serde_json::to_vec(self).map_err(|e| StateError::NotFinite(e.to_string()))
    }

    /// Reads a state written by [`WorldState::to_json`] and checks it
    /// ([`WorldState::check`]).
    pub fn from_json(bytes: &[u8]) -> Result<WorldState, StateError> {
        let parse = |e: serde_json::Error| StateError::Parse(one_line(&e.to_string()));
        let header: Header = serde_json::from_slice(bytes).map_err(parse)?;
        if header.format.as_deref() != Some(STATE_FORMAT) {
            return Err(StateError::Parse(format!(
                "no \"format\": \"{STATE_FORMAT}\" field"
            )));
        }
        match header.version {
            Some(STATE_VERSION) => {}
            Some(v) => return Err(StateError::Version(v)),
            None => return Err(StateError::Parse("no \"version\" field".into())),
        }
        let state: WorldState = serde_json::from_slice(bytes).map_err(parse)?;
        state.check()?;
        // as a scene: bodies piled on each other by the million would take gigabytes
        // of contacts at the first step
        let boxes: Vec<_> = state.bodies.iter().map(|b| b.aabb()).collect();
        let dynamic: Vec<bool> = state.bodies.iter().map(|b| b.is_dynamic()).collect();
        let filters: Vec<_> = state.bodies.iter().map(|b| b.filter).collect();
        if let Err((_, b)) = crate::world::count_start_pairs(&boxes, &dynamic, &filters) {
            return Err(StateError::Invalid(format!(
                "body {:?} (#{b}): the bodies' boxes overlap in more than {} pairs, the most a world of {} bodies may start with",
                state.bodies[b].name,
                crate::world::max_start_pairs(state.bodies.len()),
                state.bodies.len()
            )));
        }
        Ok(state)
    }

    /// Checks that the parts fit together, so that stepping the restored world cannot
    /// index out of bounds: every body index in range, polygons and manifolds within
    /// their sizes, the settings valid.
    pub fn check(&self) -> Result<(), StateError> {
        let bad = |m: String| Err(StateError::Invalid(m));
        if self.format != STATE_FORMAT {
            return bad(format!("its format is {:?}", self.format));
        }
        if self.version != STATE_VERSION {
            return Err(StateError::Version(self.version));
        }
        if let Err(e) = self.settings.check() {
            return bad(format!("solver: {e}"));
        }
        if !(self.time.is_finite() && self.time >= 0.0) {
            return bad(format!("time is {}", self.time));
        }
        if !self.origin.is_finite() {
            return bad(format!("origin is {}", self.origin));
        }
        if let Some(g) = self.gravity
            && !g.is_finite()
        {
            return bad(format!("gravity is {g}"));
        }
        if let Some(d) = &self.drag {
            let all = [d.linear, d.quadratic, d.fluid_density, d.drag_coefficient];
            if !all.iter().all(|x| x.is_finite() && *x >= 0.0) {
                return bad(format!("drag {d:?} is not finite and >= 0"));
            }
        }
        let n = self.bodies.len();
        for (i, b) in self.bodies.iter().enumerate() {
            if let Shape::Polygon(p) = &b.shape
                && !(2..=MAX_POLYGON_VERTICES).contains(&p.count)
            {
                return bad(format!(
                    "body {:?} (#{i}) is a polygon of {} vertices",
                    b.name, p.count
                ));
            }
            // checked as the scene loader checks the bodies it makes
            if let Err(e) = crate::world::check_body_state(b, self.gravity) {
                return bad(format!("body {:?} (#{i}): {e}", b.name));
            }
        }
        let body = |what: &str, i: usize| {
            if i < n {
                Ok(())
            } else {
                Err(StateError::Invalid(format!(
                    "{what} names body #{i}, but the state has {n} bodies"
                )))
            }
        };
        for (k, j) in self.joints.iter().enumerate() {
            body(&format!("joint #{k}"), j.a)?;
            body(&format!("joint #{k}"), j.b)?;
            if j.a == j.b {
                return bad(format!("joint #{k} joins body #{} to itself", j.a));
            }
            if let Some(what) = j.not_finite() {
                return bad(format!("joint #{k}: its {what} is not finite"));
            }
            let mut numbers = vec![
                ("drive", j.drive),
                ("compliance", j.compliance),
                ("max_force", j.max_force),
                ("max_torque", j.max_torque),
                ("correction", j.correction),
                ("ratio", j.ratio),
                (
                    "ground",
                    j.ground[0].x + j.ground[0].y + j.ground[1].x + j.ground[1].y,
                ),
            ];
            numbers.extend(j.impulses.iter().map(|&x| ("impulses", x)));
            numbers.extend(j.limits.iter().flatten().map(|&x| ("limits", x)));
            numbers.extend(j.break_force.map(|x| ("break_force", x)));
            numbers.extend(j.break_torque.map(|x| ("break_torque", x)));
            if let Some((what, x)) = numbers.iter().find(|(_, x)| !x.is_finite()) {
                return bad(format!("joint #{k}: {what} is {x}, not finite"));
            }
        }
        for (k, j) in self.joints.iter().enumerate() {
            for (what, x) in [
                ("break_force", j.break_force),
                ("break_torque", j.break_torque),
            ] {
                if let Some(x) = x
                    && !(x > 0.0)
                {
                    return bad(format!("joint #{k}: {what} is {x}, must be > 0"));
                }
            }
        }
        for f in &self.forces {
            body("a force", f.body)?;
            if !(f.force.is_finite() && f.local.is_finite()) {
                return bad(format!(
                    "a force on body #{} is not finite ({}, at {})",
                    f.body, f.force, f.local
                ));
            }
        }
        if let Some(m) = &self.mouse {
            body("the mouse joint", m.body)?;
            let all = [m.hertz, m.damping_ratio, m.max_force];
            if !(m.local.is_finite() && m.target.is_finite() && all.iter().all(|x| x.is_finite())) {
                return bad("the mouse joint has a number that is not finite".into());
            }
        }
        let pairs = [
            ("a joint's no-collide pair", &self.no_collide),
            ("a touching pair", &self.touching),
            ("a sensed pair", &self.sensed),
        ];
        for (what, list) in pairs {
            for &(a, b) in list {
                body(what, a as usize)?;
                body(what, b as usize)?;
            }
            if !list.is_sorted() {
                return bad(format!("the {what}s are not sorted"));
            }
        }
        for (k, c) in self
            .contacts
            .iter()
            .chain(&self.sleeping_contacts)
            .enumerate()
        {
            body("a contact", c.b as usize)?;
            if c.a >= c.b {
                return bad(format!("contact #{k} is of bodies #{} and #{}", c.a, c.b));
            }
            if c.manifold.count > c.manifold.points.len() {
                return bad(format!(
                    "contact #{k} has {} points (at most {})",
                    c.manifold.count,
                    c.manifold.points.len()
                ));
            }
            let finite = c.manifold.normal.is_finite()
                && c.friction.is_finite()
                && c.restitution.is_finite()
                && c.manifold.points().iter().all(|p| {
                    p.point.is_finite()
                        && p.anchor_a.is_finite()
                        && p.anchor_b.is_finite()
                        && p.separation.is_finite()
                        && p.normal_impulse.is_finite()
                        && p.tangent_impulse.is_finite()
                });
            if !finite {
                return bad(format!(
                    "contact #{k} (bodies #{} and #{}) has a number that is not finite",
                    c.a, c.b
                ));
            }
        }
        if !self.contacts.is_sorted_by_key(|c| (c.a, c.b)) {
            return bad("the contacts are not sorted by pair".into());
        }
        Ok(())
    }

    /// Checks that this state was saved from the world `scene` builds: the same bodies
    /// (names, types, shapes) in the same order and the same joints. With
    /// `spawned_ok`, the state may have more bodies after the scene's (bodies added
    /// while it ran, as the window's spawn key does).
    pub fn check_scene(&self, scene: &World, spawned_ok: bool) -> Result<(), StateError> {
        let mismatch = |m: String| Err(StateError::Mismatch(m));
        let (ns, nw) = (self.bodies.len(), scene.bodies.len());
        if ns < nw || (ns > nw && !spawned_ok) {
            return mismatch(format!("the state has {ns} bodies, the scene {nw}"));
        }
        for (i, (s, w)) in self.bodies.iter().zip(&scene.bodies).enumerate() {
            if s.name != w.name {
                return mismatch(format!(
                    "body #{i} is {:?} in the state, {:?} in the scene",
                    s.name, w.name
                ));
            }
            if s.shape != w.shape
                || s.parts != w.parts
                || s.body_type != w.body_type
                || s.model != w.model
            {
                return mismatch(format!(
                    "body {:?} has another shape or type in the state than in the scene",
                    s.name
                ));
            }
        }
        if self.joints.len() != scene.joints.len()
            || self
                .joints
                .iter()
                .zip(&scene.joints)
                .any(|(s, w)| (s.kind, s.a, s.b) != (w.kind, w.a, w.b))
        {
            return mismatch(format!(
                "the state has other joints ({}) than the scene ({})",
                self.joints.len(),
                scene.joints.len()
            ));
        }
        Ok(())
    }
}

/// The bytes a state of these parts takes in memory (the vectors' lengths, the bodies'
/// names and parts; a little under what the allocator hands out).
fn state_size(
    bodies: &[Body],
    joints: usize,
    contacts: usize,
    forces: usize,
    pairs: usize,
) -> usize {
    use std::mem::size_of;
    let named: usize = bodies
        .iter()
        .map(|b| b.name.len() + b.parts.len() * size_of::<crate::compound::Part>())
        .sum();
    size_of::<WorldState>()
        + std::mem::size_of_val(bodies)
        + named
        + joints * size_of::<Joint>()
        + contacts * size_of::<Contact>()
        + forces * size_of::<PointForce>()
        + pairs * size_of::<(u32, u32)>()
}

/// Control characters written as escapes: a message stays on one line.
fn one_line(s: &str) -> String {
    s.chars().flat_map(|c| c.escape_debug()).collect()
}

impl World {
    /// About the bytes [`World::snapshot`] would take in memory, without taking it.
    pub fn state_bytes(&self) -> usize {
        state_size(
            &self.bodies,
            self.joints.len(),
            self.contacts.len() + self.sleep.contacts.len(),
            self.forces.len(),
            self.collider.no_collide.len() + self.touching.len() + self.sensed.len(),
        )
    }

    /// Everything the world carries from one step to the next; [`World::restore`] puts
    /// it back. Cheap enough to take every frame for small worlds (it copies the bodies,
    /// joints and contacts).
    pub fn snapshot(&self) -> WorldState {
        let (motions, spawns) = self.events_state();
        WorldState {
            format: STATE_FORMAT.into(),
            version: STATE_VERSION,
            step_count: self.step_count,
            time: self.time,
            gravity: self.gravity,
            drag: self.drag,
            settings: self.settings,
            bodies: self.bodies.clone(),
            joints: self.joints.clone(),
            contacts: self.contacts.clone(),
            sleeping_contacts: self.sleep.contacts.clone(),
            mouse: self.mouse,
            record_events: self.record_events,
            origin: self.origin,
            forces: self.forces.clone(),
            no_collide: self.collider.no_collide.clone(),
            touching: self.touching.clone(),
            sensed: self.sensed.clone(),
            motions,
            spawns,
        }
    }

    /// Replaces the whole world with a saved state (checked first: on an error the
    /// world is unchanged). The next step continues bit-identically with the world the
    /// state was taken from. The last step's events and stats are not part of a state:
    /// they read empty until the next step.
    pub fn restore(&mut self, s: &WorldState) -> Result<(), StateError> {
        s.check()?;
        self.check_events_state(s.bodies.len(), &s.motions, &s.spawns)
            .map_err(StateError::Mismatch)?;
        self.bodies = s.bodies.clone();
        // a state saved before parts kept a number gives them all 0: number them
        for b in &mut self.bodies {
            let n = b.parts.len();
            let unique = (1..n).all(|k| b.parts[..k].iter().all(|p| p.id != b.parts[k].id));
            if !unique {
                for (k, p) in b.parts.iter_mut().enumerate() {
                    p.id = k as u32;
                }
                b.next_part_id = b.next_part_id.max(n as u32);
            }
        }
        self.edits += 1;
        self.gravity = s.gravity;
        self.drag = s.drag;
        self.settings = s.settings;
        self.origin = s.origin;
        self.forces = s.forces.clone();
        self.collider.restart();
        self.contacts = s.contacts.clone();
        self.sleep.contacts = s.sleeping_contacts.clone();
        self.joints = s.joints.clone();
        self.may_break = self.joints.iter().any(|j| j.breakable());
        // keys from before the restore name nothing in it
        self.body_keys.renew(self.bodies.len());
        self.joint_keys.renew(self.joints.len());
        self.mouse = s.mouse;
        self.collider.no_collide = s.no_collide.clone();
        self.collider.has_sensors = self.bodies.iter().any(|b| b.has_sensor());
        self.damped = self
            .bodies
            .iter()
            .any(|b| b.linear_damping != 0.0 || b.angular_damping != 0.0);
        self.restore_events(&s.motions, &s.spawns);
        self.record_events = s.record_events;
        self.events.clear();
        self.touching = s.touching.clone();
        self.sensed = s.sensed.clone();
        // the steppers hold only per-step buffers: a fresh one continues the same
        self.stepper = None;
        self.stats = StepStats::default();
        self.step_count = s.step_count;
        self.time = s.time;
        Ok(())
    }

    /// A world made from a saved state (see [`World::restore`]).
    pub fn from_state(s: &WorldState) -> Result<World, StateError> {
        let mut w = World::new(s.gravity, s.settings);
        w.restore(s)?;
        Ok(w)
    }
}
