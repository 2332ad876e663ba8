//! The world: owns the bodies and runs the step pipeline
//! forces -> integrate velocities -> broad phase -> narrow phase -> contact cache
//! -> solver -> integrate positions -> step stats.

use crate::body::SHAPE_BYTES;
use crate::body::{Body, BodyId};
use crate::collision::Contact;
use crate::collision::broad_phase::BroadPhase;
use crate::collision::contact_cache::{CacheCursor, match_points};
use crate::collision::sat;
use crate::defs::{BodyModel, BodyType, DragDef, SolverSettings};
use crate::joint::{Joint, JointId, MouseJoint};
use crate::math::{Aabb, BODY_AHEAD, BODY_PASS_BLOCK, Vec2, cross, prefetch, uf_root, uf_union};
use crate::parallel::{self, Pool};
use crate::step::integrate::{self, PointForce, body_finite};
use crate::step::{Stage, StageClock, StepContext, Stepper, new_stepper};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

mod build;
mod edit;
mod events;
mod measure;
mod query;
mod spawn;
mod state;
mod threads;

use build::energy_problem;
pub(crate) use build::joint_not_finite;
pub use build::{BodyInput, BuildError};
pub use edit::{BodyKey, JointKey, RemoveError};
pub use events::{ContactEvent, EventKind};
pub use measure::{FAR_FROM_ORIGIN, far_from_origin};
pub use query::RayHit;
pub use state::{STATE_FORMAT, STATE_VERSION, StateError, WorldState};
pub use threads::{ThreadUse, Threads};

/// How far out a pair keeps contact points (speculative contacts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Speculative {
    /// Up to the margin plus the distance the two bodies can close in h (classic PGS,
    /// XPBD).
    MarginPlusMotion,
    /// Up to the larger of the margin and the distance the two bodies can close in h:
    /// a gap beyond both cannot close in the step, and resting bodies keep no more
    /// points than the margin gives (the soft step: the same protection against
    /// tunnelling, 3 to 5% less time on the large pyramid than the sum).
    MarginOrMotion,
}

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
        name: String,
        index: usize,
        step: u64,
        what: &'static str,
        value: String,
        position: Vec2,
        angle: f32,
        velocity: Vec2,
        angular_velocity: f32,
    },
}

/// What one step did and cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// PGS velocity sweeps run (summed over substeps).
    pub iterations: u32,
    /// Largest |delta lambda| of the last sweep (N s).
    pub residual: f32,
    /// Split-impulse sweeps run.
    pub position_iterations: u32,
    /// Contact points (of the last substep).
    pub contacts: usize,
    /// Deepest overlap seen by the narrow phase this step (m, >= 0).
    pub penetration: f32,
    /// Time per stage (ms): forces and velocity integration, broad phase, narrow phase,
    /// solver, position integration.
    pub ms_forces: f32,
    pub ms_broad: f32,
    pub ms_narrow: f32,
    pub ms_solve: f32,
    pub ms_integrate: f32,
}

/// A physics world.
#[derive(Clone, Debug)]
pub struct World {
    /// The bodies, in creation order.
    pub bodies: Vec<Body>,
    /// m/s^2; `None` skips the gravity pass.
    pub gravity: Option<Vec2>,
    /// `None` = vacuum.
    pub drag: Option<DragDef>,
    /// The solver and its settings.
    pub settings: SolverSettings,
    forces: Vec<PointForce>,
    broad: BroadPhase,
    aabbs: Vec<Aabb>,
    dynamic: Vec<bool>,
    /// How far each body can move this step (the speculative margin's part per body).
    reach: Vec<f32>,
    pub(crate) contacts: Vec<Contact>,
    old_contacts: Vec<Contact>,
    /// The contacts of sleeping islands, kept with their impulses for when they wake.
    pub(crate) sleeping_contacts: Vec<Contact>,
    /// Union-find parents of the sleep pass (scratch).
    islands: Vec<u32>,
    /// Each island's least rested time (scratch of the sleep pass).
    least_rest: Vec<f32>,
    /// Islands to wake (scratch).
    to_wake: Vec<u32>,
    /// Which bodies size the waking pass's grid: the dynamic ones, asleep or not (scratch).
    wake_sized: Vec<bool>,
    pub(crate) joints: Vec<Joint>,
    /// Joints whose bodies all sleep (or do not move), with their index, taken out of
    /// `joints` for the solve of one step (see `park_sleeping_joints`).
    parked: Vec<(usize, Joint)>,
    /// The joints that stay in the solve (scratch of the parking).
    joints_scratch: Vec<Joint>,
    pub(crate) mouse: Option<MouseJoint>,
    /// Body pairs joined by a joint that must not collide, sorted.
    no_collide: Vec<(u32, u32)>,
    /// Whether any body has a filter other than the default (else the broad phase skips
    /// the check).
    filtered: bool,
    /// Whether any body is a sensor (else the narrow phase skips the check).
    has_sensors: bool,
    /// Whether any body has linear or angular damping (then the forces are not
    /// [`World::plain_forces`]).
    damped: bool,
    /// Kinematic bodies on a path, by key ([`crate::defs::MotionDef`]).
    motions: Vec<spawn::Motion>,
    /// The scene's timed spawns ([`crate::defs::SpawnDef`]) and what each has made.
    spawners: Vec<spawn::Spawner>,
    /// Whether this step's collide found no body asleep and no sleeping contact (then
    /// none is asleep at the step's end either: only `update_sleep` puts bodies to
    /// sleep), so the end of the step need not look again.
    none_asleep: bool,
    /// Whether this step's collide found `dynamic` for every body with none asleep: it
    /// then says which bodies are dynamic ([`World::bodies_with_movers`]).
    movers_found: bool,
    /// Set by a solver whose last pass over the bodies did the end of the step (cleared
    /// the forces and checked the state): whether some body's state is not finite.
    /// `World::step` then skips its own pass ([`World::end_step`]).
    pub(crate) ended: Option<bool>,
    /// Record contact and sensor events each step ([`World::events`]); off unless asked
    /// for or a sensor exists, so a world that needs no events pays nothing for them.
    pub record_events: bool,
    /// The last step's events.
    events: Vec<ContactEvent>,
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
    /// ([`WorldDef::origin`]); [`World::world_position`] adds it back.
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
    /// Per block of pairs: the contacts the narrow phase found (scratch).
    narrow_out: NarrowScratch,
    /// Each block's first contact (scratch).
    narrow_starts: Vec<usize>,
}

/// Per-thread narrow-phase output buffers; a clone starts with none.
#[derive(Default)]
struct NarrowScratch(Vec<Mutex<Vec<Contact>>>);

impl Clone for NarrowScratch {
    fn clone(&self) -> Self {
        NarrowScratch::default()
    }
}

impl std::fmt::Debug for NarrowScratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("NarrowScratch")
    }
}

/// Fewest bodies for which a world starts its worker threads.
const MIN_BODIES_FOR_THREADS: usize = 256;
/// Body pairs a thread claims at a time in the narrow phase.
const PAIR_BLOCK: usize = 256;

impl World {
    /// An empty world with the given gravity and solver settings.
    pub fn new(gravity: Option<Vec2>, settings: SolverSettings) -> World {
        World {
            bodies: Vec::new(),
            gravity,
            drag: None,
            settings,
            forces: Vec::new(),
            broad: BroadPhase::default(),
            aabbs: Vec::new(),
            dynamic: Vec::new(),
            reach: Vec::new(),
            contacts: Vec::new(),
            old_contacts: Vec::new(),
            sleeping_contacts: Vec::new(),
            islands: Vec::new(),
            least_rest: Vec::new(),
            to_wake: Vec::new(),
            wake_sized: Vec::new(),
            joints: Vec::new(),
            parked: Vec::new(),
            joints_scratch: Vec::new(),
            mouse: None,
            no_collide: Vec::new(),
            filtered: false,
            has_sensors: false,
            damped: false,
            motions: Vec::new(),
            spawners: Vec::new(),
            none_asleep: false,
            movers_found: false,
            ended: None,
            record_events: false,
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
            joint_keys: edit::Keys::default(),
            narrow_out: NarrowScratch::default(),
            narrow_starts: Vec::new(),
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

    /// The joints, in creation order.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Sets a joint's drive: a constant force (N, prismatic and distance joints, along
    /// the axis) or torque (N m, hinge and weld) on its second body, with the reaction on
    /// the first, every step until changed (the seed's ApplyForce / ApplyTorque).
    pub fn set_joint_drive(&mut self, joint: JointId, value: f32) {
        if let Some(j) = self.joints.get_mut(joint) {
            j.drive = if value.is_finite() { value } else { 0.0 };
            let (a, b) = (j.a, j.b);
            self.wake(a);
            self.wake(b);
        }
    }

    /// Grabs a body with the mouse joint (or lets go with `None`).
    pub fn set_mouse(&mut self, mouse: Option<MouseJoint>) {
        self.mouse = mouse.filter(|m| m.body < self.bodies.len() && m.target.is_finite());
        if let Some(m) = self.mouse {
            self.wake(m.body);
        }
    }

    /// The mouse joint, if a body is held.
    pub fn mouse(&self) -> Option<&MouseJoint> {
        self.mouse.as_ref()
    }

    /// A mouse joint holding the dynamic body under `world_point`, with the usual
    /// feel (5 Hz, damping ratio 0.7, up to 1000 times the body's weight at 10 m/s^2).
    pub fn grab(&self, body: BodyId, world_point: Vec2) -> Option<MouseJoint> {
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

    /// The largest anchor separation (m) of any joint now (0 without joints).
    pub fn joint_error(&self) -> f32 {
        self.joints
            .iter()
            .map(|j| j.position_error(&self.bodies))
            .fold(0.0, f32::max)
    }

    /// How many constant point forces the world has ([`World::add_force`]).
    pub fn force_count(&self) -> usize {
        self.forces.len()
    }

    /// Applies a force (N) at a world point for the next step only (the mouse's force emitter).
    pub fn apply_force(&mut self, body: BodyId, force: Vec2, world_point: Vec2) {
        if let Some(b) = self.bodies.get_mut(body)
            && b.is_dynamic()
        {
            b.force += force;
            b.torque += cross(world_point - b.position, force);
        }
    }

    /// The index of the body with this name.
    pub fn body_index(&self, name: &str) -> Option<BodyId> {
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

    /// This step's contacts (pairs and manifolds), sorted by pair.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Advances the world by one step of `settings.dt` (in `settings.substeps` substeps)
    /// with the solver `settings.kind`.
    pub fn step(&mut self) -> Result<(), StepError> {
        if !self.spawners.is_empty() || !self.motions.is_empty() {
            self.run_events();
        }
        self.sync_keys();
        let kind = self.settings.kind;
        let mut stepper = match self.stepper.take() {
            Some(st) if st.kind() == kind => st,
            _ => new_stepper(kind),
        };
        let cx = StepContext::new(&self.settings);
        let tune = self.tunes_threads();
        self.step_many = !tune || self.tuner.choose();
        let started = tune.then(std::time::Instant::now);
        // until collide finds otherwise
        self.none_asleep = false;
        self.movers_found = false;
        let mut clock = StageClock::start();
        // only this step's solver may say it ended the step
        self.ended = None;
        let mut stats = stepper.step(self, &cx, &mut clock);
        self.unpark_joints();
        clock.fill(&mut stats);
        self.stats = stats;
        self.stepper = Some(stepper);
        self.update_sleep();
        if self.record_events {
            self.update_events();
        }
        self.step_count += 1;
        self.time += self.settings.dt as f64;
        let ended = self.ended.take();
        let result = match ended {
            Some(false) => Ok(()),
            Some(true) => Err(self.first_non_finite()),
            None => self.end_step(),
        };
        if let Some(started) = started {
            self.tuner
                .record(self.step_many, started.elapsed(), self.threads);
        }
        self.step_many = true;
        result
    }

    /// The error for the first body (by index) whose state is not finite.
    fn first_non_finite(&self) -> StepError {
        let i = self.bodies.iter().position(|b| !body_finite(b));
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

    /// The solver that ran the last step, as its own type (for tests and tools).
    pub fn stepper_as<T: 'static>(&self) -> Option<&T> {
        self.stepper.as_ref()?.as_any().downcast_ref::<T>()
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

    /// What moves the bodies' velocities besides the solver's rows.
    fn forces(&self) -> integrate::Forces<'_> {
        integrate::Forces {
            joints: &self.joints,
            forces: &self.forces,
            gravity: self.gravity,
            drag: self.drag,
            damped: self.damped,
        }
    }

    /// Whether the forces change every substep's velocities by the same amount (see
    /// [`integrate::Forces::uniform`]).
    pub(crate) fn uniform_forces(&self) -> bool {
        self.forces().uniform()
    }

    /// Whether the only forces are gravity and the bodies' own force and torque (see
    /// [`integrate::Forces::plain`]).
    pub(crate) fn plain_forces(&self) -> bool {
        self.forces().plain()
    }

    /// Semi-implicit Euler, velocity half (see [`integrate::integrate_velocities`]).
    pub(crate) fn integrate_velocities(&mut self, h: f32) {
        let pool = self.pool();
        let forces = integrate::Forces {
            joints: &self.joints,
            forces: &self.forces,
            gravity: self.gravity,
            drag: self.drag,
            damped: self.damped,
        };
        integrate::integrate_velocities(&mut self.bodies, &forces, h, pool.as_deref());
    }

    /// The bodies and this step's contacts, with whether each body is dynamic where
    /// this step's collide found it for every body (none was asleep).
    #[allow(clippy::type_complexity)]
    pub(crate) fn bodies_with_movers(
        &mut self,
    ) -> (&mut [Body], &[Contact], &[Joint], Option<&[bool]>) {
        let movers = (self.movers_found && self.dynamic.len() == self.bodies.len())
            .then_some(&self.dynamic[..]);
        (&mut self.bodies, &self.contacts, &self.joints, movers)
    }

    /// Whether some body is asleep: a pass over the bodies (large), split between the
    /// threads.
    fn any_asleep(&mut self) -> bool {
        let pool = self.pool();
        let bodies = &self.bodies;
        parallel::ranges_max(pool.as_deref(), bodies.len(), BODY_PASS_BLOCK, &|_, r| {
            if bodies[r].iter().any(|b| b.asleep) {
                1.0
            } else {
                0.0
            }
        }) > 0.0
    }

    /// Broad and narrow phase; returns the deepest overlap found (m, >= 0). How far out
    /// a pair keeps points is `speculative`'s choice (see [`Speculative`]).
    pub(crate) fn collide(
        &mut self,
        h: f32,
        margin: f32,
        speculative: Speculative,
        clock: &mut StageClock,
    ) -> f32 {
        if self.sleeping_contacts.is_empty() && !self.any_asleep() {
            self.none_asleep = true;
            return self.collide_awake(h, margin, speculative, clock);
        }
        // wake every island an awake body (or a moving kinematic one) reaches, then every
        // island those reach, and so on: a woken island's own pairs were not looked for
        self.wake_reached(h, margin);
        self.park_sleeping_joints();
        if !self.bodies.iter().any(is_mover) {
            // all at rest: last step's contacts are kept aside, nothing is looked for
            self.sleeping_contacts.append(&mut self.contacts);
            clock.lap(Stage::Broad);
            clock.lap(Stage::Narrow);
            return 0.0;
        }
        self.collide_awake(h, margin, speculative, clock)
    }

    fn collide_awake(
        &mut self,
        h: f32,
        margin: f32,
        speculative: Speculative,
        clock: &mut StageClock,
    ) -> f32 {
        // sized, not cleared: the pass below writes every body's entry
        let n = self.bodies.len();
        self.aabbs.resize(
            n,
            Aabb {
                min: Vec2::ZERO,
                max: Vec2::ZERO,
            },
        );
        self.dynamic.resize(n, false);
        self.reach.resize(n, 0.0);
        // the flags are read off the bodies each step, so bodies pushed straight into
        // `bodies` (the CLI's build, tools) count as well as those added one by one
        const ASLEEP: u32 = 1;
        const FILTERED: u32 = 2;
        const SENSORS: u32 = 4;
        // the broad phase's kept boxes still hold every body (checked in the same pass)
        const LEFT: u32 = 8;
        let flags = AtomicU32::new(0);
        let pool = self.pool();
        let (bodies, broad) = (&self.bodies, &self.broad);
        let kept = broad.kept_count() == n;
        parallel::chunks_mut3(
            pool.as_deref(),
            &mut self.aabbs,
            &mut self.reach,
            &mut self.dynamic,
            BODY_PASS_BLOCK,
            &|_, offset, aabbs, reach, dynamic| {
                let bodies = &bodies[offset..];
                let mut f = 0u32;
                for (i, ((bx, re), dy)) in aabbs.iter_mut().zip(reach).zip(dynamic).enumerate() {
                    // the box reads the shape too
                    prefetch(bodies, i + BODY_AHEAD, SHAPE_BYTES);
                    let b = &bodies[i];
                    f |= if b.asleep { ASLEEP } else { 0 };
                    f |= if b.filter != crate::defs::Filter::default() {
                        FILTERED
                    } else {
                        0
                    };
                    f |= if b.has_sensor() { SENSORS } else { 0 };
                    let bb = b.aabb();
                    // the most any point of the body moves in h: h (|v| + |w| r)
                    let r = 0.5 * (bb.max - bb.min).length();
                    *re = h * (b.velocity.length() + b.angular_velocity.abs() * r);
                    *bx = swept_box(b, bb, h, margin);
                    // a sleeping body is found only by the awake bodies near it, as a
                    // static one
                    *dy = b.is_dynamic() && !b.asleep;
                    if kept
                        && !(broad.kept_holds(offset + i, bx, b.is_dynamic())
                            && broad.kept_filter_holds(offset + i, &b.filter))
                    {
                        f |= LEFT;
                    }
                }
                flags.fetch_or(f, Ordering::Relaxed);
                0.0
            },
        );
        let flags = flags.into_inner();
        let (filtered, sensors) = (flags & FILTERED != 0, flags & SENSORS != 0);
        let any_asleep = flags & ASLEEP != 0;
        // (with none asleep, `dynamic` is whether each body is dynamic)
        self.movers_found = !any_asleep;
        let holds = kept && flags & LEFT == 0;
        self.filtered = filtered;
        self.has_sensors = sensors;
        // a sensor is there to be heard
        self.record_events |= sensors;
        let bodies = &self.bodies;
        // without sensors (which read the pairs after the step) the narrow phase filters
        // the kept pairs itself, split between the threads: no list of this step's pairs
        let fused = !sensors;
        // with filters, the kept pairs are only those the filters let touch
        let filter_of = |i: usize| bodies[i].filter;
        let filter_of = filtered.then_some(&filter_of as &dyn Fn(usize) -> crate::defs::Filter);
        if fused {
            self.broad
                .refresh_kept(&self.aabbs, holds, |i| bodies[i].is_dynamic(), filter_of);
        } else {
            let test = PairTest {
                bodies,
                aabbs: &[],
                dynamic: &[],
                filtered,
                no_collide: &self.no_collide,
            };
            self.broad.find_pairs_kept_checked(
                &self.aabbs,
                &self.dynamic,
                holds,
                |i| bodies[i].is_dynamic(),
                filter_of,
                |a, b| test.may_collide(a, b),
            );
        }
        clock.lap(Stage::Broad);

        std::mem::swap(&mut self.contacts, &mut self.old_contacts);
        self.contacts.clear();
        if any_asleep {
            // contacts within sleeping islands (and of them with static bodies) are kept
            // aside with their impulses until the island wakes
            let bodies = &self.bodies;
            let asleep_pair = |c: &Contact| {
                let (a, b) = (&bodies[c.a as usize], &bodies[c.b as usize]);
                // neither awake and dynamic, one of them asleep
                !is_mover(a) && !is_mover(b) && (a.asleep || b.asleep)
            };
            let sleeping = &mut self.sleeping_contacts;
            self.old_contacts.retain(|c| {
                let keep = !asleep_pair(c);
                if !keep {
                    sleeping.push(*c);
                }
                keep
            });
        }
        let pool = self.pool();
        let narrow = Narrow {
            bodies: &self.bodies,
            pairs: if fused {
                self.broad.kept_pairs()
            } else {
                &self.broad.pairs
            },
            test: fused.then_some(PairTest {
                bodies: &self.bodies,
                aabbs: &self.aabbs,
                dynamic: &self.dynamic,
                filtered,
                no_collide: &self.no_collide,
            }),
            old: &self.old_contacts,
            reach: &self.reach,
            has_sensors: self.has_sensors,
            speculative,
            margin,
        };
        let pairs = narrow.pairs.len();
        let deepest = match pool.as_deref() {
            Some(pool) if pairs > PAIR_BLOCK => {
                // the caller writes the blocks it takes in order from the first straight
                // into the contact list (it takes its own share first, in order); every
                // other block goes into its own buffer, and the buffers are appended in
                // pair order, so the contacts are those of one thread
                let blocks = pairs.div_ceil(PAIR_BLOCK);
                let outs = &mut self.narrow_out.0;
                if outs.len() < blocks {
                    // room for a contact a pair from the start: a block the caller
                    // usually writes in place may go through its buffer in any step,
                    // and a steady step allocates nothing
                    outs.resize_with(blocks, || Mutex::new(Vec::with_capacity(PAIR_BLOCK)));
                }
                let outs = &outs[..blocks];
                // (the list, and the blocks written into it)
                let direct = Mutex::new((&mut self.contacts, 0usize));
                let deepest = parallel::ranges_max(Some(pool), pairs, PAIR_BLOCK, &|t, range| {
                    let b = range.start / PAIR_BLOCK;
                    if t == 0 {
                        let mut d = direct.lock().unwrap_or_else(|e| e.into_inner());
                        if d.1 == b {
                            d.1 += 1;
                            return narrow.run(range, d.0);
                        }
                    }
                    let mut out = outs[b].lock().unwrap_or_else(|e| e.into_inner());
                    out.clear();
                    narrow.run(range, &mut out)
                });
                let (contacts, written) = direct.into_inner().unwrap_or_else(|e| e.into_inner());
                parallel::concat(
                    Some(pool),
                    &mut self.narrow_out.0[..blocks],
                    written,
                    &mut self.narrow_starts,
                    contacts,
                );
                deepest
            }
            _ => narrow.run(0..narrow.pairs.len(), &mut self.contacts),
        };
        clock.lap(Stage::Narrow);
        deepest
    }

    /// Wakes the island `body` sleeps in (nothing if it is awake).
    pub fn wake(&mut self, body: BodyId) {
        if let Some(b) = self.bodies.get(body)
            && b.asleep
        {
            let island = b.island;
            self.wake_island(island);
        }
    }

    /// Wakes the sleeping islands labelled in `islands` (any order, repeats allowed) in
    /// one pass over the bodies and the kept contacts, as [`World::wake_island`] would
    /// one by one.
    pub(crate) fn wake_islands(&mut self, islands: &mut Vec<u32>) {
        islands.sort_unstable();
        islands.dedup();
        if islands.is_empty() {
            return;
        }
        for b in &mut self.bodies {
            if b.asleep && islands.binary_search(&b.island).is_ok() {
                b.asleep = false;
                b.sleep_time = 0.0;
            }
        }
        let bodies = &self.bodies;
        let (mut back, mut kept) = (Vec::new(), Vec::new());
        for c in self.sleeping_contacts.drain(..) {
            if bodies[c.a as usize].asleep || bodies[c.b as usize].asleep {
                kept.push(c);
            } else {
                back.push(c);
            }
        }
        self.sleeping_contacts = kept;
        if !back.is_empty() {
            // the cache is read as one list sorted by pair
            self.contacts.extend(back);
            self.contacts.sort_by_key(|c| (c.a, c.b));
        }
    }

    /// Wakes every sleeping body of `island` and puts its kept contacts back in the
    /// cache, so they start warm.
    fn wake_island(&mut self, island: u32) {
        for b in &mut self.bodies {
            if b.asleep && b.island == island {
                b.asleep = false;
                b.sleep_time = 0.0;
            }
        }
        let bodies = &self.bodies;
        let (mut back, mut kept) = (Vec::new(), Vec::new());
        for c in self.sleeping_contacts.drain(..) {
            if bodies[c.a as usize].asleep || bodies[c.b as usize].asleep {
                kept.push(c);
            } else {
                back.push(c);
            }
        }
        self.sleeping_contacts = kept;
        if !back.is_empty() {
            // the cache is read as one list sorted by pair
            self.contacts.extend(back);
            self.contacts.sort_by_key(|c| (c.a, c.b));
        }
    }

    /// Takes the joints whose bodies all sleep or do not move out of `joints` for this
    /// step's solve: a sleeping island's joints cost nothing, and their warm-started
    /// impulses (which balanced a gravity the sleeping bodies no longer get) do not push
    /// the island awake. Called after the wake passes; `unpark_joints` puts them back in
    /// order after the solve.
    fn park_sleeping_joints(&mut self) {
        let bodies = &self.bodies;
        let resting = |i: usize| {
            let b = &bodies[i];
            b.asleep || b.body_type == BodyType::Static || (!b.is_dynamic() && !is_mover(b))
        };
        if !self.joints.iter().any(|j| resting(j.a) && resting(j.b)) {
            return;
        }
        let mut keep = std::mem::take(&mut self.joints_scratch);
        keep.clear();
        for (i, j) in self.joints.drain(..).enumerate() {
            if resting(j.a) && resting(j.b) {
                self.parked.push((i, j));
            } else {
                keep.push(j);
            }
        }
        self.joints_scratch = std::mem::replace(&mut self.joints, keep);
    }

    /// Puts the parked joints back where they were.
    fn unpark_joints(&mut self) {
        if self.parked.is_empty() {
            return;
        }
        let mut all = std::mem::take(&mut self.joints_scratch);
        all.clear();
        let mut awake = self.joints.drain(..);
        let mut parked = self.parked.drain(..).peekable();
        let total = awake.len() + parked.len();
        for i in 0..total {
            match parked.peek() {
                Some((at, _)) if *at == i => all.push(parked.next().unwrap().1),
                _ => all.extend(awake.next()),
            }
        }
        drop(awake);
        self.joints_scratch = std::mem::replace(&mut self.joints, all);
    }

    /// Waking: every sleeping island that an awake dynamic body's (or a moving kinematic
    /// body's) box reaches, or whose body was pushed, set moving or given a force since
    /// it fell asleep; then every island those reach, and so on until none wakes.
    ///
    /// Each round looks only from the bodies the round before woke (the others' reach
    /// was looked at already), through one grid of every body's box (boxes do not
    /// change while waking), and wakes that round's islands in one pass
    /// ([`World::wake_islands`]): the same bodies wake, with the same contacts in the
    /// same order, as round after round of looking from every awake body.
    fn wake_reached(&mut self, h: f32, margin: f32) {
        let mut wake = std::mem::take(&mut self.to_wake);
        wake.clear();
        let mut movers = false;
        for b in &self.bodies {
            if b.asleep
                && (b.velocity != Vec2::ZERO
                    || b.angular_velocity != 0.0
                    || b.force != Vec2::ZERO
                    || b.torque != 0.0)
            {
                wake.push(b.island);
            }
            movers |= is_mover(b);
        }
        // nothing awake moves: nothing can reach a sleeping island
        if movers {
            self.aabbs.clear();
            self.dynamic.clear();
            self.wake_sized.clear();
            for b in &self.bodies {
                self.aabbs.push(swept_box(b, b.aabb(), h, margin));
                // the movers look for sleepers; sleepers and static bodies are looked up
                self.dynamic.push(is_mover(b));
                // the grid's cells fit the dynamic bodies, asleep or not: a few large
                // movers must not put many small sleepers in one cell
                self.wake_sized.push(b.is_dynamic());
            }
        }
        let mut first = true;
        loop {
            if movers {
                let bodies = &self.bodies;
                let (aabbs, look, sized) = (&self.aabbs, &self.dynamic, &self.wake_sized);
                self.broad.find_pairs_sized(aabbs, look, sized, |a, b| {
                    let (ba, bb) = (&bodies[a as usize], &bodies[b as usize]);
                    (ba.asleep && is_mover(bb)) || (bb.asleep && is_mover(ba))
                });
                for &(a, b) in &self.broad.pairs {
                    for i in [a, b] {
                        let body = &self.bodies[i as usize];
                        if body.asleep {
                            wake.push(body.island);
                        }
                    }
                }
                // a joint to a body that moves (one to a static anchor keeps it asleep)
                for j in &self.joints {
                    let (ba, bb) = (&self.bodies[j.a], &self.bodies[j.b]);
                    if ba.asleep && is_mover(bb) && (first || self.dynamic[j.b]) {
                        wake.push(ba.island);
                    }
                    if bb.asleep && is_mover(ba) && (first || self.dynamic[j.a]) {
                        wake.push(bb.island);
                    }
                }
            }
            first = false;
            wake.sort_unstable();
            wake.dedup();
            if wake.is_empty() {
                break;
            }
            // the next round looks from the bodies this one wakes
            if movers {
                for (look, b) in self.dynamic.iter_mut().zip(&self.bodies) {
                    *look = b.asleep && wake.binary_search(&b.island).is_ok();
                }
            }
            self.wake_islands(&mut wake);
            movers = true;
            if self.aabbs.len() != self.bodies.len() {
                // the first round had no mover (a pushed sleeper woke): the boxes now
                self.aabbs.clear();
                self.wake_sized.clear();
                self.dynamic.clear();
                for b in &self.bodies {
                    self.aabbs.push(swept_box(b, b.aabb(), h, margin));
                    self.wake_sized.push(b.is_dynamic());
                    self.dynamic.push(is_mover(b));
                }
            }
            wake.clear();
        }
        self.to_wake = wake;
    }

    /// After a step: a dynamic body slower than its sleep threshold (0.05 m/s unless it
    /// sets its own) and 2 degrees/s (Box2D's thresholds) for 0.5 s is at rest; an island of bodies joined by touching contacts
    /// and joints falls asleep when all of its bodies are. Bodies held by the mouse, with
    /// a constant force, on a joint with a turning motor or a drive, or touching a
    /// moving kinematic body stay awake.
    fn update_sleep(&mut self) {
        const ANGULAR: f32 = 2.0 * std::f32::consts::PI / 180.0;
        const TIME_TO_SLEEP: f32 = 0.5;
        if !self.settings.sleep {
            if !self.none_asleep
                && (self.bodies.iter().any(|b| b.asleep) || !self.sleeping_contacts.is_empty())
            {
                let islands: Vec<u32> = self
                    .bodies
                    .iter()
                    .filter(|b| b.asleep)
                    .map(|b| b.island)
                    .collect();
                for i in islands {
                    self.wake_island(i);
                }
            }
            return;
        }
        let dt = self.settings.dt;
        let n = self.bodies.len();
        for b in &mut self.bodies {
            if !b.is_dynamic() || b.asleep {
                continue;
            }
            let r = b.shape.radius();
            let linear = b.sleep_threshold;
            let slow = b.velocity.length_squared() < linear * linear
                && (b.angular_velocity * b.angular_velocity < ANGULAR * ANGULAR)
                && (b.angular_velocity * r).abs() < linear;
            b.sleep_time = if slow { b.sleep_time + dt } else { 0.0 };
        }
        // what keeps a body awake whatever its speed
        for f in &self.forces {
            self.bodies[f.body].sleep_time = 0.0;
        }
        if let Some(m) = self.mouse {
            self.bodies[m.body].sleep_time = 0.0;
        }
        // a joint that drives its bodies keeps them awake: a turning motor, a drive
        // force or torque (a servo at its target rests, and may sleep)
        for j in &self.joints {
            if j.drive != 0.0 || j.motor.is_some_and(|m| m.speed != 0.0) {
                self.bodies[j.a].sleep_time = 0.0;
                self.bodies[j.b].sleep_time = 0.0;
            }
        }
        for c in &self.contacts {
            let (ba, bb) = (&self.bodies[c.a as usize], &self.bodies[c.b as usize]);
            let kinematic_moving = |b: &Body| {
                b.body_type == BodyType::Kinematic
                    && (b.velocity != Vec2::ZERO || b.angular_velocity != 0.0)
            };
            if kinematic_moving(ba) {
                self.bodies[c.b as usize].sleep_time = 0.0;
            } else if kinematic_moving(bb) {
                self.bodies[c.a as usize].sleep_time = 0.0;
            }
        }
        if self
            .bodies
            .iter()
            .all(|b| !b.is_dynamic() || b.asleep || b.sleep_time < TIME_TO_SLEEP)
        {
            return;
        }
        // islands: union-find over awake dynamic bodies joined by touching contacts and
        // joints
        let parent = &mut self.islands;
        parent.clear();
        parent.extend(0..n as u32);
        let bodies = &self.bodies;
        let joins = |a: usize, b: usize| bodies[a].is_dynamic() && bodies[b].is_dynamic();
        let union =
            |parent: &mut Vec<u32>, a: usize, b: usize| uf_union(parent, a as u32, b as u32);
        let touch = self.settings.slop.max(0.005);
        for c in &self.contacts {
            let (a, b) = (c.a as usize, c.b as usize);
            if joins(a, b) && c.manifold.points().iter().any(|p| p.separation < touch) {
                union(parent, a, b);
            }
        }
        for j in &self.joints {
            if joins(j.a, j.b) {
                union(parent, j.a, j.b);
            }
        }
        // an island sleeps when its least rested body has rested long enough
        let least = &mut self.least_rest;
        least.clear();
        least.resize(n, f32::INFINITY);
        for (i, b) in bodies.iter().enumerate() {
            if b.is_dynamic() && !b.asleep {
                let r = uf_root(parent, i as u32) as usize;
                least[r] = least[r].min(b.sleep_time);
            }
        }
        for i in 0..n {
            let b = &self.bodies[i];
            if !b.is_dynamic() || b.asleep {
                continue;
            }
            let r = uf_root(&mut self.islands, i as u32);
            if least[r as usize] >= TIME_TO_SLEEP {
                let b = &mut self.bodies[i];
                b.asleep = true;
                b.island = r;
                b.velocity = Vec2::ZERO;
                b.angular_velocity = 0.0;
            }
        }
    }

    /// A body's position in the scene file's coordinates, [`World::origin`] added back
    /// in f64.
    pub fn world_position(&self, body: BodyId) -> glam::DVec2 {
        self.origin + self.bodies[body].position.as_dvec2()
    }

    /// The first dynamic body whose energy term ([`World::energy`]'s) is not finite,
    /// and why: to name it when the total is not.
    pub fn energy_not_finite(&self) -> Option<(BodyId, String)> {
        self.bodies.iter().enumerate().find_map(|(i, b)| {
            if !b.is_dynamic() {
                return None;
            }
            energy_problem(b, self.gravity).map(|(_, why)| (i, why))
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

/// The broad phase's box of a body whose shape's box is `bb`: grown by its motion over
/// `h` (a moving body's, so that fast bodies find their pairs) and by half the margin.
fn swept_box(b: &Body, bb: Aabb, h: f32, margin: f32) -> Aabb {
    let bb = if b.body_type != BodyType::Static {
        let d = b.velocity * h;
        Aabb {
            min: bb.min + d.min(Vec2::ZERO),
            max: bb.max + d.max(Vec2::ZERO),
        }
    } else {
        bb
    };
    bb.fattened(0.5 * margin)
}

/// How many pairs ahead the narrow phase asks for the bodies it will read.
const PAIR_AHEAD: usize = 4;

/// What the narrow phase reads: the pairs of the broad phase and last step's contacts.
/// Whether a candidate pair is a pair this step: the broad phase's test (one body
/// moves, the boxes overlap) where `aabbs` is given, then the filters and the
/// no-collide list.
struct PairTest<'a> {
    bodies: &'a [Body],
    /// This step's boxes and movers; empty when the broad phase has tested them.
    aabbs: &'a [Aabb],
    dynamic: &'a [bool],
    /// Some body has a collision filter other than the default.
    filtered: bool,
    no_collide: &'a [(u32, u32)],
}

impl PairTest<'_> {
    /// The filters and the no-collide list (the broad phase's own test aside).
    #[inline]
    fn may_collide(&self, a: u32, b: u32) -> bool {
        (!self.filtered
            || self.bodies[a as usize]
                .filter
                .collides(&self.bodies[b as usize].filter))
            && (self.no_collide.is_empty()
                || self
                    .no_collide
                    .binary_search(&(a.min(b), a.max(b)))
                    .is_err())
    }

    /// The whole test, for a kept pair.
    #[inline]
    fn holds(&self, a: u32, b: u32) -> bool {
        BroadPhase::kept_pair_holds(self.aabbs, self.dynamic, a, b) && self.may_collide(a, b)
    }
}

struct Narrow<'a> {
    bodies: &'a [Body],
    /// The pairs to collide: this step's, or (with `test`) the broad phase's kept pairs,
    /// which `test` filters.
    pairs: &'a [(u32, u32)],
    test: Option<PairTest<'a>>,
    /// Last step's contacts, sorted by pair (the cache).
    old: &'a [Contact],
    reach: &'a [f32],
    has_sensors: bool,
    speculative: Speculative,
    margin: f32,
}

impl Narrow<'_> {
    /// Collides the pairs of `range` (in order) and pushes the touching ones to `out`;
    /// returns the deepest overlap found (m, >= 0).
    fn run(&self, range: std::ops::Range<usize>, out: &mut Vec<Contact>) -> f32 {
        let pairs = &self.pairs[range];
        let Some(&first) = pairs.first() else {
            return 0.0;
        };
        // the cache from the first pair of the run on
        let from = self.old.partition_point(|c| (c.a, c.b) < first);
        let mut cache = CacheCursor::new(&self.old[from..]);
        let mut deepest = 0.0f32;
        for (i, &(a, b)) in pairs.iter().enumerate() {
            if let Some(t) = &self.test
                && !t.holds(a, b)
            {
                continue;
            }
            if let Some(&(na, nb)) = pairs.get(i + PAIR_AHEAD) {
                prefetch(self.bodies, na as usize, SHAPE_BYTES);
                prefetch(self.bodies, nb as usize, SHAPE_BYTES);
            }
            let (ba, bb) = (&self.bodies[a as usize], &self.bodies[b as usize]);
            if self.has_sensors && (ba.sensor || bb.sensor) {
                // heard (World::events), never resolved
                continue;
            }
            let (ra, rb) = (self.reach[a as usize], self.reach[b as usize]);
            let pair_margin = match self.speculative {
                Speculative::MarginPlusMotion => self.margin + ra + rb,
                Speculative::MarginOrMotion => self.margin.max(ra + rb),
            };
            if !(ba.parts.is_empty() && bb.parts.is_empty()) {
                // a compound: one manifold per pair of touching parts
                let old = cache.find_all(a, b);
                crate::compound::collide_bodies(
                    ba,
                    bb,
                    pair_margin,
                    |mut m, friction, restitution| {
                        for o in old {
                            match_points(&o.manifold, &mut m);
                        }
                        for p in m.points() {
                            deepest = deepest.max(-p.separation);
                        }
                        out.push(Contact {
                            a,
                            b,
                            manifold: m,
                            friction,
                            restitution,
                        });
                    },
                );
                continue;
            }
            let mut m = sat::collide(
                &ba.shape,
                &ba.transform(),
                &bb.shape,
                &bb.transform(),
                pair_margin,
            );
            if m.count == 0 {
                continue;
            }
            if let Some(old) = cache.find(a, b) {
                match_points(old, &mut m);
            }
            for p in m.points() {
                deepest = deepest.max(-p.separation);
            }
            out.push(Contact {
                a,
                b,
                manifold: m,
                // mu = sqrt(mu_a mu_b), e = max(e_a, e_b)
                friction: (ba.friction * bb.friction).sqrt(),
                restitution: ba.restitution.max(bb.restitution),
            });
        }
        deepest
    }
}

/// An awake dynamic body, or a kinematic one that moves: what wakes a sleeping island
/// it reaches.
fn is_mover(b: &Body) -> bool {
    (b.is_dynamic() && !b.asleep)
        || (b.body_type == BodyType::Kinematic
            && (b.velocity != Vec2::ZERO || b.angular_velocity != 0.0))
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
