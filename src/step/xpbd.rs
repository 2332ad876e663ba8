//! XPBD (Mueller et al. 2020): contacts found once per step, then per substep predict,
//! project joints and contacts, derive velocities, and a velocity pass.

use super::{Stage, StageClock, StepContext, StepState, StepStats, Stepper, integrate};
use crate::collision::Contact;
use crate::collision::collide::Speculative;
use crate::defs::SolverKind;
use crate::joint::SLOTS;
use crate::joint::pgs::JointRows;
use crate::joint::xpbd::velocity_pass;
use crate::solver::pgs::SolverBody;
use crate::solver::xpbd::XpbdContacts;

/// Extended position-based dynamics and its scratch.
#[derive(Clone, Debug, Default)]
pub struct XpbdStepper {
    xpbd: XpbdContacts,
    lambdas: Vec<[f32; SLOTS]>,
    bodies: Vec<SolverBody>,
    normal_sum: Vec<f32>,
    joint_rows: JointRows,
}

impl Stepper for XpbdStepper {
    fn kind(&self) -> SolverKind {
        SolverKind::Xpbd
    }

    /// One XPBD step: contacts found once, then per substep h = dt / n: predict
    /// (v += h a, x += h v), project the joints and contacts `iterations` times, derive
    /// v = (x - x_prev) / h, and a velocity pass (friction, restitution, motors, damping).
    fn step(
        &mut self,
        state: &mut StepState,
        cx: &StepContext,
        clock: &mut StageClock,
    ) -> StepStats {
        let s = state.settings;
        let (n, h) = (cx.substeps, cx.h);
        let mut deepest = state.collide(cx.dt, cx.margin, Speculative::MarginPlusMotion, clock);
        self.xpbd.prepare(state.bodies, state.contacts);
        self.xpbd.block = s.block_solve;
        self.lambdas.clear();
        self.lambdas.resize(state.joints.len(), [0.0; SLOTS]);
        // a joint that may break sums its substeps' impulses for the world to read
        let breakable = state.may_break;
        if breakable {
            for j in state.joints.iter_mut() {
                j.step_impulses = [0.0; SLOTS];
            }
        }
        let mut normal_sum = std::mem::take(&mut self.normal_sum);
        normal_sum.clear();
        normal_sum.resize(self.xpbd.points.len(), 0.0);
        clock.lap(Stage::Solve);
        for _ in 0..n {
            state.integrate_velocities(h);
            clock.lap(Stage::Forces);
            self.xpbd.begin_substep(state.bodies, h, s.max_push_speed);
            // predict: x += h v, theta += h w
            integrate::predict_positions(state.bodies, h);
            clock.lap(Stage::Integrate);
            // lambda is a substep's multiplier: alpha~ lambda is the spring's force over
            // this substep only (carried over the substeps, a compliance of alpha acted as
            // one of n alpha: a hanging 1 kg stretched 0.2 m at alpha = 1e-3 m/N, 20 substeps)
            for l in &mut self.lambdas {
                *l = [0.0; SLOTS];
            }
            for _ in 0..s.iterations.max(1) {
                for (j, lam) in state.joints.iter().zip(self.lambdas.iter_mut()) {
                    j.project(state.bodies, &self.xpbd.prev_rot, h, lam);
                }
                if let Some(m) = state.mouse {
                    m.xpbd_project(state.bodies, h);
                }
                let d = self.xpbd.project(state.bodies);
                deepest = deepest.max(d);
            }
            if breakable {
                for (j, lam) in state.joints.iter_mut().zip(&self.lambdas) {
                    if j.breakable() {
                        // the substep's impulse: lambda / h
                        for (acc, &l) in j.step_impulses.iter_mut().zip(lam) {
                            *acc += l / h;
                        }
                    }
                }
            }
            // v = (x - x_prev) / h, w = (theta - theta_prev) / h
            integrate::derive_velocities(state.bodies, h);
            // velocity pass
            self.bodies.clear();
            self.bodies.extend(state.bodies.iter().map(|b| SolverBody {
                v: b.velocity,
                w: b.angular_velocity,
                inv_m: b.inv_mass,
                inv_i: b.inv_inertia,
            }));
            self.xpbd
                .velocity_pass(state.bodies, &mut self.bodies, h, s.restitution_threshold);
            velocity_pass(
                state.joints,
                state.bodies,
                &mut self.bodies,
                (h, cx.dt),
                &mut self.joint_rows,
            );
            if let Some(m) = state.mouse {
                m.xpbd_damp(state.bodies, &mut self.bodies, h);
            }
            for (b, sb) in state.bodies.iter_mut().zip(&self.bodies) {
                if b.is_dynamic() {
                    b.velocity = sb.v;
                    b.angular_velocity = sb.w;
                }
            }
            for (acc, p) in normal_sum.iter_mut().zip(&self.xpbd.points) {
                // impulse of the substep: lambda / h
                *acc += p.lambda_n / h;
            }
            clock.lap(Stage::Solve);
        }
        for (p, &sum) in self.xpbd.points.iter().zip(&normal_sum) {
            let m = &mut state.contacts[p.contact as usize].manifold;
            m.points[p.index as usize].normal_impulse = sum;
        }
        self.normal_sum = normal_sum;
        clock.lap(Stage::Solve);
        StepStats {
            iterations: n * s.iterations.max(1),
            residual: 0.0,
            position_iterations: 0,
            contacts: self.xpbd.points.len(),
            penetration: deepest,
            ..Default::default()
        }
    }

    fn contact_lambdas(&self, contacts: &[Contact], out: &mut Vec<f32>) {
        super::stored_lambdas(contacts, out);
    }

    fn box_clone(&self) -> Box<dyn Stepper> {
        Box::new(self.clone())
    }

    #[cfg(test)]
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    #[cfg(test)]
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}
