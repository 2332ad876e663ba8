//! Classic PGS, the seed's method: per substep collide, integrate velocities, solve the
//! contact MLCP (collisions, warm start, velocity sweeps with joints, split-impulse
//! position sweeps), integrate positions.

use super::{Stage, StageClock, StepContext, StepState, StepStats, Stepper, integrate};
use crate::collision::Contact;
use crate::collision::collide::Speculative;
use crate::defs::SolverKind;
use crate::joint::pgs::JointRows;
use crate::solver::pgs::{PgsSolver, SolveStats, SolverBody};

/// Classic projected Gauss-Seidel and its scratch.
#[derive(Clone, Debug, Default)]
pub struct PgsStepper {
    pgs: PgsSolver,
    joint_rows: JointRows,
    pseudo_bodies: Vec<SolverBody>,
}

impl Stepper for PgsStepper {
    fn kind(&self) -> SolverKind {
        SolverKind::Pgs
    }

    fn step(
        &mut self,
        state: &mut StepState,
        cx: &StepContext,
        clock: &mut StageClock,
    ) -> StepStats {
        let mut total = StepStats::default();
        for _ in 0..cx.substeps {
            let s = self.substep(state, cx, clock);
            total.iterations += s.iterations;
            total.position_iterations += s.position_iterations;
            total.residual = s.residual;
            total.contacts = s.contacts;
            total.penetration = total.penetration.max(s.penetration);
        }
        total
    }

    fn contact_lambdas(&self, _contacts: &[Contact], out: &mut Vec<f32>) {
        self.pgs.lambdas(out);
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

impl PgsStepper {
    fn substep(
        &mut self,
        state: &mut StepState,
        cx: &StepContext,
        clock: &mut StageClock,
    ) -> StepStats {
        let h = cx.h;
        let penetration = state.collide(h, cx.margin, Speculative::MarginPlusMotion, clock);
        state.integrate_velocities(h);
        clock.lap(Stage::Forces);
        let s = state.settings;
        self.pgs.prepare(state.bodies, state.contacts, &s, h);
        self.joint_rows.prepare(
            state.joints,
            state.mouse.as_ref(),
            state.bodies,
            &self.pgs.bodies,
            &s,
            h,
        );
        let joints = !self.joint_rows.is_empty();
        let mut st = SolveStats::default();
        // restitution first, as collisions passed pair to pair
        self.pgs
            .resolve_collisions(s.restitution_threshold, h, s.iterations);
        if s.warm_start {
            self.pgs.warm_start();
            self.joint_rows.warm_start(&mut self.pgs.bodies);
        }
        for _ in 0..s.iterations {
            let rj = if joints {
                self.joint_rows.sweep(&mut self.pgs.bodies)
            } else {
                0.0
            };
            st.residual = self.pgs.sweep_velocity().max(rj);
            st.iterations += 1;
            if st.residual < s.tolerance {
                break;
            }
        }
        if joints {
            self.joint_rows.damp(&mut self.pgs.bodies, h);
            self.joint_rows.store(state.joints);
        }
        let joint_positions = joints && self.joint_rows.has_position_rows();
        if s.split_impulse && (joint_positions || self.pgs.needs_position_solve()) {
            for _ in 0..s.iterations {
                let mut r = 0.0f32;
                if joint_positions {
                    // the joints' rows on the same pseudo-velocities
                    self.pseudo_bodies.clear();
                    self.pseudo_bodies
                        .extend(self.pgs.pseudo.iter().zip(&self.pgs.bodies).map(
                            |(&(v, w), b)| SolverBody {
                                v,
                                w,
                                inv_m: b.inv_m,
                                inv_i: b.inv_i,
                            },
                        ));
                    r = self.joint_rows.sweep_position(&mut self.pseudo_bodies);
                    for (p, b) in self.pgs.pseudo.iter_mut().zip(&self.pseudo_bodies) {
                        *p = (b.v, b.w);
                    }
                }
                r = r.max(self.pgs.sweep_position());
                st.position_iterations += 1;
                if r < s.tolerance {
                    break;
                }
            }
        }
        self.pgs.store_impulses(state.contacts);
        clock.lap(Stage::Solve);
        // the solved velocities, then x += h (v + v_pseudo), theta += h (w + w_pseudo)
        for (b, sb) in state.bodies.iter_mut().zip(&self.pgs.bodies) {
            if b.is_dynamic() {
                b.velocity = sb.v;
                b.angular_velocity = sb.w;
            }
        }
        let pgs = &self.pgs;
        integrate::integrate_positions(state.bodies, h, |i| {
            // pseudo-velocities (split impulse) and collisions' time-of-impact shifts
            let ((pv, pw), (iv, iw)) = (pgs.pseudo[i], pgs.impact[i]);
            (pv + iv, pw + iw)
        });
        clock.lap(Stage::Integrate);
        StepStats {
            iterations: st.iterations,
            residual: st.residual,
            position_iterations: st.position_iterations,
            contacts: state.contacts.iter().map(|c| c.manifold.count).sum(),
            penetration,
            ..Default::default()
        }
    }
}
