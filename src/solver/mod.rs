//! The solvers' kernels, one module per solver: the soft step's ([`soft`], the
//! default: soft contacts and joints in coloured wide lanes), classic projected
//! Gauss-Seidel's ([`pgs`]) and XPBD's ([`xpbd`]). The joints' rows under each solver
//! are the joints' own, one file per kind of joint in `crate::joint`. The order of each
//! solver's stages is its stepper's, in `crate::step`.

/// The collide stage's contacts ([`crate::collision::Contact`]), under the path the
/// solver files name them by.
pub mod contact_cache {
    pub use crate::collision::Contact;
}
pub(crate) mod dense;
pub mod pgs;
pub mod soft;
pub mod xpbd;
