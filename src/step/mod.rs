//! The step. Each [`SolverKind`] is one [`Stepper`]: it owns its scratch, and its
//! `step` is the order of stages and nothing else, calling the shared stages on the
//! [`StepState`] the world lends it ([`StepState::collide`],
//! [`StepState::integrate_velocities`]; `integrate.rs`, `sleep.rs`) and its own
//! kernels in `crate::solver`. The world owns the state (bodies, joints, contacts) and
//! lends it for one step; nothing here reaches back to the world.
//!
//! Adding a solver: a file here with a type that implements [`Stepper`], its kernels
//! under `src/solver/`, one variant in [`SolverKind`] (with its name, defaults and keys
//! in `defs.rs`), and one arm in [`new_stepper`].

use std::time::Instant;

use crate::body::Body;
use crate::collision::Contact;
use crate::collision::collide::{Collider, Speculative};
use crate::defs::{DragDef, SolverKind, SolverSettings};
use crate::joint::{Joint, MouseJoint};
use crate::math::Vec2;
use crate::parallel::Pool;

pub(crate) mod integrate;
pub mod pgs;
pub(crate) mod sleep;
pub mod soft;
pub mod xpbd;

use integrate::{Forces, PointForce};
use sleep::Sleep;

pub use pgs::PgsStepper;
pub use soft::SoftStepper;
pub use xpbd::XpbdStepper;

/// Contact points are kept while the gap is below this many slops (speculative contacts).
pub const SPECULATIVE_SLOPS: f32 = 4.0;

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
    /// Colours of the soft step's constraint graph (what its threads split); 0 under
    /// the other solvers.
    pub colors: usize,
    /// Time per stage (ms): forces and velocity integration, broad phase, narrow phase,
    /// solver, position integration.
    pub ms_forces: f32,
    /// Broad phase (ms): finding the pairs whose boxes overlap.
    pub ms_broad: f32,
    /// Narrow phase (ms): the pairs' contact manifolds.
    pub ms_narrow: f32,
    /// Solver (ms): contact and joint rows.
    pub ms_solve: f32,
    /// Position integration (ms).
    pub ms_integrate: f32,
}

/// What a step needs to know of time, computed once per step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepContext {
    /// The step (s).
    pub dt: f32,
    /// Substeps.
    pub substeps: u32,
    /// The substep, dt / substeps (s).
    pub h: f32,
    /// 1 / h.
    pub inv_h: f32,
    /// The speculative margin (m): a pair keeps points while its gap is below this
    /// (plus, where the solver asks, the distance its bodies can close).
    pub margin: f32,
    /// The world's steps before this one (the soft step sweeps its colours in the
    /// reverse order on odd steps without joints).
    pub index: u64,
}

impl StepContext {
    /// The context of the step after `index` steps with these settings.
    pub fn new(s: &SolverSettings, index: u64) -> StepContext {
        let n = s.substeps.max(1);
        let h = s.dt / n as f32;
        StepContext {
            dt: s.dt,
            substeps: n,
            h,
            inv_h: 1.0 / h,
            margin: SPECULATIVE_SLOPS * s.slop.max(0.001),
            index,
        }
    }
}

/// The stages a step's time is split into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Forces, drives, gravity and drag into the velocities.
    Forces,
    /// Boxes and candidate pairs.
    Broad,
    /// SAT manifolds and the contact cache.
    Narrow,
    /// The solver's rows (contacts and joints).
    Solve,
    /// Positions from velocities.
    Integrate,
}

impl Stage {
    /// How many stages there are.
    pub const COUNT: usize = 5;
}

/// Times the stages of a step: each `lap` charges the time since the last lap to a stage.
#[derive(Clone, Copy, Debug)]
pub struct StageClock {
    last: Instant,
    /// Milliseconds per stage, indexed by `Stage as usize`.
    pub ms: [f32; Stage::COUNT],
}

impl StageClock {
    /// A clock starting now with nothing charged.
    pub fn start() -> StageClock {
        StageClock {
            last: Instant::now(),
            ms: [0.0; Stage::COUNT],
        }
    }

    /// Charges the time since the last lap (or the start) to `stage`.
    #[inline]
    pub fn lap(&mut self, stage: Stage) {
        let now = Instant::now();
        self.ms[stage as usize] += (now - self.last).as_secs_f32() * 1e3;
        self.last = now;
    }

    /// The charged times as the stats' named fields.
    pub fn fill(&self, s: &mut StepStats) {
        s.ms_forces = self.ms[Stage::Forces as usize];
        s.ms_broad = self.ms[Stage::Broad as usize];
        s.ms_narrow = self.ms[Stage::Narrow as usize];
        s.ms_solve = self.ms[Stage::Solve as usize];
        s.ms_integrate = self.ms[Stage::Integrate as usize];
    }
}

/// What a step reads and advances: the world's state, lent to the stepper for one
/// step.
pub(crate) struct StepState<'a> {
    /// The bodies, in creation order.
    pub bodies: &'a mut [Body],
    /// This step's contacts, sorted by pair: what the collide finds, the solvers read
    /// and store their impulses in.
    pub contacts: &'a mut Vec<Contact>,
    /// The joints in the solve (those of sleeping islands are parked for the step).
    pub joints: &'a mut Vec<Joint>,
    /// The mouse joint, if a body is held.
    pub mouse: Option<MouseJoint>,
    /// Constant point forces.
    pub forces: &'a [PointForce],
    /// m/s^2; `None` skips the gravity pass.
    pub gravity: Option<Vec2>,
    /// `None` = vacuum.
    pub drag: Option<DragDef>,
    /// Whether any body has linear or angular damping of its own.
    pub damped: bool,
    pub settings: SolverSettings,
    /// The worker threads for this step (`None`: one thread).
    pub pool: Option<&'a Pool>,
    /// The collide stage's state.
    pub collider: &'a mut Collider,
    /// The sleeping islands' contacts and parked joints.
    pub sleep: &'a mut Sleep,
    /// Set by a solver whose last pass over the bodies did the end of the step (cleared
    /// the forces and checked the state): whether some body's state is not finite. The
    /// world then skips its own pass ([`integrate::end_step`]).
    pub ended: Option<bool>,
    /// Some joint may break ([`crate::Joint::breakable`]): XPBD then sums its joints'
    /// substep impulses for the world to read.
    pub may_break: bool,
}

impl StepState<'_> {
    /// The collide stage: wakes what the movers reach (if anything sleeps), then the
    /// broad and narrow phases; returns the deepest overlap found (m, >= 0). How far
    /// out a pair keeps points is `speculative`'s choice (see [`Speculative`]).
    pub fn collide(
        &mut self,
        h: f32,
        margin: f32,
        speculative: Speculative,
        clock: &mut StageClock,
    ) -> f32 {
        // (none asleep may be known from the last step's end)
        debug_assert!(!self.sleep.none_asleep || !self.bodies.iter().any(|b| b.asleep));
        if self.sleep.none_asleep
            || self.sleep.contacts.is_empty() && !sleep::any_asleep(self.bodies, self.pool)
        {
            self.sleep.none_asleep = true;
        } else {
            // wake every island an awake body (or a moving kinematic one) reaches, then
            // every island those reach, and so on: a woken island's own pairs were not
            // looked for
            self.sleep.wake_reached(
                self.bodies,
                self.contacts,
                self.joints,
                self.collider,
                h,
                margin,
                self.pool,
            );
            self.sleep.park_joints(self.bodies, self.joints);
            if !self.bodies.iter().any(Body::is_mover) {
                // all at rest: last step's contacts are kept aside, nothing is looked for
                self.sleep.contacts.append(self.contacts);
                clock.lap(Stage::Broad);
                clock.lap(Stage::Narrow);
                return 0.0;
            }
        }
        self.collider
            .broad_phase(self.bodies, h, margin, &self.sleep.rest, self.pool);
        clock.lap(Stage::Broad);
        let deepest = self.collider.narrow_phase(
            self.bodies,
            self.contacts,
            &mut self.sleep.contacts,
            margin,
            speculative,
            self.pool,
        );
        clock.lap(Stage::Narrow);
        deepest
    }

    /// What moves the bodies' velocities besides the solver's rows.
    pub fn forces(&self) -> Forces<'_> {
        Forces {
            joints: self.joints,
            forces: self.forces,
            gravity: self.gravity,
            drag: self.drag,
            damped: self.damped,
        }
    }

    /// Whether the only forces are gravity, the bodies' own force and torque and the
    /// joints' drives (see [`Forces::plain`]).
    pub fn plain_forces(&self) -> bool {
        self.forces().plain()
    }

    /// Semi-implicit Euler, velocity half (see [`integrate::integrate_velocities`]).
    pub fn integrate_velocities(&mut self, h: f32) {
        let Self {
            bodies,
            joints,
            forces,
            gravity,
            drag,
            damped,
            pool,
            ..
        } = self;
        let forces = Forces {
            joints,
            forces,
            gravity: *gravity,
            drag: *drag,
            damped: *damped,
        };
        integrate::integrate_velocities(bodies, &forces, h, *pool);
    }
}

/// A solver: advances the world's state by one step.
pub(crate) trait Stepper: std::fmt::Debug + Send + Sync {
    /// Which kind this is.
    fn kind(&self) -> SolverKind;

    /// One step of `cx.dt`: the bodies, joints and contacts are advanced in place; the
    /// returned stats hold the counts (the caller fills the stage times from `clock`).
    fn step(
        &mut self,
        state: &mut StepState,
        cx: &StepContext,
        clock: &mut StageClock,
    ) -> StepStats;

    /// The contact lambdas of the last solve, normal and friction of every point,
    /// contact by contact in pair order (N s); `contacts` are the last step's.
    fn contact_lambdas(&self, contacts: &[Contact], out: &mut Vec<f32>);

    /// A boxed copy (worlds are cloned by the bench).
    fn box_clone(&self) -> Box<dyn Stepper>;

    /// The stepper as `Any`, for `World::stepper_as` (unit tests).
    #[cfg(test)]
    fn as_any(&self) -> &dyn std::any::Any;

    /// The stepper as mutable `Any`, for `World::stepper_as_mut` (unit tests).
    #[cfg(test)]
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any;
}

impl Clone for Box<dyn Stepper> {
    fn clone(&self) -> Self {
        self.box_clone()
    }
}

/// A fresh stepper of the given kind.
pub fn new_stepper(kind: SolverKind) -> Box<dyn Stepper> {
    match kind {
        SolverKind::Soft => Box::new(SoftStepper::default()),
        SolverKind::Pgs => Box::new(PgsStepper::default()),
        SolverKind::Xpbd => Box::new(XpbdStepper::default()),
    }
}

/// The lambdas the contacts hold (what the solver stored for the next warm start).
pub(crate) fn stored_lambdas(contacts: &[Contact], out: &mut Vec<f32>) {
    out.clear();
    for c in contacts {
        for p in c.manifold.points() {
            out.push(p.normal_impulse);
            out.push(p.tangent_impulse);
        }
    }
}

/// Small worlds for the solvers' unit tests.
#[cfg(test)]
pub(crate) mod testing {
    use crate::defs::{SolverKind, SolverSettings};
    use crate::world::World;

    /// A 1 kg unit box (density 1) resting on a static ground, gravity 10, under `kind`
    /// with its defaults.
    pub fn resting_box(kind: SolverKind) -> World {
        let sc = crate::scene::load_str(
            "name = \"box\"\n[world]\ngravity = [0.0, -10.0]\n\
             [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [10.0, 1.0] }\nposition = [0.0, -0.5]\n\
             [[body]]\nname = \"box\"\nshape = { box = [1.0, 1.0] }\nposition = [0.0, 0.5]\n",
            "box.toml",
        )
        .unwrap();
        // the solver's rows are under test: nothing sleeps
        let settings = SolverSettings {
            sleep: false,
            ..SolverSettings::defaults(kind)
        };
        World::from_def(&sc.world, settings).unwrap()
    }

    /// A 2 kg disc hanging at rest 1 m below a
    /// static pivot on a hinge, gravity 10.
    pub fn hanging_disc(kind: SolverKind) -> World {
        let sc = crate::scene::load_str(
            "name = \"hang\"\n[world]\ngravity = [0.0, -10.0]\n\
             [[body]]\nname = \"pivot\"\ntype = \"static\"\nshape = { circle = 0.05 }\nposition = [0.0, 0.0]\n\
             [[body]]\nname = \"disc\"\nshape = { circle = 0.1 }\nmass = 2.0\nposition = [0.0, -1.0]\n\
             [[joint]]\ntype = \"hinge\"\nbodies = [\"pivot\", \"disc\"]\nanchor = [0.0, 0.0]\n",
            "hang.toml",
        )
        .unwrap();
        // the solver's rows are under test: nothing sleeps
        let settings = SolverSettings {
            sleep: false,
            ..SolverSettings::defaults(kind)
        };
        World::from_def(&sc.world, settings).unwrap()
    }

    /// The sum of the normal lambdas of the last solve (N s).
    pub fn normal_sum(w: &World) -> f32 {
        let mut l = Vec::new();
        w.contact_lambdas(&mut l);
        l.iter().step_by(2).sum()
    }
}
