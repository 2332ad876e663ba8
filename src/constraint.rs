//! What the solvers' rows and the joints' rows share: the states a solver keeps for a
//! body while it solves ([`SolverBody`] for PGS and XPBD's velocity pass, [`SoftBody`]
//! for the soft step) and the coefficients of a soft row ([`Softness`]).
//!
//! A leaf: it uses only the maths, so `crate::solver` and `crate::joint` both build on it
//! without importing each other's way back.

use crate::math::{Rot, Vec2};

/// A body as the PGS solver (and XPBD's velocity pass) sees it: velocities and inverse
/// masses, packed.
#[derive(Clone, Copy, Debug, Default)]
pub struct SolverBody {
    pub v: Vec2,
    pub w: f32,
    pub inv_m: f32,
    pub inv_i: f32,
}

/// A body's state during the soft step: velocities and the motion since collide.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct SoftBody {
    pub v: Vec2,
    pub w: f32,
    /// Angle turned since collide (rad): the sum of h w.
    pub dtheta: f32,
    /// Displacement since collide (m).
    pub dp: Vec2,
    /// Rotation since collide, integrated as q += h w q_perp and normalised (for the
    /// separations only; the body's angle takes `dtheta`).
    pub dq: Rot,
}

impl Default for SoftBody {
    fn default() -> Self {
        Self {
            v: Vec2::ZERO,
            w: 0.0,
            dtheta: 0.0,
            dp: Vec2::ZERO,
            dq: Rot::IDENTITY,
        }
    }
}

/// The implicit spring-damper coefficients of a soft row for substep h.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Softness {
    /// omega / a1 (1/s): bias speed per metre of error.
    pub bias_rate: f32,
    /// a2 a3: the share of the rigid effective mass.
    pub mass_scale: f32,
    /// a3: the share of the accumulated impulse that leaks each sweep.
    pub impulse_scale: f32,
}

impl Softness {
    /// omega = 2 pi f, a1 = 2 zeta + h omega, a2 = h omega a1, a3 = 1 / (1 + a2).
    pub fn new(hertz: f32, zeta: f32, h: f32) -> Softness {
        Softness::from_omega(2.0 * std::f32::consts::PI * hertz, zeta, h)
    }

    /// The same from the angular frequency omega (rad/s).
    pub fn from_omega(omega: f32, zeta: f32, h: f32) -> Softness {
        if omega <= 0.0 {
            return Softness {
                bias_rate: 0.0,
                mass_scale: 1.0,
                impulse_scale: 0.0,
            };
        }
        let a1 = 2.0 * zeta + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Softness {
            bias_rate: omega / a1,
            mass_scale: a2 * a3,
            impulse_scale: a3,
        }
    }
}
