//! The soft step: a contact solver for tall stacks at a low sweep count (the scheme of
//! Box2D v3's "soft step", written for this project).
//!
//! One collide per step; the step is cut into `substeps` substeps of h = dt / n that all
//! reuse the step's manifolds. Each substep: integrate velocities, warm start,
//! `iterations` biased sweeps of the normal rows (soft contacts), integrate positions, one
//! relax sweep (rigid, no bias, normal and friction rows). After the last substep:
//! restitution. A point's separation is brought up to date each sweep from the bodies'
//! motion since collide: s = s0 + n . ((dp_b + q_b r_b - r_b) - (dp_a + q_a r_a - r_a)).
//!
//! A soft contact is a spring-damper of frequency `contact_hertz` and damping ratio
//! `contact_damping_ratio` solved implicitly (Erin Catto, "Solver2D", 2024): with
//! omega = 2 pi f, a1 = 2 zeta + h omega, a2 = h omega a1, a3 = 1 / (1 + a2), the row is
//! lambda += -m_n a2 a3 (J v + (omega / a1) S) - a3 lambda, S = min(s + slop, 0), with the
//! bias speed capped by `max_push_speed`. Contacts against a body the solver does not move
//! (static, kinematic) use twice the frequency, as they carry no second body's compliance.
//!
//! Masses far apart: an island (bodies joined by contacts) of at most 24 points where
//! some contact joins masses 10 or more apart is solved exactly after each sweep, and
//! its soft rows leak no more of their load than keeps them within a slop past the slop
//! (`direct`): a box of 1e4 times the mass of the two it stands on holds within 6 mm.
//!
//! Friction is left out of the biased sweeps: solved against the push-out speeds there,
//! it let the flanks of the 100-row pyramid creep outwards (the top box went 3.9 m
//! sideways in 500 steps at 60 Hz; 0.05 m without).
//!
//! Speed: the constraints are graph-coloured (greedy, at most 64 colours, the rest one to
//! a wide constraint) and stored colour by colour, four to a `WideConstraint`. Four
//! constraints of one colour share no moving body, so solving them in lock step in SIMD
//! lanes gives what solving them one after another would. The order is a pure function of
//! the contact list, so the step stays deterministic; the AVX2 build of the sweeps does
//! the same arithmetic as the SSE one (no fused multiply-adds), so the same bits.

use super::contact_cache::Contact;
use crate::awake::{AwakeMarks, each_awake, each_awake_in};
use crate::body::Body;
use crate::body::HOT_BYTES;
use crate::defs::{BodyModel, BodyType, SolverSettings};
use crate::joint::{Joint, MouseJoint};
use crate::math::{BODY_AHEAD, BODY_PASS_BLOCK, Rot, Vec2, cross, cross_sv, prefetch, uf_root};
use crate::parallel::{self, Disjoint, MAX_THREADS, Pool, Scratch};
use glam::Vec4;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU32, Ordering};

mod build;
mod color;
mod direct;
mod hinge;
pub mod joints;
mod kernels;
mod lanes;
mod lopsided;
mod schedule;

#[allow(unused_imports)]
use self::{build::*, color::*, hinge::*, kernels::*, lopsided::*, schedule::*};

#[cfg(target_arch = "x86_64")]
use lanes::F8;
use lanes::Lanes;

/// Test hooks, per thread (tests running side by side do not see each other's): which
/// build of the sweeps runs, and whether lanes are packed. Not for use outside tests.
#[doc(hidden)]
pub mod testing {
    use std::cell::Cell;

    thread_local! {
        pub(super) static FORCE_SSE: Cell<bool> = const { Cell::new(false) };
        pub(super) static ONE_LANE: Cell<bool> = const { Cell::new(false) };
        pub(super) static NO_HINGE_LANES: Cell<bool> = const { Cell::new(false) };
        pub(super) static FRESH_JOINT_LAYOUT: Cell<bool> = const { Cell::new(false) };
    }

    /// `true`: the joints are coloured and laid out anew every step, never kept from
    /// the step before (which gives the same bits: a test compares them).
    #[cfg(test)]
    pub fn fresh_joint_layout(on: bool) {
        FRESH_JOINT_LAYOUT.with(|c| c.set(on));
    }

    /// `true`: every hinge is solved by the scalar joint rows, none in a wide hinge's
    /// lanes (the lanes give the same bits: a test compares them).
    #[cfg(test)]
    pub fn no_hinge_lanes(on: bool) {
        NO_HINGE_LANES.with(|c| c.set(on));
    }

    /// `true`: the sweeps and the warm start run their SSE build even on a CPU with AVX2.
    #[cfg(test)]
    pub fn force_sse(on: bool) {
        FORCE_SSE.with(|c| c.set(on));
    }

    /// `true`: every contact gets a wide constraint of its own (lane 0, the rest empty),
    /// as the overflow colour does: a one-by-one solve, colour by colour, in the order
    /// the packed lanes take.
    #[cfg(test)]
    pub fn one_lane(on: bool) {
        ONE_LANE.with(|c| c.set(on));
    }

    /// Whether this CPU runs the AVX2 build by default.
    pub fn avx2_detected() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx2")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }

    #[cfg(target_arch = "x86_64")]
    pub(super) fn use_avx2() -> bool {
        avx2_detected() && !FORCE_SSE.with(Cell::get)
    }
}

pub use crate::constraint::{SoftBody, Softness};

/// Four lanes of a contact point, as the sweeps read them. A lane whose manifold has
/// one point has zero masses here, so its row does nothing.
#[derive(Clone, Copy, Debug, Default)]
struct WidePoint {
    rax: Vec4,
    ray: Vec4,
    rbx: Vec4,
    rby: Vec4,
    /// s0 - n . (rb - ra): the separation at collide, less the anchors' part.
    base_separation: Vec4,
    /// 1 / (J M^-1 J^T) of the normal row
    normal_mass: Vec4,
    /// 1 / (J M^-1 J^T) of the friction row
    tangent_mass: Vec4,
    normal_impulse: Vec4,
    tangent_impulse: Vec4,
    max_normal_impulse: Vec4,
}

/// Four constraints of one colour (no two share a moving body), solved in lock step:
/// the result is the same as solving them one after another.
#[derive(Clone, Copy, Debug)]
struct WideConstraint {
    /// Bodies read, per lane.
    a: [u32; 4],
    b: [u32; 4],
    /// Bodies written, per lane: the body, or the sink for a body the solver does not move.
    wa: [u32; 4],
    wb: [u32; 4],
    nx: Vec4,
    ny: Vec4,
    friction: Vec4,
    m: InvMass4,
    bias_rate: Vec4,
    mass_scale: Vec4,
    impulse_scale: Vec4,
    points: [WidePoint; 2],
}

/// Inverse masses and inertias of four constraints' bodies.
#[derive(Clone, Copy, Debug, Default)]
struct InvMass4 {
    ima: Vec4,
    iia: Vec4,
    imb: Vec4,
    iib: Vec4,
}

/// A body takes the velocities `v`, `w` after the first substep's forces, and keeps the
/// increment for the later substeps: dv = v_after - v_before (`take_increments` and
/// `prepare_integrating` both, so the two paths agree to the bit).
#[inline(always)]
fn take_velocity(s: &mut SoftBody, inc: &mut (Vec2, f32), v: Vec2, w: f32) {
    *inc = (v - s.v, w - s.w);
    s.v = v;
    s.w = w;
}

/// What restitution and the cache need, kept out of the sweeps' way.
#[derive(Clone, Copy, Debug, Default)]
struct WideCold {
    /// Each lane's restitution, where some point of it approaches faster than the
    /// restitution threshold (else 0: restitution leaves the lane be)
    restitution: Vec4,
    /// relative normal velocity of each point before the step, for restitution
    relative_velocity: [Vec4; 2],
    /// points per lane (0 for an empty lane)
    count: [u8; 4],
}

/// The soft bodies as one job's threads share them. Within a colour no two constraints
/// share a moving body, so the threads of a job read and write disjoint bodies, apart
/// from the rest slot (only read) and the sink (only written): each thread writes to a
/// sink of its own.
#[derive(Clone, Copy)]
struct BodyPtr {
    p: *mut SoftBody,
    len: usize,
    /// The index of the shared sink in the constraints, and this thread's own sink.
    sink: u32,
    my_sink: u32,
}

// SAFETY: see the type's docs: the threads of a job touch disjoint bodies.
unsafe impl Send for BodyPtr {}
unsafe impl Sync for BodyPtr {}

impl BodyPtr {
    fn new(bodies: &mut [SoftBody], sink: u32) -> BodyPtr {
        BodyPtr {
            p: bodies.as_mut_ptr(),
            len: bodies.len(),
            sink,
            my_sink: sink,
        }
    }

    /// The same bodies, as thread `t` of a job writes them.
    fn for_thread(self, t: usize) -> BodyPtr {
        BodyPtr {
            my_sink: self.sink + t as u32,
            ..self
        }
    }

    /// Body i, to read.
    ///
    /// Every index a wide constraint holds was checked when `prepare` built it: a
    /// contact's bodies index `inv_mass` (one entry per body, checked), and the rest slot
    /// and the sinks follow the bodies in `bodies`. So the sweeps check only in debug
    /// builds: the check was an eighth of a sweep's instructions.
    #[inline(always)]
    fn at(self, i: u32) -> *mut SoftBody {
        debug_assert!((i as usize) < self.len);
        // SAFETY: in bounds (see above).
        unsafe { self.p.add(i as usize) }
    }

    /// Bodies `r`, to write.
    ///
    /// # Safety
    /// In bounds, and no other thread touches them while the slice is in use.
    #[allow(clippy::mut_from_ref)]
    unsafe fn range<'a>(self, r: std::ops::Range<usize>) -> &'a mut [SoftBody] {
        assert!(r.start <= r.end && r.end <= self.len, "bodies past the end");
        // SAFETY: in bounds (checked); the caller keeps the threads apart.
        unsafe { std::slice::from_raw_parts_mut(self.p.add(r.start), r.len()) }
    }

    /// Body i, to write: with `SHARED` (threads of a job write at once) the sink goes to
    /// this thread's own; alone, to the shared sink.
    #[inline(always)]
    fn written<const SHARED: bool>(self, i: u32) -> *mut SoftBody {
        if SHARED {
            self.at(if i == self.sink { self.my_sink } else { i })
        } else {
            self.at(i)
        }
    }
}

/// The soft-step contact solver and its reusable buffers.
#[derive(Clone, Default, Debug)]
pub struct SoftSolver {
    /// Every body's state, by body index; then slots of the solver's own: a body at rest
    /// that empty lanes read, and one sink per thread that writes of unmoved bodies go to.
    bodies: Vec<SoftBody>,
    /// The first sink's index.
    sink: u32,
    /// Each colour's wide constraints, [start, end), in order; the overflow group follows
    /// the last.
    color_ranges: Vec<(u32, u32)>,
    /// With a pool of `cut_threads` threads: per colour range, where each thread's share
    /// starts (`cut_threads` + 1 wide indices: the range's start, the inner cuts, its
    /// end). The shares are cut where the contacts are (see `build`), so a thread solves
    /// about the same bodies colour after colour.
    color_cuts: Vec<u32>,
    cut_threads: usize,
    /// The counters of the jobs that run the colours one after another (`for_colors`,
    /// `substeps_in_one_job`).
    phases: parallel::Phases,
    /// The plan of the substeps `run` runs: what each phase does, in order (scratch).
    plan: Vec<(Pass, u8)>,
    /// The joints' rows, and each joint's colour; the joints laid out colour by colour
    /// (indices into the joints), each used colour's range of them (beside
    /// `color_ranges`), and the range of those no colour was free for (solved one by
    /// one after the colours, with the overflow contacts).
    joints: joints::SoftJoints,
    joint_colors: Vec<u8>,
    joint_order: Vec<u32>,
    joint_ranges: Vec<(u32, u32)>,
    joint_rest: (u32, u32),
    /// Each used colour's hinges, four to a wide hinge (their limits and motors beside
    /// them, and the joint in each lane), and each colour's range of them.
    hinges: Vec<WideHinge>,
    hinge_rows: Vec<HingeRows>,
    hinge_frames: Vec<HingeFrames>,
    hinge_joints: Vec<[u32; 4]>,
    hinge_ranges: Vec<(u32, u32)>,
    /// Per colour (the overflow last), its span of `joint_order` and its span of hinge
    /// lanes, as the joints were last laid out.
    joint_spans: Vec<(u32, u32)>,
    hinge_spans: Vec<(u32, u32)>,
    /// The joints as they were last coloured and laid out, and whether this step's are
    /// the same (then their colours and layout are kept).
    kept_joints: KeptJoints,
    joints_kept: bool,
    /// Per used colour and thread (`colour * cut_threads + thread`), that thread's share
    /// of the colour.
    shares: Vec<ColorShare>,
    /// Per thread's share of the colours: the least and the largest body it writes
    /// (least > largest for none), from the fill and the wide hinges' pass (two threads
    /// only).
    share_bodies: Vec<(u32, u32)>,
    /// Per thread and colour (`thread * colours + colour`): the blocks of its share, in
    /// the order it runs them, that may touch a body another thread's share writes
    /// (worked out by each thread at the start of `substeps_in_one_job`).
    ahead_blocks: Scratch<AtomicU32>,
    /// Per inner cut, the lane each colour had reached there (scratch of `build`: the
    /// colouring counts each colour there, the layout turns the counts into lanes).
    cut_lanes: Vec<[u32; OVERFLOW + 1]>,
    /// The blocks of wide constraints the build fills, thread by thread (as many per
    /// thread, empty ones last): each thread's share of every colour, so that it fills
    /// the constraints it will solve.
    fill_blocks: Vec<(u32, u32)>,
    /// The wide hinges' blocks, the same way: each thread's share of every colour.
    hinge_blocks: Vec<(u32, u32)>,
    /// Whether the solver moves body i (dynamic).
    moves: Vec<bool>,
    /// (1/m, 1/I) of body i.
    pub(crate) inv_mass: Vec<(f32, f32)>,
    /// The least and the largest positive 1/m of the moving bodies, as the bits of an
    /// f32 (which order positive floats as the floats): where the largest is less than
    /// `direct::MASS_RATIO` times the least, no contact can be lopsided, and the
    /// colouring skips the test.
    inv_mass_range: (u32, u32),
    /// Velocity change per substep from forces, (dv, dw), when it is the same each substep.
    increments: Vec<(Vec2, f32)>,
    /// Where some body has damping of its own and `prepare_integrating` took it: each
    /// body's factors (1 / (1 + h c_linear), 1 / (1 + h c_angular)) (1 where the body
    /// does not move), which every substep's velocities take after the increment
    /// (Box2D's). Empty where no body is damped.
    damping: Vec<(f32, f32)>,
    /// The constraints, four to a wide constraint, colour by colour.
    wide: Vec<WideConstraint>,
    cold: Vec<WideCold>,
    /// Where contact i's constraint lies: wide index * 4 + lane.
    slot: Vec<u32>,
    /// The contact in each lane (wide index * 4 + lane), u32::MAX for an empty lane.
    lane_contact: Vec<u32>,
    /// Per body: the colours its constraints use.
    body_colors: Vec<u64>,
    colors: Vec<u8>,
    colors_used: usize,
    inv_h: f32,
    slop: f32,
    max_push: f32,
    /// Whether some contact of the step has restitution.
    restitution: bool,
    /// Islands of widely differing masses, solved exactly after each sweep.
    direct: direct::DirectIslands,
    /// Per contact: whether its island is solved exactly.
    direct_contact: Vec<bool>,
    /// Union-find parents by body (finding those islands), and per root its points
    /// and whether a lopsided contact joins it; per contact its island's root (scratch).
    parent: Vec<u32>,
    root_points: Vec<u32>,
    root_flagged: Vec<bool>,
    roots: Vec<u32>,
    /// The contact points of the step's contacts.
    points: usize,
    /// The deepest overlap of the step's contacts (m), as the collide found it
    /// ([`SoftSolver::set_deepest`]): past [`direct::deep_overlap`], the small islands of
    /// such contacts are solved exactly.
    deepest: f32,
    /// Whether the last `prepare_integrating` coloured the contacts beside its load pass.
    colored_beside_load: bool,
    /// Whether this step is an odd one (see [`SoftSolver::set_odd_step`]).
    odd_step: bool,
    /// Per block of bodies, whether the step's body passes visit it (the collide found a
    /// body in it awake; empty: every block). See [`crate::awake`].
    awake: Vec<bool>,
}

impl SoftSolver {
    /// Whether this step is an odd one (the world's step count before it): an odd step
    /// with no joint (nor the mouse joint) takes the colours from the last to the first
    /// (`SoftSolver::run`), so that no colour is always solved first.
    ///
    /// Why: greedy colouring in contact order (the bodies' order) puts one kind of
    /// contact in each colour over a whole pile built row by row (every box's contact
    /// with its right-hand neighbour in one colour, say), and Gauss-Seidel favours what
    /// it solves first: with the same order every step the large pyramid's top box swayed
    /// 0.22 to 0.31 m in the first 150 steps and ended 0.10 to 0.13 m aside after 500
    /// (to the left or the right as the colouring ran), where Box2D's sways 0.07 m and
    /// ends 0.017 m aside. Reversed every other step, it sways 0.03 m and ends within
    /// 0.02 m, at no cost: the colours and their phases are the same (`tests/physics.rs`,
    /// `the_large_pyramid_stands_straight_with_one_soft_sweep_a_substep`). A step with
    /// joints keeps the one order: the joints are coloured first, in joint order, which
    /// runs along a chain from its anchor, and reversed every other step Box2D's joint
    /// grid stretched 0.63 m against 0.57 (Box2D's own: 0.62).
    pub fn set_odd_step(&mut self, odd: bool) {
        self.odd_step = odd;
    }

    /// Tells the next `prepare` how deep the step's deepest overlap is (m, as the
    /// collide returns it; 0 if not known).
    pub fn set_deepest(&mut self, deepest: f32) {
        self.deepest = deepest;
    }

    /// Fills the solver's entries of the bodies that sleep with NaN (tests: a body pass
    /// or a constraint that read a sleeper's entry the step did not load would spread
    /// them into the world).
    #[cfg(test)]
    pub(crate) fn poison_sleepers(&mut self, bodies: &[Body]) {
        let nan = Vec2::splat(f32::NAN);
        for (i, b) in bodies.iter().enumerate().take(self.moves.len()) {
            if b.asleep {
                self.bodies[i] = SoftBody {
                    v: nan,
                    w: f32::NAN,
                    dtheta: f32::NAN,
                    dp: nan,
                    dq: Rot {
                        c: f32::NAN,
                        s: f32::NAN,
                    },
                };
                self.inv_mass[i] = (f32::NAN, f32::NAN);
                if let Some(inc) = self.increments.get_mut(i) {
                    *inc = (nan, f32::NAN);
                }
            }
        }
    }

    /// Per block of bodies, whether this step's body passes visit it (empty: all).
    #[cfg(test)]
    pub(crate) fn awake_blocks(&self) -> &[bool] {
        &self.awake
    }

    /// Tells the step's body passes which blocks of bodies to visit: those the collide
    /// found awake, or every block if it found none (see [`crate::awake`]). A skipped
    /// block's entries keep whatever they held: no constraint reads a sleeping body.
    pub(crate) fn set_awake(&mut self, marks: &AwakeMarks) {
        marks.copy_into(&mut self.awake);
    }

    /// Builds this step's constraints from the contacts (collided at the step's start)
    /// and the joints (and the mouse joint) for substeps of `h`, and loads the bodies.
    /// Lambdas start from the cache and the joints' own if warm starting. (The step
    /// calls its two halves itself, deciding between the second and
    /// [`SoftSolver::prepare_integrating`] on what the first finds.)
    #[cfg(test)]
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        bodies: &[Body],
        contacts: &[Contact],
        joints: &[Joint],
        mouse: Option<&MouseJoint>,
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        self.prepare_joints(joints, mouse, bodies, s, h, pool);
        self.prepare_constraints(bodies, contacts, joints, s, h, pool);
    }

    /// The joints' part of [`SoftSolver::prepare`], first: their geometry at the step's
    /// start (the joints and the mouse joint). Returns whether some joint has a drive.
    pub fn prepare_joints(
        &mut self,
        joints: &[Joint],
        mouse: Option<&MouseJoint>,
        bodies: &[Body],
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) -> bool {
        self.joints.prepare(joints, mouse, bodies, s, h, pool)
    }

    /// The rest of [`SoftSolver::prepare`], after [`SoftSolver::prepare_joints`]: the
    /// bodies loaded, the contacts' and joints' constraints built.
    pub fn prepare_constraints(
        &mut self,
        bodies: &[Body],
        contacts: &[Contact],
        joints: &[Joint],
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        self.size_bodies(bodies.len());
        self.damping.clear();
        self.load_bodies(bodies, pool);
        self.build(bodies, contacts, joints, s, h, pool);
    }

    /// [`SoftSolver::prepare_constraints`] (after [`SoftSolver::prepare_joints`]), with
    /// the first substep's forces integrated in the same pass over the bodies: what
    /// `World::integrate_velocities(h)` and then [`SoftSolver::take_increments`] do, to
    /// the same bits, for a world whose only forces are gravity and each body's own force
    /// and torque (no drag, drives or point forces: the caller checks). One pass over the
    /// bodies instead of three.
    ///
    /// `damped`: some body has damping of its own. Its first substep's velocities are
    /// then damped as `World::integrate_velocities(h)` damps them, its increment is the
    /// undamped one, and every later substep damps again after the increment (see
    /// `damping`): each substep's forces and damping as the world's pass would apply
    /// them, without a pass over the world's bodies a substep.
    ///
    /// `movers`, where the caller has it: whether each body is dynamic, as the solver's
    /// own load pass finds it. With threads, one of them then colours the contacts while
    /// the others run that pass (the colouring reads no body), instead of after it.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare_integrating(
        &mut self,
        bodies: &mut [Body],
        contacts: &[Contact],
        joints: &[Joint],
        movers: Option<&[bool]>,
        s: &SolverSettings,
        h: f32,
        gravity: Option<Vec2>,
        damped: bool,
        pool: Option<&Pool>,
    ) {
        // (the joints' frames were taken from the positions, which the load leaves)
        let nb = bodies.len();
        self.size_bodies(nb);
        self.increments.resize(nb, (Vec2::ZERO, 0.0));
        self.damping.clear();
        if damped {
            self.damping.resize(nb, (1.0, 1.0));
        }
        let deep = self.deep_gate(s);
        let damping = Disjoint::new(&mut self.damping);
        let (soft, moves) = (
            Disjoint::new(&mut self.bodies[..nb]),
            Disjoint::new(&mut self.moves),
        );
        let inv_mass = Disjoint::new(&mut self.inv_mass);
        let increments = Disjoint::new(&mut self.increments);
        let all = Disjoint::new(bodies);
        let shared_range = SharedMassRange::new();
        let awake = &self.awake[..];
        let load = |t: usize, r: std::ops::Range<usize>| {
            let mut range = MassRange::default();
            each_awake(awake, r, |r| {
                // SAFETY: each block takes only its own range of each slice
                let (soft, moves, inv_mass, increments, bodies) = unsafe {
                    (
                        soft.range(r.clone()),
                        moves.range(r.clone()),
                        inv_mass.range(r.clone()),
                        increments.range(r.clone()),
                        all.range(r.clone()),
                    )
                };
                // SAFETY: as above (empty where no body is damped)
                let damping = if damped {
                    unsafe { damping.range(r) }
                } else {
                    &mut []
                };
                for i in 0..bodies.len() {
                    prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
                    let b = &mut bodies[i];
                    let (v0, w0) = (b.velocity, b.angular_velocity);
                    if b.is_dynamic() && !b.asleep {
                        (b.velocity, b.angular_velocity) = b.free_velocity(h, gravity);
                        if let Some(d) = damping.get_mut(i) {
                            *d = b.damping_factors(h);
                        }
                    }
                    // the constraints are built from the velocities before the step (restitution
                    // keeps each point's approach speed): the new ones wait in `increments`
                    increments[i] = (b.velocity, b.angular_velocity);
                    soft[i] = SoftBody {
                        v: v0,
                        w: w0,
                        ..SoftBody::default()
                    };
                    moves[i] = b.is_dynamic();
                    inv_mass[i] = (b.inv_mass, b.inv_inertia);
                    range.add(moves[i], b.inv_mass);
                }
            });
            range.publish(&shared_range, t);
            0.0
        };
        let threads = pool.map_or(1, Pool::threads);
        let side_by_side = match (pool, movers) {
            (Some(pool), Some(movers))
                if threads > 1 && contacts.len() >= PARALLEL_COLORING && movers.len() == nb =>
            {
                Some((pool, movers))
            }
            _ => None,
        };
        self.colored_beside_load = side_by_side.is_some();
        if let Some((pool, movers)) = side_by_side {
            // block 0 colours the contacts (the caller claims it first); the others are
            // the load pass's, which the other threads take meanwhile
            // (the colouring's thread reads the flags the collide found, which are what
            // the load pass finds)
            self.joints_kept = self.kept_joints.hold(&self.joints, movers, Some(pool));
            let recolor = !self.joints_kept;
            let coloring = Mutex::new((
                &mut self.body_colors,
                &mut self.colors,
                &mut self.joint_colors,
                &mut self.cut_lanes,
                None,
            ));
            let ends = self.joints.ends();
            parallel::blocks_max(pool, 1 + nb.div_ceil(BODY_PASS_BLOCK), &|t, b| {
                if b > 0 {
                    let at = (b - 1) * BODY_PASS_BLOCK;
                    return load(t, at..(at + BODY_PASS_BLOCK).min(nb));
                }
                let mut c = coloring.lock().unwrap_or_else(|e| e.into_inner());
                let (body_colors, colors, joint_colors, cut_lanes, found) = &mut *c;
                *found = Some(color_contacts(
                    contacts,
                    ends,
                    movers,
                    None,
                    deep,
                    threads,
                    body_colors,
                    colors,
                    joint_colors,
                    recolor,
                    cut_lanes,
                ));
                0.0
            });
            let found = coloring.into_inner().unwrap_or_else(|e| e.into_inner()).4;
            let mut found = found.expect("the colouring block ran");
            self.inv_mass_range = shared_range.get();
            if may_be_lopsided(self.inv_mass_range) {
                // (the masses were not loaded yet when the contacts were coloured)
                let (moves, inv_mass) = (&self.moves, &self.inv_mass);
                found.lopsided = contacts
                    .iter()
                    .any(|c| is_lopsided_contact(c, moves, inv_mass));
            }
            self.build_colored(bodies, contacts, joints, found, s, h, Some(pool));
        } else {
            parallel::ranges_max(pool, nb, BODY_PASS_BLOCK, &load);
            self.inv_mass_range = shared_range.get();
            self.build(bodies, contacts, joints, s, h, pool);
        }
        // then take the new velocities and keep their increments, as take_increments
        // does (a pass over the solver's own small arrays)
        let n = self.increments.len();
        let (awake, damping) = (&self.awake[..], &self.damping[..]);
        parallel::chunks_mut2(
            pool,
            &mut self.bodies[..n],
            &mut self.increments,
            BODY_BLOCK,
            &|_, offset, soft, increments| {
                each_awake_in(awake, offset, soft.len(), |r| {
                    let (soft, increments) = (&mut soft[r.clone()], &mut increments[r.clone()]);
                    for (s, inc) in soft.iter_mut().zip(increments.iter_mut()) {
                        let (v, w) = *inc;
                        take_velocity(s, inc, v, w);
                    }
                    if !damping.is_empty() {
                        let damping = &damping[offset + r.start..offset + r.end];
                        for (s, &(dl, da)) in soft.iter_mut().zip(damping) {
                            s.v *= dl;
                            s.w *= da;
                        }
                    }
                });
                0.0
            },
        );
    }

    /// Sizes the solver's body arrays for `nb` bodies, the rest slot and the sinks, and
    /// resets the rest slot and the sinks (the bodies' entries, move flags and masses
    /// are written whole by the load pass).
    fn size_bodies(&mut self, nb: usize) {
        self.bodies
            .resize(nb + 1 + MAX_THREADS, SoftBody::default());
        self.bodies[nb..].fill(SoftBody::default());
        self.sink = nb as u32 + 1;
        self.moves.resize(nb, false);
        // inverse mass and inertia, packed, so the contact loop reads no `Body`
        self.inv_mass.resize(nb, (0.0, 0.0));
    }

    /// Loads the bodies' velocities, move flags and masses.
    fn load_bodies(&mut self, bodies: &[Body], pool: Option<&Pool>) {
        let nb = bodies.len();
        let shared_range = SharedMassRange::new();
        let awake = &self.awake[..];
        // one pass over the bodies (large: each read is a cache miss on a big scene),
        // split between the threads
        parallel::chunks_mut3(
            pool,
            &mut self.bodies[..nb],
            &mut self.moves[..],
            &mut self.inv_mass[..],
            BODY_PASS_BLOCK,
            &|t, offset, soft, moves, inv_mass| {
                let mut range = MassRange::default();
                let bodies = &bodies[offset..];
                each_awake_in(awake, offset, soft.len(), |r| {
                    let bodies = &bodies[r.clone()];
                    let (soft, moves, inv_mass) = (
                        &mut soft[r.clone()],
                        &mut moves[r.clone()],
                        &mut inv_mass[r],
                    );
                    for (i, ((s, m), im)) in soft.iter_mut().zip(moves).zip(inv_mass).enumerate() {
                        prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
                        let b = &bodies[i];
                        *s = SoftBody {
                            v: b.velocity,
                            w: b.angular_velocity,
                            ..SoftBody::default()
                        };
                        *m = b.is_dynamic();
                        *im = (b.inv_mass, b.inv_inertia);
                        range.add(*m, b.inv_mass);
                    }
                });
                range.publish(&shared_range, t);
                0.0
            },
        );
        self.inv_mass_range = shared_range.get();
    }

    /// The contact points `prepare` was given.
    pub fn points(&self) -> usize {
        self.points
    }

    /// Copies the bodies' velocities in (after the world integrated forces into them).
    pub fn load_velocities(&mut self, bodies: &[Body]) {
        for (s, b) in self.bodies.iter_mut().zip(bodies) {
            s.v = b.velocity;
            s.w = b.angular_velocity;
        }
    }

    /// Takes the bodies' velocities after the world integrated one substep of forces into
    /// them: the change since `prepare` is kept as each later substep's increment.
    pub fn take_increments(&mut self, bodies: &[Body], pool: Option<&Pool>) {
        let n = bodies.len().min(self.bodies.len());
        self.damping.clear();
        self.increments.clear();
        self.increments.resize(n, (Vec2::ZERO, 0.0));
        let awake = &self.awake[..];
        parallel::chunks_mut2(
            pool,
            &mut self.bodies[..n],
            &mut self.increments,
            BODY_PASS_BLOCK,
            &|_, offset, soft, increments| {
                let bodies = &bodies[offset..];
                each_awake_in(awake, offset, soft.len(), |r| {
                    let bodies = &bodies[r.clone()];
                    let (soft, increments) = (&mut soft[r.clone()], &mut increments[r]);
                    for (i, (s, inc)) in soft.iter_mut().zip(increments).enumerate() {
                        prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
                        let b = &bodies[i];
                        take_velocity(s, inc, b.velocity, b.angular_velocity);
                    }
                });
                0.0
            },
        );
    }

    /// The end of the step, in one pass over the bodies: the dynamic ones take their
    /// solved velocities, and every body that is not static moves by its displacement
    /// and turn since collide (x = x0 + sum h v, theta = theta0 + sum h w). The same
    /// pass does the world's end of step (see `World::end_step`): every body's force and
    /// torque are cleared, and the return says whether some body's state is not finite.
    pub fn finish(&self, bodies: &mut [Body], pool: Option<&Pool>) -> bool {
        let n = bodies.len().min(self.moves.len());
        let bad = parallel::chunks_mut(
            pool,
            &mut bodies[..n],
            BODY_PASS_BLOCK,
            &|_, offset, bodies| {
                let mut bad = false;
                let (soft, moves) = (&self.bodies[offset..], &self.moves[offset..]);
                each_awake_in(&self.awake, offset, bodies.len(), |r| {
                    let (soft, moves) = (&soft[r.clone()], &moves[r.clone()]);
                    let bodies = &mut bodies[r];
                    for (i, (s, &m)) in soft.iter().zip(moves).take(bodies.len()).enumerate() {
                        prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
                        let b = &mut bodies[i];
                        b.force = Vec2::ZERO;
                        b.torque = 0.0;
                        if m {
                            b.velocity = s.v;
                            b.angular_velocity = s.w;
                        }
                        if b.body_type != BodyType::Static {
                            b.position += s.dp;
                            if b.model == BodyModel::Rigid {
                                b.angle += s.dtheta;
                                b.rot = Rot::from_angle(b.angle);
                            }
                        }
                        bad |= !b.is_finite();
                    }
                });
                if bad { 1.0 } else { 0.0 }
            },
        );
        // bodies past the solver's (none in a step) are checked and cleared too
        let mut rest_bad = false;
        for b in &mut bodies[n..] {
            b.force = Vec2::ZERO;
            b.torque = 0.0;
            rest_bad |= !b.is_finite();
        }
        bad > 0.0 || rest_bad
    }

    /// Copies the solved velocities out to the dynamic bodies.
    pub fn store_velocities(&self, bodies: &mut [Body]) {
        for ((s, b), &m) in self.bodies.iter().zip(bodies).zip(&self.moves) {
            if m {
                b.velocity = s.v;
                b.angular_velocity = s.w;
            }
        }
    }

    /// Writes the joints' lambdas back into them, for the next step's warm start.
    pub fn store_joints(&mut self, joints: &mut [Joint], pool: Option<&Pool>) {
        // the joints solved one by one, from their rows
        self.joints.store(joints, pool);
        // the lanes' lambdas into their joints (a joint has one lane)
        let joints = Disjoint::new(joints);
        let (hinges, rows, of) = (&self.hinges, &self.hinge_rows, &self.hinge_joints);
        parallel::ranges_max(pool, hinges.len(), WIDE_BLOCK, &|_, r| {
            for w in r {
                for (k, &i) in of[w].iter().enumerate() {
                    if i != u32::MAX {
                        let i = i as usize;
                        // SAFETY: each joint is in one lane of one wide hinge
                        let j = unsafe { &mut joints.range(i..i + 1)[0] };
                        hinges[w].impulses(&rows[w], k, &mut j.impulses);
                    }
                }
            }
            0.0
        });
    }

    /// Writes the lambdas back into the contacts, for next step's warm start.
    pub fn store_impulses(&self, contacts: &mut [Contact], pool: Option<&Pool>) {
        parallel::chunks_mut(pool, contacts, CONTACT_BLOCK, &|_, offset, contacts| {
            let slots = &self.slot[offset..];
            for (i, (c, &at)) in contacts.iter_mut().zip(slots).enumerate() {
                // the constraints lie in colour order: ask for one a few contacts ahead
                if let Some(&ahead) = slots.get(i + STORE_AHEAD) {
                    prefetch_impulses(&self.wide, (ahead / 4) as usize);
                }
                let (w, k) = (&self.wide[(at / 4) as usize], (at % 4) as usize);
                for (p, q) in c.manifold.points[..c.manifold.count]
                    .iter_mut()
                    .zip(&w.points)
                {
                    p.normal_impulse = q.normal_impulse[k];
                    p.tangent_impulse = q.tangent_impulse[k];
                }
            }
            0.0
        });
    }

    /// The normal and friction lambdas of every row, contact by contact.
    pub fn lambdas(&self, out: &mut Vec<f32>) {
        out.clear();
        for &at in &self.slot {
            let (w, k) = (&self.wide[(at / 4) as usize], (at % 4) as usize);
            let count = self.cold[(at / 4) as usize].count[k] as usize;
            for p in &w.points[..count] {
                out.push(p.normal_impulse[k]);
                out.push(p.tangent_impulse[k]);
            }
        }
    }

    /// The solved bodies' state, by body index, then the solver's own slots (for
    /// tests: the bodies are the solver's to size, never a caller's).
    #[cfg(test)]
    pub(crate) fn solved_bodies(&self) -> &[SoftBody] {
        &self.bodies
    }

    /// Checks the layout: every contact's slot holds its pair, and no moving body appears
    /// in two lanes of one wide constraint (for tests).
    #[cfg(test)]
    pub fn lanes_are_independent(&self, contacts: &[Contact]) -> bool {
        let sink = self.sink;
        let pairs_ok = contacts.iter().zip(&self.slot).all(|(c, &at)| {
            let (w, k) = (&self.wide[(at / 4) as usize], (at % 4) as usize);
            w.a[k] == c.a && w.b[k] == c.b
        });
        let lanes_ok = self.wide.iter().all(|w| {
            let mut written: Vec<u32> = w.wa.iter().chain(&w.wb).copied().collect();
            written.retain(|&i| i != sink);
            let n = written.len();
            written.sort_unstable();
            written.dedup();
            written.len() == n
        });
        pairs_ok && lanes_ok
    }

    /// Colours in use (the overflow group counts as one), for tests and figures.
    pub fn color_count(&self) -> usize {
        self.colors_used
    }

    /// Wide (four-lane) constraints in this step's layout (for tests).
    #[doc(hidden)]
    #[cfg(test)]
    pub fn wide_count(&self) -> usize {
        self.wide.len()
    }
}

impl WideConstraint {
    /// Four empty lanes: they read the rest slot, write the sink, and weigh nothing.
    fn empty(rest: u32, sink: u32) -> WideConstraint {
        WideConstraint {
            a: [rest; 4],
            b: [rest; 4],
            wa: [sink; 4],
            wb: [sink; 4],
            nx: Vec4::ZERO,
            ny: Vec4::ZERO,
            friction: Vec4::ZERO,
            m: InvMass4::default(),
            bias_rate: Vec4::ZERO,
            mass_scale: Vec4::ZERO,
            impulse_scale: Vec4::ZERO,
            points: [WidePoint::default(); 2],
        }
    }
}

/// How many contacts ahead `store_impulses` asks for the lambdas it will copy.
const STORE_AHEAD: usize = 8;

/// Asks the cache for the lambdas of wide constraint `wi` (nothing past the end). A
/// hint only: no result depends on it.
#[inline(always)]
fn prefetch_impulses(wide: &[WideConstraint], wi: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(w) = wide.get(wi) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        for p in &w.points {
            // normal_impulse and tangent_impulse: 32 bytes, in at most two lines
            let at = (&p.normal_impulse as *const Vec4).cast::<i8>();
            // SAFETY: prefetching has no effect on memory and cannot fault (the second
            // address is only computed, with wrapping arithmetic, never read).
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(at);
                _mm_prefetch::<_MM_HINT_T0>(at.wrapping_add(31));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (wide, wi);
}

/// Wide constraints a thread fills at a time (about a microsecond of work).
const WIDE_BLOCK: usize = 32;
/// Wide constraints a thread claims at a time in a sweep over the colours (a few
/// microseconds of work): each claim is a locked instruction, which waits on the
/// block's stores, and a block taken by the other thread moves its constraints and
/// bodies to that core and back. With 32, two threads took 1.04 of the time on the large
/// pyramid.
const PHASE_BLOCK: usize = 128;
/// Bodies a thread claims at a time (integration).
const BODY_BLOCK: usize = 1024;
/// Contacts from which one thread colours them while the others load the bodies.
const PARALLEL_COLORING: usize = 1024;
/// Contacts from which the layout of the constraints is split between the threads.
const PARALLEL_LAYOUT: usize = 2048;
/// Contacts a thread claims at a time (copying lambdas out).
const CONTACT_BLOCK: usize = 512;

/// What a sweep reads besides the constraints and bodies.
struct SweepConsts {
    inv_h: f32,
    slop: f32,
    max_push: f32,
    /// Keep each point's largest normal impulse (for restitution).
    max_impulse: bool,
    avx2: bool,
}

/// The joints as the solver last coloured and laid them out: each one's bodies, whether
/// it takes lanes, and whether each of its bodies moved.
#[derive(Clone, Debug, Default)]
struct KeptJoints {
    ends: Vec<(u32, u32)>,
    lanes: Vec<bool>,
    moves: Vec<(bool, bool)>,
    /// The bodies then (empty lanes read the slot after them, and bodies that do not
    /// move are written to the sinks after that).
    bodies: usize,
    /// Whether a layout was made for them.
    laid_out: bool,
}

/// Joints a block of [`KeptJoints::hold`]'s comparison takes.
const KEPT_BLOCK: usize = 2048;

impl KeptJoints {
    /// Whether this step's joints (and which of their bodies move, `moves`) are those
    /// last laid out (and not while a test asks for a new layout every step); if not,
    /// they become the ones kept, for the layout this step makes.
    /// (The comparison is split between the threads of `pool`.)
    fn hold(&mut self, joints: &joints::SoftJoints, moves: &[bool], pool: Option<&Pool>) -> bool {
        let (ends, lanes) = (joints.ends(), joints.lanes());
        let kept = &*self;
        let same = kept.laid_out
            && !testing::FRESH_JOINT_LAYOUT.with(std::cell::Cell::get)
            && kept.bodies == moves.len()
            && kept.ends.len() == ends.len()
            && kept.lanes.len() == lanes.len()
            && parallel::ranges_max(pool, ends.len(), KEPT_BLOCK, &|_, r| {
                let same = kept.ends[r.clone()] == ends[r.clone()]
                    && kept.lanes[r.clone()] == lanes[r.clone()]
                    && ends[r.clone()]
                        .iter()
                        .zip(&kept.moves[r])
                        .all(|(&(a, b), &m)| (moves[a as usize], moves[b as usize]) == m);
                if same { 0.0 } else { 1.0 }
            }) <= 0.0;
        if !same {
            self.ends.clear();
            self.ends.extend_from_slice(ends);
            self.lanes.clear();
            self.lanes.extend_from_slice(lanes);
            self.moves.clear();
            self.moves.extend(
                ends.iter()
                    .map(|&(a, b)| (moves[a as usize], moves[b as usize])),
            );
            self.bodies = moves.len();
            self.laid_out = true;
        }
        same
    }
}

/// A thread's share of a colour: its joints solved one by one (a range of `joint_order`),
/// its wide hinges, its wide constraints, and where it starts among the colour's items
/// (the shares one after another, each its joints, then its hinges, then its contacts).
#[derive(Clone, Copy, Debug, Default)]
struct ColorShare {
    joints: (u32, u32),
    hinges: (u32, u32),
    contacts: (u32, u32),
    first: u32,
}

impl ColorShare {
    /// Its items.
    fn len(&self) -> u32 {
        (self.joints.1 - self.joints.0)
            + (self.hinges.1 - self.hinges.0)
            + (self.contacts.1 - self.contacts.0)
    }
}

#[cfg(test)]
mod tests {
    use super::{
        MassRange, PARALLEL_LAYOUT, SharedMassRange, SoftSolver, Softness, is_lopsided,
        may_be_lopsided,
    };
    use crate::defs::SolverKind;
    use crate::defs::SolverSettings;
    use crate::parallel::Pool;
    use crate::step::testing::{normal_sum, resting_box};

    #[test]
    fn coloring_beside_the_load_pass_gives_the_bits_of_coloring_after_it() {
        // a pyramid of 1,830 boxes (enough contacts for one thread to colour them while
        // the other loads the bodies, and for the layout to be split), a box 100 times
        // heavier at its foot (lopsided contacts, looked for after the colouring on that
        // path), and a heavy box on a light one, apart (an island solved exactly)
        let sc = crate::scene::load_str(
            "name = \"pile\"\n[world]\ngravity = [0.0, -10.0]\n\
             [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [400.0, 2.0] }\nposition = [0.0, -1.0]\n\
             [[pyramid]]\nbase = 60\n\
             [[body]]\nname = \"light\"\nshape = { box = [1.0, 1.0] }\nposition = [150.0, 0.5]\n\
             [[body]]\nname = \"heavy\"\nshape = { box = [1.0, 1.0] }\nposition = [150.0, 1.5]\ndensity = 100.0\n",
            "pile.toml",
        )
        .unwrap();
        let settings = SolverSettings::soft();
        let mut w = crate::World::from_def(&sc.world, settings).unwrap();
        let foot = w.bodies.iter().position(|b| b.is_dynamic()).unwrap();
        w.bodies[foot].inv_mass *= 0.01;
        w.bodies[foot].inv_inertia *= 0.01;
        for _ in 0..5 {
            w.step().unwrap();
        }
        assert!(
            w.contacts().len() > 2 * PARALLEL_LAYOUT,
            "{}",
            w.contacts().len()
        );
        let h = settings.dt / settings.substeps as f32;
        let movers: Vec<bool> = w.bodies.iter().map(|b| b.is_dynamic()).collect();
        let pool = Pool::new(2);
        let run = |movers: Option<&[bool]>, pool: Option<&Pool>, beside: bool| {
            let mut bodies = w.bodies.clone();
            let mut s = SoftSolver::default();
            s.prepare_joints(&[], None, &bodies, &settings, h, pool);
            s.prepare_integrating(
                &mut bodies,
                w.contacts(),
                &[],
                movers,
                &settings,
                h,
                w.gravity,
                false,
                pool,
            );
            assert_eq!(s.colored_beside_load, beside);
            assert!(
                s.direct_contact.iter().any(|&d| d),
                "an island solved exactly"
            );
            let layout = (
                s.colors.clone(),
                s.slot.clone(),
                s.lane_contact.clone(),
                s.color_cuts.clone(),
                s.direct_contact.clone(),
            );
            // one substep: warm start, a soft sweep, positions, a relax sweep
            let r = s.run(&[], 1, &settings, h, pool);
            let mut lam = Vec::new();
            s.lambdas(&mut lam);
            let bits: Vec<u32> = s.bodies[..bodies.len()]
                .iter()
                .flat_map(|b| [b.v.x, b.v.y, b.w, b.dp.x, b.dp.y, b.dtheta])
                .chain(bodies.iter().flat_map(|b| [b.velocity.x, b.velocity.y]))
                .chain(lam)
                .chain([r])
                .map(f32::to_bits)
                .collect();
            (layout, bits)
        };
        let serial = run(Some(&movers), Some(&pool), true);
        assert_eq!(serial, run(None, Some(&pool), false));
        // (one thread lays out the contacts as one run: only the cuts differ)
        let (one_layout, one_bits) = run(Some(&movers), None, false);
        assert_eq!(one_bits, serial.1);
        assert_eq!(one_layout.0, serial.0.0);
    }

    #[test]
    fn a_stalled_worker_leaves_its_shares_to_the_caller_with_the_same_bits() {
        // (a hang, the stalled thread waiting for ever, fails under the watchdog)
        crate::parallel::tests::within_30s(|| {
            // a pyramid of 465 boxes; the worker of a two-thread pool does nothing in a job
            // until the caller has done every block of it (a test's stall): the colour
            // passes and the substeps in one job still end, with the bits of one thread
            let sc = crate::scene::load_str(
                "name = \"pile\"\n[world]\ngravity = [0.0, -10.0]\n\
                 [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [200.0, 2.0] }\nposition = [0.0, -1.0]\n\
                 [[pyramid]]\nbase = 30\n",
                "pile.toml",
            )
            .unwrap();
            let settings = SolverSettings::soft();
            let mut w = crate::World::from_def(&sc.world, settings).unwrap();
            for _ in 0..20 {
                w.step().unwrap();
            }
            let substeps = settings.substeps as usize;
            let h = settings.dt / substeps as f32;
            let pool = Pool::new(2);
            let bits = |s: &SoftSolver, r: f32| {
                let mut lam = Vec::new();
                s.lambdas(&mut lam);
                s.bodies[..w.bodies.len()]
                    .iter()
                    .flat_map(|b| [b.v.x, b.v.y, b.w, b.dp.x, b.dp.y, b.dtheta])
                    .chain(lam)
                    .chain([r])
                    .map(f32::to_bits)
                    .collect::<Vec<u32>>()
            };
            // every substep on one thread, and as one job of the pool with the worker
            // stalled, then the caller
            let run = |pool: Option<&Pool>, stall: usize| {
                let mut s = SoftSolver::default();
                s.phases.stall = stall;
                s.prepare(&w.bodies, w.contacts(), &[], None, &settings, h, pool);
                s.take_increments(&w.bodies, pool);
                let r = s.run(&[], substeps, &settings, h, pool);
                bits(&s, r)
            };
            let one = run(None, 0);
            assert_eq!(one, run(Some(&pool), 2), "the worker stalled");
            assert_eq!(one, run(Some(&pool), 1), "the caller stalled");
        });
    }

    #[test]
    fn the_substeps_as_one_job_of_a_pool_give_the_bits_of_one_thread() {
        // a pyramid of 435 boxes, bouncing balls (restitution) and a 12 x 12 hinged grid
        // hanging from two static cells: contacts in many colours, joints among them
        // (one by one and in lanes), the overflow-free plan and its increments
        let sc = crate::scene::load_str(
            "name = \"threads\"\n[world]\ngravity = [0.0, -10.0]\n\
             [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [200.0, 2.0] }\nposition = [0.0, -1.0]\n\
             [[pyramid]]\nbase = 29\n\
             [[grid]]\nrows = 1\ncolumns = 20\nspacing = [1.5, 1.0]\norigin = [-14.0, 34.0]\nshape = { circle = 0.4 }\nrestitution = 0.8\n\
             [[grid]]\nrows = 12\ncolumns = 12\nspacing = [1.0, 1.0]\norigin = [40.0, 5.0]\nshape = { box = [0.6, 0.6] }\njoints = \"hinge\"\nstatic_cells = [[11, 0], [11, 11]]\n",
            "threads.toml",
        )
        .unwrap();
        let settings = SolverSettings::soft();
        let mut w = crate::World::from_def(&sc.world, settings).unwrap();
        for _ in 0..30 {
            w.step().unwrap();
        }
        let substeps = settings.substeps as usize;
        let h = settings.dt / substeps as f32;
        let pool = Pool::new(2);
        let run = |pool: Option<&Pool>| {
            let mut s = SoftSolver::default();
            s.prepare(&w.bodies, w.contacts(), &w.joints, None, &settings, h, pool);
            s.take_increments(&w.bodies, pool);
            assert!(!s.hinges.is_empty() && !s.joint_ranges.is_empty());
            let jobs = pool.map_or(0, Pool::jobs);
            let r = s.run(&w.joints, substeps, &settings, h, pool);
            if let Some(pool) = pool {
                assert_eq!(pool.jobs(), jobs + 1, "one job for every substep");
            }
            let mut lam = Vec::new();
            s.lambdas(&mut lam);
            let mut joints = w.joints.to_vec();
            s.store_joints(&mut joints, pool);
            s.bodies[..w.bodies.len()]
                .iter()
                .flat_map(|b| [b.v.x, b.v.y, b.w, b.dp.x, b.dp.y, b.dtheta])
                .chain(lam)
                .chain(joints.iter().flat_map(|j| j.impulses))
                .chain([r])
                .map(f32::to_bits)
                .collect::<Vec<u32>>()
        };
        let one = run(None);
        let two = run(Some(&pool));
        let first = one.iter().zip(&two).position(|(a, b)| a != b);
        assert_eq!(first, None, "the first value that differs");
    }

    #[test]
    fn a_kept_joint_layout_gives_the_bits_of_a_new_one_every_step() {
        // the joints' colours and wide hinges kept from step to step (the bodies' new
        // geometry taken each step) against a layout made anew every step; the ragdoll
        // falls asleep and wakes on the way (its joints leave the step and come back),
        // the chain's grabbed link has a mouse joint; at step 90 every motor's speed and
        // every limit changes (a kept layout reads them anew); Box2D's humans carry
        // springs and joint friction
        for name in [
            "ragdoll",
            "chain",
            "joint_grid",
            "bridge",
            "joints",
            "humans",
        ] {
            let sc = scene_for_lanes(name);
            let run = |fresh: bool| {
                super::testing::fresh_joint_layout(fresh);
                let mut w = crate::World::from_def(&sc.world, sc.world.solver.resolve()).unwrap();
                let steps = if name == "joint_grid" { 10 } else { 200 };
                let hashes: Vec<u64> = (0..steps)
                    .map(|i| {
                        if i == 30 {
                            let body = w.bodies.iter().position(|b| b.is_dynamic()).unwrap();
                            let at = w.bodies[body].position + glam::Vec2::new(0.1, 0.0);
                            let m = w.grab_index(body, at);
                            w.set_mouse(m);
                        }
                        if i == 60 {
                            w.set_mouse(None);
                        }
                        if i == 90 {
                            for j in &mut w.joints {
                                if let Some(m) = &mut j.motor {
                                    m.speed = 1.0 - 2.0 * m.speed;
                                }
                                if let Some(l) = &mut j.limits {
                                    *l = [0.5 * l[0], 0.5 * l[1]];
                                }
                                if let Some(sp) = &mut j.spring {
                                    sp.hertz *= 2.0;
                                }
                            }
                        }
                        w.step().unwrap();
                        w.state_hash()
                    })
                    .collect();
                super::testing::fresh_joint_layout(false);
                hashes
            };
            let (fresh, kept) = (run(true), run(false));
            let first = fresh.iter().zip(&kept).position(|(a, b)| a != b);
            assert_eq!(first, None, "{name}: the first step that differs");
        }
    }

    /// A built-in scene, or `humans`: six of Box2D's ragdolls dropped on a ground.
    fn scene_for_lanes(name: &str) -> crate::scene::Scene {
        if name != "humans" {
            return crate::scene::load(name).unwrap();
        }
        let text = "name = \"h\"\n[world]\ngravity = [0.0, -10.0]\n\
            [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [40.0, 2.0] }\nposition = [0.0, -1.0]\n\
            [[humans]]\norigin = [-3.0, 1.0]\ncount = 3\nspacing = [1.0, 0.0]\n\
            [[humans]]\norigin = [-3.0, 3.5]\ncount = 3\nspacing = [1.0, 0.0]\ngroup = 4\n";
        crate::scene::load_str(text, "humans.toml").unwrap()
    }

    #[test]
    fn hinges_in_lanes_give_the_bits_of_hinges_one_by_one() {
        // the ragdoll (hinges with limits), the joints scene (a motor, limits, a servo,
        // a prismatic and a weld beside them), a chain and the joint grid: the same state
        // after every step whether the hinges take lanes or the scalar rows
        for name in [
            "ragdoll",
            "joints",
            "chain",
            "joint_grid",
            "car",
            "bridge",
            "humans",
        ] {
            // (the car's joints are wheels, the joints scene's hinges have servos or
            // motors beside other kinds: some of them take lanes, some not; the humans'
            // hinges have springs, joint friction and limits)
            let sc = scene_for_lanes(name);
            let run = |lanes: bool| {
                super::testing::no_hinge_lanes(!lanes);
                let mut w = crate::World::from_def(&sc.world, sc.world.solver.resolve()).unwrap();
                let steps = if name == "joint_grid" { 10 } else { 90 };
                let hashes: Vec<u64> = (0..steps)
                    .map(|_| {
                        w.step().unwrap();
                        w.state_hash()
                    })
                    .collect();
                super::testing::no_hinge_lanes(false);
                let st = w.stepper_as::<crate::step::soft::SoftStepper>().unwrap();
                (hashes, st.soft.hinges.len())
            };
            let (one_by_one, none) = run(false);
            let (laned, wide) = run(true);
            assert_eq!(none, 0, "{name}: no lanes when told");
            if name != "car" {
                assert!(wide > 0, "{name}: hinges in lanes");
            }
            // (compared step by step; the first step that differs is named)
            let first = one_by_one.iter().zip(&laned).position(|(a, b)| a != b);
            assert_eq!(first, None, "{name}: the first step that differs");
        }
    }

    #[test]
    fn a_hinged_grid_on_two_threads_runs_ahead_with_the_bits_of_one() {
        // 30 x 30 circles on hinges, hanging from two corners, beside a pyramid of 120
        // boxes: wide hinges and contacts in the same colours. On two threads each runs
        // ahead into the next colour, each thread's share writing its own half of the
        // grid; the state is the one thread's after every step
        let text = "name = \"grid\"\n[world]\ngravity = [0.0, -10.0]\n\
                    [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [200.0, 2.0] }\nposition = [0.0, -1.0]\n\
                    [[pyramid]]\nbase = 15\n\
                    [[grid]]\nrows = 30\ncolumns = 30\nspacing = [1.0, 1.0]\norigin = [20.0, 5.0]\n\
                    shape = { circle = 0.4 }\njoints = \"hinge\"\nstatic_cells = [[29, 0], [29, 29]]\n\
                    filter = { group = -1 }\n";
        let sc = crate::scene::load_str(text, "grid.toml").unwrap();
        let run = |threads: usize| {
            let mut w = crate::World::from_def(&sc.world, sc.world.solver.resolve()).unwrap();
            w.set_threads(threads);
            let hashes: Vec<u64> = (0..30)
                .map(|_| {
                    w.step().unwrap();
                    w.state_hash()
                })
                .collect();
            let st = w.stepper_as::<crate::step::soft::SoftStepper>().unwrap();
            let s = &st.soft;
            (
                hashes,
                s.runs_ahead(threads),
                s.share_bodies.clone(),
                s.hinges.len(),
            )
        };
        let (one, ahead_one, _, _) = run(1);
        let (two, ahead_two, shares, wide) = run(2);
        assert!(!ahead_one);
        assert!(wide > 0, "hinges in lanes");
        assert!(ahead_two, "two threads run ahead");
        // (the hinges' bodies come after the pyramid's: the second share's reach the last)
        let (first, second) = (shares[0], shares[1]);
        assert!(first.0 <= first.1 && second.0 <= second.1, "{shares:?}");
        assert!(first.1 < second.1 && first.0 < second.0, "{shares:?}");
        let first_step = one.iter().zip(&two).position(|(a, b)| a != b);
        assert_eq!(first_step, None, "the first step that differs");
    }

    #[test]
    fn a_lopsided_pair_is_never_missed_by_the_mass_range() {
        // blocks of bodies fold their ranges; any pair of them that is lopsided finds
        // the range saying it may be, and a range of close masses rules every pair out
        let masses = [0.5f32, 0.051, 0.0501, 5.0, 0.49, 0.0, 7.9, 1e-30, 1e30];
        let shared = SharedMassRange::new();
        // (blocks on three threads, some running more than one block)
        for (i, block) in masses.chunks(2).enumerate() {
            let mut r = MassRange::default();
            for &m in block {
                r.add(true, m);
            }
            r.add(false, 1e6); // a body that does not move does not count
            r.publish(&shared, i % 3);
        }
        let range = shared.get();
        assert_eq!(range, (1e-30f32.to_bits(), 1e30f32.to_bits()));
        for &a in &masses {
            for &b in &masses {
                let mut r = MassRange::default();
                r.add(true, a);
                r.add(true, b);
                if is_lopsided(a, b) {
                    assert!(may_be_lopsided((r.least, r.most)), "{a} {b}");
                    assert!(may_be_lopsided(range));
                }
            }
        }
        // masses within a factor 10: no pair is lopsided, and the range says so
        let mut r = MassRange::default();
        for m in [0.5f32, 0.051, 0.4999, 0.1] {
            r.add(true, m);
        }
        assert!(!may_be_lopsided((r.least, r.most)));
        assert!(may_be_lopsided((0.05f32.to_bits(), 0.5f32.to_bits())));
        let none = MassRange::default();
        assert!(!may_be_lopsided((none.least, none.most)));
    }

    #[test]
    fn softness_has_the_closed_form_of_an_implicit_spring() {
        // a2 a3 + a3 = 1 for every setting; omega / a1 the bias rate; hertz 0 is rigid
        let h = 1.0 / 240.0;
        let s = Softness::new(30.0, 10.0, h);
        let omega = std::f32::consts::TAU * 30.0;
        let a1 = 2.0 * 10.0 + h * omega;
        assert!((s.bias_rate - omega / a1).abs() < 1e-4);
        assert!((s.mass_scale + s.impulse_scale - 1.0).abs() < 1e-6);
        let r = Softness::new(0.0, 10.0, h);
        assert_eq!(
            (r.mass_scale, r.impulse_scale, r.bias_rate),
            (1.0, 0.0, 0.0)
        );
    }

    #[test]
    fn a_resting_box_is_held_by_its_weight_each_substep() {
        // at rest the contact carries m g h per substep: 1 kg, g 10, h = dt / 8
        let mut w = resting_box(SolverKind::Soft);
        for _ in 0..120 {
            w.step().unwrap();
        }
        let h = w.settings.dt / w.settings.substeps as f32;
        let sum = normal_sum(&w);
        assert!(
            (sum - 10.0 * h).abs() < 0.01 * 10.0 * h,
            "{sum} vs {}",
            10.0 * h
        );
        assert!(w.bodies[1].velocity.length() < 1e-3);
    }

    #[test]
    fn restitution_keeps_only_the_lanes_whose_points_approach_past_the_threshold() {
        // two balls of restitution 0.8 (sleep off): one resting on the ground, whose
        // contact approaches at g dt a step (below the 1 m/s threshold), and one dropped
        // from 5 m, which lands at about 10 m/s
        let sc = crate::scene::load_str(
            "name = \"two\"\n[world]\ngravity = [0.0, -10.0]\n[solver]\nsleep = false\n\
             [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [20.0, 1.0] }\nposition = [0.0, -0.5]\nrestitution = 0.8\n\
             [[body]]\nname = \"resting\"\nshape = { circle = 0.5 }\nposition = [-5.0, 0.5]\nrestitution = 0.8\n\
             [[body]]\nname = \"dropped\"\nshape = { circle = 0.5 }\nposition = [5.0, 5.5]\nrestitution = 0.8\n",
            "two.toml",
        )
        .unwrap();
        let mut w = crate::World::from_def(&sc.world, SolverSettings::soft()).unwrap();
        let kept = |w: &crate::World| {
            let st = w.stepper_as::<crate::step::soft::SoftStepper>();
            st.expect("a soft stepper").soft.restitution
        };
        // the dropped ball is still 3.75 m up after half a second: only the resting
        // ball's contact is in the step, and restitution leaves it be
        for _ in 0..30 {
            w.step().unwrap();
            assert!(!w.contacts().is_empty());
            assert!(!kept(&w), "no point approaches past the threshold");
        }
        // the landing: the lanes of the step that meets the ground keep restitution,
        // and the ball leaves at e times its landing speed
        let (mut landing, mut kept_some) = (0.0f32, false);
        for _ in 0..60 {
            let before = w.bodies[2].velocity.y;
            w.step().unwrap();
            kept_some |= kept(&w);
            if before < -5.0 && w.bodies[2].velocity.y > 0.0 {
                landing = -before;
                break;
            }
        }
        assert!(kept_some, "the landing's lane keeps its restitution");
        assert!(landing > 9.0, "landed at {landing} m/s");
        let up = w.bodies[2].velocity.y;
        assert!(
            (up / landing - 0.8).abs() < 0.05,
            "left at {up} m/s after landing at {landing}"
        );
    }
}
