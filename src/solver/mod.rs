//! Constraint solvers: the contact MLCP by projected Gauss-Seidel ([`pgs`]) and the
//! contact cache that warm-starts it.

pub mod contact_cache;
pub mod joint_rows;
pub mod pgs;
pub mod soft;
pub mod xpbd;
