//! sandbox2d: a 2D physics sandbox: particles and rigid bodies, SAT contacts, and three
//! solvers behind one [`World`]. The default, [`SolverSettings::soft`] (the soft step),
//! takes substeps with soft contacts and a relax pass; [`SolverSettings::pgs`] is classic
//! warm-started projected Gauss-Seidel with Baumgarte and slop; [`SolverSettings::xpbd`]
//! is extended position-based dynamics.
//!
//! ```
//! use sandbox2d::{BodyDef, BodyType, ShapeDef, SolverSettings, World};
//! use glam::Vec2;
//! for settings in [SolverSettings::default(), SolverSettings::pgs(), SolverSettings::xpbd()] {
//!     let mut world = World::new(Some(Vec2::new(0.0, -10.0)), settings);
//!     world.create_body(&BodyDef { name: "ground".into(), body_type: BodyType::Static,
//!         shape: ShapeDef::Box { width: 20.0, height: 1.0 }, position: Vec2::new(0.0, -0.5), ..Default::default() }).unwrap();
//!     let ball = world.create_body(&BodyDef { name: "ball".into(), shape: ShapeDef::Circle { radius: 0.5 },
//!         position: Vec2::new(0.0, 3.0), ..Default::default() }).unwrap();
//!     for _ in 0..120 { world.step().unwrap(); }
//!     // at rest on the ground: its centre one radius above it
//!     assert!((world.body(ball).unwrap().position.y - 0.5).abs() < 0.02);
//! }
//! ```
//!
//! Bodies, joints and shapes are named by generational keys ([`BodyKey`], [`JointKey`],
//! [`ShapeKey`]) that stay valid across removals: a removed body's key names nothing,
//! never another body. Events ([`World::events`], [`World::hits`],
//! [`World::sleep_events`]) and query results ([`World::ray_cast_closest`] and the rest)
//! name their bodies by key, so they can be kept and looked up ([`World::body`]) after
//! bodies are removed. [`World::bodies`] walks every body with its key in creation
//! order; a body changes only through setters that check what they are given and wake
//! it ([`World::set_transform`], [`World::set_velocity`], [`World::apply_impulse`],
//! [`World::apply_force`]). Indices are the crate's own.
//!
//! The solvers' internals (their scratch, the threads' passes) are not part of the
//! API: a program steps a [`World`], and cannot reach a solver's buffers.
//!
//! ```compile_fail
//! // the soft solver's buffers are the crate's own: this does not compile
//! let s = sandbox2d::solver::soft::SoftSolver::default();
//! ```

// `!(x > 0.0)` is the crate's idiom for "reject NaN too"; the partial_cmp spelling
// clippy suggests reads worse and is easy to get wrong.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Every public item of the API says what it is: units, defaults, what it means.
#![deny(missing_docs)]

// The README's Rust example is compiled and run with the doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeExample;

pub(crate) mod awake;
pub mod body;
pub mod collision;
pub mod compound;
pub(crate) mod constraint;
pub mod defs;
pub mod draw;
pub mod joint;
pub mod math;
pub(crate) mod parallel;
pub mod scene;
pub mod shape;
pub(crate) mod solver;
pub(crate) mod step;
pub mod timeline;
pub mod world;

#[cfg(feature = "render")]
pub mod render;

// The sandbox2d program's own parts (the lab, runs and their outputs, side-by-side
// panes, the window): public for the binary and the tests, not part of the API a
// program embeds.
#[cfg(feature = "app")]
#[doc(hidden)]
pub mod app;
#[doc(hidden)]
pub mod bench;
#[doc(hidden)]
pub mod compare;
#[doc(hidden)]
pub mod output;
#[doc(hidden)]
pub mod sim;

/// Threads: what a new world may use unless told otherwise, and what the machine has.
/// Results are the same to the bit whatever the thread count.
pub mod threads {
    pub use crate::parallel::{
        MAX_THREADS, available, core_round_trip_ns, default_adaptive, default_threads,
        set_default_adaptive, set_default_threads,
    };
    pub use crate::world::{ThreadUse, Threads};
}

pub use body::Body;
pub use defs::*;
pub use draw::{Camera, DrawList};
pub use joint::{Joint, MouseJoint};
pub use world::{
    BodyKey, BuildError, ContactEvent, DEFAULT_HIT_SPEED, EditError, EventKind, HitEvent,
    JointBreakEvent, JointKey, QUERY_MARGIN, QueryShape, RayHit, RemoveError, SHAPE_CAST_TOLERANCE,
    ShapeCastHit, ShapeKey, SleepEvent, StateError, StepError, StepStats, ThreadUse, Threads,
    World, WorldState,
};
