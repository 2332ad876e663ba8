//! Contact and sensor events: which pairs began and ended touching in the last step.
//!
//! Recorded only when [`World::record_events`] is on (a world with a sensor turns it on),
//! so a world that needs no events pays nothing for them. A pair *touches* in a step when
//! the solve pushed it apart (a normal impulse) or its manifold has a point of separation
//! <= 0; a sensor pair when the shapes overlap after the step.

use super::{BodyKey, JointKey, World};
use crate::math::{Vec2, cross_sv};

/// What happened to a pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EventKind {
    /// Two bodies started touching.
    Begin,
    /// Two bodies stopped touching.
    End,
    /// A body started overlapping a sensor.
    SensorBegin,
    /// A body stopped overlapping a sensor.
    SensorEnd,
}

impl EventKind {
    /// The name in `simulate --events` files and `--json`.
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Begin => "begin",
            EventKind::End => "end",
            EventKind::SensorBegin => "sensor_begin",
            EventKind::SensorEnd => "sensor_end",
        }
    }
}

/// One event of the last step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactEvent {
    /// Began or ended touching, or a sensor overlap began or ended.
    pub kind: EventKind,
    /// The pair's body created first (of two bodies, the one earlier in
    /// [`World::bodies`]).
    pub a: BodyKey,
    /// The pair's other body (created later).
    pub b: BodyKey,
    /// For [`EventKind::Begin`]: the normal impulse the step's solve put through the new
    /// contact (N s, summed over its points, as the solver keeps it for warm starting:
    /// for sounds and damage); 0 for the other kinds.
    pub impulse: f32,
}

/// Box2D's default for [`World::hit_speed`] (m/s): slower approaches make no hit event.
pub const DEFAULT_HIT_SPEED: f32 = 1.0;

/// Two bodies that began touching in the last step ([`EventKind::Begin`]) while
/// approaching faster than [`World::hit_speed`]: an impact, for sounds, damage and
/// effects. One per touch: a pair that stays in touch (a box tipping from one edge onto
/// the other) makes no second hit until it parts and meets again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitEvent {
    /// The pair's body created first.
    pub a: BodyKey,
    /// The other body (created later).
    pub b: BodyKey,
    /// Where they met (world frame): the contact point of the fastest approach.
    pub point: Vec2,
    /// The contact normal there, from `a` to `b`.
    pub normal: Vec2,
    /// How fast the two surfaces closed along the normal at that point when the step
    /// began (m/s), before the solve stopped them: for a body dropped from rest through a
    /// height h onto the ground, sqrt(2 g h) less at most g dt.
    pub approach_speed: f32,
}

/// A body that fell asleep or woke in the last step (or, for a wake, between the
/// steps: a setter, a removal, [`World::wake`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SleepEvent {
    /// The body.
    pub body: BodyKey,
    /// True: it fell asleep; false: it woke.
    pub asleep: bool,
}

/// A joint that broke in the last step: its constraint force or torque went past its
/// [`crate::JointDef::break_force`] or [`crate::JointDef::break_torque`], and it was
/// removed after the step (its key now names nothing).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointBreakEvent {
    /// The joint's key (stale from now on).
    pub joint: JointKey,
    /// The two bodies it held, its `a` and `b`.
    pub bodies: [BodyKey; 2],
    /// The constraint force it carried in the step (N): the magnitude of its linear
    /// part, the step's impulse over the step's time.
    pub force: f32,
    /// The constraint torque it carried in the step (N m, magnitude): its angular rows.
    pub torque: f32,
}

/// Walks two sorted pair lists and calls `began` for each pair only in `now` and
/// `ended` for each only in `before`.
fn diff(
    before: &[(u32, u32)],
    now: &[(u32, u32)],
    mut began: impl FnMut(usize),
    mut ended: impl FnMut((u32, u32)),
) {
    let (mut i, mut j) = (0, 0);
    while i < before.len() || j < now.len() {
        match (before.get(i), now.get(j)) {
            (Some(p), Some(q)) if p == q => {
                i += 1;
                j += 1;
            }
            (Some(p), Some(q)) if p < q => {
                ended(*p);
                i += 1;
            }
            (Some(_), Some(_)) | (None, Some(_)) => {
                began(j);
                j += 1;
            }
            (Some(p), None) => {
                ended(*p);
                i += 1;
            }
            (None, None) => break,
        }
    }
}

impl World {
    /// The events of the last step, ends before begins, each kind in pair order. Empty
    /// unless [`World::record_events`] is on.
    pub fn events(&self) -> &[ContactEvent] {
        &self.events
    }

    /// The hit events of the last step, in pair order, one per pair (its fastest
    /// point). Empty unless [`World::record_events`] is on.
    pub fn hits(&self) -> &[HitEvent] {
        &self.hits
    }

    /// The bodies that fell asleep or woke in the last step, in body order. Empty unless
    /// [`World::record_events`] is on. Bodies added or removed between two steps reset
    /// the comparison: that step reports none.
    pub fn sleep_events(&self) -> &[SleepEvent] {
        &self.sleep_events
    }

    /// The joints that broke in the last step, in joint order (whether or not
    /// [`World::record_events`] is on: breaking is part of the step).
    pub fn joint_breaks(&self) -> &[JointBreakEvent] {
        &self.joint_breaks
    }

    /// After the solve: removes each joint whose constraint force or torque went past
    /// its threshold and records it. The soft step and PGS keep each (sub)step's
    /// lambdas (impulses of a substep of `h`); XPBD sums its substeps' impulses over
    /// the step of `dt`. A joint the step left parked (its island asleep) carried no
    /// load this step and is not looked at.
    pub(super) fn break_joints(&mut self, h: f32, dt: f32) {
        self.joint_breaks.clear();
        if !self.may_break {
            return;
        }
        if !self.joints.iter().any(|j| j.breakable()) {
            self.may_break = false;
            return;
        }
        let xpbd = self.settings.kind == crate::defs::SolverKind::Xpbd;
        let resting = |b: &crate::body::Body| b.asleep || (!b.is_dynamic() && !b.is_mover());
        let mut broken: Vec<(usize, f32, f32)> = Vec::new();
        for (i, j) in self.joints.iter().enumerate() {
            if !j.breakable() || (resting(&self.bodies[j.a]) && resting(&self.bodies[j.b])) {
                continue;
            }
            let (f, t) = if xpbd {
                let (f, t) = j.reaction(&j.step_impulses);
                (f / dt, t / dt)
            } else {
                let (f, t) = j.reaction(&j.impulses);
                (f / h, t / h)
            };
            if j.break_force.is_some_and(|m| f > m) || j.break_torque.is_some_and(|m| t > m) {
                broken.push((i, f, t));
            }
        }
        // highest index first, so the others keep theirs while they go
        for &(i, force, torque) in broken.iter().rev() {
            let joint = self.joint_key(i).expect("a joint's key");
            let (a, b) = (self.joints[i].a, self.joints[i].b);
            let bodies = [
                self.body_key(a).expect("a body's key"),
                self.body_key(b).expect("a body's key"),
            ];
            self.remove_joint_at(i);
            self.joint_breaks.push(JointBreakEvent {
                joint,
                bodies,
                force,
                torque,
            });
        }
        self.joint_breaks.reverse();
    }

    /// Compares each body's asleep flag with the last step's.
    fn update_sleep_events(&mut self) {
        self.sleep_events.clear();
        let (before, edits) = &mut self.was_asleep;
        if before.len() == self.bodies.len() && *edits == self.edits {
            for (i, (b, was)) in self.bodies.iter().zip(before.iter()).enumerate() {
                if b.asleep != *was {
                    self.sleep_events.push(SleepEvent {
                        body: self.body_keys.body(i),
                        asleep: b.asleep,
                    });
                }
            }
        }
        before.clear();
        before.extend(self.bodies.iter().map(|b| b.asleep));
        *edits = self.edits;
    }

    /// The pairs that began touching in this step (`begins`, sorted) and approached
    /// faster than the hit speed.
    fn update_hits(&mut self, begins: &[((u32, u32), f32)]) {
        self.hits.clear();
        if begins.is_empty() {
            return;
        }
        if self.step_start_velocity.len() != self.bodies.len() {
            // bodies added in the step (a spawn): no start velocity to compare
            return;
        }
        // (lower index, higher index, point, normal, speed), in pair order below
        let mut found: Vec<(usize, usize, Vec2, Vec2, f32)> = Vec::new();
        for c in &self.contacts {
            let points = c.manifold.points();
            if !points
                .iter()
                .any(|p| p.normal_impulse > 0.0 || p.separation <= 0.0)
            {
                continue;
            }
            let (a, b) = (c.a as usize, c.b as usize);
            let pair = (c.a.min(c.b), c.a.max(c.b));
            if begins.binary_search_by_key(&pair, |(p, _)| *p).is_err() {
                continue;
            }
            let (va, wa) = self.step_start_velocity[a];
            let (vb, wb) = self.step_start_velocity[b];
            let (pa, pb) = (self.bodies[a].position, self.bodies[b].position);
            let n = c.manifold.normal;
            let mut best: Option<(f32, Vec2)> = None;
            for p in points {
                let dv = vb + cross_sv(wb, p.point - pb) - va - cross_sv(wa, p.point - pa);
                let speed = -dv.dot(n);
                if best.is_none_or(|(s, _)| speed > s) {
                    best = Some((speed, p.point));
                }
            }
            let Some((speed, point)) = best else { continue };
            if speed <= self.hit_speed {
                continue;
            }
            let (lo, hi, normal) = if a < b { (a, b, n) } else { (b, a, -n) };
            found.push((lo, hi, point, normal, speed));
        }
        // a compound meets a body through several parts: one event, the fastest
        found.sort_unstable_by(|x, y| (x.0, x.1).cmp(&(y.0, y.1)).then(y.4.total_cmp(&x.4)));
        found.dedup_by_key(|h| (h.0, h.1));
        let keys = &self.body_keys;
        self.hits.extend(
            found
                .iter()
                .map(|&(a, b, point, normal, approach_speed)| HitEvent {
                    a: keys.body(a),
                    b: keys.body(b),
                    point,
                    normal,
                    approach_speed,
                }),
        );
    }

    /// Compares the pairs touching after this step with those after the last one.
    pub(crate) fn update_events(&mut self) {
        self.update_sleep_events();
        self.events.clear();
        // touching pairs now, with their summed normal impulse
        let mut now: Vec<((u32, u32), f32)> = Vec::new();
        // a sleeping island's contacts still touch
        for c in self.contacts.iter().chain(&self.sleep.contacts) {
            let points = c.manifold.points();
            let impulse: f32 = points.iter().map(|p| p.normal_impulse).sum();
            // overlapping, or pushed apart by the solve (a speculative point the solver
            // had to act on is a touch: the bodies met within the step)
            if impulse > 0.0 || points.iter().any(|p| p.separation <= 0.0) {
                now.push(((c.a.min(c.b), c.a.max(c.b)), impulse));
            }
        }
        now.sort_by_key(|(p, _)| *p);
        // a compound touches a body through several parts: one touch, impulses summed
        now.dedup_by(|later, kept| {
            let same = later.0 == kept.0;
            if same {
                kept.1 += later.1;
            }
            same
        });
        let pairs: Vec<(u32, u32)> = now.iter().map(|(p, _)| *p).collect();
        let mut ends = Vec::new();
        let mut begins = Vec::new();
        diff(
            &self.touching,
            &pairs,
            |j| begins.push(now[j]),
            |p| ends.push(p),
        );
        let event = |keys: &super::edit::Keys, kind, (a, b): (u32, u32), impulse| ContactEvent {
            kind,
            a: keys.body(a as usize),
            b: keys.body(b as usize),
            impulse,
        };
        let keys = &self.body_keys;
        self.events
            .extend(ends.iter().map(|&p| event(keys, EventKind::End, p, 0.0)));
        self.events.extend(
            begins
                .iter()
                .map(|&(p, imp)| event(keys, EventKind::Begin, p, imp)),
        );
        self.touching = pairs;
        self.update_hits(&begins);

        // sensors: the broad phase's sensor pairs (its boxes hold each body's motion over
        // the step), tested at the positions after the step
        let mut sensing: Vec<(u32, u32)> = Vec::new();
        if self.collider.has_sensors {
            for &(a, b) in &self.collider.broad.pairs {
                let (ba, bb) = (&self.bodies[a as usize], &self.bodies[b as usize]);
                if !(ba.has_sensor() || bb.has_sensor()) {
                    continue;
                }
                // a sensor body or a sensor part over another body's solid shape
                let overlap = crate::compound::senses(ba, bb);
                if overlap {
                    sensing.push((a.min(b), a.max(b)));
                }
            }
        }
        // a pair that nothing moves (each body static or asleep) is not among the broad
        // phase's pairs, yet overlaps as it did: a body that falls asleep in a sensor
        // stays heard until it wakes and leaves
        let still = |i: u32| {
            let b = &self.bodies[i as usize];
            b.asleep || b.body_type == crate::defs::BodyType::Static
        };
        sensing.extend(self.sensed.iter().filter(|&&(a, b)| still(a) && still(b)));
        sensing.sort_unstable();
        sensing.dedup();
        let (mut ends, mut begins) = (Vec::new(), Vec::new());
        let keys = &self.body_keys;
        diff(
            &self.sensed,
            &sensing,
            |j| begins.push(sensing[j]),
            |p| ends.push(p),
        );
        self.events.extend(
            ends.iter()
                .map(|&p| event(keys, EventKind::SensorEnd, p, 0.0)),
        );
        self.events.extend(
            begins
                .iter()
                .map(|&p| event(keys, EventKind::SensorBegin, p, 0.0)),
        );
        self.sensed = sensing;
    }
}

#[cfg(test)]
mod tests {
    use super::diff;

    #[test]
    fn diff_finds_what_began_and_what_ended() {
        let before = [(0, 1), (0, 3), (2, 5)];
        let now = [(0, 1), (1, 2), (2, 5), (4, 6)];
        let (mut b, mut e) = (Vec::new(), Vec::new());
        diff(&before, &now, |j| b.push(now[j]), |p| e.push(p));
        assert_eq!(b, [(1, 2), (4, 6)]);
        assert_eq!(e, [(0, 3)]);
    }
}
