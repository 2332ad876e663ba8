//! sandbox2d: a 2D physics sandbox.
pub mod defs;
pub use defs::*;
pub mod scene;
