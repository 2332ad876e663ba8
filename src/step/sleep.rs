//! Sleeping and islands. After a step, a dynamic body none of whose points moves faster
//! than its sleep threshold (0.05 m/s unless it sets its own: its speed plus its spin
//! times its reach, as Box2D v3 measures it) for 0.5 s is at rest; an island (bodies
//! joined by joints and by contacts whose boxes are within the margin, found by
//! union-find, and kept from pass to pass while the contacts, the joints and the bodies
//! stay as they were) falls asleep when all of its bodies are. A sleeping body is left out of the step: its contacts are kept aside with
//! their impulses, and its joints are parked out of the solve. Before each collide,
//! every sleeping island an awake body's (or a moving kinematic body's) box reaches
//! wakes, with its kept contacts put back in the cache so they start warm.

use crate::awake::{AwakeMarks, RestBlocks, each_awake};
use crate::body::Body;
use crate::collision::Contact;
use crate::collision::collide::{Collider, swept_box};
use crate::defs::{BodyType, SolverSettings};
use crate::joint::{Joint, MouseJoint};
use crate::math::{AWAKE_BLOCK, Aabb, BODY_PASS_BLOCK, Vec2, uf_root, uf_union};
use crate::parallel::{self, Disjoint, Pool};
use crate::step::integrate::PointForce;
use std::sync::Mutex;

/// An island that rested this long (s) falls asleep.
const TIME_TO_SLEEP: f32 = 0.5;

/// The waking pass looks through a grid of the sleepers' boxes alone where every body
/// is at least this many sleepers (else through a grid of every box).
const SLEEPERS_GRID: usize = 4;

/// A test's view of the waking pass's grids.
#[cfg(test)]
pub(crate) mod testing {
    use std::cell::Cell;

    thread_local! {
        /// Every waking pass looks through a grid of every box (never the sleepers').
        pub(crate) static EVERY_BOX: Cell<bool> = const { Cell::new(false) };
        /// Waking passes that found their pairs through a grid of the sleepers' boxes.
        pub(crate) static SLEEPERS_GRIDS: Cell<usize> = const { Cell::new(0) };
        /// Every sleep pass finds its islands afresh (never keeps them).
        pub(crate) static FRESH_ISLANDS: Cell<bool> = const { Cell::new(false) };
        /// Sleep passes that used the islands kept from the last.
        pub(crate) static KEPT_PASSES: Cell<usize> = const { Cell::new(0) };
    }
}

/// The sleeping islands' contacts and parked joints, and the sleep pass's scratch.
#[derive(Clone, Debug, Default)]
pub(crate) struct Sleep {
    /// The contacts of sleeping islands, kept with their impulses for when they wake.
    pub(crate) contacts: Vec<Contact>,
    /// Union-find parents of the sleep pass (scratch).
    islands: Vec<u32>,
    /// The islands as the contacts and joints joined them, kept while those stay.
    kept: KeptIslands,
    /// What each body is to the islands (scratch of the sleep pass; the sleeping
    /// blocks' entries are stale).
    kinds: Vec<Kind>,
    /// Islands to wake (scratch).
    to_wake: Vec<u32>,
    /// What the waking pass reads of each body, side by side (scratch).
    wake_bodies: WakeBodies,
    /// Joints whose bodies all sleep (or do not move), each with the index it was
    /// taken from, taken out of the world's joints for the solve of one step, in the
    /// order they were taken (see [`Sleep::park_joints`]).
    parked: Vec<(usize, Joint)>,
    /// Whether no body is asleep and no contact is kept aside in this step: known at its
    /// start (see `awake_at`), else found by its collide. Then none is asleep at the
    /// step's end either (only [`Sleep::update`] puts bodies to sleep), so the end of the
    /// step need not look again.
    pub(crate) none_asleep: bool,
    /// The bodies' edit count (`World::edits`) as the last step ended with no body
    /// asleep and no contact kept aside: while the bodies are not edited (an added or
    /// restored body may sleep), none is asleep until a sleep pass puts one to sleep,
    /// and the next collide need not look.
    pub(crate) awake_at: Option<u64>,
    /// The blocks of bodies that slept through the last step, which the wake pass and
    /// the broad phase skip (see [`RestBlocks`]).
    pub(crate) rest: RestBlocks,
    /// Each body's reach, the farthest its shape's points lie from its centre (the
    /// spin's part of the sleep test, as Box2D's `maxExtent`), found once for the
    /// bodies as they are at `reach_for`: (the bodies' edit count, their number).
    reach: Vec<f32>,
    reach_for: Option<(u64, usize)>,
}

/// What the waking pass reads of the bodies, in arrays of their own (the bodies are
/// large, and its grid asks of every pair it finds). A rest block's entries hold from
/// the step it was visited, as the collider's boxes do.
#[derive(Clone, Debug, Default)]
struct WakeBodies {
    /// Which bodies size the grid: the dynamic ones, asleep or not.
    sized: Vec<bool>,
    /// Which bodies are asleep.
    asleep: Vec<bool>,
    /// The sleepers, in increasing order.
    sleepers: Vec<u32>,
    /// What each block of [`BODY_PASS_BLOCK`] bodies of the pass over the boxes found.
    found: parallel::Scratch<Mutex<BoxesFound>>,
}

/// What one block of bodies of [`Sleep::find_boxes`]'s pass found.
#[derive(Debug, Default)]
struct BoxesFound {
    /// The box holding each mover's box.
    reach: Option<Aabb>,
    /// Its sleepers, in increasing order.
    sleepers: Vec<u32>,
    /// The islands of its sleepers pushed since they fell asleep.
    pushed: Vec<u32>,
    /// The bounds of the sleepers of each of its awake blocks that does not rest.
    loose: Vec<Aabb>,
}

/// Whether some body is asleep: a pass over the bodies (large), split between the
/// threads.
pub(crate) fn any_asleep(bodies: &[Body], pool: Option<&Pool>) -> bool {
    parallel::ranges_max(pool, bodies.len(), BODY_PASS_BLOCK, &|_, r| {
        if bodies[r].iter().any(|b| b.asleep) {
            1.0
        } else {
            0.0
        }
    }) > 0.0
}

impl Sleep {
    /// Wakes every sleeping body of `island` and puts its kept contacts back in
    /// `contacts` (the cache), so they start warm.
    pub(crate) fn wake_island(
        &mut self,
        bodies: &mut [Body],
        contacts: &mut Vec<Contact>,
        island: u32,
    ) {
        let mut one = std::mem::take(&mut self.to_wake);
        one.clear();
        one.push(island);
        self.wake_islands(bodies, contacts, &mut one);
        self.to_wake = one;
    }

    /// Wakes the sleeping islands labelled in `islands` (any order, repeats allowed) in
    /// one pass over the bodies and the kept contacts, with the kept contacts of every
    /// pair no longer asleep put back in `contacts` (the cache, sorted by pair), so
    /// they start warm.
    pub(crate) fn wake_islands(
        &mut self,
        bodies: &mut [Body],
        contacts: &mut Vec<Contact>,
        islands: &mut Vec<u32>,
    ) {
        islands.sort_unstable();
        islands.dedup();
        if islands.is_empty() {
            return;
        }
        for (i, b) in bodies.iter_mut().enumerate() {
            if b.asleep && islands.binary_search(&b.island).is_ok() {
                self.rest.wake(i);
                b.asleep = false;
                b.sleep_time = 0.0;
                b.rest_box = None;
            }
        }
        let (mut back, mut kept) = (Vec::new(), Vec::new());
        for c in self.contacts.drain(..) {
            if bodies[c.a as usize].asleep || bodies[c.b as usize].asleep {
                kept.push(c);
            } else {
                back.push(c);
            }
        }
        self.contacts = kept;
        if !back.is_empty() {
            // the cache is read as one list sorted by pair
            contacts.extend(back);
            contacts.sort_by_key(|c| (c.a, c.b));
        }
    }

    /// Waking: every sleeping island that an awake dynamic body's (or a moving kinematic
    /// body's) box reaches, or whose body was pushed, set moving or given a force since
    /// it fell asleep; then every island those reach, and so on until none wakes. The
    /// broad phase's pairs and the collider's boxes are its scratch.
    ///
    /// Each round looks only from the bodies the round before woke (the others' reach
    /// was looked at already), through one grid of every body's box (boxes do not
    /// change while waking), and wakes that round's islands in one pass
    /// ([`Sleep::wake_islands`]): the same bodies wake, with the same contacts in the
    /// same order, as round after round of looking from every awake body. Where the
    /// sleepers are few beside the bodies (a world mostly awake), the first round's
    /// grid holds the sleepers' boxes alone, and every other box looks into it: the
    /// same pairs, without a grid of every box a step.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn wake_reached(
        &mut self,
        bodies: &mut [Body],
        contacts: &mut Vec<Contact>,
        joints: &[Joint],
        collider: &mut Collider,
        h: f32,
        margin: f32,
        pool: Option<&Pool>,
    ) {
        let mut wake = std::mem::take(&mut self.to_wake);
        wake.clear();
        // (one pass: the boxes, and the sleepers pushed since they fell asleep)
        self.rest.begin(bodies.len(), h, margin);
        let (mut movers, reachable) = Self::find_boxes(
            bodies,
            collider,
            &mut self.rest,
            &mut self.wake_bodies,
            &mut wake,
            h,
            margin,
            pool,
        );
        let mut first = true;
        loop {
            // (nothing awake moves in the first round: nothing can reach a sleeping island;
            // its grid only where a mover's box may reach a sleeper)
            if movers && (reachable || !first) {
                let WakeBodies {
                    sized,
                    asleep,
                    sleepers,
                    ..
                } = &self.wake_bodies;
                let (aabbs, look) = (&collider.aabbs, &collider.dynamic);
                // a sleeper and a body that looks for sleepers (a mover, in the first
                // round: every one of them looks; in a later one, one that was found
                // then would have woken the sleeper)
                let reaches = |a: u32, b: u32| {
                    let (a, b) = (a as usize, b as usize);
                    (asleep[a] && look[b]) || (asleep[b] && look[a])
                };
                // (a rest block's bounds: its sleepers no mover's box reaches go by whole)
                let bounds = self.rest.bounds();
                // where the sleepers are few beside the movers (a world mostly awake),
                // the movers look into a grid of the sleepers' boxes alone, not into one
                // of every box: the same pairs
                let few = first && SLEEPERS_GRID * sleepers.len() <= aabbs.len();
                #[cfg(test)]
                let few = few && !testing::EVERY_BOX.with(std::cell::Cell::get);
                let found = few
                    && collider
                        .broad
                        .find_pairs_of_some(aabbs, sleepers, asleep, bounds, reaches, pool);
                #[cfg(test)]
                if found {
                    testing::SLEEPERS_GRIDS.with(|c| c.set(c.get() + 1));
                }
                if !found {
                    collider
                        .broad
                        .find_pairs_sized(aabbs, look, sized, bounds, reaches, pool);
                }
                for &(a, b) in &collider.broad.pairs {
                    for i in [a as usize, b as usize] {
                        if asleep[i] {
                            wake.push(bodies[i].island);
                        }
                    }
                }
            }
            if movers {
                // a joint to a body that moves (one to a static anchor keeps it asleep)
                // (as above: in a later round, a mover found in the first would have
                // woken the sleeper)
                let (asleep, look) = (&self.wake_bodies.asleep, &collider.dynamic);
                for j in joints {
                    if asleep[j.a] && look[j.b] {
                        wake.push(bodies[j.a].island);
                    }
                    if asleep[j.b] && look[j.a] {
                        wake.push(bodies[j.b].island);
                    }
                }
            }
            first = false;
            wake.sort_unstable();
            wake.dedup();
            if wake.is_empty() {
                break;
            }
            // the next round looks from the bodies this one wakes (with no mover in the
            // first round, a pushed sleeper's)
            let asleep = &mut self.wake_bodies.asleep;
            for ((look, b), asleep) in collider.dynamic.iter_mut().zip(bodies.iter()).zip(asleep) {
                *look = *asleep && wake.binary_search(&b.island).is_ok();
                *asleep &= !*look;
            }
            self.wake_islands(bodies, contacts, &mut wake);
            movers = true;
            wake.clear();
        }
        self.to_wake = wake;
    }

    /// Every body's swept box of this step into the collider's boxes (found there by
    /// its broad phase too), whether it looks for sleepers (a mover) into its flags, and
    /// whether it sizes the grid's cells (a dynamic body, asleep or not: a few large
    /// movers must not put many small sleepers in one cell) into `sized`; the island of
    /// each sleeper pushed, set moving or given a force since it fell asleep into
    /// `pushed`; whether it sleeps, and the sleepers in order, into `wake_bodies`. With a
    /// pool the threads share the bodies, block by block, and the findings are read back
    /// in block order (the same as on one thread). A sleeper's box is found once and kept
    /// with it until it wakes; the
    /// `rest` blocks' entries are kept as they are (their bounds found once). Returns
    /// whether some body moves (a mover), and whether a mover's box may reach a
    /// sleeper: the bounds of some block's sleepers (a rest block's, or those of the
    /// sleepers in a block that does not rest) meet the box holding every mover's box
    /// (else no grid need look, and sleepers far from every mover cost nothing).
    #[allow(clippy::too_many_arguments)]
    fn find_boxes(
        bodies: &mut [Body],
        collider: &mut Collider,
        rest: &mut RestBlocks,
        wake_bodies: &mut WakeBodies,
        pushed: &mut Vec<u32>,
        h: f32,
        margin: f32,
        pool: Option<&Pool>,
    ) -> (bool, bool) {
        let n = bodies.len();
        // sized, not cleared: a rest block's entries hold from the step it was visited
        collider.aabbs.resize(n, crate::math::Aabb::default());
        collider.dynamic.resize(n, false);
        let WakeBodies {
            sized,
            asleep,
            sleepers: listed,
            found,
        } = wake_bodies;
        sized.resize(n, false);
        asleep.resize(n, false);
        let found = &*found.first_with(n.div_ceil(BODY_PASS_BLOCK), BoxesFound::default);
        let (all, aabbs, movers, sizes, sleeps) = (
            Disjoint::new(bodies),
            Disjoint::new(&mut collider.aabbs[..]),
            Disjoint::new(&mut collider.dynamic[..]),
            Disjoint::new(&mut sized[..]),
            Disjoint::new(&mut asleep[..]),
        );
        let shared_rest = &*rest;
        // the blocks of bodies between the threads, each into its own entry of `found`
        parallel::ranges_max(pool, n, BODY_PASS_BLOCK, &|_, r| {
            let mut out = found[r.start / BODY_PASS_BLOCK]
                .lock()
                .unwrap_or_else(|e| e.into_inner());
            let BoxesFound {
                reach,
                sleepers: listed,
                pushed,
                loose,
            } = &mut *out;
            *reach = None;
            listed.clear();
            pushed.clear();
            loose.clear();
            for start in r.step_by(AWAKE_BLOCK) {
                let end = (start + AWAKE_BLOCK).min(n);
                // SAFETY: each block of the pass takes only its own range of each slice
                let (bodies, aabbs, movers, sizes, sleeps) = unsafe {
                    (
                        all.range(start..end),
                        aabbs.range(start..end),
                        movers.range(start..end),
                        sizes.range(start..end),
                        sleeps.range(start..end),
                    )
                };
                if shared_rest.is_rest(start / AWAKE_BLOCK) {
                    #[cfg(debug_assertions)]
                    for (i, b) in bodies.iter().enumerate() {
                        let i = start + i;
                        assert!(
                            b.asleep && b.is_still(),
                            "a rest block's body {i} sleeps still (asleep {}, v {}, w {}, force {})",
                            b.asleep,
                            b.velocity,
                            b.angular_velocity,
                            b.force
                        );
                        let bb = b.rest_box.expect("a rest block's sleeper keeps its box");
                        assert!(bb == b.aabb(), "a sleeper's kept box is its box");
                        let k = i - start;
                        assert!(aabbs[k] == swept_box(b, bb, h, margin));
                        assert!(!movers[k] && sizes[k] == b.is_dynamic());
                        assert!(sleeps[k]);
                    }
                    listed.extend(start as u32..end as u32);
                    continue;
                }
                let mut sleepers: Option<Aabb> = None;
                for (i, (((b, bx), (mover, size)), sleeps)) in bodies
                    .iter_mut()
                    .zip(aabbs.iter_mut())
                    .zip(movers.iter_mut().zip(sizes.iter_mut()))
                    .zip(sleeps.iter_mut())
                    .enumerate()
                {
                    if b.asleep && !b.is_still() {
                        pushed.push(b.island);
                    }
                    // (an awake body's box is found afresh: its kept one, far into the
                    // body, is not read)
                    let bb = if !b.asleep {
                        b.aabb()
                    } else if let Some(bb) = b.rest_box {
                        debug_assert!(bb == b.aabb(), "a sleeper's kept box is its box");
                        bb
                    } else {
                        *b.rest_box.insert(b.aabb())
                    };
                    *bx = swept_box(b, bb, h, margin);
                    *mover = b.is_mover();
                    *sleeps = b.asleep;
                    if b.asleep {
                        listed.push((start + i) as u32);
                        sleepers = Some(sleepers.map_or(*bx, |s| s.union(bx)));
                    }
                    if *mover {
                        *reach = Some(reach.map_or(*bx, |r| r.union(bx)));
                    }
                    *size = b.is_dynamic();
                }
                loose.extend(sleepers);
            }
            0.0
        });
        // the blocks' findings in block order; the box holding every mover's box; the
        // bounds of the sleepers of each awake block outside the rest blocks
        let mut reach: Option<Aabb> = None;
        let mut loose = std::mem::take(&mut rest.loose);
        loose.clear();
        listed.clear();
        for out in found {
            let out = out.lock().unwrap_or_else(|e| e.into_inner());
            reach = match (reach, out.reach) {
                (Some(a), Some(b)) => Some(a.union(&b)),
                (a, b) => a.or(b),
            };
            listed.extend_from_slice(&out.sleepers);
            pushed.extend_from_slice(&out.pushed);
            loose.extend_from_slice(&out.loose);
        }
        // a rest block's bounds, found once
        for (k, start) in (0..n).step_by(AWAKE_BLOCK).enumerate() {
            if rest.is_rest(k) {
                rest.bound(k, &collider.aabbs[start..(start + AWAKE_BLOCK).min(n)]);
            }
        }
        collider.boxes_found = true;
        let reachable = reach.is_some_and(|r| {
            let mut sleepers = loose.iter().chain(rest.bounds().iter().flatten());
            sleepers.any(|b| b.overlaps(&r))
        });
        rest.loose = loose;
        (reach.is_some(), reachable)
    }

    /// Takes the joints whose bodies all sleep or do not move out of `joints` for this
    /// step's solve: a sleeping island's joints cost nothing, and their warm-started
    /// impulses (which balanced a gravity the sleeping bodies no longer get) do not push
    /// the island awake. Called after the wake passes; [`Sleep::unpark_joints`] puts
    /// them back where they were after the solve. Each parked joint's place is taken by
    /// the list's last joint (from the highest index down), so a step moves two joints
    /// for each parked one, not the whole list: the solve's order is the world's but for
    /// the joints moved into the gaps. A step that collides every substep parks again
    /// each time (none more, in practice: no body comes to rest within a step); every
    /// parking is undone at the step's end, the last first.
    pub(crate) fn park_joints(&mut self, bodies: &[Body], joints: &mut Vec<Joint>) {
        let resting = |i: usize| {
            let b = &bodies[i];
            b.asleep || b.body_type == BodyType::Static || (!b.is_dynamic() && !b.is_mover())
        };
        for i in (0..joints.len()).rev() {
            if resting(joints[i].a) && resting(joints[i].b) {
                self.parked.push((i, joints.swap_remove(i)));
            }
        }
    }

    /// Puts the parked joints back where they were: each parking undone, the last
    /// first.
    pub(crate) fn unpark_joints(&mut self, joints: &mut Vec<Joint>) {
        for (i, j) in self.parked.drain(..).rev() {
            if i == joints.len() {
                joints.push(j);
            } else {
                let moved = std::mem::replace(&mut joints[i], j);
                joints.push(moved);
            }
        }
    }

    /// After a step: a dynamic body none of whose points moves faster than its sleep
    /// threshold for 0.5 s is at rest; an island of bodies joined by contacts (boxes
    /// within the margin) and joints falls asleep when all of its bodies are. Bodies held by the mouse, with
    /// a constant force, on a joint with a turning motor or a drive, or touching a
    /// moving kinematic body stay awake. With sleeping off, every sleeping island wakes.
    /// Returns whether it is known, without a pass over the bodies, that none is asleep
    /// and no contact is kept aside now.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn update(
        &mut self,
        bodies: &mut [Body],
        contacts: &mut Vec<Contact>,
        joints: &[Joint],
        forces: &[PointForce],
        mouse: Option<&MouseJoint>,
        settings: &SolverSettings,
        awake: &AwakeMarks,
        edits: u64,
        pool: Option<&Pool>,
    ) -> bool {
        if !settings.sleep {
            self.rest.forget();
            if !self.none_asleep && (bodies.iter().any(|b| b.asleep) || !self.contacts.is_empty()) {
                let mut islands: Vec<u32> = bodies
                    .iter()
                    .filter(|b| b.asleep)
                    .map(|b| b.island)
                    .collect();
                self.wake_islands(bodies, contacts, &mut islands);
            }
            return self.contacts.is_empty();
        }
        // (before anything falls asleep: a block that falls asleep now rests from the
        // step after next)
        self.rest.keep(awake);
        let dt = settings.dt;
        let n = bodies.len();
        // the reaches, found again only after an edit (a shape of many vertices takes a
        // square root for each)
        if self.reach_for != Some((edits, n)) {
            self.reach.resize(n, 0.0);
            let all = &*bodies;
            parallel::chunks_mut(pool, &mut self.reach, BODY_PASS_BLOCK, &|_, at, r| {
                for (re, b) in r.iter_mut().zip(&all[at..]) {
                    *re = b.shape.radius();
                }
                0.0
            });
            self.reach_for = Some((edits, n));
        }
        // the blocks where every body sleeps hold no timer to run and none to read;
        // the same pass notes what each body is to the islands (the sleeping blocks'
        // entries are not written: no contact reaches a sleeper)
        let blocks = awake.blocks();
        let kinds = &mut self.kinds;
        kinds.resize(n, Kind::Asleep);
        // (the blocks of bodies between the threads: each body's timer and kind are its own)
        let (all, shared_kinds, reach) = (
            Disjoint::new(&mut bodies[..]),
            Disjoint::new(&mut kinds[..]),
            &self.reach[..],
        );
        let pushers = parallel::ranges_max(pool, n, BODY_PASS_BLOCK, &|_, r| {
            let mut pushers = false;
            each_awake(blocks, r, |r| {
                // SAFETY: each block takes only its own range of each slice
                let reach = &reach[r.clone()];
                let (bodies, kinds) = unsafe { (all.range(r.clone()), shared_kinds.range(r)) };
                for ((b, k), &r) in bodies.iter_mut().zip(kinds).zip(reach) {
                    if b.is_dynamic() && !b.asleep {
                        let linear = b.sleep_threshold;
                        let slow = b.velocity.length() + (b.angular_velocity * r).abs() < linear;
                        b.sleep_time = if slow { b.sleep_time + dt } else { 0.0 };
                    }
                    *k = Kind::of(b);
                    // (a kinematic body never sleeps: its block is awake)
                    pushers |= *k == Kind::Pushing;
                }
            });
            if pushers { 1.0 } else { 0.0 }
        }) > 0.0;
        #[cfg(debug_assertions)]
        for (i, b) in bodies.iter().enumerate() {
            assert!(
                b.asleep || awake.is_awake(i),
                "an awake body {i} in a sleeping block"
            );
        }
        // (the contacts' kinds are read from `kinds`: a sleeper's contacts are kept
        // aside, so none reaches a sleeping block, whose entries are not written)
        debug_assert!(
            contacts
                .iter()
                .all(|c| awake.is_awake(c.a as usize) && awake.is_awake(c.b as usize))
        );
        // what keeps a body awake whatever its speed
        let hold = |bodies: &mut [Body], kinds: &mut [Kind], i: usize| {
            bodies[i].sleep_time = 0.0;
            kinds[i] = Kind::of(&bodies[i]);
        };
        for f in forces {
            hold(bodies, kinds, f.body);
        }
        if let Some(m) = mouse {
            hold(bodies, kinds, m.body);
        }
        // a joint that drives its bodies keeps them awake: a turning motor, a drive
        // force or torque (a servo at its target rests, and may sleep)
        for j in joints {
            if j.drive != 0.0 || j.motor.is_some_and(|m| m.speed != 0.0) {
                hold(bodies, kinds, j.a);
                hold(bodies, kinds, j.b);
            }
        }
        // a moving kinematic body keeps what it touches awake (looked for only where
        // one moves)
        if pushers {
            for c in contacts.iter() {
                let (a, b) = (c.a as usize, c.b as usize);
                if kinds[a] == Kind::Pushing {
                    hold(bodies, kinds, b);
                } else if kinds[b] == Kind::Pushing {
                    hold(bodies, kinds, a);
                }
            }
        }
        let kinds = &self.kinds;
        let mut ready = false;
        each_awake(blocks, 0..n, |r| {
            ready |= kinds[r].contains(&Kind::Rested);
        });
        if !ready {
            return self.none_asleep;
        }
        // (a joint's bodies may both sleep, in a sleeping block, whose kinds were not
        // written: those are read from the bodies)
        let kind = |i: usize| {
            if awake.is_awake(i) {
                debug_assert_eq!(kinds[i], Kind::of(&bodies[i]));
                kinds[i]
            } else {
                Kind::of(&bodies[i])
            }
        };
        // the same contacts and joints as at the last sleep pass, and the same bodies:
        // the islands found then hold (kept from the second pass in a row over the
        // same, as Box2D keeps its islands from step to step), and a pass over the awake
        // bodies tells which hold a restless body
        let kept = &mut self.kept;
        let same = kept.holds(contacts, joints, (edits, n), pool);
        #[cfg(test)]
        let same = same && !testing::FRESH_ISLANDS.with(std::cell::Cell::get);
        #[cfg(test)]
        testing::KEPT_PASSES.with(|c| c.set(c.get() + usize::from(same)));
        let falls: Vec<(usize, u32)>;
        if same {
            if kept.roots.is_empty() {
                kept.find(n, kinds, &kind, contacts.len(), &mut self.islands);
            }
            falls = kept.falling(kinds, blocks);
            #[cfg(debug_assertions)]
            {
                let mut parent = Vec::new();
                let nc = contacts.len();
                let fresh = fresh_islands(&mut parent, &kept.edges, nc, kinds, &kind, blocks);
                assert_eq!(
                    falls, fresh,
                    "the kept islands put the same bodies to sleep"
                );
            }
        } else {
            // (over the list `holds` has just kept: the contacts are read once more, not
            // twice)
            let nc = contacts.len();
            falls = fresh_islands(&mut self.islands, &kept.edges, nc, kinds, &kind, blocks);
        }
        for &(i, island) in &falls {
            let b = &mut bodies[i];
            b.asleep = true;
            b.rest_box = None;
            b.island = island;
            b.velocity = Vec2::ZERO;
            b.angular_velocity = 0.0;
        }
        self.none_asleep && falls.is_empty()
    }
}

/// The rested bodies that fall asleep, each with its island (its least body), in body
/// order, from islands found afresh: union-find over the dynamic bodies joined by
/// contacts and joints (`edges`: the first `contacts` a contact's bodies, then a
/// joint's). An island falls asleep when none of its awake bodies is restless, so every
/// restless body stands for one node (`restless`, after the bodies), and a contact or
/// joint between two restless bodies is passed over: in a heap where most bodies still
/// move, most joins are. An island with no restless body is found whole, with the same
/// root (its least body) as a union-find over every contact; one with a restless body
/// is joined to that node and stays awake. `parent`: scratch.
fn fresh_islands(
    parent: &mut Vec<u32>,
    edges: &[(u32, u32)],
    contacts: usize,
    kinds: &[Kind],
    kind: &dyn Fn(usize) -> Kind,
    blocks: &[bool],
) -> Vec<(usize, u32)> {
    let n = kinds.len();
    let restless = n as u32;
    parent.clear();
    parent.extend(0..=restless);
    let node = |i: u32, k: Kind| if k == Kind::Restless { restless } else { i };
    // every pair of the contact cache (boxes within the margin): a pair close enough
    // that an awake body would wake the other is one island, or two such bodies could
    // take turns waking each other forever
    for ((a, ka), (b, kb)) in edge_kinds(edges, contacts, kinds, kind) {
        if ka.joins() && kb.joins() && (ka, kb) != (Kind::Restless, Kind::Restless) {
            uf_union(parent, node(a, ka), node(b, kb));
        }
    }
    let held = uf_root(parent, restless);
    let mut falls = Vec::new();
    each_awake(blocks, 0..n, |r| {
        for i in r.filter(|&i| kinds[i] == Kind::Rested) {
            let root = uf_root(parent, i as u32);
            if root != held {
                falls.push((i, root));
            }
        }
    });
    falls
}

/// Each edge's two bodies with their kinds: a contact's (the first `contacts` edges)
/// read from `kinds`, a joint's from `kind` (its bodies may sleep, whose kinds in
/// `kinds` are stale).
fn edge_kinds<'a>(
    edges: &'a [(u32, u32)],
    contacts: usize,
    kinds: &'a [Kind],
    kind: &'a dyn Fn(usize) -> Kind,
) -> impl Iterator<Item = ((u32, Kind), (u32, Kind))> + 'a {
    let (by_contact, by_joint) = edges.split_at(contacts);
    let by_contact =
        (by_contact.iter()).map(|&(a, b)| ((a, kinds[a as usize]), (b, kinds[b as usize])));
    let by_joint = (by_joint.iter()).map(|&(a, b)| ((a, kind(a as usize)), (b, kind(b as usize))));
    by_contact.chain(by_joint)
}

/// The islands of the last sleep passes, kept while the contacts, the joints and the
/// bodies stay as they were.
#[derive(Clone, Debug, Default)]
struct KeptIslands {
    /// Each contact's bodies, then each joint's, at the last sleep pass.
    edges: Vec<(u32, u32)>,
    /// The bodies' edit count and number at the last sleep pass.
    bodies: Option<(u64, usize)>,
    /// Each body's island over `edges`: the least body of its set (empty until found).
    roots: Vec<u32>,
    /// Per island root: whether it holds a restless body (scratch).
    held: Vec<bool>,
}

/// Contacts to a block of the pass that compares them with the kept ones.
const EDGE_BLOCK: usize = 2048;

impl KeptIslands {
    /// Whether the contacts, joints and bodies (`bodies`: edit count and number) are
    /// the last pass's; else they are kept for the next, and the islands forgotten.
    fn holds(
        &mut self,
        contacts: &[Contact],
        joints: &[Joint],
        bodies: (u64, usize),
        pool: Option<&Pool>,
    ) -> bool {
        let nc = contacts.len();
        let edges = &self.edges;
        let same = self.bodies == Some(bodies)
            && edges.len() == nc + joints.len()
            && (joints.iter().zip(&edges[nc..])).all(|(j, &e)| (j.a as u32, j.b as u32) == e)
            && parallel::ranges_max(pool, nc, EDGE_BLOCK, &|_, r| {
                let differs =
                    (contacts[r.clone()].iter().zip(&edges[r])).any(|(c, &e)| (c.a, c.b) != e);
                if differs { 1.0 } else { 0.0 }
            }) <= 0.0;
        if !same {
            self.edges.clear();
            self.edges.extend(contacts.iter().map(|c| (c.a, c.b)));
            self.edges
                .extend(joints.iter().map(|j| (j.a as u32, j.b as u32)));
            self.bodies = Some(bodies);
            self.roots.clear();
        }
        same
    }

    /// Finds each body's island over the kept contacts (the first `contacts` edges)
    /// and joints, every join between two dynamic bodies made. `parent`: scratch.
    fn find(
        &mut self,
        n: usize,
        kinds: &[Kind],
        kind: &dyn Fn(usize) -> Kind,
        contacts: usize,
        parent: &mut Vec<u32>,
    ) {
        parent.clear();
        parent.extend(0..n as u32);
        for ((a, ka), (b, kb)) in edge_kinds(&self.edges, contacts, kinds, kind) {
            if ka.joins() && kb.joins() {
                uf_union(parent, a, b);
            }
        }
        self.roots.clear();
        self.roots.extend((0..n as u32).map(|i| uf_root(parent, i)));
    }

    /// The rested bodies that fall asleep, each with its island, in body order: those
    /// whose island holds no restless body.
    fn falling(&mut self, kinds: &[Kind], blocks: &[bool]) -> Vec<(usize, u32)> {
        let (roots, held) = (&self.roots, &mut self.held);
        held.clear();
        held.resize(kinds.len(), false);
        each_awake(blocks, 0..kinds.len(), |r| {
            for i in r.filter(|&i| kinds[i] == Kind::Restless) {
                held[roots[i] as usize] = true;
            }
        });
        let mut falls = Vec::new();
        each_awake(blocks, 0..kinds.len(), |r| {
            for i in r.filter(|&i| kinds[i] == Kind::Rested) {
                let root = roots[i];
                if !held[root as usize] {
                    falls.push((i, root));
                }
            }
        });
        falls
    }
}

/// What a body is to the sleep pass's islands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Static, or kinematic and still: joins no island.
    Apart,
    /// Kinematic and moving: joins no island, keeps what it touches awake.
    Pushing,
    /// Asleep (dynamic): joins its island, holds nothing back.
    Asleep,
    /// Awake and rested long enough to sleep.
    Rested,
    /// Awake and not yet rested long enough: its island stays awake.
    Restless,
}

impl Kind {
    fn of(b: &Body) -> Kind {
        if !b.is_dynamic() {
            if kinematic_moving(b) {
                Kind::Pushing
            } else {
                Kind::Apart
            }
        } else if b.asleep {
            Kind::Asleep
        } else if b.sleep_time >= TIME_TO_SLEEP {
            Kind::Rested
        } else {
            Kind::Restless
        }
    }

    /// Whether the body is a node of the islands (a dynamic body).
    fn joins(self) -> bool {
        !matches!(self, Kind::Apart | Kind::Pushing)
    }
}

/// Whether `b` is a kinematic body that moves (it keeps what it touches awake).
fn kinematic_moving(b: &Body) -> bool {
    b.body_type == BodyType::Kinematic && (b.velocity != Vec2::ZERO || b.angular_velocity != 0.0)
}

/// Whether a step would change nothing: every dynamic body asleep and still (nothing to
/// wake it: see [`Sleep::wake_reached`]), no kinematic body moving, no contact awake (the
/// step before put them aside), no point force and no mouse joint. Such a step needs no
/// solver: the bodies stay as they are, to the bit.
pub(crate) fn at_rest(
    bodies: &[Body],
    contacts: &[Contact],
    forces: &[PointForce],
    mouse: Option<MouseJoint>,
) -> bool {
    contacts.is_empty()
        && forces.is_empty()
        && mouse.is_none()
        && bodies
            .iter()
            .all(|b| !b.is_mover() && (!b.asleep || b.is_still()))
}

#[cfg(test)]
mod tests {
    use super::testing::{FRESH_ISLANDS, KEPT_PASSES};
    use crate::{SolverSettings, World};

    /// Two stacks settle: the first falls asleep, and the second is held awake by a
    /// kinematic disc spinning against its top box while the rest of it has rested (so
    /// every pass looks for its islands). The islands kept from pass to pass decide as
    /// islands found afresh at every pass do, to the bit, on one thread and on two; the
    /// first stack sleeps as one island named by its least body.
    #[test]
    fn kept_islands_put_bodies_to_sleep_as_islands_found_afresh_do() {
        let scene = "name = \"two stacks\"\n[world]\ngravity = [0.0, -10.0]\n[solver]\nkind = \"soft\"\nsleep = true\n\
             [[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [40.0, 1.0] }\nposition = [0.0, -0.5]\n\
             [[stack]]\ncount = 6\nbox = [1.0, 1.0]\norigin = [-5.0, 0.0]\n\
             [[stack]]\ncount = 4\nbox = [1.0, 1.0]\norigin = [5.0, 0.0]\n\
             [[body]]\nname = \"disc\"\ntype = \"kinematic\"\nshape = { circle = 0.5 }\nposition = [6.0, 3.5]\n\
             angular_velocity = 1.0\nfriction = 0.0\n";
        let sc = crate::scene::load_str(scene, "two.toml").unwrap();
        let bits = |w: &World| -> Vec<u32> {
            let islands = w
                .bodies
                .iter()
                .map(|b| if b.asleep { b.island } else { u32::MAX });
            w.motion_bits().into_iter().chain(islands).collect()
        };
        for threads in [1, 2] {
            let run = |fresh: bool| {
                FRESH_ISLANDS.with(|c| c.set(fresh));
                KEPT_PASSES.with(|c| c.set(0));
                let mut w = World::from_def(&sc.world, SolverSettings::soft()).unwrap();
                w.set_threads(threads);
                let mut trace = Vec::new();
                for _ in 0..150 {
                    w.step().unwrap();
                    trace.push(bits(&w));
                }
                FRESH_ISLANDS.with(|c| c.set(false));
                (w, trace, KEPT_PASSES.with(|c| c.get()))
            };
            let (kept, kept_trace, kept_passes) = run(false);
            let (_, fresh_trace, fresh_passes) = run(true);
            assert_eq!(fresh_passes, 0);
            assert!(kept_passes > 0, "the stacks at rest kept their islands");
            assert!(
                kept_trace == fresh_trace,
                "threads {threads}: the runs differ"
            );
            let sleep = |left: bool| -> Vec<Option<u32>> {
                (kept.bodies.iter().enumerate())
                    .filter(|(_, b)| b.is_dynamic() && (b.position.x < 0.0) == left)
                    .map(|(_, b)| b.asleep.then_some(b.island))
                    .collect()
            };
            let least = (kept.bodies.iter().position(|b| b.is_dynamic())).unwrap() as u32;
            assert_eq!(sleep(true), [Some(least); 6], "threads {threads}");
            assert_eq!(sleep(false), [None; 4], "threads {threads}");
        }
    }
}
