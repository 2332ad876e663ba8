//! Removing bodies and joints, and the generational keys that name them across removals.
//!
//! Bodies and joints live in vectors in creation order, and their index ([`BodyId`],
//! [`JointId`]) is what the step and the rest of the API use. Removing one shifts the
//! later ones down by one, so that the world is exactly the world that never had it
//! (same order, so the same results to the bit). An index therefore goes stale on a
//! removal; a key does not: [`BodyKey`] and [`JointKey`] name one body or joint for the
//! world's life, and a removed one's key never names another (its slot's generation
//! moves on).

use super::World;
use crate::body::{Body, BodyId};
use crate::joint::{Joint, JointId};

/// A body's name for the world's life: [`World::create_body`] and [`World::find_body`]
/// give one, [`World::body`] reads the body, [`World::bodies`] lists every body's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct BodyKey {
    slot: u32,
    generation: u32,
}

/// A joint's name for the world's life: [`World::create_joint`] gives one,
/// [`World::joint`] reads the joint, [`World::joints`] lists every joint's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct JointKey {
    slot: u32,
    generation: u32,
}

/// What a removal refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RemoveError {
    /// The body key names no body of this world: already removed, or from another world.
    #[error("the key names no body of this world (removed, or from another world)")]
    NoSuchBody,
    /// The joint key names no joint of this world: already removed, or from another world.
    #[error("the key names no joint of this world (removed, or from another world)")]
    NoSuchJoint,
}

/// Slots and generations behind one kind of key.
#[derive(Clone, Debug, Default)]
pub(crate) struct Keys {
    /// (slot, generation) of the item at each index.
    by_index: Vec<(u32, u32)>,
    /// Per slot: its generation, and the index of its item (u32::MAX: free).
    slots: Vec<(u32, u32)>,
    free: Vec<u32>,
    /// The generation fresh slots start at (moves past every old one on a restore).
    base: u32,
}

impl Keys {
    /// Gives keys to items added since (indices len.. of a list of `len` items); forgets
    /// the keys of items beyond `len` (a list cut short by hand).
    pub(crate) fn sync(&mut self, len: usize) {
        while self.by_index.len() > len {
            let i = self.by_index.len() - 1;
            self.remove(i);
        }
        while self.by_index.len() < len {
            let index = self.by_index.len() as u32;
            let key = match self.free.pop() {
                Some(slot) => {
                    let s = &mut self.slots[slot as usize];
                    s.1 = index;
                    (slot, s.0)
                }
                None => {
                    self.slots.push((self.base, index));
                    (self.slots.len() as u32 - 1, self.base)
                }
            };
            self.by_index.push(key);
        }
    }

    /// How many items have keys.
    pub(crate) fn len(&self) -> usize {
        self.by_index.len()
    }

    fn key(&self, index: usize) -> Option<(u32, u32)> {
        self.by_index.get(index).copied()
    }

    /// The key of body `index`, for a list of bodies whose keys are in step (the
    /// step's own records: events).
    pub(crate) fn body(&self, index: usize) -> BodyKey {
        let (slot, generation) = self.by_index[index];
        BodyKey { slot, generation }
    }

    /// The key of joint `index`, for a list of joints whose keys are in step.
    pub(crate) fn joint(&self, index: usize) -> JointKey {
        let (slot, generation) = self.by_index[index];
        JointKey { slot, generation }
    }

    fn index(&self, slot: u32, generation: u32) -> Option<usize> {
        let &(g, i) = self.slots.get(slot as usize)?;
        (g == generation && i != u32::MAX).then_some(i as usize)
    }

    /// Frees the slot of the item at `index` (its generation moves on) and shifts the
    /// later items down.
    fn remove(&mut self, index: usize) {
        let (slot, _) = self.by_index.remove(index);
        let s = &mut self.slots[slot as usize];
        s.0 = s.0.wrapping_add(1);
        s.1 = u32::MAX;
        self.free.push(slot);
        for &(slot, _) in &self.by_index[index..] {
            self.slots[slot as usize].1 -= 1;
        }
    }

    /// Frees the slots of the items at `gone` (sorted, distinct indices) and closes up
    /// the rest, in one pass.
    fn remove_many(&mut self, gone: &[usize]) {
        let mut g = gone.iter().peekable();
        let mut kept = Vec::with_capacity(self.by_index.len() - gone.len());
        for (i, &(slot, generation)) in self.by_index.iter().enumerate() {
            if g.peek() == Some(&&i) {
                g.next();
                let s = &mut self.slots[slot as usize];
                s.0 = s.0.wrapping_add(1);
                s.1 = u32::MAX;
                self.free.push(slot);
            } else {
                self.slots[slot as usize].1 = kept.len() as u32;
                kept.push((slot, generation));
            }
        }
        self.by_index = kept;
    }

    /// New keys for `len` items, none equal to a key handed out before (a restore).
    pub(crate) fn renew(&mut self, len: usize) {
        let base = self
            .slots
            .iter()
            .map(|s| s.0)
            .max()
            .map_or(self.base, |g| g.wrapping_add(1).max(self.base));
        *self = Keys {
            base,
            ..Keys::default()
        };
        self.sync(len);
    }
}

/// The index after removing `gone`: later ones move down by one.
fn shift(i: usize, gone: usize) -> usize {
    if i > gone { i - 1 } else { i }
}

impl World {
    /// The key of body `index` (None past the end).
    pub(crate) fn body_key(&self, index: BodyId) -> Option<BodyKey> {
        let (slot, generation) = self.body_keys.key(index)?;
        Some(BodyKey { slot, generation })
    }

    /// Where the body of `key` is now, or None if it was removed.
    pub(crate) fn body_of_key(&self, key: BodyKey) -> Option<BodyId> {
        self.body_keys.index(key.slot, key.generation)
    }

    /// The key of joint `index` (None past the end).
    pub(crate) fn joint_key(&self, index: JointId) -> Option<JointKey> {
        let (slot, generation) = self.joint_keys.key(index)?;
        Some(JointKey { slot, generation })
    }

    /// Where the joint of `key` is now, or None if it was removed.
    pub(crate) fn joint_of_key(&self, key: JointKey) -> Option<JointId> {
        self.joint_keys.index(key.slot, key.generation)
    }

    /// Removes a body, and the joints, forces and contacts that hold it (and the mouse
    /// joint if it holds it). Later bodies move down one index (their keys stay): the
    /// world is the one that never had the body, so a body removed before the first step
    /// leaves every other body's trajectory exactly as in a world built without it. The
    /// bodies it touched wake. Returns the body.
    pub fn remove_body(&mut self, key: BodyKey) -> Result<Body, RemoveError> {
        self.sync_keys();
        let gone = self.body_of_key(key).ok_or(RemoveError::NoSuchBody)?;
        self.edits += 1;
        // what rests on it falls: wake its island, and the islands of what it touches
        self.wake_index(gone);
        let touching: Vec<usize> = self
            .contacts
            .iter()
            .chain(&self.sleep.contacts)
            .filter(|c| c.a as usize == gone || c.b as usize == gone)
            .map(|c| if c.a as usize == gone { c.b } else { c.a } as usize)
            .collect();
        for b in touching {
            self.wake_index(b);
        }
        // its joints go first (highest index first, so the others keep theirs)
        let mut i = self.joints.len();
        while i > 0 {
            i -= 1;
            if self.joints[i].a == gone || self.joints[i].b == gone {
                self.remove_joint_at(i);
            }
        }
        self.forces.retain(|f| f.body != gone);
        for f in &mut self.forces {
            f.body = shift(f.body, gone);
        }
        if let Some(m) = &mut self.mouse {
            if m.body == gone {
                self.mouse = None;
            } else {
                m.body = shift(m.body, gone);
            }
        }
        let g = gone as u32;
        let shift32 = |i: u32| if i > g { i - 1 } else { i };
        for list in [
            &mut self.contacts,
            &mut self.collider.old_contacts,
            &mut self.sleep.contacts,
        ] {
            list.retain(|c| c.a != g && c.b != g);
            for c in list.iter_mut() {
                c.a = shift32(c.a);
                c.b = shift32(c.b);
            }
        }
        for list in [
            &mut self.collider.no_collide,
            &mut self.touching,
            &mut self.sensed,
        ] {
            list.retain(|&(a, b)| a != g && b != g);
            for p in list.iter_mut() {
                *p = (shift32(p.0), shift32(p.1));
            }
        }
        for j in &mut self.joints {
            j.a = shift(j.a, gone);
            j.b = shift(j.b, gone);
        }
        let body = self.bodies.remove(gone);
        self.body_keys.remove(gone);
        // a sleeping island's label is a body index: relabel each by its first member
        // now, so that no label can meet one the sleep pass hands out later
        let mut first: Vec<(u32, u32)> = Vec::new();
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if !b.asleep {
                continue;
            }
            match first.iter().find(|(old, _)| *old == b.island) {
                Some(&(_, new)) => b.island = new,
                None => {
                    first.push((b.island, i as u32));
                    b.island = i as u32;
                }
            }
        }
        Ok(body)
    }

    /// Removes several bodies at once, as [`World::remove_body`] would one after the
    /// other (their joints, forces and contacts go too, what they touched wakes, the
    /// rest keep their order), in one pass over the world instead of one per body.
    /// Returns how many were removed; a key that names no body is refused before
    /// anything is removed.
    pub fn remove_bodies(&mut self, keys: &[BodyKey]) -> Result<usize, RemoveError> {
        self.sync_keys();
        let mut indices = Vec::with_capacity(keys.len());
        for &k in keys {
            indices.push(self.body_of_key(k).ok_or(RemoveError::NoSuchBody)?);
        }
        Ok(self.remove_indices(&mut indices))
    }

    /// Removes the bodies at `gone` (any order, repeats allowed); see
    /// [`World::remove_bodies`].
    pub(crate) fn remove_indices(&mut self, gone: &mut Vec<usize>) -> usize {
        gone.sort_unstable();
        gone.dedup();
        gone.retain(|&i| i < self.bodies.len());
        if gone.is_empty() {
            return 0;
        }
        self.edits += 1;
        let n = self.bodies.len();
        let mut is_gone = vec![false; n];
        for &i in gone.iter() {
            is_gone[i] = true;
        }
        // what rests on them falls: wake their islands and those of what they touch
        let mut islands: Vec<u32> = Vec::new();
        let mut note = |b: &Body| {
            if b.asleep {
                islands.push(b.island);
            }
        };
        for &i in gone.iter() {
            note(&self.bodies[i]);
        }
        for c in self.contacts.iter().chain(&self.sleep.contacts) {
            let (a, b) = (c.a as usize, c.b as usize);
            if is_gone[a] {
                note(&self.bodies[b]);
            } else if is_gone[b] {
                note(&self.bodies[a]);
            }
        }
        for j in &self.joints {
            if is_gone[j.a] {
                note(&self.bodies[j.b]);
            } else if is_gone[j.b] {
                note(&self.bodies[j.a]);
            }
        }
        self.sleep
            .wake_islands(&mut self.bodies, &mut self.contacts, &mut islands);
        // the new index of each body that stays
        let mut map = vec![u32::MAX; n];
        let mut next = 0u32;
        for (i, m) in map.iter_mut().enumerate() {
            if !is_gone[i] {
                *m = next;
                next += 1;
            }
        }
        let new = |i: usize| map[i] as usize;
        // joints: those that hold a removed body go
        let mut gone_joints = Vec::new();
        for (ji, j) in self.joints.iter().enumerate() {
            if is_gone[j.a] || is_gone[j.b] {
                gone_joints.push(ji);
            }
        }
        if !gone_joints.is_empty() {
            let mut g = gone_joints.iter().peekable();
            let mut ji = 0;
            self.joints.retain(|_| {
                let drop = g.peek() == Some(&&ji);
                if drop {
                    g.next();
                }
                ji += 1;
                !drop
            });
            self.joint_keys.remove_many(&gone_joints);
        }
        for j in &mut self.joints {
            j.a = new(j.a);
            j.b = new(j.b);
        }
        self.forces.retain(|f| !is_gone[f.body]);
        for f in &mut self.forces {
            f.body = new(f.body);
        }
        if let Some(m) = &mut self.mouse {
            if is_gone[m.body] {
                self.mouse = None;
            } else {
                m.body = new(m.body);
            }
        }
        for list in [
            &mut self.contacts,
            &mut self.collider.old_contacts,
            &mut self.sleep.contacts,
        ] {
            list.retain(|c| !is_gone[c.a as usize] && !is_gone[c.b as usize]);
            for c in list.iter_mut() {
                c.a = map[c.a as usize];
                c.b = map[c.b as usize];
            }
        }
        for list in [
            &mut self.collider.no_collide,
            &mut self.touching,
            &mut self.sensed,
        ] {
            list.retain(|&(a, b)| !is_gone[a as usize] && !is_gone[b as usize]);
            for p in list.iter_mut() {
                *p = (map[p.0 as usize], map[p.1 as usize]);
            }
        }
        let mut i = 0;
        self.bodies.retain(|_| {
            let keep = !is_gone[i];
            i += 1;
            keep
        });
        self.body_keys.remove_many(gone);
        self.relabel_islands();
        self.damped = self
            .bodies
            .iter()
            .any(|b| b.linear_damping != 0.0 || b.angular_damping != 0.0);
        gone.len()
    }

    /// A sleeping island's label is a body index: after bodies are removed, relabel
    /// each by its first member, so that no label can meet one the sleep pass hands out
    /// later.
    fn relabel_islands(&mut self) {
        let mut first: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if b.asleep {
                b.island = *first.entry(b.island).or_insert(i as u32);
            }
        }
    }

    /// Removes a joint; later joints move down one index (their keys stay). The two
    /// bodies wake, and collide again unless another joint between them forbids it.
    pub fn remove_joint(&mut self, key: JointKey) -> Result<Joint, RemoveError> {
        self.sync_keys();
        let i = self.joint_of_key(key).ok_or(RemoveError::NoSuchJoint)?;
        Ok(self.remove_joint_at(i))
    }

    pub(super) fn remove_joint_at(&mut self, i: usize) -> Joint {
        let j = self.joints.remove(i);
        self.joint_keys.remove(i);
        self.wake_index(j.a);
        self.wake_index(j.b);
        let pair = (j.a.min(j.b) as u32, j.a.max(j.b) as u32);
        let still = self
            .joints
            .iter()
            .any(|o| !o.collide_connected && (o.a.min(o.b) as u32, o.a.max(o.b) as u32) == pair);
        if !still && let Ok(at) = self.collider.no_collide.binary_search(&pair) {
            self.collider.no_collide.remove(at);
        }
        j
    }

    /// Keys for bodies and joints added by hand since the last call.
    pub(crate) fn sync_keys(&mut self) {
        self.body_keys.sync(self.bodies.len());
        self.joint_keys.sync(self.joints.len());
    }
}
