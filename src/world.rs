//! The world: owns the bodies and runs the step pipeline
//! forces -> integrate velocities -> broad phase -> narrow phase -> contact cache
//! -> solver -> integrate positions -> step stats.

use crate::body::{Body, BodyId};
use crate::collision::Contact;
use crate::collision::broad_phase::BroadPhase;
use crate::collision::collide::Collider;
use crate::defs::{BodyModel, DragDef, SolverSettings};
use crate::joint::{Joint, MouseJoint};
use crate::math::{Aabb, Vec2};
use crate::parallel::{self, Pool};
pub use crate::step::StepStats;
use crate::step::integrate::{self, PointForce};
use crate::step::sleep::{self, Sleep};
use crate::step::{StageClock, StepContext, StepState, Stepper, new_stepper};
use std::sync::Arc;

mod body_api;
mod build;
mod edit;
mod events;
mod measure;
mod query;
mod shapes;
mod spawn;
mod state;
mod threads;
mod walls;

pub use body_api::{Bodies, EditError, Joints, Keyed};
use build::energy_problem;
pub use build::{BodyInput, BuildError};
pub use edit::{BodyKey, JointKey, RemoveError};
pub use events::{
    ContactEvent, DEFAULT_HIT_SPEED, EventKind, HitEvent, JointBreakEvent, SleepEvent,
};
pub use measure::{FAR_FROM_ORIGIN, far_from_origin};
pub use query::{QUERY_MARGIN, QueryShape, RayHit, SHAPE_CAST_TOLERANCE, ShapeCastHit};
pub use shapes::ShapeKey;
pub use state::{STATE_FORMAT, STATE_VERSION, StateError, WorldState};
pub use threads::{ThreadUse, Threads};
use walls::WallGrid;

/// Why a step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// A body's state went NaN or infinite: `what` names the first quantity that did
    /// (velocity, angular velocity, position, angle, in that order: a velocity gone bad
    /// takes its position with it), `value` is it as written.
    #[error(
        "body {name:?} (#{index}) has a non-finite state after step {step}: its {what} is {value} (position {position:?}, angle {angle}, velocity {velocity:?}, angular velocity {angular_velocity})"
    )]
    NonFinite {
        /// The body's name.
        name: String,
        /// The body's key.
        body: BodyKey,
        /// The body's place in creation order (0: the first; a scene file's order), as
        /// the message gives it.
        index: usize,
        /// The world's step count with the failed step counted (1: the first step).
        step: u64,
        /// The first quantity that is not finite: `"velocity"`, `"angular velocity"`,
        /// `"position"` or `"angle"`.
        what: &'static str,
        /// That quantity's value, as written (`NaN`, `inf`, ...).
        value: String,
        /// The body's centre of mass after the step (m).
        position: Vec2,
        /// The body's angle after the step (rad).
        angle: f32,
        /// The body's velocity after the step (m/s).
        velocity: Vec2,
        /// The body's angular velocity after the step (rad/s).
        angular_velocity: f32,
    },
}

/// A physics world.
#[derive(Clone, Debug)]
pub struct World {
    /// The bodies, in creation order (the public way: [`World::bodies()`] and the key
    /// setters).
    pub(crate) bodies: Vec<Body>,
    /// m/s^2; `None` skips the gravity pass.
    pub gravity: Option<Vec2>,
    /// `None` = vacuum.
    pub drag: Option<DragDef>,
    /// The solver and its settings.
    pub settings: SolverSettings,
    forces: Vec<PointForce>,
    pub(crate) contacts: Vec<Contact>,
    /// The collide stage's state (broad phase, boxes, the cache, no-collide pairs).
    pub(crate) collider: Collider,
    /// The sleeping islands' contacts and parked joints.
    pub(crate) sleep: Sleep,
    /// Whether a static body is a one-sided segment, worked out for this many bodies
    /// ([`World::keep_in_front`] looks only when one is).
    one_sided: (usize, bool),
    /// With a one-sided segment: where each body's centre was when the step began.
    step_start: Vec<Vec2>,
    /// The static one-sided segments by grid cell ([`World::keep_in_front`]).
    walls: WallGrid,
    /// Whether any body has linear or angular damping (then the forces change each
    /// substep's velocities by different amounts).
    damped: bool,
    /// Kinematic bodies on a path, by key ([`crate::defs::MotionDef`]).
    motions: Vec<spawn::Motion>,
    /// The scene's timed spawns ([`crate::defs::SpawnDef`]) and what each has made.
    spawners: Vec<spawn::Spawner>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) mouse: Option<MouseJoint>,
    /// Record contact and sensor events each step ([`World::events`]); off unless asked
    /// for or a sensor exists, so a world that needs no events pays nothing for them.
    pub record_events: bool,
    /// The last step's events.
    events: Vec<ContactEvent>,
    /// Hit events are made for touching pairs that approach faster than this (m/s).
    pub hit_speed: f32,
    /// The last step's hit events.
    hits: Vec<HitEvent>,
    /// The last step's bodies that fell asleep or woke.
    sleep_events: Vec<SleepEvent>,
    /// The joints that broke in the last step.
    joint_breaks: Vec<JointBreakEvent>,
    /// Some joint may break: set where a breakable joint comes in (added, restored, a
    /// threshold set), cleared by the step when it finds none, so a world without one
    /// never looks.
    may_break: bool,
    /// Each body's asleep flag after the last step with events on, and the edits count
    /// then (a flag list of another world's bodies is not compared).
    was_asleep: (Vec<bool>, u64),
    /// With events on: each body's (velocity, angular velocity) when the step began.
    step_start_velocity: Vec<(Vec2, f32)>,
    /// Pairs touching (a contact point with separation <= 0) after the last step, sorted.
    touching: Vec<(u32, u32)>,
    /// Sensor pairs overlapping after the last step, sorted.
    sensed: Vec<(u32, u32)>,
    /// The solver of `settings.kind` and its scratch (taken out while it steps).
    stepper: Option<Box<dyn Stepper>>,
    stats: StepStats,
    step_count: u64,
    time: f64,
    /// Where this world's (0, 0) is (m): positions in it are relative to this
    /// ([`crate::defs::WorldDef::origin`]); [`World::world_position`] adds it back.
    pub origin: glam::DVec2,
    /// Threads the step may use ([`World::set_threads`]), and whether the step measures
    /// if they pay and uses one while they do not ([`World::set_thread_policy`]).
    threads: usize,
    adaptive: bool,
    tuner: threads::ThreadTuner,
    /// This step runs on many threads (the tuner's choice; true when it does not adapt).
    step_many: bool,
    /// The worker threads, made at the first step that has work for them; clones share
    /// it (taking turns).
    pool: Option<Arc<Pool>>,
    /// Keys of the bodies and joints, by index ([`World::body_key`]).
    body_keys: edit::Keys,
    joint_keys: edit::Keys,
    /// Bodies added, removed or restored through the world's methods: the query index
    /// is made again after one, and the sleep events start over.
    edits: u64,
    /// Bodies moved by [`World::set_transform`]: the query index is made again.
    moves: u64,
    /// The queries' tree, made at the first query ([`World::query_point`] and the rest).
    queries: query::QueryCache,
}

/// Fewest bodies for which a world starts its worker threads.
const MIN_BODIES_FOR_THREADS: usize = 256;
/// Fewest joints for which [`World::joint_error`] uses the threads, and the joints a
/// thread takes at a time (tens of microseconds).
const PARALLEL_JOINT_ERROR: usize = 2048;
const JOINT_ERROR_BLOCK: usize = 1024;

impl World {
    /// Each body's position, angle and x velocity, as bits (tests compare two runs).
    #[cfg(test)]
    pub(crate) fn motion_bits(&self) -> Vec<u32> {
        (self.bodies.iter())
            .flat_map(|b| [b.position.x, b.position.y, b.angle, b.velocity.x])
            .map(f32::to_bits)
            .collect()
    }

    /// An empty world with the given gravity and solver settings.
    pub fn new(gravity: Option<Vec2>, settings: SolverSettings) -> World {
        World {
            bodies: Vec::new(),
            gravity,
            drag: None,
            settings,
            forces: Vec::new(),
            contacts: Vec::new(),
            collider: Collider::default(),
            sleep: Sleep::default(),
            one_sided: (usize::MAX, false),
            step_start: Vec::new(),
            walls: WallGrid::default(),
            joints: Vec::new(),
            mouse: None,
            damped: false,
            motions: Vec::new(),
            spawners: Vec::new(),
            record_events: false,
            hit_speed: DEFAULT_HIT_SPEED,
            hits: Vec::new(),
            sleep_events: Vec::new(),
            joint_breaks: Vec::new(),
            may_break: false,
            was_asleep: (Vec::new(), 0),
            step_start_velocity: Vec::new(),
            events: Vec::new(),
            touching: Vec::new(),
            sensed: Vec::new(),
            stepper: None,
            stats: StepStats::default(),
            step_count: 0,
            time: 0.0,
            origin: glam::DVec2::ZERO,
            threads: parallel::default_threads(),
            adaptive: parallel::default_adaptive(),
            tuner: threads::ThreadTuner::default(),
            step_many: true,
            pool: None,
            body_keys: edit::Keys::default(),
            edits: 0,
            moves: 0,
            queries: Default::default(),
            joint_keys: edit::Keys::default(),
        }
    }

    /// Lets every step use exactly `n` threads (1 = the caller alone; clamped to
    /// 1..=[`parallel::MAX_THREADS`]): `set_thread_policy(Threads::Fixed(n))`. The results
    /// are the same to the bit whatever `n`: only independent work is split (pairs,
    /// constraints of one colour, bodies). A new world takes
    /// [`parallel::default_threads`] (1 unless the program set it).
    pub fn set_threads(&mut self, n: usize) {
        self.set_thread_policy(Threads::Fixed(n));
    }

    /// How many threads the steps use: exactly n, or up to n, measured as the world
    /// steps (see [`Threads`]). The results are the same to the bit either way.
    pub fn set_thread_policy(&mut self, policy: Threads) {
        let n = policy.most().clamp(1, parallel::MAX_THREADS);
        if n != self.threads {
            self.threads = n;
            self.pool = None;
        }
        let adaptive = matches!(policy, Threads::UpTo(_));
        if adaptive != self.adaptive {
            self.adaptive = adaptive;
            self.tuner = threads::ThreadTuner::default();
        }
    }

    /// Threads the step may use.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// The thread policy in force.
    pub fn thread_policy(&self) -> Threads {
        if self.adaptive {
            Threads::UpTo(self.threads)
        } else {
            Threads::Fixed(self.threads)
        }
    }

    /// How the steps so far were shared between one thread and many (an adapting world
    /// with several threads allowed; zeros otherwise).
    pub fn thread_use(&self) -> ThreadUse {
        self.tuner.used()
    }

    /// Whether the step has a choice of threads to measure: several allowed, adapting,
    /// and a world large enough for the worker threads.
    fn tunes_threads(&self) -> bool {
        self.adaptive && self.threads > 1 && self.bodies.len() >= MIN_BODIES_FOR_THREADS
    }

    /// Parallel jobs the steps of this world (and its clones) have run so far: 0 with one
    /// thread or while the world is too small for its worker threads.
    pub fn parallel_jobs(&self) -> u64 {
        self.pool.as_ref().map_or(0, |p| p.jobs())
    }

    /// The pool for this step: `None` for one thread or a small world.
    pub(crate) fn pool(&mut self) -> Option<Arc<Pool>> {
        if self.threads < 2 || self.bodies.len() < MIN_BODIES_FOR_THREADS || !self.step_many {
            return None;
        }
        Some(Arc::clone(
            self.pool
                .get_or_insert_with(|| Arc::new(Pool::new(self.threads))),
        ))
    }

    /// Sets a joint's drive: a constant force (N, prismatic and distance joints, along
    /// the axis) or torque (N m, hinge and weld) on its second body, with the reaction on
    /// the first, every step until changed (the seed's ApplyForce / ApplyTorque).
    /// A stale key or a value that is not finite is refused and changes nothing; the
    /// joint's bodies wake.
    pub fn set_joint_drive(&mut self, key: JointKey, value: f32) -> Result<(), EditError> {
        let i = self.joint_of_key(key).ok_or(EditError::NoSuchJoint)?;
        if !value.is_finite() {
            return Err(EditError::BadJointValue {
                what: "drive",
                must: "finite",
                value: value.to_string(),
            });
        }
        let j = &mut self.joints[i];
        j.drive = value;
        let (a, b) = (j.a, j.b);
        self.wake_index(a);
        self.wake_index(b);
        Ok(())
    }

    /// The joint of `key`, or None if it was removed (or broke).
    /// [`World::joint_bodies`] gives its bodies' keys.
    pub fn joint(&self, key: JointKey) -> Option<&Joint> {
        self.joints.get(self.joint_of_key(key)?)
    }

    /// The keys of the two bodies the joint of `key` holds (its `a`, then its `b`), or
    /// None if it was removed.
    pub fn joint_bodies(&self, key: JointKey) -> Option<[BodyKey; 2]> {
        let j = self.joint(key)?;
        Some([self.body_key(j.a)?, self.body_key(j.b)?])
    }

    /// Grabs a body with the mouse joint (or lets go with `None`).
    pub fn set_mouse(&mut self, mouse: Option<MouseJoint>) {
        self.mouse = mouse.filter(|m| m.body < self.bodies.len() && m.target.is_finite());
        if let Some(m) = self.mouse {
            self.wake_index(m.body);
        }
    }

    /// The mouse joint, if a body is held.
    pub fn mouse(&self) -> Option<&MouseJoint> {
        self.mouse.as_ref()
    }

    /// The key of the body the mouse joint holds, if one is held.
    pub fn mouse_body(&self) -> Option<BodyKey> {
        self.body_key(self.mouse.as_ref()?.body)
    }

    /// A mouse joint holding the dynamic body of `key` by its point at `world_point`,
    /// with the usual feel (5 Hz, damping ratio 0.7, up to 1000 times the body's weight
    /// at 10 m/s^2): hand it to [`World::set_mouse`]. Refused: a stale key, a body that
    /// is not dynamic, a point that is not finite.
    pub fn grab(&self, key: BodyKey, world_point: Vec2) -> Result<MouseJoint, EditError> {
        let i = self.body_of_key(key).ok_or(EditError::NoSuchBody)?;
        let b = &self.bodies[i];
        if !world_point.is_finite() {
            let what = "grab point";
            let value = format!("{world_point}");
            return Err(EditError::NotFinite {
                name: b.name.clone(),
                what,
                value,
            });
        }
        self.grab_index(i, world_point)
            .ok_or_else(|| EditError::NotApplicable {
                name: b.name.clone(),
                why: "only a dynamic body is grabbed",
            })
    }

    /// [`World::grab`] by body index: None for a body that is not there or not dynamic.
    pub(crate) fn grab_index(&self, body: BodyId, world_point: Vec2) -> Option<MouseJoint> {
        let b = self.bodies.get(body).filter(|b| b.is_dynamic())?;
        Some(MouseJoint {
            body,
            local: b.rot.inv_rotate(world_point - b.position),
            target: world_point,
            hertz: 5.0,
            damping_ratio: 0.7,
            max_force: 1000.0 * 10.0 * b.mass,
        })
    }

    /// The largest anchor separation (m) of any joint now (0 without joints). With a
    /// fixed number of threads and many joints, split between the step's threads: a
    /// caller that measures it after every step (the CLI's `simulate` and the bench)
    /// then keeps the workers busy between steps instead of letting them fall asleep
    /// there and be woken at the next step (on the joint grid, 20k joints, that wake
    /// cost two threads 4.5% of their step).
    pub fn joint_error(&self) -> f32 {
        let (joints, bodies) = (&self.joints, &self.bodies);
        let largest = |r: std::ops::Range<usize>| {
            joints[r]
                .iter()
                .map(|j| j.position_error(bodies))
                .fold(0.0, f32::max)
        };
        // (`ranges_max` runs it on the caller alone without a pool or with one block;
        // every block's fold starts at 0, and a max is the same in any order)
        let pool = (self.pool.as_deref())
            .filter(|_| !self.adaptive && joints.len() >= PARALLEL_JOINT_ERROR);
        parallel::ranges_max(pool, joints.len(), JOINT_ERROR_BLOCK, &|_, r| largest(r))
    }

    /// How many constant point forces the world has ([`World::add_force`]).
    pub fn force_count(&self) -> usize {
        self.forces.len()
    }

    /// Adds a force (N) at a world point for the next step only, and wakes the body:
    /// [`World::apply_force_at`] with no torque. Only a dynamic body takes one; a stale
    /// key or a value that is not finite is refused and changes nothing.
    pub fn apply_force(
        &mut self,
        key: BodyKey,
        force: Vec2,
        world_point: Vec2,
    ) -> Result<(), EditError> {
        self.apply_force_at(key, force, world_point, 0.0)
    }

    /// Applies a force (N) at a world point to body `body` (an index) for the next step
    /// only (the window's force emitter); nothing for a body that is not dynamic. The
    /// program's; a library user names a body by key ([`World::apply_force`]).
    #[cfg(any(feature = "app", test))]
    pub(crate) fn apply_force_index(&mut self, body: BodyId, force: Vec2, world_point: Vec2) {
        if let Some(b) = self.bodies.get_mut(body)
            && b.is_dynamic()
        {
            b.add_force_at(force, world_point, -0.0);
            if b.asleep {
                // the next wake pass wakes a pushed sleeper: its block is visited again
                self.sleep.rest.wake(body);
            }
        }
    }

    /// The key of the body with this name.
    pub fn find_body(&self, name: &str) -> Option<BodyKey> {
        self.body_key(self.body_index(name)?)
    }

    /// The index of the body with this name.
    pub(crate) fn body_index(&self, name: &str) -> Option<BodyId> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Statistics of the last step.
    pub fn stats(&self) -> &StepStats {
        &self.stats
    }

    /// Steps taken.
    pub fn step_count(&self) -> u64 {
        self.step_count
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// This step's contacts (pairs and manifolds), sorted by pair (the bodies'
    /// creation order).
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// The keys of the two bodies of a contact of [`World::contacts`], a (made first)
    /// then b: the normal points from a to b. A contact is this step's: one copied
    /// from another world or kept across a removal may name other bodies, or none (then
    /// None).
    pub fn contact_bodies(&self, contact: &Contact) -> Option<[BodyKey; 2]> {
        Some([
            self.body_key(contact.a as usize)?,
            self.body_key(contact.b as usize)?,
        ])
    }

    /// Advances the world by one step of `settings.dt` (in `settings.substeps` substeps)
    /// with the solver `settings.kind`.
    pub fn step(&mut self) -> Result<(), StepError> {
        if !self.spawners.is_empty() || !self.motions.is_empty() {
            self.run_events();
        }
        self.sync_keys();
        let kind = self.settings.kind;
        if self.stepper.as_ref().is_none_or(|st| st.kind() != kind) {
            self.stepper = Some(new_stepper(kind));
        }
        let cx = StepContext::new(&self.settings, self.step_count);
        let tune = self.tunes_threads();
        self.step_many = !tune || self.tuner.choose();
        let started = tune.then(std::time::Instant::now);
        // known from the last step's end while the bodies were not edited since, else
        // until the collide finds it
        self.sleep.none_asleep =
            self.sleep.awake_at == Some(self.edits) && self.sleep.contacts.is_empty();
        self.collider.movers_found = false;
        self.collider.boxes_found = false;
        self.collider.awake.forget();
        self.sleep.rest.since_edits(self.edits);
        let mut clock = StageClock::start();
        let one_sided = self.has_one_sided();
        // (a rest block's bodies are as they were: their entries hold)
        let rest = &self.sleep.rest;
        if one_sided {
            rest.copy_but_rest(&self.bodies, &mut self.step_start, |b| b.position);
        }
        if self.record_events {
            rest.copy_but_rest(&self.bodies, &mut self.step_start_velocity, |b| {
                (b.velocity, b.angular_velocity)
            });
        }
        let pool = self.pool();
        let mut state = StepState {
            bodies: &mut self.bodies,
            contacts: &mut self.contacts,
            joints: &mut self.joints,
            mouse: self.mouse,
            forces: &self.forces,
            gravity: self.gravity,
            drag: self.drag,
            damped: self.damped,
            settings: self.settings,
            pool: pool.as_deref(),
            collider: &mut self.collider,
            sleep: &mut self.sleep,
            // only this step's solver may say it ended the step
            ended: None,
            may_break: self.may_break,
        };
        let stepper = self.stepper.as_mut().expect("a stepper of this kind");
        // a world at rest steps to itself: no solver runs (Box2D's sleeping solver sets
        // cost nothing a step either)
        let at_rest = sleep::at_rest(state.bodies, state.contacts, state.forces, state.mouse);
        let mut stats = if at_rest {
            StepStats::default()
        } else {
            stepper.step(&mut state, &cx, &mut clock)
        };
        let ended = state.ended;
        self.sleep.unpark_joints(&mut self.joints);
        self.break_joints(cx.h, cx.dt);
        if one_sided {
            self.keep_in_front();
        }
        if std::mem::take(&mut self.collider.heard_sensors) {
            // a sensor is there to be heard
            self.record_events = true;
        }
        clock.fill(&mut stats);
        self.stats = stats;
        let awake = self.sleep.update(
            &mut self.bodies,
            &mut self.contacts,
            &self.joints,
            &self.forces,
            self.mouse.as_ref(),
            &self.settings,
            &self.collider.awake,
            self.edits,
            pool.as_deref(),
        );
        self.sleep.awake_at = awake.then_some(self.edits);
        if self.record_events {
            self.update_events();
        }
        self.step_count += 1;
        self.time += self.settings.dt as f64;
        self.refresh_queries();
        let result = match ended {
            Some(false) => Ok(()),
            Some(true) => Err(self.first_non_finite()),
            None => self.end_step(),
        };
        if let Some(started) = started.filter(|_| !at_rest) {
            self.tuner
                .record(self.step_many, started.elapsed(), self.threads);
        }
        self.step_many = true;
        result
    }

    /// The error for the first body (by index) whose state is not finite.
    fn first_non_finite(&self) -> StepError {
        let i = self.bodies.iter().position(|b| !b.is_finite());
        self.non_finite(i.unwrap_or(0))
    }

    /// The step's last pass over the bodies: clears the accumulated forces, and finds
    /// the first body whose state is not finite (the step's error).
    fn end_step(&mut self) -> Result<(), StepError> {
        let pool = self.pool();
        if !integrate::end_step(&mut self.bodies, pool.as_deref()) {
            return Ok(());
        }
        // the first one, by index (rare: the step failed)
        Err(self.first_non_finite())
    }

    /// The solver that ran the last step, as its own type (for tests).
    #[cfg(test)]
    pub(crate) fn stepper_as<T: 'static>(&self) -> Option<&T> {
        self.stepper.as_ref()?.as_any().downcast_ref::<T>()
    }

    /// The solver that ran the last step, as its own type, to change (for tests).
    #[cfg(test)]
    pub(crate) fn stepper_as_mut<T: 'static>(&mut self) -> Option<&mut T> {
        self.stepper.as_mut()?.as_any_mut().downcast_mut::<T>()
    }

    /// The error for body `i`, whose state is not finite.
    fn non_finite(&self, i: usize) -> StepError {
        let b = &self.bodies[i];
        let (what, value) = if !b.velocity.is_finite() {
            ("velocity", format!("{:?}", b.velocity))
        } else if !b.angular_velocity.is_finite() {
            ("angular velocity", b.angular_velocity.to_string())
        } else if !b.position.is_finite() {
            ("position", format!("{:?}", b.position))
        } else {
            ("angle", b.angle.to_string())
        };
        StepError::NonFinite {
            name: b.name.clone(),
            // the step gave every body its key before it began
            body: self.body_keys.body(i),
            index: i,
            step: self.step_count,
            what,
            value,
            position: b.position,
            angle: b.angle,
            velocity: b.velocity,
            angular_velocity: b.angular_velocity,
        }
    }

    /// Wakes the island the body of `key` sleeps in (nothing if it is awake). A stale
    /// key is refused.
    pub fn wake(&mut self, key: BodyKey) -> Result<(), EditError> {
        let i = self.body_of_key(key).ok_or(EditError::NoSuchBody)?;
        self.wake_index(i);
        Ok(())
    }

    /// Wakes the island body `body` (an index) sleeps in (nothing if it is awake).
    pub(crate) fn wake_index(&mut self, body: BodyId) {
        if let Some(b) = self.bodies.get(body)
            && b.asleep
        {
            let island = b.island;
            self.sleep
                .wake_island(&mut self.bodies, &mut self.contacts, island);
        }
    }

    /// The position of the body of `key` (its centre of mass) in the scene file's
    /// coordinates, [`World::origin`] added back in f64; None for a stale key.
    pub fn world_position(&self, key: BodyKey) -> Option<glam::DVec2> {
        Some(self.world_position_index(self.body_of_key(key)?))
    }

    /// [`World::world_position`] of body `body` (an index).
    pub(crate) fn world_position_index(&self, body: BodyId) -> glam::DVec2 {
        self.origin + self.bodies[body].position.as_dvec2()
    }

    /// The first dynamic body whose energy term ([`World::energy`]'s) is not finite,
    /// and why: to name it when the total is not.
    pub fn energy_not_finite(&self) -> Option<(BodyKey, String)> {
        self.bodies().find_map(|(key, b)| {
            if !b.is_dynamic() {
                return None;
            }
            energy_problem(b, self.gravity).map(|(_, why)| (key, why))
        })
    }

    /// Kinetic plus gravitational potential energy of the dynamic bodies (J), with the
    /// potential zero at the origin: E = sum 1/2 m v^2 + 1/2 I w^2 - m g.x
    pub fn energy(&self) -> f64 {
        let g = self.gravity.unwrap_or(Vec2::ZERO);
        self.bodies
            .iter()
            .filter(|b| b.is_dynamic())
            .map(|b| b.kinetic_energy() as f64 - (b.mass * g.dot(b.position)) as f64)
            .sum()
    }

    /// A 64-bit FNV-1a digest of every body's position, angle and velocities, bit for bit.
    pub fn state_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: f32| {
            for byte in x.to_bits().to_le_bytes() {
                h ^= byte as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for b in &self.bodies {
            eat(b.position.x);
            eat(b.position.y);
            eat(b.angle);
            eat(b.velocity.x);
            eat(b.velocity.y);
            eat(b.angular_velocity);
        }
        h
    }
}

/// Checks a body as a saved state holds it the way the scene loader checks one it
/// makes ([`World::make_body`]): every number finite, friction and restitution in
/// range, the shape sound, the mass properties those of its type (a dynamic body's
/// mass and inertia positive with their inverses, a static or kinematic body's zero),
/// and its energy finite. `Err` names the field and what is wrong.
pub(crate) fn check_body_state(b: &Body, gravity: Option<Vec2>) -> Result<(), String> {
    let numbers: [(&str, bool); 17] = [
        ("position", b.position.is_finite()),
        ("angle", b.angle.is_finite()),
        ("rot", b.rot.c.is_finite() && b.rot.s.is_finite()),
        ("velocity", b.velocity.is_finite()),
        ("angular_velocity", b.angular_velocity.is_finite()),
        ("mass", b.mass.is_finite()),
        ("inv_mass", b.inv_mass.is_finite()),
        ("inertia", b.inertia.is_finite()),
        ("inv_inertia", b.inv_inertia.is_finite()),
        ("force", b.force.is_finite()),
        ("torque", b.torque.is_finite()),
        ("correction", b.correction.is_finite()),
        ("correction_angle", b.correction_angle.is_finite()),
        ("friction", b.friction.is_finite()),
        ("restitution", b.restitution.is_finite()),
        ("origin_offset", b.origin_offset.is_finite()),
        ("sleep_time", b.sleep_time.is_finite()),
    ];
    if let Some((what, _)) = numbers.iter().find(|(_, ok)| !ok) {
        return Err(format!("{what} is not finite"));
    }
    let max_friction = crate::scene::MAX_FRICTION;
    if !(0.0..=max_friction).contains(&b.friction) {
        return Err(format!(
            "friction must be in [0, {max_friction:e}], got {}",
            b.friction
        ));
    }
    if !(0.0..=1.0).contains(&b.restitution) {
        return Err(format!(
            "restitution must be in [0, 1], got {}",
            b.restitution
        ));
    }
    if ((b.rot.c * b.rot.c + b.rot.s * b.rot.s) - 1.0).abs() > 1e-3 {
        return Err(format!("rot [{}, {}] is not a rotation", b.rot.c, b.rot.s));
    }
    b.shape.check_sound().map_err(|e| format!("shape: {e}"))?;
    for (k, p) in b.parts.iter().enumerate() {
        p.shape
            .check_sound()
            .map_err(|e| format!("part {k}'s shape: {e}"))?;
    }
    // a mass and its inverse: both positive, finite and each other's inverse (to a few
    // ulps); or both zero
    let pair = |what: &str, inv: &str, m: f32, im: f32, zero: bool| -> Result<(), String> {
        if zero {
            if m != 0.0 || im != 0.0 {
                return Err(format!("{what} {m} and {inv} {im} must be 0 here"));
            }
            return Ok(());
        }
        if !(m > 0.0 && im > 0.0) {
            return Err(format!("{what} {m} and {inv} {im} must be > 0"));
        }
        if ((m as f64 * im as f64) - 1.0).abs() > 1e-5 {
            return Err(format!("{inv} {im} is not 1 / {what} ({m})"));
        }
        Ok(())
    };
    let dynamic = b.is_dynamic();
    let particle = b.model == BodyModel::Particle;
    pair("mass", "inv_mass", b.mass, b.inv_mass, !dynamic)?;
    pair(
        "inertia",
        "inv_inertia",
        b.inertia,
        b.inv_inertia,
        !dynamic || particle,
    )?;
    if particle && (b.angle != 0.0 || b.angular_velocity != 0.0) {
        return Err("a particle has no angle or angular_velocity".into());
    }
    if dynamic && let Some((input, what)) = energy_problem(b, gravity) {
        let field = match input {
            BodyInput::Velocity => "velocity",
            BodyInput::AngularVelocity => "angular_velocity",
            BodyInput::Position => "position",
            BodyInput::Shape | BodyInput::Mass => "mass",
        };
        return Err(format!("{field}: {what}"));
    }
    Ok(())
}

/// A world may start with at most this many pairs of bodies whose boxes overlap, or
/// [`START_PAIRS_PER_BODY`] a body where that is more: see [`max_start_pairs`].
pub const START_PAIRS_FLOOR: u64 = 1 << 20;

/// Pairs a body may start with, on average, in a large world: bodies that do not
/// overlap touch a handful of neighbours each.
pub const START_PAIRS_PER_BODY: u64 = 8;

/// The most pairs of overlapping boxes a world of `bodies` bodies may start with:
/// [`START_PAIRS_PER_BODY`] a body, and at least [`START_PAIRS_FLOOR`]. Each pair the
/// step keeps costs memory (about 1 KB under the soft step, its contact and its rows),
/// so a scene whose bodies overlap by the million (a grid of circles far larger than
/// its spacing) is refused when it loads instead of taking gigabytes when it runs.
pub fn max_start_pairs(bodies: usize) -> u64 {
    (START_PAIRS_PER_BODY * bodies as u64).max(START_PAIRS_FLOOR)
}

/// Counts the pairs a step would consider at the start: two bodies whose boxes
/// (`boxes`, widened by the broad phase's margin) overlap, one of them dynamic, whose
/// filters let them touch, up to [`max_start_pairs`]. `Ok(count)`, or `Err((a, b))`
/// with the pair that went past it. Its memory grows with the bodies, not the pairs.
pub fn count_start_pairs(
    boxes: &[Aabb],
    dynamic: &[bool],
    filters: &[crate::defs::Filter],
) -> Result<u64, (usize, usize)> {
    let fat: Vec<Aabb> = boxes
        .iter()
        .map(|b| {
            let extent = (b.max - b.min).max_element();
            b.fattened(0.1f32.min(0.25 * extent))
        })
        .collect();
    BroadPhase::count_pairs(
        &fat,
        dynamic,
        |a, b| filters[a as usize].collides(&filters[b as usize]),
        max_start_pairs(boxes.len()),
    )
    .map_err(|(a, b)| (a as usize, b as usize))
}
