//! Constraint solvers: the contact MLCP by projected Gauss-Seidel ([`pgs`]) and the
//! contact cache that warm-starts it.

/// The collide stage's contacts ([`crate::collision::Contact`]), under the path the
/// solver files name them by.
pub mod contact_cache {
    pub use crate::collision::Contact;
}
pub mod joint_rows;
pub mod pgs;
pub mod soft;
pub mod xpbd;
