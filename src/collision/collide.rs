//! The collide stage: every body's box (grown by its motion and half the speculative
//! margin), the broad phase's pairs (kept from step to step while the boxes stay inside
//! their fattened ones), the filters and the joints' no-collide pairs, then SAT
//! manifolds for each pair, matched against last step's by the contact cache. The
//! narrow phase is split between the threads in blocks of pairs; the contact list comes
//! out in pair order whatever the thread count.
//!
//! Sleeping is the caller's (`step::sleep`): it wakes what the movers reach before the
//! collide, and the collide keeps the contacts of sleeping pairs aside.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU32, Ordering};

use super::broad_phase::{BroadPhase, Left};
use super::contact_cache::{CacheCursor, match_points};
use super::{Manifold, sat};
use crate::awake::{AwakeMarks, RestBlocks};
use crate::body::{Body, SHAPE_BYTES};
use crate::defs::{BodyType, Filter};
use crate::math::{AWAKE_BLOCK, Aabb, BODY_AHEAD, BODY_PASS_BLOCK, Vec2, gallop, prefetch};
use crate::parallel::{self, BlockScratch, Pool};

/// A touching pair of bodies and its manifold: a made before b; the normal points from
/// a to b. [`crate::World::contact_bodies`] gives the two bodies' keys.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// Index of the first body (the lower one) in the world.
    pub(crate) a: u32,
    /// Index of the second body in the world.
    pub(crate) b: u32,
    /// The touching points and their shared normal.
    pub manifold: Manifold,
    /// Mixed friction coefficient: sqrt(mu_a mu_b).
    pub friction: f32,
    /// Mixed restitution: max(e_a, e_b).
    pub restitution: f32,
}

/// Beyond this many margins of the two bodies' own motion in a step, the soft step
/// bounds how far a pair can close by the pair's relative motion instead.
const FAST_MARGINS: f32 = 16.0;

/// How far out a pair keeps contact points (speculative contacts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Speculative {
    /// Up to the margin plus the distance the two bodies can move in h, each at its own
    /// speed (classic PGS, XPBD).
    MarginPlusMotion,
    /// Up to the larger of the margin and the distance the two bodies can close in h (for
    /// fast bodies, by their relative velocity and their spins):
    /// a gap beyond both cannot close in the step, and resting bodies keep no more
    /// points than the margin gives (the soft step: the same protection against
    /// tunnelling, 3 to 5% less time on the large pyramid than the sum).
    MarginOrMotion,
}

/// The collide stage's state, kept from step to step: the broad phase, this step's
/// boxes, reach and flags, last step's contacts (the cache) and the narrow phase's
/// buffers.
#[derive(Clone, Debug, Default)]
pub(crate) struct Collider {
    pub(crate) broad: BroadPhase,
    /// Each body's swept box this step (scratch of the wake pass too).
    pub(crate) aabbs: Vec<Aabb>,
    /// Whether each body is dynamic and awake this step (the wake pass: whether it
    /// wakes what it reaches).
    pub(crate) dynamic: Vec<bool>,
    /// How far each body's points can move this step, h (|v| + |w| r), and how far by
    /// its spin alone, h |w| r (the speculative margins' parts per body).
    reach: Vec<(f32, f32)>,
    /// The step the reaches are for (s).
    reach_h: f32,
    /// Last step's contacts while this step's are found (the cache).
    pub(crate) old_contacts: Vec<Contact>,
    /// Body pairs joined by a joint that must not collide, sorted.
    pub(crate) no_collide: Vec<(u32, u32)>,
    /// Whether this step's broad phase found a body with a filter other than the
    /// default (else the pairs' test skips the filters).
    filtered: bool,
    /// Whether any body is a sensor (else the narrow phase skips the check).
    pub(crate) has_sensors: bool,
    /// Set when a broad phase finds a sensor (the world then records events); the
    /// world clears it.
    pub(crate) heard_sensors: bool,
    /// Whether this step's broad phase found `dynamic` for every body with none asleep:
    /// it then says which bodies are dynamic ([`Collider::movers`]).
    pub(crate) movers_found: bool,
    /// Whether this step's wake pass left every body's swept box of this step in
    /// `aabbs` (the broad phase then takes the sleeping bodies' as they are: they do not
    /// move). Cleared by each broad phase.
    pub(crate) boxes_found: bool,
    /// The blocks of bodies this step's broad phase found awake (see [`crate::awake`]);
    /// forgotten at each collide's start.
    pub(crate) awake: AwakeMarks,
    /// Per block of pairs: the contacts the narrow phase found (scratch).
    narrow_out: BlockScratch<Contact>,
    /// Per block of bodies of the broad phase's pass: those whose kept box (or filter)
    /// no longer holds (scratch, each list empty between steps).
    left_out: BlockScratch<u32>,
    /// The bodies whose kept box (or filter) no longer holds, in increasing order, when
    /// the kept boxes are for these bodies (scratch).
    left: Vec<u32>,
    /// Per body: the last narrow phase (`stamp`) that found it a contact.
    touched: Touched,
    /// Narrow phases so far (wrapping; the first is 1, so that no body starts touched).
    stamp: u32,
    /// Each block's first contact (scratch).
    narrow_starts: Vec<usize>,
    /// Each block's first pair, then the pair count (scratch).
    narrow_blocks: Vec<usize>,
}

/// Per body: the last narrow phase that found it a contact, marked from the narrow
/// phase's threads.
#[derive(Debug, Default)]
struct Touched(Vec<AtomicU32>);

impl Clone for Touched {
    fn clone(&self) -> Self {
        Touched(
            (self.0.iter())
                .map(|t| AtomicU32::new(t.load(Ordering::Relaxed)))
                .collect(),
        )
    }
}

/// Body pairs a thread claims at a time in the narrow phase.
const PAIR_BLOCK: usize = 256;

impl Collider {
    /// Forgets what it kept from the last step (the broad phase's kept pairs, the
    /// boxes, the cache), keeping the no-collide pairs: for a world restored from a
    /// saved state.
    pub(crate) fn restart(&mut self) {
        self.broad = BroadPhase::default();
        self.aabbs.clear();
        self.dynamic.clear();
        self.reach.clear();
        self.old_contacts.clear();
        self.touched.0.clear();
    }

    /// Whether each body is dynamic, where this step's broad phase found it for every
    /// body with none asleep.
    pub(crate) fn movers(&self, bodies: usize) -> Option<&[bool]> {
        (self.movers_found && self.dynamic.len() == bodies).then_some(&self.dynamic[..])
    }

    /// The broad phase: every body's swept box, reach and flags (with the check that
    /// the kept boxes still hold folded in), then this step's candidate pairs (the kept
    /// pairs, filtered in the narrow phase, or with sensors the pairs themselves).
    pub(crate) fn broad_phase(
        &mut self,
        bodies: &[Body],
        h: f32,
        margin: f32,
        rest: &RestBlocks,
        pool: Option<&Pool>,
    ) {
        // sized, not cleared: the pass below writes every body's entry but the rest
        // blocks' (which the wake pass found as they are)
        let n = bodies.len();
        self.aabbs.resize(n, Aabb::default());
        self.dynamic.resize(n, false);
        self.reach.resize(n, (0.0, 0.0));
        // the flags are read off the bodies each step, so bodies pushed straight into
        // `bodies` (the CLI's build, tools) count as well as those added one by one
        const ASLEEP: u32 = 1;
        const FILTERED: u32 = 2;
        const SENSORS: u32 = 4;
        let flags = AtomicU32::new(0);
        // the bodies whose kept box no longer holds (checked in the same pass), listed
        // by the block they are in
        let lists = &*self.left_out.first(n.div_ceil(BODY_PASS_BLOCK), 0);
        let broad = &self.broad;
        let kept = broad.kept_count() == n;
        // (the wake pass sized `aabbs` for these bodies when it found their boxes)
        let found = std::mem::take(&mut self.boxes_found);
        // (the rest blocks count only after a wake pass: with none asleep there are none)
        let known = found.then_some(rest);
        self.awake.start(n);
        let awake = &self.awake;
        parallel::chunks_mut3(
            pool,
            &mut self.aabbs,
            &mut self.reach,
            &mut self.dynamic,
            BODY_PASS_BLOCK,
            &|_, offset, aabbs, reach, dynamic| {
                let bodies = &bodies[offset..];
                let mut f = 0u32;
                // (taken at the first body that left)
                let mut list = None;
                // block by block (the chunks are whole blocks): a rest block holds only
                // sleepers whose entries the wake pass kept, their flags as last found
                for start in (0..aabbs.len()).step_by(AWAKE_BLOCK) {
                    let end = (start + AWAKE_BLOCK).min(aabbs.len());
                    let block = (offset + start) / AWAKE_BLOCK;
                    let rest = known.filter(|r| r.is_rest(block));
                    if let Some(rest) = rest {
                        f |= ASLEEP | rest.flags(block);
                        if !cfg!(debug_assertions) {
                            continue;
                        }
                    }
                    let mut fb = 0u32;
                    let mut marked = false;
                    let mut left = false;
                    for (i, ((bx, re), dy)) in aabbs[start..end]
                        .iter_mut()
                        .zip(&mut reach[start..end])
                        .zip(&mut dynamic[start..end])
                        .enumerate()
                    {
                        let i = start + i;
                        // the box reads the shape too
                        prefetch(bodies, i + BODY_AHEAD, SHAPE_BYTES);
                        let b = &bodies[i];
                        let at = offset + i;
                        if rest.is_some() {
                            debug_assert!(*re == (0.0, 0.0) && !*dy, "a rest block's entries hold");
                        }
                        if b.asleep {
                            fb |= ASLEEP;
                        } else if !marked {
                            // (once a block: the threads' marks share a cache line)
                            marked = true;
                            awake.mark(at);
                        }
                        fb |= if b.filter != Filter::default() {
                            FILTERED
                        } else {
                            0
                        };
                        fb |= if b.has_sensor() { SENSORS } else { 0 };
                        if found && b.asleep {
                            // a sleeper is still (the wake pass woke any that was not):
                            // its box is the one the wake pass found, and it reaches
                            // nothing
                            debug_assert!(*bx == swept_box(b, b.aabb(), h, margin));
                            debug_assert!(b.velocity == Vec2::ZERO && b.angular_velocity == 0.0);
                            *re = (0.0, 0.0);
                        } else {
                            let bb = b.aabb();
                            // the most any point of the body moves in h: h (|v| + |w| r)
                            let r = 0.5 * (bb.max - bb.min).length();
                            *re = (
                                h * (b.velocity.length() + b.angular_velocity.abs() * r),
                                h * b.angular_velocity.abs() * r,
                            );
                            *bx = swept_box(b, bb, h, margin);
                        }
                        // a sleeping body is found only by the awake bodies near it, as a
                        // static one
                        *dy = b.is_dynamic() && !b.asleep;
                        if kept
                            && !(broad.kept_holds(at, bx, *dy)
                                && broad.kept_filter_holds(at, &b.filter))
                        {
                            list.get_or_insert_with(|| {
                                lists[offset / BODY_PASS_BLOCK]
                                    .lock()
                                    .unwrap_or_else(|e| e.into_inner())
                            })
                            .push(at as u32);
                            left = true;
                        }
                    }
                    if let Some(rest) = rest {
                        // (debug builds: the skipped block's entries are what a visit
                        // finds, its flags the same and its kept boxes holding)
                        assert!(!marked && fb == ASLEEP | rest.flags(block));
                        assert!(!left, "a rest block's kept boxes hold");
                        continue;
                    }
                    if let Some(r) = known {
                        r.set_flags(block, fb & !ASLEEP);
                    }
                    f |= fb;
                }
                flags.fetch_or(f, Ordering::Relaxed);
                0.0
            },
        );
        self.reach_h = h;
        let flags = flags.into_inner();
        let (filtered, sensors) = (flags & FILTERED != 0, flags & SENSORS != 0);
        let any_asleep = flags & ASLEEP != 0;
        if any_asleep {
            // (with none asleep every block is awake: the passes after need not look)
            self.awake.finish();
        }
        // (with none asleep, `dynamic` is whether each body is dynamic)
        self.movers_found = !any_asleep;
        // the lists in block order: every body that left, in increasing order (each
        // list emptied for the next step)
        self.left.clear();
        for list in &mut self.left_out.0 {
            let list = list.get_mut().unwrap_or_else(|e| e.into_inner());
            self.left.extend_from_slice(list);
            list.clear();
        }
        let left = if kept {
            Left::These(&self.left)
        } else {
            Left::All
        };
        self.filtered = filtered;
        self.has_sensors = sensors;
        // a sensor is there to be heard
        self.heard_sensors |= sensors;
        // without sensors (which read the pairs after the step) the narrow phase filters
        // the kept pairs itself, split between the threads: no list of this step's pairs
        // with filters, the kept pairs are only those the filters let touch
        let filter_of = |i: usize| bodies[i].filter;
        let filter_of = filtered.then_some(&filter_of as &dyn Fn(usize) -> Filter);
        // each body's motion over a step, for its kept box to reach ahead along (see
        // `BroadPhase::refresh_kept`): none for a body that had a contact at the last
        // narrow phase, whose path a touch may bend (a body in a heap), so that only
        // bodies in flight reach ahead
        let (touched, stamp) = (&self.touched.0, self.stamp);
        let motion = |i: usize| {
            if touched
                .get(i)
                .is_some_and(|t| t.load(Ordering::Relaxed) == stamp)
            {
                Vec2::ZERO
            } else {
                bodies[i].velocity * h
            }
        };
        if !sensors {
            // (the pass above set it for every body)
            let dynamic = &self.dynamic;
            let may_move = |i: usize| dynamic[i];
            self.broad
                .refresh_kept(&self.aabbs, left, may_move, &motion, filter_of, pool);
        } else {
            let test = PairTest {
                bodies,
                aabbs: &[],
                dynamic: &[],
                filtered,
                no_collide: &self.no_collide,
            };
            self.broad.find_pairs_kept_checked(
                &self.aabbs,
                &self.dynamic,
                left,
                |i| self.dynamic[i],
                &motion,
                filter_of,
                |a, b| test.may_collide(a, b),
                pool,
            );
        }
    }

    /// The narrow phase, after [`Collider::broad_phase`]: this step's contacts, in pair
    /// order, into `contacts` (last step's become the cache; those of pairs that sleep
    /// go to `sleeping`, with their impulses, until their island wakes). Returns the
    /// deepest overlap found (m, >= 0). How far out a pair keeps points is
    /// `speculative`'s choice (see [`Speculative`]).
    pub(crate) fn narrow_phase(
        &mut self,
        bodies: &[Body],
        contacts: &mut Vec<Contact>,
        sleeping: &mut Vec<Contact>,
        margin: f32,
        speculative: Speculative,
        pool: Option<&Pool>,
    ) -> f32 {
        let fused = !self.has_sensors;
        let any_asleep = !self.movers_found;
        std::mem::swap(contacts, &mut self.old_contacts);
        contacts.clear();
        if any_asleep {
            // contacts within sleeping islands (and of them with static bodies) are kept
            // aside with their impulses until the island wakes
            let dynamic = &self.dynamic;
            let asleep_pair = |c: &Contact| {
                // (most pairs have a body awake and dynamic: no body is read for them)
                if dynamic[c.a as usize] || dynamic[c.b as usize] {
                    return false;
                }
                let (a, b) = (&bodies[c.a as usize], &bodies[c.b as usize]);
                // neither awake and dynamic, one of them asleep
                !a.is_mover() && !b.is_mover() && (a.asleep || b.asleep)
            };
            self.old_contacts.retain(|c| {
                let keep = !asleep_pair(c);
                if !keep {
                    sleeping.push(*c);
                }
                keep
            });
        }
        self.stamp = self.stamp.wrapping_add(1).max(1);
        self.touched.0.resize_with(bodies.len(), AtomicU32::default);
        let narrow = Narrow {
            bodies,
            pairs: if fused {
                self.broad.kept_pairs()
            } else {
                &self.broad.pairs
            },
            test: fused.then_some(PairTest {
                bodies,
                aabbs: &self.aabbs,
                dynamic: &self.dynamic,
                filtered: self.filtered,
                no_collide: &self.no_collide,
            }),
            old: &self.old_contacts,
            reach: &self.reach,
            reach_h: self.reach_h,
            has_sensors: self.has_sensors,
            speculative,
            margin,
            awake: &self.awake,
            touched: &self.touched.0,
            stamp: self.stamp,
        };
        let pairs = narrow.pairs.len();
        match pool {
            Some(pool) if pairs > PAIR_BLOCK => {
                // the caller writes the blocks it takes in order from the first straight
                // into the contact list (it takes its own share first, in order); every
                // other block goes into its own buffer, and the buffers are appended in
                // pair order, so the contacts are those of one thread
                // (finer at each share's end, so that the threads end close together)
                let starts = &mut self.narrow_blocks;
                parallel::tapered_blocks(pairs, pool.threads(), PAIR_BLOCK, starts);
                let starts = &starts[..];
                let blocks = starts.len() - 1;
                // room for a contact a pair from the start: a block the caller usually
                // writes in place may go through its buffer in any step, and a steady
                // step allocates nothing
                let outs = &*self.narrow_out.first(blocks, PAIR_BLOCK);
                // (the list, and the blocks written into it)
                let direct = Mutex::new((contacts, 0usize));
                let deepest = parallel::blocks_max(pool, blocks, &|t, b| {
                    let range = starts[b]..starts[b + 1];
                    if t == 0 {
                        let mut d = direct.lock().unwrap_or_else(|e| e.into_inner());
                        if d.1 == b {
                            d.1 += 1;
                            return narrow.run(range, d.0);
                        }
                    }
                    let mut out = outs[b].lock().unwrap_or_else(|e| e.into_inner());
                    out.clear();
                    narrow.run(range, &mut out)
                });
                let (contacts, written) = direct.into_inner().unwrap_or_else(|e| e.into_inner());
                parallel::concat(
                    Some(pool),
                    &mut self.narrow_out.0[..blocks],
                    written,
                    &mut self.narrow_starts,
                    contacts,
                );
                deepest
            }
            _ => narrow.run(0..narrow.pairs.len(), contacts),
        }
    }
}

/// The broad phase's box of a body whose shape's box is `bb`: grown by its motion over
/// `h` (a moving body's, so that fast bodies find their pairs) and by half the margin.
pub(crate) fn swept_box(b: &Body, bb: Aabb, h: f32, margin: f32) -> Aabb {
    let bb = if b.body_type != BodyType::Static {
        bb.swept(b.velocity * h)
    } else {
        bb
    };
    bb.fattened(0.5 * margin)
}

/// How many pairs ahead the narrow phase asks for the bodies it will read.
const PAIR_AHEAD: usize = 4;

/// What the narrow phase reads: the pairs of the broad phase and last step's contacts.
/// Whether a candidate pair is a pair this step: the broad phase's test (one body
/// moves, the boxes overlap) where `aabbs` is given, then the filters and the
/// no-collide list.
struct PairTest<'a> {
    bodies: &'a [Body],
    /// This step's boxes and movers; empty when the broad phase has tested them.
    aabbs: &'a [Aabb],
    dynamic: &'a [bool],
    /// Some body has a collision filter other than the default.
    filtered: bool,
    no_collide: &'a [(u32, u32)],
}

impl PairTest<'_> {
    /// The filters and the no-collide list (the broad phase's own test aside).
    #[inline]
    fn may_collide(&self, a: u32, b: u32) -> bool {
        (!self.filtered
            || self.bodies[a as usize]
                .filter
                .collides(&self.bodies[b as usize].filter))
            && (self.no_collide.is_empty()
                || self
                    .no_collide
                    .binary_search(&(a.min(b), a.max(b)))
                    .is_err())
    }

    /// The whole test, for a kept pair (debug checks).
    fn holds(&self, a: u32, b: u32) -> bool {
        BroadPhase::kept_pair_holds(self.aabbs, self.dynamic, a, b) && self.may_collide(a, b)
    }

    /// [`PairTest::holds`] for kept pairs asked in increasing order (a < b): `at` walks
    /// the no-collide list (sorted) beside them instead of a search per pair (in a pile
    /// of ragdolls, whose parts' boxes overlap at every joint, the search cost about 4%
    /// of the step).
    #[inline]
    fn holds_along(&self, a: u32, b: u32, at: &mut usize) -> bool {
        if !BroadPhase::kept_pair_holds(self.aabbs, self.dynamic, a, b)
            || (self.filtered
                && !self.bodies[a as usize]
                    .filter
                    .collides(&self.bodies[b as usize].filter))
        {
            return false;
        }
        let joined = &self.no_collide;
        while *at < joined.len() && joined[*at] < (a, b) {
            *at += 1;
        }
        let held = joined.get(*at) != Some(&(a, b));
        debug_assert_eq!(held, self.may_collide(a, b));
        held
    }
}

struct Narrow<'a> {
    bodies: &'a [Body],
    /// The pairs to collide: this step's, or (with `test`) the broad phase's kept pairs,
    /// which `test` filters.
    pairs: &'a [(u32, u32)],
    test: Option<PairTest<'a>>,
    /// Last step's contacts, sorted by pair (the cache).
    old: &'a [Contact],
    reach: &'a [(f32, f32)],
    reach_h: f32,
    has_sensors: bool,
    speculative: Speculative,
    margin: f32,
    /// The blocks of bodies the broad phase found awake: a kept pair whose first body's
    /// block sleeps is skipped with its block (see [`Narrow::run`]).
    awake: &'a AwakeMarks,
    /// Per body: the last narrow phase that found it a contact, written `stamp` here.
    touched: &'a [AtomicU32],
    stamp: u32,
}

impl Narrow<'_> {
    /// Marks bodies `a` and `b` as having a contact this step.
    #[inline]
    fn touch(&self, a: u32, b: u32) {
        // (relaxed: the threads write the same stamp, read after the job's end)
        self.touched[a as usize].store(self.stamp, Ordering::Relaxed);
        self.touched[b as usize].store(self.stamp, Ordering::Relaxed);
    }

    /// Collides the pairs of `range` (in order) and pushes the touching ones to `out`;
    /// returns the deepest overlap found (m, >= 0).
    fn run(&self, range: std::ops::Range<usize>, out: &mut Vec<Contact>) -> f32 {
        let pairs = &self.pairs[range];
        let Some(&first) = pairs.first() else {
            return 0.0;
        };
        // the cache from the first pair of the run on
        let from = self.old.partition_point(|c| (c.a, c.b) < first);
        let mut cache = CacheCursor::new(&self.old[from..]);
        // (the no-collide list is read along the pairs, from the run's first on)
        let mut joined_at = self
            .test
            .as_ref()
            .map_or(0, |t| t.no_collide.partition_point(|&p| p < first));
        let mut deepest = 0.0f32;
        let mut i = 0;
        while i < pairs.len() {
            let (a, b) = pairs[i];
            i += 1;
            if let Some(t) = &self.test {
                if !self.awake.is_awake(a as usize) {
                    // every body of a's block sleeps: no kept pair of a sleeper is a pair
                    // this step (the wake pass woke every island an awake body's box
                    // reaches), so the pairs from that block, and from the sleeping
                    // blocks after it, go by at once (sorted by their first body; found
                    // near, so a mostly sleeping world's pass reads its awake pairs only)
                    let next = self.awake.next_awake(a as usize);
                    let from = i - 1;
                    i = from + gallop(&pairs[from..], |p| (p.0 as usize) < next);
                    debug_assert!(pairs[from..i].iter().all(|&(a, b)| !t.holds(a, b)));
                    continue;
                }
                debug_assert!(a < b && pairs.get(i).is_none_or(|&p| (a, b) < p));
                if !t.holds_along(a, b, &mut joined_at) {
                    continue;
                }
            }
            if let Some(&(na, nb)) = pairs.get(i - 1 + PAIR_AHEAD) {
                prefetch(self.bodies, na as usize, SHAPE_BYTES);
                prefetch(self.bodies, nb as usize, SHAPE_BYTES);
            }
            let (ba, bb) = (&self.bodies[a as usize], &self.bodies[b as usize]);
            if self.has_sensors && (ba.sensor || bb.sensor) {
                // heard (World::events), never resolved
                continue;
            }
            let ((ra, sa), (rb, sb)) = (self.reach[a as usize], self.reach[b as usize]);
            let pair_margin = match self.speculative {
                // each body's own motion
                Speculative::MarginPlusMotion => self.margin + ra + rb,
                // the distance the pair can close in h: while it is a few margins, each
                // body's own motion (a generous bound that keeps a resting pile's points
                // under gravity); beyond that, fast bodies, their relative velocity and
                // each one's spin (bodies carried along together, as a stirred pile,
                // close slowly however fast they go: no point is kept for them)
                Speculative::MarginOrMotion => {
                    let own = ra + rb;
                    let closing = if own <= FAST_MARGINS * self.margin {
                        own
                    } else {
                        self.reach_h * (ba.velocity - bb.velocity).length() + sa + sb
                    };
                    self.margin.max(closing)
                }
            };
            if !(ba.parts.is_empty() && bb.parts.is_empty()) {
                // a compound: one manifold per pair of touching parts
                let old = cache.find_all(a, b);
                crate::compound::collide_bodies(
                    ba,
                    bb,
                    pair_margin,
                    |mut m, friction, restitution| {
                        for o in old {
                            match_points(&o.manifold, &mut m);
                        }
                        for p in m.points() {
                            deepest = deepest.max(-p.separation);
                        }
                        self.touch(a, b);
                        out.push(Contact {
                            a,
                            b,
                            manifold: m,
                            friction,
                            restitution,
                        });
                    },
                );
                continue;
            }
            let mut m = sat::collide(
                &ba.shape,
                &ba.transform(),
                &bb.shape,
                &bb.transform(),
                pair_margin,
            );
            if m.count == 0 {
                continue;
            }
            if let Some(old) = cache.find(a, b) {
                match_points(old, &mut m);
            }
            for p in m.points() {
                deepest = deepest.max(-p.separation);
            }
            self.touch(a, b);
            out.push(Contact {
                a,
                b,
                manifold: m,
                // mu = sqrt(mu_a mu_b), e = max(e_a, e_b)
                friction: (ba.friction * bb.friction).sqrt(),
                restitution: ba.restitution.max(bb.restitution),
            });
        }
        deepest
    }
}
