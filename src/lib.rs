//! sandbox2d: a 2D physics sandbox: particles and rigid bodies, SAT contacts and joints,
//! three solvers behind one interface ([`SolverKind`]): the soft step (the default:
//! substeps with soft contact and joint rows and a rigid relax sweep), classic PGS (the
//! contact MLCP by warm-started projected Gauss-Seidel with Baumgarte or split impulse
//! and slop) and XPBD.
//!
//! ```
//! use sandbox2d::{BodyDef, BodyType, ShapeDef, SolverSettings, World};
//! use glam::Vec2;
//! let mut world = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::pgs());
//! world.add_body(&BodyDef { name: "ground".into(), body_type: BodyType::Static,
//!     shape: ShapeDef::Box { width: 20.0, height: 1.0 }, position: Vec2::new(0.0, -0.5), ..Default::default() }).unwrap();
//! let ball = world.add_body(&BodyDef { name: "ball".into(), shape: ShapeDef::Circle { radius: 0.5 },
//!     position: Vec2::new(0.0, 3.0), ..Default::default() }).unwrap();
//! for _ in 0..120 { world.step().unwrap(); }
//! assert!((world.bodies[ball].position.y - 0.5).abs() < 0.02);
//! ```

// `!(x > 0.0)` is the crate's idiom for "reject NaN too"; the partial_cmp spelling
// clippy suggests reads worse and is easy to get wrong.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bench;
pub mod body;
pub mod collision;
pub mod compare;
pub mod compound;
pub mod defs;
pub mod draw;
pub mod joint;
pub mod math;
pub mod output;
pub mod parallel;
pub mod scene;
pub mod shape;
pub mod sim;
pub mod solver;
pub mod step;
pub mod timeline;
pub mod world;

#[cfg(feature = "render")]
pub mod render;

#[cfg(feature = "app")]
pub mod app;

pub use body::{Body, BodyId};
pub use defs::*;
pub use draw::{Camera, DrawList};
pub use joint::{Joint, JointId, MouseJoint};
pub use world::{
    BodyKey, BuildError, ContactEvent, EventKind, JointKey, RayHit, RemoveError, StateError,
    StepError, StepStats, ThreadUse, Threads, World, WorldState,
};
