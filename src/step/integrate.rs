//! Integration, the stages every stepper shares: forces into velocities (the velocity
//! half of semi-implicit Euler: joint drives, constant point forces, gravity, drag),
//! velocities into positions, and the step's last pass over the bodies (forces cleared,
//! state checked). The soft step folds the same arithmetic into its own passes over its
//! bodies (`solver::soft`), through [`Body::free_velocity`] and [`Body::is_finite`].

use crate::body::{Body, HOT_BYTES};
use crate::defs::{BodyModel, BodyType, DragDef};
use crate::joint::Joint;
use crate::math::{BODY_AHEAD, BODY_PASS_BLOCK, Rot, Vec2, cross, prefetch};
use crate::parallel::{self, Pool};

/// A constant force at a body point.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub(crate) struct PointForce {
    pub(crate) body: usize,
    pub(crate) force: Vec2,
    /// point relative to the centre of mass, body frame
    pub(crate) local: Vec2,
}

/// What moves the bodies' velocities besides the solver's rows.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Forces<'a> {
    /// The joints (their drives).
    pub joints: &'a [Joint],
    /// Constant point forces.
    pub forces: &'a [PointForce],
    /// m/s^2; `None` skips the gravity pass.
    pub gravity: Option<Vec2>,
    /// `None` = vacuum.
    pub drag: Option<DragDef>,
    /// Whether any body has linear or angular damping of its own.
    pub damped: bool,
}

impl Forces<'_> {
    /// Whether the forces change every substep's velocities by the same amount (no drag
    /// and no body's own damping, which scale with the velocity).
    pub fn uniform(&self) -> bool {
        self.drag.is_none() && !self.damped
    }

    /// Whether the only forces are gravity, the bodies' own force, torque and damping
    /// and the joints' drives (no drag or point forces). Where no joint has a drive
    /// either (the caller checks, in a pass it makes over the joints anyway), a solver
    /// may integrate them in a pass of its own (see `SoftSolver::prepare_integrating`),
    /// and apply the damping every substep itself.
    pub fn plain(&self) -> bool {
        self.drag.is_none() && self.forces.is_empty()
    }
}

/// Semi-implicit Euler, velocity half: v += h (g + F/m), w += h tau / I; drag taken
/// implicitly so it can only slow a body down, whatever the step.
pub(crate) fn integrate_velocities(bodies: &mut [Body], f: &Forces, h: f32, pool: Option<&Pool>) {
    if !f.joints.is_empty() {
        crate::joint::apply_drives(f.joints, bodies, h);
    }
    // constant point forces: dv = h F / m, dw = h (r x F) / I
    for pf in f.forces {
        let b = &mut bodies[pf.body];
        if b.is_dynamic() {
            let r = b.rot.rotate(pf.local);
            b.velocity += h * b.inv_mass * pf.force;
            b.angular_velocity += h * b.inv_inertia * cross(r, pf.force);
        }
    }
    let (g, drag, damped) = (f.gravity, f.drag, f.damped);
    parallel::chunks_mut(pool, bodies, BODY_PASS_BLOCK, &|_, _, bodies| {
        integrate_velocities_of(bodies, h, g, drag, damped);
        0.0
    });
}

/// The velocity half of semi-implicit Euler for `bodies` (see
/// [`integrate_velocities`]): each dynamic, awake body on its own.
fn integrate_velocities_of(
    bodies: &mut [Body],
    h: f32,
    g: Option<Vec2>,
    drag: Option<DragDef>,
    damped: bool,
) {
    for i in 0..bodies.len() {
        prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
        let b = &mut bodies[i];
        if !b.is_dynamic() || b.asleep {
            continue;
        }
        let Some(d) = drag else {
            (b.velocity, b.angular_velocity) = b.free_velocity(h, g);
            if damped {
                damp(b, h);
            }
            continue;
        };
        let (mut v, w) = b.free_velocity(h, g);
        // F = -(k1 + k2 |v|) v with k2 = quadratic + 1/2 rho Cd width; backward Euler in the factor
        let speed = v.length();
        let mut k = d.linear + d.quadratic * speed;
        if d.fluid_density > 0.0 && d.drag_coefficient > 0.0 && speed > 0.0 {
            let width = b.shape.extent_across(&b.transform(), v / speed);
            k += 0.5 * d.fluid_density * d.drag_coefficient * width * speed;
        }
        v /= 1.0 + h * k * b.inv_mass;
        (b.velocity, b.angular_velocity) = (v, w);
        if damped {
            damp(b, h);
        }
    }
}

/// A body's own damping over h (Box2D's): v /= 1 + h c_linear, w /= 1 + h c_angular.
#[inline]
fn damp(b: &mut Body, h: f32) {
    let (linear, angular) = b.damping_factors(h);
    if b.linear_damping != 0.0 {
        b.velocity *= linear;
    }
    if b.angular_damping != 0.0 {
        b.angular_velocity *= angular;
    }
}

/// Positions from velocities: x += h (v + dv), theta += h (w + dw) for every body that
/// is not static, where (dv, dw) = `shift(i)` for a dynamic body is motion the solver
/// adds to the positions only (classic PGS: split-impulse pseudo-velocities and
/// collisions' time-of-impact shifts), zero for a kinematic one.
pub(crate) fn integrate_positions(
    bodies: &mut [Body],
    h: f32,
    shift: impl Fn(usize) -> (Vec2, f32),
) {
    for (i, b) in bodies.iter_mut().enumerate() {
        if b.body_type == BodyType::Static {
            continue;
        }
        let (pv, pw) = if b.is_dynamic() {
            shift(i)
        } else {
            (Vec2::ZERO, 0.0)
        };
        b.position += h * (b.velocity + pv);
        if b.model == BodyModel::Rigid {
            b.angle += h * (b.angular_velocity + pw);
            b.rot = Rot::from_angle(b.angle);
        }
    }
}

/// XPBD's prediction: x += h v, theta += h w for every body that is not static (a body
/// that does not turn keeps its rotation as it is).
pub(crate) fn predict_positions(bodies: &mut [Body], h: f32) {
    for b in bodies {
        if b.body_type == BodyType::Static {
            continue;
        }
        b.position += h * b.velocity;
        if b.model == BodyModel::Rigid && b.angular_velocity != 0.0 {
            b.angle += h * b.angular_velocity;
            b.rot = Rot::from_angle(b.angle);
        }
    }
}

/// XPBD's velocities from the positions' corrections: v = (x - x_prev) / h,
/// w = (theta - theta_prev) / h, as v += dx / h on the predicted velocity (the
/// corrections are cleared).
pub(crate) fn derive_velocities(bodies: &mut [Body], h: f32) {
    for b in bodies {
        if b.is_dynamic() {
            b.velocity += b.correction / h;
            b.angular_velocity += b.correction_angle / h;
        }
        b.correction = Vec2::ZERO;
        b.correction_angle = 0.0;
    }
}

/// The step's last pass over the bodies: clears the accumulated forces; returns whether
/// some body's state is not finite (the step failed).
pub(crate) fn end_step(bodies: &mut [Body], pool: Option<&Pool>) -> bool {
    parallel::chunks_mut(pool, bodies, BODY_PASS_BLOCK, &|_, _, bodies| {
        let mut bad = false;
        for i in 0..bodies.len() {
            prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
            let b = &mut bodies[i];
            b.force = Vec2::ZERO;
            b.torque = 0.0;
            bad |= !b.is_finite();
        }
        if bad { 1.0 } else { 0.0 }
    }) > 0.0
}
