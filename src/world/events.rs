//! Contact and sensor events: which pairs began and ended touching in the last step.
//!
//! Recorded only when [`World::record_events`] is on (a world with a sensor turns it on),
//! so a world that needs no events pays nothing for them. A pair *touches* in a step when
//! the solve pushed it apart (a normal impulse) or its manifold has a point of separation
//! <= 0; a sensor pair when the shapes overlap after the step.

use super::World;
use crate::body::BodyId;

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
    pub kind: EventKind,
    /// The pair, lower index first.
    pub a: BodyId,
    pub b: BodyId,
    /// For [`EventKind::Begin`]: the normal impulse the step's solve put through the new
    /// contact (N s, summed over its points, as the solver keeps it for warm starting:
    /// for sounds and damage); 0 for the other kinds.
    pub impulse: f32,
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

    /// Compares the pairs touching after this step with those after the last one.
    pub(crate) fn update_events(&mut self) {
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
        let event = |kind, (a, b): (u32, u32), impulse| ContactEvent {
            kind,
            a: a as usize,
            b: b as usize,
            impulse,
        };
        self.events
            .extend(ends.iter().map(|&p| event(EventKind::End, p, 0.0)));
        self.events.extend(
            begins
                .iter()
                .map(|&(p, imp)| event(EventKind::Begin, p, imp)),
        );
        self.touching = pairs;

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
        diff(
            &self.sensed,
            &sensing,
            |j| begins.push(sensing[j]),
            |p| ends.push(p),
        );
        self.events
            .extend(ends.iter().map(|&p| event(EventKind::SensorEnd, p, 0.0)));
        self.events.extend(
            begins
                .iter()
                .map(|&p| event(EventKind::SensorBegin, p, 0.0)),
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
