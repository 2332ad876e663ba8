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
use super::pgs::SolveStats;
use crate::body::Body;
use crate::body::HOT_BYTES;
use crate::defs::{BodyModel, BodyType, SolverSettings};
use crate::math::{BODY_AHEAD, Rot, Vec2, cross, cross_sv, prefetch, uf_root, uf_union};
use crate::parallel::{self, Disjoint, MAX_THREADS, Pool};
use glam::Vec4;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU32, Ordering};

mod direct;
mod lanes;

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
    }

    /// `true`: the sweeps and the warm start run their SSE build even on a CPU with AVX2.
    pub fn force_sse(on: bool) {
        FORCE_SSE.with(|c| c.set(on));
    }

    /// `true`: every contact gets a wide constraint of its own (lane 0, the rest empty),
    /// as the overflow colour does: a one-by-one solve, colour by colour, in the order
    /// the packed lanes take.
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

/// Whether a contact between two moving bodies of inverse masses `ia` and `ib` joins
/// masses `direct::MASS_RATIO` apart or more.
#[inline(always)]
fn is_lopsided(ia: f32, ib: f32) -> bool {
    // max(ia / ib, ib / ia) is the larger over the smaller (division rounds monotonically)
    ia > 0.0 && ib > 0.0 && ia.max(ib) / ia.min(ib) >= direct::MASS_RATIO
}

/// Whether contact `c` joins two moving bodies (`moves`) whose masses (`inv_mass`) are
/// lopsided.
fn is_lopsided_contact(c: &Contact, moves: &[bool], inv_mass: &[(f32, f32)]) -> bool {
    let (a, b) = (c.a as usize, c.b as usize);
    moves[a] && moves[b] && is_lopsided(inv_mass[a].0, inv_mass[b].0)
}

/// The least and the largest positive 1/m of the moving bodies in one block of a pass
/// over the bodies, as f32 bits (positive floats order as their bits).
#[derive(Clone, Copy)]
struct MassRange {
    least: u32,
    most: u32,
}

impl Default for MassRange {
    fn default() -> Self {
        MassRange {
            least: u32::MAX,
            most: 0,
        }
    }
}

impl MassRange {
    #[inline(always)]
    fn add(&mut self, moves: bool, inv_mass: f32) {
        if moves && inv_mass > 0.0 {
            let bits = inv_mass.to_bits();
            self.least = self.least.min(bits);
            self.most = self.most.max(bits);
        }
    }

    /// Folds this block's range into the pass's, as thread `t` of the pass's job (the
    /// blocks of one thread run one after another).
    fn publish(self, to: &SharedMassRange, t: usize) {
        if self.least <= self.most {
            let slot = &to.0[t];
            let (least, most) = (
                slot.0.load(Ordering::Relaxed),
                slot.1.load(Ordering::Relaxed),
            );
            slot.0.store(least.min(self.least), Ordering::Relaxed);
            slot.1.store(most.max(self.most), Ordering::Relaxed);
        }
    }
}

/// Whether some contact between moving bodies whose positive 1/m lie in `range` (as
/// [`SharedMassRange::get`] gives it) may be lopsided: the larger over the smaller of two
/// such masses is at most the largest over the least (division rounds monotonically).
fn may_be_lopsided((least, most): (u32, u32)) -> bool {
    least <= most && f32::from_bits(most) / f32::from_bits(least) >= direct::MASS_RATIO
}

/// A pass's [`MassRange`], folded from its blocks: per thread of the pass's job, each on
/// a cache line of its own that only that thread writes (one shared pair of counters,
/// folded into with an atomic min and max per block, moved its line between the cores
/// some twenty times a pass).
struct SharedMassRange([ThreadMassRange; MAX_THREADS]);

/// One thread's least and largest 1/m bits.
#[repr(align(64))]
struct ThreadMassRange(AtomicU32, AtomicU32);

impl SharedMassRange {
    fn new() -> Self {
        SharedMassRange(std::array::from_fn(|_| {
            ThreadMassRange(AtomicU32::new(u32::MAX), AtomicU32::new(0))
        }))
    }

    /// (least, most); least > most where no moving body has a positive 1/m.
    fn get(&self) -> (u32, u32) {
        self.0.iter().fold((u32::MAX, 0), |(least, most), t| {
            (
                least.min(t.0.load(Ordering::Relaxed)),
                most.max(t.1.load(Ordering::Relaxed)),
            )
        })
    }
}

/// What restitution and the cache need, kept out of the sweeps' way.
#[derive(Clone, Copy, Debug, Default)]
struct WideCold {
    restitution: Vec4,
    /// relative normal velocity of each point before the step, for restitution
    relative_velocity: [Vec4; 2],
    /// points per lane (0 for an empty lane)
    count: [u8; 4],
}

/// Colour of a constraint no colour was free for: it gets a wide constraint to itself.
const OVERFLOW: usize = 64;

/// What [`color_contacts`] counted.
struct Colored {
    /// Contacts per colour.
    counts: [u32; OVERFLOW + 1],
    /// Contact points.
    points: usize,
    /// Whether some contact is lopsided (looked for only where masses were given).
    lopsided: bool,
}

/// Greedy colouring, in contact order: each contact takes the lowest colour neither of
/// its moving bodies (`moves`) uses yet, [`OVERFLOW`] where none is free; a body that
/// does not move takes no colour. Writes each contact's colour to `colors`, and to
/// `cut_counts` what each colour had counted at the start of each of the `threads` even
/// runs of the contacts but the first (the layout cuts the colours there). With
/// `inv_mass`, also looks for a lopsided contact (see `SoftSolver::find_direct`): each
/// pass over the contacts reads them from far in the cache.
fn color_contacts(
    contacts: &[Contact],
    moves: &[bool],
    inv_mass: Option<&[(f32, f32)]>,
    threads: usize,
    body_colors: &mut Vec<u64>,
    colors: &mut Vec<u8>,
    cut_counts: &mut Vec<[u32; OVERFLOW + 1]>,
) -> Colored {
    body_colors.clear();
    body_colors.resize(moves.len(), 0);
    colors.resize(contacts.len(), 0);
    cut_counts.clear();
    let mut counts = [0u32; OVERFLOW + 1];
    let (mut points, mut lopsided) = (0usize, false);
    // plain slices, so the loop keeps its pointers in registers
    let body_colors = &mut body_colors[..];
    for k in 0..threads {
        if k > 0 {
            cut_counts.push(counts);
        }
        let run = parallel::split(contacts.len(), threads, k);
        for (c, out) in contacts[run.clone()].iter().zip(&mut colors[run]) {
            let (a, b) = (c.a as usize, c.b as usize);
            let (ma, mb) = (moves[a], moves[b]);
            points += c.manifold.count;
            if let Some(inv_mass) = inv_mass
                && ma
                && mb
            {
                lopsided |= is_lopsided(inv_mass[a].0, inv_mass[b].0);
            }
            let used =
                (if ma { body_colors[a] } else { 0 }) | (if mb { body_colors[b] } else { 0 });
            let color = (!used).trailing_zeros() as usize;
            if color < OVERFLOW {
                let bit = 1u64 << color;
                if ma {
                    body_colors[a] |= bit;
                }
                if mb {
                    body_colors[b] |= bit;
                }
            }
            counts[color] += 1;
            *out = color as u8;
        }
    }
    Colored {
        counts,
        points,
        lopsided,
    }
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

/// Bodies' states, transposed: lane k holds body k.
struct WideBody<L = Vec4> {
    vx: L,
    vy: L,
    w: L,
    /// kept only to be written back unchanged with the velocities
    dtheta: L,
    dpx: L,
    dpy: L,
    qc: L,
    qs: L,
}

impl WideBody {
    /// Loads four bodies (two 16-byte loads each) and transposes them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn gather(bodies: BodyPtr, idx: &[u32; 4]) -> WideBody {
        use std::arch::x86_64::*;
        let rows = idx.map(|i| {
            let p = bodies.at(i) as *const f32;
            // SAFETY: SoftBody is repr(C, align(32)): eight f32, so both 16-byte loads
            // stay inside the body and are aligned (SSE2 is part of x86_64); `at` checks
            // the index in debug builds, and no other thread writes this body now
            // (BodyPtr).
            unsafe { (_mm_load_ps(p), _mm_load_ps(p.add(4))) }
        });
        let (v, d) = (
            transpose4([rows[0].0, rows[1].0, rows[2].0, rows[3].0]),
            transpose4([rows[0].1, rows[1].1, rows[2].1, rows[3].1]),
        );
        WideBody {
            vx: v[0].into(),
            vy: v[1].into(),
            w: v[2].into(),
            dtheta: v[3].into(),
            dpx: d[0].into(),
            dpy: d[1].into(),
            qc: d[2].into(),
            qs: d[3].into(),
        }
    }

    /// Writes v, w and the unchanged dtheta of four bodies (one 16-byte store each).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn scatter_velocities<const SHARED: bool>(
        vx: Vec4,
        vy: Vec4,
        w: Vec4,
        dtheta: Vec4,
        bodies: BodyPtr,
        idx: &[u32; 4],
    ) {
        use std::arch::x86_64::*;
        let rows = transpose4([vx.into(), vy.into(), w.into(), dtheta.into()]);
        for k in 0..4 {
            let p = bodies.written::<SHARED>(idx[k]) as *mut f32;
            // SAFETY: as in gather; the first four f32 are v, w, dtheta.
            unsafe { _mm_store_ps(p, rows[k]) };
        }
    }

    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    fn gather(bodies: BodyPtr, idx: &[u32; 4]) -> WideBody {
        // SAFETY: as in the x86_64 build.
        let [s0, s1, s2, s3] = idx.map(|i| unsafe { *bodies.at(i) });
        WideBody {
            vx: Vec4::new(s0.v.x, s1.v.x, s2.v.x, s3.v.x),
            vy: Vec4::new(s0.v.y, s1.v.y, s2.v.y, s3.v.y),
            w: Vec4::new(s0.w, s1.w, s2.w, s3.w),
            dtheta: Vec4::new(s0.dtheta, s1.dtheta, s2.dtheta, s3.dtheta),
            dpx: Vec4::new(s0.dp.x, s1.dp.x, s2.dp.x, s3.dp.x),
            dpy: Vec4::new(s0.dp.y, s1.dp.y, s2.dp.y, s3.dp.y),
            qc: Vec4::new(s0.dq.c, s1.dq.c, s2.dq.c, s3.dq.c),
            qs: Vec4::new(s0.dq.s, s1.dq.s, s2.dq.s, s3.dq.s),
        }
    }

    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    fn scatter_velocities<const SHARED: bool>(
        vx: Vec4,
        vy: Vec4,
        w: Vec4,
        _dtheta: Vec4,
        bodies: BodyPtr,
        idx: &[u32; 4],
    ) {
        let (vx, vy, w) = (vx.to_array(), vy.to_array(), w.to_array());
        for k in 0..4 {
            // SAFETY: as in the x86_64 build.
            let s = unsafe { &mut *bodies.written::<SHARED>(idx[k]) };
            s.v = Vec2::new(vx[k], vy[k]);
            s.w = w[k];
        }
    }
}

/// The 4x4 transpose of four SSE rows.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn transpose4(r: [std::arch::x86_64::__m128; 4]) -> [std::arch::x86_64::__m128; 4] {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of x86_64.
    unsafe {
        let t0 = _mm_unpacklo_ps(r[0], r[1]);
        let t1 = _mm_unpacklo_ps(r[2], r[3]);
        let t2 = _mm_unpackhi_ps(r[0], r[1]);
        let t3 = _mm_unpackhi_ps(r[2], r[3]);
        [
            _mm_movelh_ps(t0, t1),
            _mm_movehl_ps(t1, t0),
            _mm_movelh_ps(t2, t3),
            _mm_movehl_ps(t3, t2),
        ]
    }
}

/// The velocities of a group's bodies, loaded once and stored once.
struct PairVel<L> {
    vax: L,
    vay: L,
    wa: L,
    vbx: L,
    vby: L,
    wb: L,
}

/// A point's anchors (from A's and B's centres, at collide), as lanes.
struct Anchors<L> {
    rax: L,
    ray: L,
    rbx: L,
    rby: L,
}

/// Inverse masses and inertias of a group's bodies, as lanes.
struct InvMass<L> {
    ima: L,
    iia: L,
    imb: L,
    iib: L,
}

impl<L: Lanes> PairVel<L> {
    /// (vb + wb x rb - va - wa x ra) . d, with w x r = (-w r.y, w r.x)
    #[inline(always)]
    fn along(&self, p: &Anchors<L>, dx: L, dy: L) -> L {
        let dvx = self.vbx - self.wb * p.rby - self.vax + self.wa * p.ray;
        let dvy = self.vby + self.wb * p.rbx - self.vay - self.wa * p.rax;
        dvx * dx + dvy * dy
    }

    /// v -= P/mA, w -= (ra x P)/IA; v += P/mB, w += (rb x P)/IB
    #[inline(always)]
    fn apply(&mut self, m: &InvMass<L>, p: &Anchors<L>, px: L, py: L) {
        self.vax = self.vax - m.ima * px;
        self.vay = self.vay - m.ima * py;
        self.wa = self.wa - m.iia * (p.rax * py - p.ray * px);
        self.vbx = self.vbx + m.imb * px;
        self.vby = self.vby + m.imb * py;
        self.wb = self.wb + m.iib * (p.rbx * py - p.rby * px);
    }
}

/// What [`SoftSolver::for_colors`] runs on a slice of wide constraints: `(thread (None
/// when alone), constraints, all of one colour)`, returning a figure to take the largest of.
type ColorKernel<'a> = dyn Fn(Option<usize>, &mut [WideConstraint], bool) -> f32 + Sync + 'a;

/// The constraints a kernel solves in lock step: one wide constraint (four lanes) or, in
/// the AVX2 build, two of one colour side by side (eight lanes, [`F8`]).
trait Group {
    type L: Lanes;
    /// A field of the constraints, as lanes.
    fn get(&self, f: impl Fn(&WideConstraint) -> Vec4) -> Self::L;
    /// Writes a field of the constraints.
    fn set(&mut self, f: impl Fn(&mut WideConstraint) -> &mut Vec4, v: Self::L);
    /// The states of the bodies A (`B = false`) or B of the lanes.
    fn gather<const B: bool>(&self, bodies: BodyPtr) -> WideBody<Self::L>;
    /// Writes the velocities of the bodies A or B back.
    fn scatter<const B: bool, const SHARED: bool>(
        &self,
        s: &WideBody<Self::L>,
        v: [Self::L; 3],
        bodies: BodyPtr,
    );

    /// The point's anchors.
    #[inline(always)]
    fn anchors(&self, i: usize) -> Anchors<Self::L> {
        Anchors {
            rax: self.get(|c| c.points[i].rax),
            ray: self.get(|c| c.points[i].ray),
            rbx: self.get(|c| c.points[i].rbx),
            rby: self.get(|c| c.points[i].rby),
        }
    }

    #[inline(always)]
    fn inv_mass(&self) -> InvMass<Self::L> {
        InvMass {
            ima: self.get(|c| c.m.ima),
            iia: self.get(|c| c.m.iia),
            imb: self.get(|c| c.m.imb),
            iib: self.get(|c| c.m.iib),
        }
    }

    /// Both sides' velocities.
    #[inline(always)]
    fn velocities(sa: &WideBody<Self::L>, sb: &WideBody<Self::L>) -> PairVel<Self::L> {
        PairVel {
            vax: sa.vx,
            vay: sa.vy,
            wa: sa.w,
            vbx: sb.vx,
            vby: sb.vy,
            wb: sb.w,
        }
    }

    /// Writes both sides' velocities back.
    #[inline(always)]
    fn store<const SHARED: bool>(
        &self,
        sa: &WideBody<Self::L>,
        sb: &WideBody<Self::L>,
        v: &PairVel<Self::L>,
        bodies: BodyPtr,
    ) {
        self.scatter::<false, SHARED>(sa, [v.vax, v.vay, v.wa], bodies);
        self.scatter::<true, SHARED>(sb, [v.vbx, v.vby, v.wb], bodies);
    }
}

/// One wide constraint: four lanes.
struct One<'a>(&'a mut WideConstraint);

impl Group for One<'_> {
    type L = Vec4;
    #[inline(always)]
    fn get(&self, f: impl Fn(&WideConstraint) -> Vec4) -> Vec4 {
        f(self.0)
    }
    #[inline(always)]
    fn set(&mut self, f: impl Fn(&mut WideConstraint) -> &mut Vec4, v: Vec4) {
        *f(self.0) = v;
    }
    #[inline(always)]
    fn gather<const B: bool>(&self, bodies: BodyPtr) -> WideBody<Vec4> {
        WideBody::gather(bodies, if B { &self.0.b } else { &self.0.a })
    }
    #[inline(always)]
    fn scatter<const B: bool, const SHARED: bool>(
        &self,
        s: &WideBody<Vec4>,
        [vx, vy, w]: [Vec4; 3],
        bodies: BodyPtr,
    ) {
        let idx = if B { &self.0.wb } else { &self.0.wa };
        WideBody::<Vec4>::scatter_velocities::<SHARED>(vx, vy, w, s.dtheta, bodies, idx);
    }
}

/// Two wide constraints of one colour: eight lanes (AVX2).
#[cfg(target_arch = "x86_64")]
struct Two<'a>(&'a mut WideConstraint, &'a mut WideConstraint);

#[cfg(target_arch = "x86_64")]
impl Group for Two<'_> {
    type L = F8;
    #[inline(always)]
    fn get(&self, f: impl Fn(&WideConstraint) -> Vec4) -> F8 {
        F8::join(f(self.0), f(self.1))
    }
    #[inline(always)]
    fn set(&mut self, f: impl Fn(&mut WideConstraint) -> &mut Vec4, v: F8) {
        let (lo, hi) = v.split();
        *f(self.0) = lo;
        *f(self.1) = hi;
    }
    /// Loads eight bodies as four rows (lane k's body in the low half, lane k + 4's in
    /// the high half: one load and one insert) and transposes each half in place: the
    /// lanes [`WideBody::gather`] and [`F8::join`] give, in fewer shuffles.
    #[inline(always)]
    fn gather<const B: bool>(&self, bodies: BodyPtr) -> WideBody<F8> {
        let (lo, hi) = if B {
            (self.0.b, self.1.b)
        } else {
            (self.0.a, self.1.a)
        };
        // (no closures here: one not inlined would be compiled without AVX)
        let (v, d) = (
            transpose4x2([
                row2(bodies, lo[0], hi[0], 0),
                row2(bodies, lo[1], hi[1], 0),
                row2(bodies, lo[2], hi[2], 0),
                row2(bodies, lo[3], hi[3], 0),
            ]),
            transpose4x2([
                row2(bodies, lo[0], hi[0], 4),
                row2(bodies, lo[1], hi[1], 4),
                row2(bodies, lo[2], hi[2], 4),
                row2(bodies, lo[3], hi[3], 4),
            ]),
        );
        WideBody {
            vx: F8::from_raw(v[0]),
            vy: F8::from_raw(v[1]),
            w: F8::from_raw(v[2]),
            dtheta: F8::from_raw(v[3]),
            dpx: F8::from_raw(d[0]),
            dpy: F8::from_raw(d[1]),
            qc: F8::from_raw(d[2]),
            qs: F8::from_raw(d[3]),
        }
    }
    /// Transposes v, w and the unchanged dtheta back into rows, as `gather` loads them,
    /// and stores each half (one 16-byte store per body).
    #[inline(always)]
    fn scatter<const B: bool, const SHARED: bool>(
        &self,
        s: &WideBody<F8>,
        [vx, vy, w]: [F8; 3],
        bodies: BodyPtr,
    ) {
        use std::arch::x86_64::*;
        let (lo, hi) = if B {
            (self.0.wb, self.1.wb)
        } else {
            (self.0.wa, self.1.wa)
        };
        let rows = transpose4x2([vx.raw(), vy.raw(), w.raw(), s.dtheta.raw()]);
        for k in 0..4 {
            let (p, q) = (
                bodies.written::<SHARED>(lo[k]) as *mut f32,
                bodies.written::<SHARED>(hi[k]) as *mut f32,
            );
            // SAFETY: as in `WideBody::scatter_velocities`; AVX as in `gather`.
            unsafe {
                _mm_store_ps(p, _mm256_castps256_ps128(rows[k]));
                _mm_store_ps(q, _mm256_extractf128_ps::<1>(rows[k]));
            }
        }
    }
}

/// Row `off..off + 4` of bodies `lo` (low half) and `hi` (high half).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn row2(bodies: BodyPtr, lo: u32, hi: u32, off: usize) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    let (p, q) = (bodies.at(lo) as *const f32, bodies.at(hi) as *const f32);
    // SAFETY: as in `WideBody::gather` (aligned 16-byte loads inside each body); AVX:
    // reached only from the sweeps' AVX2 functions (see `F8`).
    unsafe {
        _mm256_insertf128_ps::<1>(
            _mm256_castps128_ps256(_mm_load_ps(p.add(off))),
            _mm_load_ps(q.add(off)),
        )
    }
}

/// [`transpose4`] in each 128-bit half of four AVX rows (the in-lane forms of the same
/// unpacks and moves).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn transpose4x2(r: [std::arch::x86_64::__m256; 4]) -> [std::arch::x86_64::__m256; 4] {
    use std::arch::x86_64::*;
    // SAFETY: AVX: reached only from the sweeps' AVX2 functions (see `F8`).
    unsafe {
        let t0 = _mm256_unpacklo_ps(r[0], r[1]);
        let t1 = _mm256_unpacklo_ps(r[2], r[3]);
        let t2 = _mm256_unpackhi_ps(r[0], r[1]);
        let t3 = _mm256_unpackhi_ps(r[2], r[3]);
        // shuffle 0x44: (a0, a1, b0, b1), as movelh; 0xEE: (a2, a3, b2, b3), as movehl
        // with its operands swapped
        [
            _mm256_shuffle_ps::<0x44>(t0, t1),
            _mm256_shuffle_ps::<0xEE>(t0, t1),
            _mm256_shuffle_ps::<0x44>(t2, t3),
            _mm256_shuffle_ps::<0xEE>(t2, t3),
        ]
    }
}

/// The soft-step contact solver and its reusable buffers.
#[derive(Clone, Default, Debug)]
pub struct SoftSolver {
    /// Every body's state, by body index; then slots of the solver's own: a body at rest
    /// that empty lanes read, and one sink per thread that writes of unmoved bodies go to.
    pub bodies: Vec<SoftBody>,
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
    /// The phases of `substeps_in_one_job`, in order: what each does (scratch).
    fused: Vec<(Pass, u8)>,
    /// Per thread's share of the colours: the least and the largest body it writes
    /// (least > largest for none), from the fill.
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
    /// Whether the last `prepare_integrating` coloured the contacts beside its load pass.
    colored_beside_load: bool,
}

impl SoftSolver {
    /// Builds this step's constraints from the contacts (collided at the step's start)
    /// for substeps of `h`, and loads the bodies. Lambdas start from the cache if warm
    /// starting.
    pub fn prepare(
        &mut self,
        bodies: &[Body],
        contacts: &[Contact],
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        self.size_bodies(bodies.len());
        self.load_bodies(bodies, pool);
        self.build(bodies.len(), contacts, s, h, pool);
    }

    /// [`SoftSolver::prepare`], with the first substep's forces integrated in the same
    /// pass over the bodies: what `World::integrate_velocities(h)` and then
    /// [`SoftSolver::take_increments`] do, to the same bits, for a world whose only
    /// forces are gravity and each body's own force and torque (no drag, drives or point
    /// forces: the caller checks). One pass over the bodies instead of three.
    ///
    /// `movers`, where the caller has it: whether each body is dynamic, as the solver's
    /// own load pass finds it. With threads, one of them then colours the contacts while
    /// the others run that pass (the colouring reads no body), instead of after it.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare_integrating(
        &mut self,
        bodies: &mut [Body],
        contacts: &[Contact],
        movers: Option<&[bool]>,
        s: &SolverSettings,
        h: f32,
        gravity: Option<Vec2>,
        pool: Option<&Pool>,
    ) {
        let nb = bodies.len();
        self.size_bodies(nb);
        self.increments.resize(nb, (Vec2::ZERO, 0.0));
        let (soft, moves) = (
            Disjoint::new(&mut self.bodies[..nb]),
            Disjoint::new(&mut self.moves),
        );
        let inv_mass = Disjoint::new(&mut self.inv_mass);
        let increments = Disjoint::new(&mut self.increments);
        let all = Disjoint::new(bodies);
        let shared_range = SharedMassRange::new();
        let load = |t: usize, r: std::ops::Range<usize>| {
            // SAFETY: each block takes only its own range of each slice
            let (soft, moves, inv_mass, increments, bodies) = unsafe {
                (
                    soft.range(r.clone()),
                    moves.range(r.clone()),
                    inv_mass.range(r.clone()),
                    increments.range(r.clone()),
                    all.range(r),
                )
            };
            let mut range = MassRange::default();
            for i in 0..bodies.len() {
                prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
                let b = &mut bodies[i];
                let (v0, w0) = (b.velocity, b.angular_velocity);
                if b.is_dynamic() && !b.asleep {
                    (b.velocity, b.angular_velocity) = crate::world::free_velocity(b, h, gravity);
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
            let coloring = Mutex::new((
                &mut self.body_colors,
                &mut self.colors,
                &mut self.cut_lanes,
                None,
            ));
            parallel::blocks_max(pool, 1 + nb.div_ceil(BODY_PASS_BLOCK), &|t, b| {
                if b > 0 {
                    let at = (b - 1) * BODY_PASS_BLOCK;
                    return load(t, at..(at + BODY_PASS_BLOCK).min(nb));
                }
                let mut c = coloring.lock().unwrap_or_else(|e| e.into_inner());
                let (body_colors, colors, cut_lanes, found) = &mut *c;
                *found = Some(color_contacts(
                    contacts,
                    movers,
                    None,
                    threads,
                    body_colors,
                    colors,
                    cut_lanes,
                ));
                0.0
            });
            let found = coloring.into_inner().unwrap_or_else(|e| e.into_inner()).3;
            let mut found = found.expect("the colouring block ran");
            self.inv_mass_range = shared_range.get();
            if may_be_lopsided(self.inv_mass_range) {
                // (the masses were not loaded yet when the contacts were coloured)
                let (moves, inv_mass) = (&self.moves, &self.inv_mass);
                found.lopsided = contacts
                    .iter()
                    .any(|c| is_lopsided_contact(c, moves, inv_mass));
            }
            self.build_colored(nb, contacts, found, s, h, Some(pool));
        } else {
            parallel::ranges_max(pool, nb, BODY_PASS_BLOCK, &load);
            self.inv_mass_range = shared_range.get();
            self.build(nb, contacts, s, h, pool);
        }
        // then take the new velocities and keep their increments, as take_increments
        // does (a pass over the solver's own small arrays)
        let n = self.increments.len();
        parallel::chunks_mut2(
            pool,
            &mut self.bodies[..n],
            &mut self.increments,
            BODY_BLOCK,
            &|_, _, soft, increments| {
                for (s, inc) in soft.iter_mut().zip(increments) {
                    let (v, w) = *inc;
                    take_velocity(s, inc, v, w);
                }
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
        // one pass over the bodies (large: each read is a cache miss on a big scene),
        // split between the threads
        parallel::chunks_mut3(
            pool,
            &mut self.bodies[..nb],
            &mut self.moves[..],
            &mut self.inv_mass[..],
            BODY_PASS_BLOCK,
            &|t, offset, soft, moves, inv_mass| {
                let bodies = &bodies[offset..];
                let mut range = MassRange::default();
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
                range.publish(&shared_range, t);
                0.0
            },
        );
        self.inv_mass_range = shared_range.get();
    }

    /// The rest of [`SoftSolver::prepare`], once the bodies are loaded: colours the
    /// contacts and builds the wide constraints.
    fn build(
        &mut self,
        nb: usize,
        contacts: &[Contact],
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        let threads = pool.map_or(1, Pool::threads);
        let may_lopsided = may_be_lopsided(self.inv_mass_range);
        let found = color_contacts(
            contacts,
            &self.moves,
            may_lopsided.then_some(&self.inv_mass[..]),
            threads,
            &mut self.body_colors,
            &mut self.colors,
            &mut self.cut_lanes,
        );
        self.build_colored(nb, contacts, found, s, h, pool);
    }

    /// The rest of [`SoftSolver::build`], once the contacts are coloured (`found`, and
    /// `colors`, `cut_lanes` as [`color_contacts`] leaves them): lays the constraints out
    /// colour by colour and fills them.
    fn build_colored(
        &mut self,
        nb: usize,
        contacts: &[Contact],
        found: Colored,
        s: &SolverSettings,
        h: f32,
        pool: Option<&Pool>,
    ) {
        self.inv_h = 1.0 / h;
        self.slop = s.slop;
        self.max_push = s.max_push_speed;
        self.restitution = false;
        let (rest, sink) = (nb as u32, nb as u32 + 1);
        let one_lane = testing::ONE_LANE.with(std::cell::Cell::get);
        let Colored {
            counts,
            points,
            lopsided,
        } = found;
        self.colors_used = counts.iter().filter(|&&n| n > 0).count();
        // first lane of each colour; a colour starts on a fresh wide constraint, and an
        // overflow constraint has one to itself
        let step = |color: usize| if color == OVERFLOW || one_lane { 4 } else { 1 };
        let mut next = [0u32; OVERFLOW + 1];
        let mut acc = 0u32;
        self.color_ranges.clear();
        for (color, (nx, &n)) in next.iter_mut().zip(&counts).enumerate() {
            *nx = acc;
            acc += if step(color) == 4 {
                4 * n
            } else {
                n.div_ceil(4) * 4
            };
            if color < OVERFLOW && n > 0 {
                self.color_ranges.push((*nx / 4, acc / 4));
            }
        }
        let n_wide = (acc / 4) as usize;
        // with threads, each takes an equal run of the contacts in contact order (which
        // follows the bodies' order: pairs are found and kept sorted) from every colour:
        // the lane each colour had reached at the contacts' quantiles (counted by the
        // colouring) is where it is cut, and where that thread's run starts laying out
        let threads = pool.map_or(1, Pool::threads);
        for counted in &mut self.cut_lanes {
            for (color, (lane, &start)) in counted.iter_mut().zip(&next).enumerate() {
                *lane = start + *lane * step(color);
            }
        }
        // where each contact goes, and which contact each lane holds
        self.slot.resize(contacts.len(), 0);
        self.lane_contact.clear();
        self.lane_contact.resize(n_wide * 4, u32::MAX);
        {
            let (colors, cut_lanes) = (&self.colors[..], &self.cut_lanes[..]);
            let (slots, lanes) = (
                Disjoint::new(&mut self.slot[..]),
                Disjoint::new(&mut self.lane_contact[..]),
            );
            // run k of the contacts, from the lanes each colour had reached there
            let lay_out = |k: usize| {
                let run = parallel::split(contacts.len(), threads, k);
                let mut at = if k == 0 { next } else { cut_lanes[k - 1] };
                // SAFETY: the runs tile the contacts, and the lanes a run fills are its
                // own: from each colour's lane at the run's start to the next run's
                let slot = unsafe { slots.range(run.clone()) };
                for ((i, &color), out) in run.clone().zip(&colors[run]).zip(slot) {
                    let lane = &mut at[color as usize];
                    *out = *lane;
                    // SAFETY: as above
                    unsafe { lanes.set(*lane as usize, i as u32) };
                    *lane += step(color as usize);
                }
                0.0
            };
            match pool {
                Some(pool) if threads > 1 && contacts.len() >= PARALLEL_LAYOUT => {
                    parallel::blocks_max(pool, threads, &|_, k| lay_out(k));
                }
                _ => {
                    for k in 0..threads {
                        lay_out(k);
                    }
                }
            }
        }
        self.cut_colors(threads, &counts, n_wide as u32);
        self.points = points;
        self.find_direct(contacts, lopsided);
        // rigid contacts soften to a quarter of the substep rate at most; against a body
        // that does not move, twice as stiff
        let hertz = s.contact_hertz.min(0.25 * self.inv_h);
        let soft_dynamic = Softness::new(hertz, s.contact_damping_ratio, h);
        let soft_static = Softness::new(2.0 * hertz, s.contact_damping_ratio, h);
        let omega = 2.0 * std::f32::consts::PI * hertz;

        // every wide constraint is written whole below: old contents do not matter
        self.wide.resize(n_wide, WideConstraint::empty(rest, sink));
        self.cold.resize(n_wide, WideCold::default());
        let fill = Fill {
            contacts,
            lane_contact: &self.lane_contact,
            bodies: &self.bodies,
            inv_mass: &self.inv_mass,
            moves: &self.moves,
            soft_dynamic,
            soft_static,
            omega2_dynamic: omega * omega,
            omega2_static: 4.0 * omega * omega,
            load_scale: 1.0 / (h * s.slop.max(MIN_LOAD_DEPTH)),
            direct: &self.direct_contact,
            warm_start: s.warm_start,
            rest,
            sink,
        };
        // one pass over the contacts builds both halves of each wide constraint
        let fill_range = |offset: usize, wide: &mut [WideConstraint], cold: &mut [WideCold]| {
            let mut any = false;
            for (i, (w, c)) in wide.iter_mut().zip(cold.iter_mut()).enumerate() {
                fill.prefetch(offset + i + PREFETCH_AHEAD);
                fill.wide(offset + i, w);
                // (the flag comes from the lanes as they are written: reading the
                // four back as one vector would wait on the stores)
                let (cold, restitution) = fill.cold(offset + i);
                *c = cold;
                any |= restitution;
            }
            if any { 1.0 } else { 0.0 }
        };
        self.share_bodies.clear();
        let restitution = match pool {
            Some(pool) if threads > 1 && n_wide > WIDE_BLOCK => {
                // each thread fills its share of every colour: the constraints it solves
                let (wide, cold) = (Disjoint::new(&mut self.wide), Disjoint::new(&mut self.cold));
                let blocks = &self.fill_blocks;
                // the bodies each thread's share writes (the fill's blocks are laid out
                // thread by thread, as many for each), for the substeps' job to run ahead:
                // only with two threads (see `substeps_in_one_job`)
                let ranges = threads == 2;
                let per = blocks.len() / threads;
                let written = SharedMassRange::new();
                let r = parallel::blocks_max(pool, blocks.len(), &|_, b| {
                    let r = blocks[b].0 as usize..blocks[b].1 as usize;
                    if r.is_empty() {
                        return 0.0;
                    }
                    // SAFETY: the blocks' ranges do not overlap (see `cut_colors`)
                    let (w, c) = unsafe { (wide.range(r.clone()), cold.range(r.clone())) };
                    let any = fill_range(r.start, w, c);
                    if !ranges {
                        return any;
                    }
                    let (mut least, mut most) = (u32::MAX, 0);
                    for c in w.iter() {
                        for &i in c.wa.iter().chain(&c.wb) {
                            // (a body that does not move is written to a sink)
                            if i < rest {
                                least = least.min(i);
                                most = most.max(i);
                            }
                        }
                    }
                    // (a thread's blocks may run on another thread: shared counters)
                    let slot = &written.0[b / per];
                    slot.0.fetch_min(least, Ordering::Relaxed);
                    slot.1.fetch_max(most, Ordering::Relaxed);
                    any
                });
                if ranges {
                    self.share_bodies.extend(
                        written.0[..threads]
                            .iter()
                            .map(|s| (s.0.load(Ordering::Relaxed), s.1.load(Ordering::Relaxed))),
                    );
                }
                r
            }
            _ => parallel::chunks_mut2(
                pool,
                &mut self.wide,
                &mut self.cold,
                WIDE_BLOCK,
                &|_, offset, wide, cold| fill_range(offset, wide, cold),
            ),
        };
        self.restitution = restitution > 0.0;
        self.build_direct(contacts);
    }

    /// Cuts each colour's wide constraints between `threads` threads where the contacts'
    /// quantiles fell (`cut_lanes`): the lane a colour had reached, rounded up to its
    /// wide constraint. Then lists the fill's blocks of the `n_wide` wide constraints.
    fn cut_colors(&mut self, threads: usize, counts: &[u32; OVERFLOW + 1], n_wide: u32) {
        self.color_cuts.clear();
        self.cut_threads = threads;
        if threads < 2 {
            return;
        }
        // the ranges are the used colours, in order
        let used = (0..OVERFLOW).filter(|&c| counts[c] > 0);
        for (&(start, end), color) in self.color_ranges.iter().zip(used) {
            self.color_cuts.push(start);
            let len = end - start;
            for (k, lanes) in self.cut_lanes.iter().enumerate() {
                // no further than a quarter of the colour from an even cut: a colour
                // whose constraints bunch up (the last, small ones) is still shared. (A
                // tighter bound, a sixteenth, balanced the shares better but moved more
                // bodies between the cores from colour to colour: 1.02 of the time)
                let even = start + (len as usize * (k + 1) / threads) as u32;
                let slack = len / 4;
                let cut = lanes[color].div_ceil(4);
                let lo = even.saturating_sub(slack).max(start);
                let hi = (even + slack).min(end);
                self.color_cuts.push(cut.clamp(lo, hi));
            }
            self.color_cuts.push(end);
        }
        // the fill's blocks: thread t's share of each colour, a block at a time; the
        // overflow group (one constraint per wide constraint, after the colours) goes to
        // the first thread
        let done = self.color_ranges.last().map_or(0, |r| r.1);
        let cuts = &self.color_cuts;
        let shares = |t: usize| {
            let overflow = (t == 0).then_some((done, n_wide));
            cuts.chunks(threads + 1)
                .map(move |c| (c[t], c[t + 1]))
                .chain(overflow)
        };
        let blocks_of = |(a, b): (u32, u32)| (b - a).div_ceil(WIDE_BLOCK as u32) as usize;
        let per = (0..threads)
            .map(|t| shares(t).map(blocks_of).sum::<usize>())
            .max()
            .unwrap_or(0)
            .max(1);
        // room for the most blocks these constraints could make, so that a share grown
        // by a block in a steady step allocates nothing
        self.fill_blocks.clear();
        let colors = self.color_ranges.len() + 1;
        self.fill_blocks
            .reserve(threads * ((n_wide as usize).div_ceil(WIDE_BLOCK) + colors));
        for t in 0..threads {
            let first = self.fill_blocks.len();
            for (a, b) in shares(t) {
                let mut at = a;
                while at < b {
                    let to = (at + WIDE_BLOCK as u32).min(b);
                    self.fill_blocks.push((at, to));
                    at = to;
                }
            }
            let pad = per - (self.fill_blocks.len() - first);
            self.fill_blocks.extend(std::iter::repeat_n((0, 0), pad));
        }
    }

    /// Marks the contacts of islands to solve exactly (`direct`): bodies joined by
    /// contacts between moving bodies, with some contact joining masses
    /// `direct::MASS_RATIO` apart or more, and at most `direct::MAX_POINTS` points.
    /// `any_lopsided`: whether some contact is lopsided (found by the colouring pass).
    fn find_direct(&mut self, contacts: &[Contact], any_lopsided: bool) {
        self.direct_contact.clear();
        self.direct.clear();
        if !any_lopsided {
            return;
        }
        let (moves, inv_mass) = (&self.moves, &self.inv_mass);
        let lopsided = |c: &Contact| is_lopsided_contact(c, moves, inv_mass);
        let nb = self.moves.len();
        self.parent.clear();
        self.parent.extend(0..nb as u32);
        for c in contacts {
            if self.moves[c.a as usize] && self.moves[c.b as usize] {
                uf_union(&mut self.parent, c.a, c.b);
            }
        }
        // per island root: points, and whether some contact is lopsided
        let (points, flagged) = (&mut self.root_points, &mut self.root_flagged);
        points.clear();
        points.resize(nb, 0);
        flagged.clear();
        flagged.resize(nb, false);
        self.roots.clear();
        for c in contacts {
            let body = if self.moves[c.a as usize] { c.a } else { c.b };
            let r = uf_root(&mut self.parent, body);
            points[r as usize] += c.manifold.count as u32;
            flagged[r as usize] |= lopsided(c);
            self.roots.push(r);
        }
        self.direct_contact.extend(
            self.roots
                .iter()
                .map(|&r| flagged[r as usize] && points[r as usize] as usize <= direct::MAX_POINTS),
        );
    }

    /// Builds the exactly solved islands from the filled wide constraints.
    fn build_direct(&mut self, contacts: &[Contact]) {
        if !self.direct_contact.iter().any(|&d| d) {
            return;
        }
        // islands in order of their first contact; lanes in contact order
        let island_of = &mut self.root_points;
        island_of.fill(u32::MAX);
        let mut lanes: Vec<Vec<(u32, u8, u8)>> = Vec::new();
        for (i, c) in contacts.iter().enumerate() {
            if !self.direct_contact[i] {
                continue;
            }
            let r = self.roots[i] as usize;
            let at = self.slot[i];
            let lane = (at / 4, (at % 4) as u8, c.manifold.count as u8);
            if island_of[r] == u32::MAX {
                island_of[r] = lanes.len() as u32;
                lanes.push(Vec::new());
            }
            lanes[island_of[r] as usize].push(lane);
        }
        for l in &lanes {
            self.direct.add_island(l, &self.wide, &self.moves);
        }
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
        self.increments.clear();
        self.increments.resize(n, (Vec2::ZERO, 0.0));
        parallel::chunks_mut2(
            pool,
            &mut self.bodies[..n],
            &mut self.increments,
            BODY_PASS_BLOCK,
            &|_, offset, soft, increments| {
                let bodies = &bodies[offset..];
                for (i, (s, inc)) in soft.iter_mut().zip(increments).enumerate() {
                    prefetch(bodies, i + BODY_AHEAD, HOT_BYTES);
                    let b = &bodies[i];
                    take_velocity(s, inc, b.velocity, b.angular_velocity);
                }
                0.0
            },
        );
    }

    /// Adds the force increments of one substep: v += dv, w += dw.
    pub fn apply_increments(&mut self, pool: Option<&Pool>) {
        let n = self.increments.len();
        let increments = &self.increments[..];
        parallel::chunks_mut(
            pool,
            &mut self.bodies[..n],
            BODY_BLOCK,
            &|_, offset, soft| {
                add_increments(soft, &increments[offset..]);
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
                let (soft, moves) = (&self.bodies[offset..], &self.moves[offset..]);
                let mut bad = false;
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
                    bad |= !crate::world::body_finite(b);
                }
                if bad { 1.0 } else { 0.0 }
            },
        );
        // bodies past the solver's (none in a step) are checked and cleared too
        let mut rest_bad = false;
        for b in &mut bodies[n..] {
            b.force = Vec2::ZERO;
            b.torque = 0.0;
            rest_bad |= !crate::world::body_finite(b);
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

    /// Applies the accumulated lambdas (the last substep's impulses).
    pub fn warm_start(&mut self, pool: Option<&Pool>) {
        let avx2 = use_avx2();
        let bodies = BodyPtr::new(&mut self.bodies, self.sink);
        self.for_colors(pool, &|t, chunk, pairs| {
            match t {
                Some(t) => warm_start_range::<true>(chunk, bodies.for_thread(t), avx2, pairs),
                None => warm_start_range::<false>(chunk, bodies, avx2, pairs),
            }
            0.0
        });
    }

    /// The sweeps' constants for this step.
    fn sweep_consts(&self) -> SweepConsts {
        SweepConsts {
            inv_h: self.inv_h,
            slop: self.slop,
            max_push: self.max_push,
            // the largest normal impulse of each point is read only by restitution: kept
            // only when some contact of the step has restitution
            max_impulse: self.restitution,
            avx2: use_avx2(),
        }
    }

    /// One sweep over every row: with `BIAS`, soft rows that push overlap out; without,
    /// rigid rows that only remove approach speed (relax). Returns max |delta lambda|.
    pub fn sweep<const BIAS: bool>(&mut self, pool: Option<&Pool>) -> f32 {
        let k = self.sweep_consts();
        let bodies = BodyPtr::new(&mut self.bodies, self.sink);
        let r = self.for_colors(pool, &|t, chunk, pairs| match t {
            Some(t) => sweep_range::<BIAS, true>(chunk, bodies.for_thread(t), &k, pairs),
            None => sweep_range::<BIAS, false>(chunk, bodies, &k, pairs),
        });
        if self.direct.is_empty() {
            return r;
        }
        let d = self.direct.solve::<BIAS>(
            &mut self.wide,
            &mut self.bodies,
            self.inv_h,
            self.slop,
            self.max_push,
            self.restitution,
        );
        r.max(d)
    }

    /// Runs `f(thread, constraints, one_colour)` over every wide constraint, colour after
    /// colour: the constraints of one colour split between the pool's threads (they share
    /// no moving body; `Some(thread)`) or on the caller alone (`None`, with one thread),
    /// then the overflow group on the caller alone (`one_colour` false: they may share
    /// bodies, so one by one). Returns the largest value `f` returned.
    fn for_colors(&mut self, pool: Option<&Pool>, f: &ColorKernel<'_>) -> f32 {
        let pool = pool.filter(|p| p.threads() > 1);
        let done = self.color_ranges.last().map_or(0, |r| r.1 as usize);
        let r = match pool {
            // the colours one after another in one job, each thread solving its share
            // of each colour first
            Some(pool) if pool.threads() == self.cut_threads => {
                let (n, cuts) = (self.cut_threads, &self.color_cuts);
                let wide = Disjoint::new(&mut self.wide[..done]);
                parallel::phases_max(
                    pool,
                    &mut self.phases,
                    self.color_ranges.len(),
                    &|c, j| color_share(cuts, n, c, j),
                    &|_| PHASE_BLOCK,
                    // SAFETY: the blocks of one phase tile its colour's shares, which
                    // tile the colour, and the phases run one after another
                    &|t, _, r| f(Some(t), unsafe { wide.range(r) }, true),
                )
            }
            _ => {
                let mut r = f32::NEG_INFINITY;
                for &(start, end) in &self.color_ranges {
                    let wide = &mut self.wide[start as usize..end as usize];
                    r = r.max(match pool {
                        Some(pool) => {
                            parallel::chunks_mut(Some(pool), wide, WIDE_BLOCK, &|t, _, c| {
                                f(Some(t), c, true)
                            })
                        }
                        None => f(None, wide, true),
                    });
                }
                r
            }
        };
        r.max(f(None, &mut self.wide[done..], false))
    }

    /// Moves every body by its velocity for one substep: dp += h v, dtheta += h w,
    /// q += h w q_perp (normalised).
    pub fn integrate_positions(&mut self, h: f32, pool: Option<&Pool>) {
        parallel::chunks_mut(pool, &mut self.bodies, BODY_BLOCK, &|_, _, bodies| {
            integrate_range(bodies, h);
            0.0
        });
    }

    /// Restitution: a point that was approaching faster than the threshold and was pushed
    /// leaves with -e times its approach speed. Lane by lane (rarely needed).
    pub fn apply_restitution(&mut self, threshold: f32) {
        if !self.restitution {
            return;
        }
        let bodies = &mut self.bodies;
        for (c, cold) in self.wide.iter_mut().zip(&self.cold) {
            if cold.restitution.cmpeq(Vec4::ZERO).all() {
                continue;
            }
            for k in 0..4 {
                let e = cold.restitution[k];
                if e == 0.0 {
                    continue;
                }
                let (a, b) = (c.a[k] as usize, c.b[k] as usize);
                let (mut sa, mut sb) = (bodies[a], bodies[b]);
                let n = Vec2::new(c.nx[k], c.ny[k]);
                for i in 0..cold.count[k] as usize {
                    let p = &mut c.points[i];
                    let rv = cold.relative_velocity[i][k];
                    if rv > -threshold || p.max_normal_impulse[k] == 0.0 {
                        continue;
                    }
                    let ra = Vec2::new(p.rax[k], p.ray[k]);
                    let rb = Vec2::new(p.rbx[k], p.rby[k]);
                    // target vn = -e vn_before
                    let vn = n.dot(sb.v + cross_sv(sb.w, rb) - sa.v - cross_sv(sa.w, ra));
                    let old = p.normal_impulse[k];
                    let new = (old - p.normal_mass[k] * (vn + e * rv)).max(0.0);
                    let imp = (new - old) * n;
                    p.normal_impulse[k] = new;
                    sa.v -= c.m.ima[k] * imp;
                    sa.w -= c.m.iia[k] * cross(ra, imp);
                    sb.v += c.m.imb[k] * imp;
                    sb.w += c.m.iib[k] * cross(rb, imp);
                }
                bodies[c.wa[k] as usize].v = sa.v;
                bodies[c.wa[k] as usize].w = sa.w;
                bodies[c.wb[k] as usize].v = sb.v;
                bodies[c.wb[k] as usize].w = sb.w;
            }
        }
    }

    /// Substep loop of the solver's part: warm start, `iterations` biased sweeps,
    /// integrate positions, one relax sweep. The caller integrates velocities before.
    pub fn substep(
        &mut self,
        s: &SolverSettings,
        h: f32,
        stats: &mut SolveStats,
        pool: Option<&Pool>,
    ) {
        if s.warm_start {
            self.warm_start(pool);
        }
        for _ in 0..s.iterations {
            stats.residual = self.sweep::<true>(pool);
            stats.iterations += 1;
        }
        self.integrate_positions(h, pool);
        stats.residual = self.sweep::<false>(pool);
        stats.iterations += 1;
    }

    /// Whether [`SoftSolver::substeps_in_one_job`] can run this step's substeps: with a
    /// pool of threads the colours were cut for, and every constraint in a colour (no
    /// overflow group, no lopsided contact solved apart).
    pub fn can_run_substeps_in_one_job(&self, pool: Option<&Pool>) -> bool {
        let colored = self.color_ranges.last().map_or(0, |r| r.1 as usize);
        pool.is_some_and(|p| p.threads() > 1 && p.threads() == self.cut_threads)
            && colored == self.wide.len()
            && colored > 0
            && self.direct.is_empty()
    }

    /// `substeps` substeps of the contacts alone (no joints), each but the first
    /// beginning with the force increments: warm start, `iterations` soft sweeps,
    /// positions, one relax sweep, as [`SoftSolver::substep`] does, but all in one job
    /// of the pool whose phases are each pass's colours (and the passes over the
    /// bodies): the threads meet at each phase's end and no job is posted between them.
    /// The same bits as the substeps one by one. Returns the last relax sweep's
    /// residual. Call only when [`SoftSolver::can_run_substeps_in_one_job`] says so.
    pub fn substeps_in_one_job(
        &mut self,
        substeps: usize,
        s: &SolverSettings,
        h: f32,
        pool: &Pool,
    ) -> f32 {
        assert!(self.can_run_substeps_in_one_job(Some(pool)), "cannot fuse");
        let colors = self.color_ranges.len();
        self.fused.clear();
        for i in 0..substeps {
            if i > 0 {
                self.fused.push((Pass::Increments, 0));
            }
            let passes = [
                (Pass::WarmStart, usize::from(s.warm_start)),
                (Pass::Sweep, s.iterations as usize),
            ];
            for (pass, times) in passes {
                for _ in 0..times {
                    self.fused.extend((0..colors).map(|c| (pass, c as u8)));
                }
            }
            self.fused.push((Pass::Integrate, 0));
            self.fused
                .extend((0..colors).map(|c| (Pass::Relax, c as u8)));
        }
        // with two threads, each may run ahead into the next colour once the other has
        // done the blocks of its share that touch bodies of the first's share (see
        // `phases_ahead`): each works out which those are in a first phase
        let n = self.cut_threads;
        let ahead = n == 2 && self.share_bodies.len() == n;
        if ahead {
            self.fused.insert(0, (Pass::Bounds, 0));
            self.ahead_blocks.0.clear();
            self.ahead_blocks
                .0
                .resize_with(n * colors, || AtomicU32::new(0));
        }
        // the last relax sweep's colours
        let last_relax = self.fused.len() - colors;
        let k = self.sweep_consts();
        let nb = self.bodies.len();
        let (cuts, fused, increments) = (&self.color_cuts, &self.fused, &self.increments);
        let share_bodies = &self.share_bodies;
        let bodies = BodyPtr::new(&mut self.bodies, self.sink);
        let wide = Disjoint::new(&mut self.wide);
        let ahead_blocks = &self.ahead_blocks.0;
        // each thread's share of a colour, or of the bodies a pass goes over
        let share = |p: usize, j: usize| match fused[p] {
            (Pass::Increments, _) => parallel::split(increments.len(), n, j),
            (Pass::Integrate, _) => parallel::split(nb, n, j),
            (Pass::Bounds, _) => j..j + 1,
            (_, c) => color_share(cuts, n, c as usize, j),
        };
        let block = |p: usize| match fused[p].0 {
            Pass::Increments | Pass::Integrate => BODY_BLOCK,
            Pass::Bounds => 1,
            _ => PHASE_BLOCK,
        };
        let (avx2, pairs) = (k.avx2, true);
        let kernel = |t: usize, p: usize, r: std::ops::Range<usize>| {
            let mine = bodies.for_thread(t);
            // SAFETY (each arm): the blocks of a phase tile the shares of its colour or
            // of the bodies, which tile them, and the phases run one after another (or
            // ahead only where `Pass::Bounds` found they touch nothing of each other's)
            match fused[p].0 {
                Pass::Bounds => {
                    // share j's row (phase 0's block of share j is j..j + 1), from its
                    // own shares of the colours, only read while others write theirs
                    let j = r.start;
                    let (least, most) = share_bodies[1 - j];
                    for c in 0..colors {
                        let items = color_share(cuts, n, c, j);
                        let w = unsafe { wide.range(items) };
                        let k = reach_touching(w, j == 0, least, most) as u32;
                        ahead_blocks[j * colors + c].store(k, Ordering::Relaxed);
                    }
                }
                Pass::Increments => {
                    add_increments(unsafe { bodies.range(r.clone()) }, &increments[r]);
                }
                Pass::Integrate => integrate_range(unsafe { bodies.range(r) }, h),
                Pass::WarmStart => {
                    warm_start_range::<true>(unsafe { wide.range(r) }, mine, avx2, pairs);
                }
                Pass::Sweep => {
                    sweep_range::<true, true>(unsafe { wide.range(r) }, mine, &k, pairs);
                }
                Pass::Relax => {
                    let d = sweep_range::<false, true>(unsafe { wide.range(r) }, mine, &k, pairs);
                    if p >= last_relax {
                        return d;
                    }
                }
            }
            f32::NEG_INFINITY
        };
        if ahead {
            let full = |p: usize| matches!(fused[p].0, Pass::Increments | Pass::Integrate);
            let run_ahead = |p: usize, t: usize| match fused[p] {
                (Pass::Bounds, _) => (0, false),
                // share t's row, written in phase 0 (which is done before this is asked)
                (_, c) => {
                    let k = ahead_blocks[t * colors + c as usize].load(Ordering::Relaxed);
                    (k as usize, t == 0)
                }
            };
            parallel::phases_ahead(
                pool,
                &mut self.phases,
                fused.len(),
                &share,
                &block,
                &full,
                &run_ahead,
                &kernel,
            )
        } else {
            parallel::phases_max(pool, &mut self.phases, fused.len(), &share, &block, &kernel)
        }
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

    /// Checks the layout: every contact's slot holds its pair, and no moving body appears
    /// in two lanes of one wide constraint (for tests).
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

/// What `prepare` builds each wide constraint from (shared by the threads that build
/// them, each writing its own wide constraints).
struct Fill<'a> {
    contacts: &'a [Contact],
    lane_contact: &'a [u32],
    bodies: &'a [SoftBody],
    inv_mass: &'a [(f32, f32)],
    moves: &'a [bool],
    soft_dynamic: Softness,
    soft_static: Softness,
    /// omega^2 of the two (rad^2/s^2)
    omega2_dynamic: f32,
    omega2_static: f32,
    /// 1 / (h depth): a contact whose load would hold it `depth` deeper than the slop
    /// at its own frequency is stiffened until it does not (see `wide`)
    load_scale: f32,
    /// Per contact: solved exactly (`direct`), so its leak is load-aware.
    direct: &'a [bool],
    warm_start: bool,
    rest: u32,
    sink: u32,
}

/// How many wide constraints ahead `prepare` asks for the contacts it will read: the
/// lanes hold contacts colour by colour, an order the hardware cannot guess.
const PREFETCH_AHEAD: usize = 4;

impl Fill<'_> {
    /// Asks the cache for the contacts of wide constraint `wi`'s lanes (nothing past
    /// the end). A hint only: the results do not depend on it.
    #[inline(always)]
    fn prefetch(&self, wi: usize) {
        if let Some(lanes) = self.lane_contact.get(wi * 4..wi * 4 + 4) {
            for &i in lanes {
                prefetch(self.contacts, i as usize, usize::MAX);
            }
        }
    }

    /// The contacts of wide constraint `wi`'s lanes.
    fn lanes(&self, wi: usize) -> impl Iterator<Item = (usize, &Contact)> {
        self.lane_contact[wi * 4..wi * 4 + 4]
            .iter()
            .enumerate()
            .filter(|(_, i)| **i != u32::MAX)
            .map(|(k, &i)| (k, &self.contacts[i as usize]))
    }

    fn wide(&self, wi: usize, w: &mut WideConstraint) {
        *w = WideConstraint::empty(self.rest, self.sink);
        for (k, c) in self.lanes(wi) {
            let ((ima, iia), (imb, iib)) =
                (self.inv_mass[c.a as usize], self.inv_mass[c.b as usize]);
            let (ma, mb) = (self.moves[c.a as usize], self.moves[c.b as usize]);
            let (soft, omega2) = if ma && mb {
                (self.soft_dynamic, self.omega2_dynamic)
            } else {
                (self.soft_static, self.omega2_static)
            };
            // omega^2 the load needs: at rest a soft row holds its load F = lambda / h at
            // a depth F / (m_n omega^2) past the slop (m_n = 1 / K), so a point carrying
            // more than m_n omega^2 depth sinks further: its frequency rises to hold it
            let mut need = 0.0f32;
            let n = c.manifold.normal;
            let t = Vec2::new(n.y, -n.x);
            w.a[k] = c.a;
            w.b[k] = c.b;
            w.wa[k] = if ma { c.a } else { self.sink };
            w.wb[k] = if mb { c.b } else { self.sink };
            w.nx.as_mut()[k] = n.x;
            w.ny.as_mut()[k] = n.y;
            w.friction.as_mut()[k] = c.friction;
            w.m.ima.as_mut()[k] = ima;
            w.m.iia.as_mut()[k] = iia;
            w.m.imb.as_mut()[k] = imb;
            w.m.iib.as_mut()[k] = iib;
            for (i, cp) in c.manifold.points().iter().enumerate() {
                let (ra, rb) = (cp.anchor_a, cp.anchor_b);
                let rna = cross(ra, n);
                let rnb = cross(rb, n);
                // K = 1/mA + 1/mB + (ra x n)^2/IA + (rb x n)^2/IB
                let kn = ima + imb + iia * rna * rna + iib * rnb * rnb;
                let rta = cross(ra, t);
                let rtb = cross(rb, t);
                let kt = ima + imb + iia * rta * rta + iib * rtb * rtb;
                let (ni, ti) = if self.warm_start {
                    (cp.normal_impulse, cp.tangent_impulse)
                } else {
                    (0.0, 0.0)
                };
                let p = &mut w.points[i];
                p.rax.as_mut()[k] = ra.x;
                p.ray.as_mut()[k] = ra.y;
                p.rbx.as_mut()[k] = rb.x;
                p.rby.as_mut()[k] = rb.y;
                // s0 - n . (rb - ra)
                p.base_separation.as_mut()[k] = cp.separation - n.dot(rb - ra);
                // K for now: the masses 1 / K are taken below, four lanes at once
                p.normal_mass.as_mut()[k] = kn;
                p.tangent_mass.as_mut()[k] = kt;
                p.normal_impulse.as_mut()[k] = ni;
                p.tangent_impulse.as_mut()[k] = ti;
                need = need.max(ni * kn * self.load_scale);
            }
            // need > omega^2 only under a load some times a body's own weight (a heavy
            // body on light ones, the foot of a tall stack)
            let direct = self
                .direct
                .get(self.lane_contact[wi * 4 + k] as usize)
                .copied()
                .unwrap_or(false);
            let soft = if direct && need > omega2 {
                Softness {
                    impulse_scale: soft.impulse_scale * (omega2 / need),
                    ..soft
                }
            } else {
                soft
            };
            w.bias_rate.as_mut()[k] = soft.bias_rate;
            w.mass_scale.as_mut()[k] = soft.mass_scale;
            w.impulse_scale.as_mut()[k] = soft.impulse_scale;
        }
        // 1 / K where K > 0 (lanes and points not in use hold 0): the same quotients as
        // one at a time
        let inv = |k: Vec4| Vec4::select(k.cmpgt(Vec4::ZERO), Vec4::ONE / k, Vec4::ZERO);
        for p in &mut w.points {
            p.normal_mass = inv(p.normal_mass);
            p.tangent_mass = inv(p.tangent_mass);
        }
    }

    /// The cold half of wide constraint `wi`, and whether some lane has restitution.
    fn cold(&self, wi: usize) -> (WideCold, bool) {
        let mut cold = WideCold::default();
        let mut any = false;
        for (k, c) in self.lanes(wi) {
            cold.restitution[k] = c.restitution;
            cold.count[k] = c.manifold.count as u8;
            if c.restitution == 0.0 {
                continue;
            }
            any = true;
            // dv = vb + wb x rb - va - wa x ra (read only by restitution)
            let (ba, bb) = (self.bodies[c.a as usize], self.bodies[c.b as usize]);
            let n = c.manifold.normal;
            for (i, cp) in c.manifold.points().iter().enumerate() {
                let (ra, rb) = (cp.anchor_a, cp.anchor_b);
                let dv = bb.v + cross_sv(bb.w, rb) - ba.v - cross_sv(ba.w, ra);
                cold.relative_velocity[i][k] = n.dot(dv);
            }
        }
        (cold, any)
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

/// The depth past the slop a contact's load may hold it at, when the slop is less.
const MIN_LOAD_DEPTH: f32 = 1e-3;

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
/// Bodies per block of a parallel pass over the world's bodies (`Body`, large).
const BODY_PASS_BLOCK: usize = 256;
/// Contacts from which one thread colours them while the others load the bodies.
const PARALLEL_COLORING: usize = 1024;
/// Contacts from which the layout of the constraints is split between the threads.
const PARALLEL_LAYOUT: usize = 2048;
/// Contacts a thread claims at a time (copying lambdas out).
const CONTACT_BLOCK: usize = 512;

/// Whether the sweeps run their AVX2 build, read once on the caller (the test hook is
/// per thread).
fn use_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        testing::use_avx2()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// What a sweep reads besides the constraints and bodies.
struct SweepConsts {
    inv_h: f32,
    slop: f32,
    max_push: f32,
    /// Keep each point's largest normal impulse (for restitution).
    max_impulse: bool,
    avx2: bool,
}

/// The sweeps' constants, as lanes.
struct Consts<L> {
    inv_h: L,
    slop: L,
    min_bias: L,
    zero: L,
    one: L,
}

impl<L: Lanes> Consts<L> {
    #[inline(always)]
    fn new(k: &SweepConsts) -> Consts<L> {
        Consts {
            inv_h: L::splat(k.inv_h),
            slop: L::splat(k.slop),
            min_bias: L::splat(-k.max_push),
            zero: L::splat(0.0),
            one: L::splat(1.0),
        }
    }
}

/// Thread j's share of colour `color` (wide constraints), with the colours cut for `n`
/// threads in `cuts` (see `SoftSolver::color_cuts`).
fn color_share(cuts: &[u32], n: usize, color: usize, j: usize) -> std::ops::Range<usize> {
    let c = &cuts[color * (n + 1) + j..][..2];
    c[0] as usize..c[1] as usize
}

/// How many of the wide constraints `w`, counted in the order they run (from the last
/// if `reversed`), reach the last one in that order that touches a body in
/// `least..=most`: 0 if none does.
fn reach_touching(w: &[WideConstraint], reversed: bool, least: u32, most: u32) -> usize {
    let touches = |c: &WideConstraint| c.wa.iter().chain(&c.wb).any(|&i| least <= i && i <= most);
    if reversed {
        w.iter().position(touches).map_or(0, |i| w.len() - i)
    } else {
        w.iter().rposition(touches).map_or(0, |i| i + 1)
    }
}

/// Adds each body's force increment for one substep: v += dv, w += dw.
fn add_increments(bodies: &mut [SoftBody], increments: &[(Vec2, f32)]) {
    for (s, &(dv, dw)) in bodies.iter_mut().zip(increments) {
        s.v += dv;
        s.w += dw;
    }
}

/// Moves each body by its velocity for one substep of `h`.
fn integrate_range(bodies: &mut [SoftBody], h: f32) {
    for s in bodies {
        s.dp += h * s.v;
        s.dtheta += h * s.w;
        // q' = q + h w (-s, c), then |q'| = 1
        let hw = h * s.w;
        let (c, sn) = (s.dq.c - hw * s.dq.s, s.dq.s + hw * s.dq.c);
        let inv = 1.0 / (c * c + sn * sn).sqrt();
        s.dq = Rot {
            c: c * inv,
            s: sn * inv,
        };
    }
}

/// A step's scratch that a clone of the solver starts without.
#[derive(Debug)]
struct Scratch<T>(Vec<T>);

impl<T> Default for Scratch<T> {
    fn default() -> Self {
        Scratch(Vec::new())
    }
}

impl<T> Clone for Scratch<T> {
    fn clone(&self) -> Self {
        Scratch::default()
    }
}

/// What a phase of [`SoftSolver::substeps_in_one_job`] does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pass {
    /// Each thread works out which of its blocks of each colour the other may wait for.
    Bounds,
    /// The substep's force increments (every substep after the first).
    Increments,
    /// One colour's warm start, soft sweep or relax sweep.
    WarmStart,
    Sweep,
    Relax,
    /// Positions.
    Integrate,
}

/// Warm start of the constraints `wide`; `pairs`: they are of one colour, so the AVX2
/// build may take them two at a time.
fn warm_start_range<const SHARED: bool>(
    wide: &mut [WideConstraint],
    bodies: BodyPtr,
    avx2: bool,
    pairs: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: the CPU has AVX2 (use_avx2).
        return unsafe { warm_start_avx2::<SHARED>(wide, bodies, pairs) };
    }
    let _ = (avx2, pairs);
    for c in wide {
        warm_start_group::<_, SHARED>(&mut One(c), bodies);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn warm_start_avx2<const SHARED: bool>(wide: &mut [WideConstraint], bodies: BodyPtr, pairs: bool) {
    let mut rest = wide;
    if pairs {
        let mut it = rest.chunks_exact_mut(2);
        for pair in &mut it {
            if let [c0, c1] = pair {
                warm_start_group::<_, SHARED>(&mut Two(c0, c1), bodies);
            }
        }
        rest = it.into_remainder();
    }
    for c in rest {
        warm_start_group::<_, SHARED>(&mut One(c), bodies);
    }
}

/// Applies a group's accumulated lambdas to its bodies.
#[inline(always)]
fn warm_start_group<G: Group, const SHARED: bool>(g: &mut G, bodies: BodyPtr) {
    let sa = g.gather::<false>(bodies);
    let sb = g.gather::<true>(bodies);
    let mut v = G::velocities(&sa, &sb);
    let (nx, ny, m) = (g.get(|c| c.nx), g.get(|c| c.ny), g.inv_mass());
    for i in 0..2 {
        let p = g.anchors(i);
        let (ln, lt) = (
            g.get(|c| c.points[i].normal_impulse),
            g.get(|c| c.points[i].tangent_impulse),
        );
        // P = lambda_n n + lambda_t t, t = (ny, -nx)
        let px = ln * nx + lt * ny;
        let py = ln * ny - lt * nx;
        v.apply(&m, &p, px, py);
    }
    g.store::<SHARED>(&sa, &sb, &v, bodies);
}

/// One sweep over the constraints `wide`; `pairs` as in [`warm_start_range`].
fn sweep_range<const BIAS: bool, const SHARED: bool>(
    wide: &mut [WideConstraint],
    bodies: BodyPtr,
    k: &SweepConsts,
    pairs: bool,
) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if k.avx2 {
        // SAFETY: the CPU has AVX2 (use_avx2).
        return unsafe {
            if k.max_impulse {
                sweep_avx2::<BIAS, true, SHARED>(wide, bodies, k, pairs)
            } else {
                sweep_avx2::<BIAS, false, SHARED>(wide, bodies, k, pairs)
            }
        };
    }
    let _ = pairs;
    let k4 = Consts::new(k);
    let mut residual = Vec4::ZERO;
    for c in wide {
        if k.max_impulse {
            solve_group::<_, BIAS, true, SHARED>(&mut One(c), bodies, &k4, &mut residual);
        } else {
            solve_group::<_, BIAS, false, SHARED>(&mut One(c), bodies, &k4, &mut residual);
        }
    }
    residual.max_element()
}

/// The sweep compiled for AVX2: with `pairs`, two wide constraints at a time in eight
/// lanes (the same arithmetic lane by lane, so the same results to the bit), else one
/// at a time (three-operand forms, blends).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn sweep_avx2<const BIAS: bool, const MAX_IMPULSE: bool, const SHARED: bool>(
    wide: &mut [WideConstraint],
    bodies: BodyPtr,
    k: &SweepConsts,
    pairs: bool,
) -> f32 {
    let mut rest = wide;
    let mut residual = Vec4::ZERO;
    if pairs {
        let k8 = Consts::new(k);
        let mut r8 = F8::splat(0.0);
        let mut it = rest.chunks_exact_mut(2);
        for pair in &mut it {
            if let [c0, c1] = pair {
                solve_group::<_, BIAS, MAX_IMPULSE, SHARED>(&mut Two(c0, c1), bodies, &k8, &mut r8);
            }
        }
        rest = it.into_remainder();
        let (lo, hi) = r8.split();
        residual = lo.max(hi);
    }
    let k4 = Consts::new(k);
    for c in rest {
        solve_group::<_, BIAS, MAX_IMPULSE, SHARED>(&mut One(c), bodies, &k4, &mut residual);
    }
    residual.max_element()
}

/// One sweep's rows of a group: the normal rows, and in the relax sweep (`!BIAS`) the
/// friction rows.
#[inline(always)]
fn solve_group<G: Group, const BIAS: bool, const MAX_IMPULSE: bool, const SHARED: bool>(
    g: &mut G,
    bodies: BodyPtr,
    k: &Consts<G::L>,
    residual: &mut G::L,
) {
    let sa = g.gather::<false>(bodies);
    let sb = g.gather::<true>(bodies);
    let mut v = G::velocities(&sa, &sb);
    let (nx, ny, m) = (g.get(|c| c.nx), g.get(|c| c.ny), g.inv_mass());
    let dpx = sb.dpx - sa.dpx;
    let dpy = sb.dpy - sa.dpy;
    for i in 0..2 {
        let p = g.anchors(i);
        // q r: the anchors turned by the rotation since collide
        let qrax = sa.qc * p.rax - sa.qs * p.ray;
        let qray = sa.qs * p.rax + sa.qc * p.ray;
        let qrbx = sb.qc * p.rbx - sb.qs * p.rby;
        let qrby = sb.qs * p.rbx + sb.qc * p.rby;
        // s = s0 - n.(rb - ra) + n.(dp_b - dp_a + q_b rb - q_a ra)
        let s = g.get(|c| c.points[i].base_separation)
            + nx * (dpx + qrbx - qrax)
            + ny * (dpy + qrby - qray);
        let speculative = s.gt(k.zero);
        // speculative: bias = s / h (may close the gap this substep, not more)
        let spec_bias = s * k.inv_h;
        let (bias, mass_scale, impulse_scale) = if BIAS {
            // bias = max(rate S, -v_max), S = min(s + slop, 0)
            let soft_bias = (g.get(|c| c.bias_rate) * (s + k.slop).min(k.zero)).max(k.min_bias);
            (
                G::L::select(speculative, spec_bias, soft_bias),
                G::L::select(speculative, k.one, g.get(|c| c.mass_scale)),
                G::L::select(speculative, k.zero, g.get(|c| c.impulse_scale)),
            )
        } else {
            (spec_bias.max(k.zero), k.one, k.zero)
        };
        let vn = v.along(&p, nx, ny);
        let old = g.get(|c| c.points[i].normal_impulse);
        // d lambda = -m_n s_m (vn + bias) - s_i lambda, then lambda >= 0
        let d =
            -g.get(|c| c.points[i].normal_mass) * mass_scale * (vn + bias) - impulse_scale * old;
        let new = (old + d).max(k.zero);
        let d = new - old;
        g.set(|c| &mut c.points[i].normal_impulse, new);
        if MAX_IMPULSE {
            let most = g.get(|c| c.points[i].max_normal_impulse).max(new);
            g.set(|c| &mut c.points[i].max_normal_impulse, most);
        }
        *residual = residual.max(d.abs());
        v.apply(&m, &p, d * nx, d * ny);
    }
    if !BIAS {
        // friction only in the relax sweep: solved against the push-out speeds of the
        // biased sweep it lets the flanks of a tall pile creep outwards
        let (tx, ty) = (ny, -nx);
        let friction = g.get(|c| c.friction);
        for i in 0..2 {
            let p = g.anchors(i);
            let vt = v.along(&p, tx, ty);
            // lambda_t = -m_t vt, projected onto [-mu lambda_n, mu lambda_n]
            let bound = friction * g.get(|c| c.points[i].normal_impulse);
            let old = g.get(|c| c.points[i].tangent_impulse);
            let new = (old - g.get(|c| c.points[i].tangent_mass) * vt)
                .min(bound)
                .max(-bound);
            let d = new - old;
            *residual = residual.max(d.abs());
            v.apply(&m, &p, d * tx, d * ty);
            g.set(|c| &mut c.points[i].tangent_impulse, new);
        }
    }
    g.store::<SHARED>(&sa, &sb, &v, bodies);
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
            s.prepare_integrating(
                &mut bodies,
                w.contacts(),
                movers,
                &settings,
                h,
                w.gravity,
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
            s.warm_start(pool);
            let r = s.sweep::<true>(pool);
            s.integrate_positions(h, pool);
            let r = r.max(s.sweep::<false>(pool));
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
            // the substeps one by one, each pass over the colours a job (or on one thread)
            let by_passes = |pool: Option<&Pool>, stall: usize| {
                let mut s = SoftSolver::default();
                s.phases.stall = stall;
                s.prepare(&w.bodies, w.contacts(), &settings, h, pool);
                s.take_increments(&w.bodies, pool);
                let mut r = 0.0;
                for i in 0..substeps {
                    if i > 0 {
                        s.apply_increments(pool);
                    }
                    s.warm_start(pool);
                    for _ in 0..settings.iterations {
                        s.sweep::<true>(pool);
                    }
                    s.integrate_positions(h, pool);
                    r = s.sweep::<false>(pool);
                }
                bits(&s, r)
            };
            let one = by_passes(None, 0);
            assert_eq!(
                one,
                by_passes(Some(&pool), 2),
                "colour passes, worker stalled"
            );
            assert_eq!(
                one,
                by_passes(Some(&pool), 1),
                "colour passes, caller stalled"
            );
            // every substep in one job, the worker stalled, then the caller
            for stall in [2, 1] {
                let mut s = SoftSolver::default();
                s.phases.stall = stall;
                s.prepare(&w.bodies, w.contacts(), &settings, h, Some(&pool));
                s.take_increments(&w.bodies, Some(&pool));
                assert!(s.can_run_substeps_in_one_job(Some(&pool)));
                let r = s.substeps_in_one_job(substeps, &settings, h, &pool);
                assert_eq!(
                    one,
                    bits(&s, r),
                    "substeps in one job, thread {} stalled",
                    stall - 1
                );
            }
        });
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
}
