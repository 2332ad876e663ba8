//! sandbox2d: a 2D physics sandbox.
pub mod defs;
pub use defs::*;
pub mod draw;
#[cfg(feature = "render")]
pub mod render;

pub use draw::{Camera, DrawList};
