//! The sweeps' kernels (Box2D's contact_solver.c): warm start, the soft and the relax
//! sweep over wide constraints, four lanes at a time (eight with AVX2), and restitution.

#[allow(unused_imports)]
use super::*;

/// Bodies' states, transposed: lane k holds body k.
pub(super) struct WideBody<L = Vec4> {
    pub(super) vx: L,
    pub(super) vy: L,
    pub(super) w: L,
    /// kept only to be written back unchanged with the velocities
    pub(super) dtheta: L,
    pub(super) dpx: L,
    pub(super) dpy: L,
    pub(super) qc: L,
    pub(super) qs: L,
}

impl WideBody {
    /// Loads four bodies (two 16-byte loads each) and transposes them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) fn gather(bodies: BodyPtr, idx: &[u32; 4]) -> WideBody {
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
    pub(super) fn scatter_velocities<const SHARED: bool>(
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
    pub(super) fn gather(bodies: BodyPtr, idx: &[u32; 4]) -> WideBody {
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
    pub(super) fn scatter_velocities<const SHARED: bool>(
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
pub(super) fn transpose4(r: [std::arch::x86_64::__m128; 4]) -> [std::arch::x86_64::__m128; 4] {
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
pub(super) struct PairVel<L> {
    vax: L,
    vay: L,
    wa: L,
    vbx: L,
    vby: L,
    wb: L,
}

/// A point's anchors (from A's and B's centres, at collide), as lanes.
pub(super) struct Anchors<L> {
    rax: L,
    ray: L,
    rbx: L,
    rby: L,
}

/// Inverse masses and inertias of a group's bodies, as lanes.
pub(super) struct InvMass<L> {
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

/// The constraints a kernel solves in lock step: one wide constraint (four lanes) or, in
/// the AVX2 build, two of one colour side by side (eight lanes, [`F8`]).
pub(super) trait Group {
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
pub(super) struct One<'a>(&'a mut WideConstraint);

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
pub(super) struct Two<'a>(&'a mut WideConstraint, &'a mut WideConstraint);

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
pub(super) fn row2(bodies: BodyPtr, lo: u32, hi: u32, off: usize) -> std::arch::x86_64::__m256 {
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
pub(super) fn transpose4x2(r: [std::arch::x86_64::__m256; 4]) -> [std::arch::x86_64::__m256; 4] {
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

/// Whether the sweeps run their AVX2 build, read once on the caller (the test hook is
/// per thread).
pub(super) fn use_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        testing::use_avx2()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The sweeps' constants, as lanes.
pub(super) struct Consts<L> {
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

/// Warm start of the constraints `wide`; `pairs`: they are of one colour, so the AVX2
/// build may take them two at a time.
pub(super) fn warm_start_range<const SHARED: bool>(
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
pub(super) fn warm_start_avx2<const SHARED: bool>(
    wide: &mut [WideConstraint],
    bodies: BodyPtr,
    pairs: bool,
) {
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
pub(super) fn warm_start_group<G: Group, const SHARED: bool>(g: &mut G, bodies: BodyPtr) {
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
pub(super) fn sweep_range<const BIAS: bool, const SHARED: bool>(
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
pub(super) fn sweep_avx2<const BIAS: bool, const MAX_IMPULSE: bool, const SHARED: bool>(
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
pub(super) fn solve_group<
    G: Group,
    const BIAS: bool,
    const MAX_IMPULSE: bool,
    const SHARED: bool,
>(
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

impl SoftSolver {
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
}
