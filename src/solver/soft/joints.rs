//! The soft step's joints as the solver holds them: every joint's rows prepared at the
//! step's start (split between the threads), the mouse joint's, and the calls that load
//! a joint's two bodies, hand them to the joint's rows (`crate::joint::soft` and the
//! joint's kind) and store them back. Which joints a colour takes, and the hinges that
//! go four at a time in SIMD lanes instead (`hinge.rs`), are the solver's.

use super::{BodyPtr, Softness};
use crate::parallel::{self, Pool};
use std::sync::atomic::{AtomicBool, Ordering};

/// Joints per block of a parallel pass over the joints.
const JOINT_BLOCK: usize = 512;
use crate::body::Body;
use crate::defs::SolverSettings;
use crate::joint::soft::{Pair, Sweep};
use crate::joint::{Joint, MouseJoint};

pub(super) use crate::joint::mouse::{
    PreparedMouse, soft_solve as solve_mouse, soft_warm_start as warm_start_mouse,
};
pub(super) use crate::joint::soft::Prepared;

/// The soft step's joint rows and their lambdas.
#[derive(Clone, Debug, Default)]
pub(crate) struct SoftJoints {
    prepared: Vec<Prepared>,
    /// Each joint's two bodies (for the colouring), and whether it takes a wide hinge's
    /// lanes.
    ends: Vec<(u32, u32)>,
    lanes: Vec<bool>,
    mouse: Option<PreparedMouse>,
    /// Whether some joint is damped (found by `prepare`).
    damped: bool,
    soft: Softness,
    h: f32,
    dt: f32,
}

impl SoftJoints {
    /// Takes the joints' geometry at the step's start for substeps of `h`; lambdas start
    /// from the joints' stored ones if warm starting. Returns whether some joint has a
    /// drive (found in the same pass, as whether some joint is damped).
    pub fn prepare(
        &mut self,
        joints: &[Joint],
        mouse: Option<&MouseJoint>,
        bodies: &[Body],
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) -> bool {
        self.h = h;
        self.dt = s.dt;
        // a rigid row's spring: at most a quarter of the substep rate
        let hertz = s.joint_hertz.min(0.25 / h);
        self.soft = Softness::new(hertz, s.joint_damping_ratio, h);
        // every joint's frames, split between the threads (a pass over the joints and
        // their bodies: a cache miss each on a large scene)
        self.prepared.resize(joints.len(), Prepared::default());
        self.ends.resize(joints.len(), (0, 0));
        self.lanes.resize(joints.len(), false);
        let warm = s.warm_start;
        // (a test may turn the lanes off, on the thread that prepares)
        let lanes_on = !super::testing::NO_HINGE_LANES.with(std::cell::Cell::get);
        let (driven, damped) = (AtomicBool::new(false), AtomicBool::new(false));
        parallel::chunks_mut3(
            pool,
            &mut self.prepared,
            &mut self.ends,
            &mut self.lanes,
            JOINT_BLOCK,
            &|_, offset, prepared, ends, lanes| {
                let (mut drive, mut damp) = (false, false);
                for (k, ((out, end), lane)) in prepared.iter_mut().zip(ends).zip(lanes).enumerate()
                {
                    let j = &joints[offset + k];
                    *end = (j.a as u32, j.b as u32);
                    drive |= j.drive != 0.0;
                    damp |= j.damping.linear > 0.0 || j.damping.angular > 0.0;
                    *lane = lanes_on && super::hinge::takes_lanes(j);
                    if *lane {
                        // (a hinge in lanes takes its rows from the joint itself)
                        continue;
                    }
                    *out = Prepared::of(j, bodies, h, warm);
                }
                // (rare: a store only where found)
                if drive {
                    driven.store(true, Ordering::Relaxed);
                }
                if damp {
                    damped.store(true, Ordering::Relaxed);
                }
                0.0
            },
        );
        self.mouse = mouse.and_then(|m| m.soft_prepare(bodies, h));
        self.damped = damped.into_inner();
        driven.into_inner()
    }

    /// Each joint's two bodies, in joint order.
    pub(super) fn ends(&self) -> &[(u32, u32)] {
        &self.ends
    }

    /// Whether each joint takes a wide hinge's lanes, in joint order.
    pub(super) fn lanes(&self) -> &[bool] {
        &self.lanes
    }

    /// Whether there is a mouse joint.
    pub(super) fn has_mouse(&self) -> bool {
        self.mouse.is_some()
    }

    /// The joint's two bodies as they are now.
    ///
    /// # Safety
    /// No other thread writes either body meanwhile (joints and contacts of one colour
    /// share no moving body; a body that does not move is never written).
    #[inline]
    unsafe fn pair(p: &Prepared, bodies: BodyPtr, inv_mass: &[(f32, f32)]) -> Pair {
        let ((ima, iia), (imb, iib)) = (inv_mass[p.a], inv_mass[p.b]);
        // SAFETY: in bounds (the joint's bodies are the world's), and no one else writes
        // them (above)
        let (a, b) = unsafe { (*bodies.at(p.a as u32), *bodies.at(p.b as u32)) };
        Pair {
            a,
            b,
            ima,
            iia,
            imb,
            iib,
        }
    }

    /// Writes the pair's velocities back to the bodies that move.
    ///
    /// # Safety
    /// As [`SoftJoints::pair`].
    #[inline]
    unsafe fn store_pair(p: &Prepared, pair: &Pair, bodies: BodyPtr, inv_mass: &[(f32, f32)]) {
        if inv_mass[p.a] != (0.0, 0.0) {
            // SAFETY: as above
            let a = unsafe { &mut *bodies.at(p.a as u32) };
            a.v = pair.a.v;
            a.w = pair.a.w;
        }
        if inv_mass[p.b] != (0.0, 0.0) {
            // SAFETY: as above
            let b = unsafe { &mut *bodies.at(p.b as u32) };
            b.v = pair.b.v;
            b.w = pair.b.w;
        }
    }

    /// The rigid rows' softness in the biased sweeps.
    pub(super) fn softness(&self) -> Softness {
        self.soft
    }

    /// The constants of a sweep: with `bias`, rigid rows are soft springs that pull the
    /// error out; without, they only remove relative speed (relax).
    pub(super) fn sweep_params(&self, bias: bool) -> Sweep {
        Sweep::new(bias, self.soft, self.h, self.dt)
    }

    /// Whether some joint is damped (the step then runs a damping pass).
    pub(super) fn any_damped(&self) -> bool {
        self.damped
    }

    /// The joints' prepared rows (by joint), and the mouse joint's.
    pub(super) fn parts(&mut self) -> (&mut [Prepared], &mut Option<PreparedMouse>) {
        (&mut self.prepared, &mut self.mouse)
    }

    /// Writes the lambdas back into the joints, for the next step's warm start.
    pub fn store(&self, joints: &mut [Joint], pool: Option<&Pool>) {
        let (prepared, lanes) = (&self.prepared, &self.lanes);
        parallel::chunks_mut(pool, joints, JOINT_BLOCK, &|_, offset, joints| {
            for ((j, p), &lane) in joints
                .iter_mut()
                .zip(&prepared[offset..])
                .zip(&lanes[offset..])
            {
                // (a hinge in lanes is stored from its lanes)
                if !lane {
                    j.impulses = p.impulses;
                }
            }
            0.0
        });
    }
}

/// Applies a joint's lambdas (`p`, its prepared rows) (start of each substep).
///
/// # Safety
/// As [`SoftJoints::pair`].
pub(super) unsafe fn warm_start_joint(
    p: &Prepared,
    j: &Joint,
    bodies: BodyPtr,
    inv_mass: &[(f32, f32)],
) {
    // SAFETY: the caller's
    let mut pair = unsafe { SoftJoints::pair(p, bodies, inv_mass) };
    j.soft_warm_start(p, &mut pair);
    // SAFETY: the caller's
    unsafe { SoftJoints::store_pair(p, &pair, bodies, inv_mass) };
}

/// A joint's rows in a sweep (`sw`, from [`SoftJoints::sweep_params`]); returns the
/// largest |delta lambda|.
///
/// # Safety
/// As [`SoftJoints::pair`]; and no other thread works on the joint meanwhile (its
/// entry is `p`).
pub(super) unsafe fn solve_joint(
    sw: &Sweep,
    p: &mut Prepared,
    j: &Joint,
    bodies: BodyPtr,
    inv_mass: &[(f32, f32)],
) -> f32 {
    // SAFETY: the caller's
    let mut pair = unsafe { SoftJoints::pair(p, bodies, inv_mass) };
    let r = j.soft_solve(sw, p, &mut pair);
    // SAFETY: the caller's
    unsafe { SoftJoints::store_pair(p, &pair, bodies, inv_mass) };
    r
}

/// Joint damping of one joint (`p`, its prepared rows, over substeps of `h`): removes
/// the fraction min(h c, 1) of the relative velocity along each damped row, once per
/// substep (the seed's DampLinear / DampAngular).
///
/// # Safety
/// As [`SoftJoints::pair`].
pub(super) unsafe fn damp_joint(
    h: f32,
    p: &Prepared,
    j: &Joint,
    bodies: BodyPtr,
    inv_mass: &[(f32, f32)],
) {
    if j.damping.linear <= 0.0 && j.damping.angular <= 0.0 {
        return;
    }
    // SAFETY: the caller's
    let mut pair = unsafe { SoftJoints::pair(p, bodies, inv_mass) };
    j.soft_damp(h, p, &mut pair);
    // SAFETY: the caller's
    unsafe { SoftJoints::store_pair(p, &pair, bodies, inv_mass) };
}

#[cfg(test)]
mod tests {
    use crate::defs::SolverKind;
    use crate::joint::slot;
    use crate::step::testing::hanging_disc;

    #[test]
    fn a_hanging_disc_pulls_its_hinge_with_its_weight_each_substep() {
        // at rest the point row carries m g h per substep upwards: 2 kg, g 10
        let mut w = hanging_disc(SolverKind::Soft);
        for _ in 0..120 {
            w.step().unwrap();
        }
        let j = &w.joints[0];
        let h = w.settings.dt / w.settings.substeps as f32;
        let want = 2.0 * 10.0 * h;
        let (x, y) = (j.impulses[slot::POINT_X], j.impulses[slot::POINT_Y]);
        assert!(x.abs() < 1e-3 * want, "{x}");
        assert!((y - want).abs() < 0.01 * want, "{y} vs {want}");
        // and the joint holds: the soft row's sag is m g / (m omega^2) at most
        let omega = std::f32::consts::TAU * w.settings.joint_hertz.min(0.25 / h);
        assert!(
            w.joint_error() <= 10.0 / (omega * omega),
            "{}",
            w.joint_error()
        );
    }

    #[test]
    fn a_compliant_distance_joint_stretches_by_its_compliance_times_the_load() {
        // a spring of compliance alpha under a 2 kg load stretches alpha m g (Hooke)
        let sc = crate::scene::load_str(
            "name = \"spring\"\n[world]\ngravity = [0.0, -10.0]\n\
             [[body]]\nname = \"top\"\ntype = \"static\"\nshape = { circle = 0.05 }\nposition = [0.0, 0.0]\n\
             [[body]]\nname = \"bob\"\nshape = { circle = 0.1 }\nmass = 2.0\nposition = [0.0, -1.0]\n\
             [[joint]]\ntype = \"distance\"\nbodies = [\"top\", \"bob\"]\ncompliance = 0.001\n\
             damping = { linear = 5.0 }\n",
            "spring.toml",
        )
        .unwrap();
        let settings = crate::SolverSettings {
            sleep: false,
            ..crate::SolverSettings::soft()
        };
        let mut w = crate::World::from_def(&sc.world, settings).unwrap();
        for _ in 0..600 {
            w.step().unwrap();
        }
        let stretch = -1.0 - w.bodies[1].position.y;
        let want = 0.001 * 2.0 * 10.0;
        assert!((stretch - want).abs() < 0.02 * want, "{stretch} vs {want}");
    }
}
