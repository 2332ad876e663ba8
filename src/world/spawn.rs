//! What a world does on its own between steps: kinematic bodies that follow a path
//! ([`MotionDef`]) and groups of bodies and joints spawned every few steps, the oldest
//! removed when too many live ([`SpawnDef`]). Both run at the start of
//! [`World::step`], before the step's collide, from the step count alone: a run is
//! as deterministic with them as without, at any number of threads.

use std::collections::VecDeque;
use std::sync::Arc;

use super::{BodyKey, EditError, World};
use crate::defs::{BodyType, MotionDef, SpawnDef};
use crate::math::Vec2;
use crate::world::BuildError;

/// A kinematic body on a path: where it started (centre of mass) and the path.
#[derive(Clone, Debug)]
pub(crate) struct Motion {
    pub key: BodyKey,
    pub start: Vec2,
    pub def: MotionDef,
}

/// A spawn table and what it has made: the copies made so far, and the live ones'
/// bodies, oldest first.
#[derive(Clone, Debug)]
pub(crate) struct Spawner {
    pub def: Arc<SpawnDef>,
    pub made: u64,
    pub alive: VecDeque<Vec<BodyKey>>,
}

/// A spawner's progress as a saved state holds it: copies made, and each live copy's
/// bodies by index.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpawnProgress {
    pub made: u64,
    pub alive: Vec<Vec<usize>>,
}

/// A motion as a saved state holds it: the body by index, where it started, the path.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MotionState {
    pub body: usize,
    pub start: Vec2,
    pub amplitude: Vec2,
    pub angular_frequency: f32,
    pub phase: f32,
}

impl MotionDef {
    /// The path's offset from its start at time `t` (s), in f64 so that a long run's
    /// time keeps its precision.
    pub fn offset_at(&self, t: f64) -> Vec2 {
        let (w, phase) = (self.angular_frequency as f64, self.phase as f64);
        let s = (w * t + phase).sin() - phase.sin();
        Vec2::new(
            (self.amplitude.x as f64 * s) as f32,
            (self.amplitude.y as f64 * s) as f32,
        )
    }
}

impl World {
    /// Puts the kinematic body of `key` on a path ([`MotionDef`]; `def.body` is not
    /// read): from the next step on, its velocity is set before each step so that it
    /// ends the step on the path. A stale key is refused ([`EditError::NoSuchBody`]),
    /// and so is a body that is not kinematic or a path that is not finite
    /// ([`EditError::Build`]); either way the world is unchanged.
    pub fn create_motion(&mut self, key: BodyKey, def: &MotionDef) -> Result<(), EditError> {
        let body = self.body_of_key(key).ok_or(EditError::NoSuchBody)?;
        self.add_motion(&MotionDef { body, ..*def })?;
        Ok(())
    }

    /// [`World::create_motion`] for the body at place `def.body` in creation order (as
    /// a [`crate::WorldDef`] names it): the program builds a scene's paths so.
    #[doc(hidden)]
    pub fn add_motion(&mut self, def: &MotionDef) -> Result<(), BuildError> {
        let count = self.bodies.len();
        let Some(b) = self.bodies.get(def.body) else {
            return Err(BuildError::NoSuchBody {
                what: "motion",
                index: def.body,
                count,
            });
        };
        if b.body_type != BodyType::Kinematic {
            return Err(BuildError::Derived {
                name: b.name.clone(),
                input: super::BodyInput::Velocity,
                what: "only a kinematic body follows a path".into(),
            });
        }
        if !(def.amplitude.is_finite()
            && def.angular_frequency.is_finite()
            && def.angular_frequency > 0.0
            && def.phase.is_finite())
        {
            return Err(BuildError::Derived {
                name: b.name.clone(),
                input: super::BodyInput::Velocity,
                what: "a path needs a finite amplitude and phase and an angular frequency > 0"
                    .into(),
            });
        }
        let start = b.position;
        self.sync_keys();
        let key = self.body_key(def.body).expect("the body exists");
        self.motions.push(Motion {
            key,
            start,
            def: *def,
        });
        Ok(())
    }

    /// Adds a spawn table: its copies are made from the next step on (see
    /// [`SpawnDef`]). Its joints must join two of its own bodies.
    pub fn add_spawn(&mut self, def: &SpawnDef) -> Result<(), BuildError> {
        let n = def.bodies.len();
        for j in &def.joints {
            for &i in &j.bodies {
                if i >= n {
                    return Err(BuildError::NoSuchBody {
                        what: "spawned joint",
                        index: i,
                        count: n,
                    });
                }
            }
        }
        if def.every == 0 {
            return Err(BuildError::Settings(format!(
                "{}: every must be >= 1 step",
                def.name
            )));
        }
        self.spawners.push(Spawner {
            def: Arc::new(def.clone()),
            made: 0,
            alive: VecDeque::new(),
        });
        Ok(())
    }

    /// Copies the spawn tables have made so far, table by table.
    pub fn spawned(&self) -> Vec<u64> {
        self.spawners.iter().map(|s| s.made).collect()
    }

    /// The motions' velocities and the spawns due before the step numbered
    /// `step_count` (run by [`World::step`]).
    pub(super) fn run_events(&mut self) {
        let step = self.step_count;
        let dt = self.settings.dt;
        // where each path is at the step's end
        let t = (step + 1) as f64 * dt as f64;
        let moves: Vec<(usize, Vec2)> = self
            .motions
            .iter()
            .filter_map(|m| Some((self.body_of_key(m.key)?, m.start + m.def.offset_at(t))))
            .collect();
        for (i, target) in moves {
            let b = &mut self.bodies[i];
            b.velocity = (target - b.position) / dt;
        }
        for s in 0..self.spawners.len() {
            let def = Arc::clone(&self.spawners[s].def);
            let Some(k) = def.due(step) else {
                continue;
            };
            if let Some(keep) = def.keep {
                let mut gone = Vec::new();
                while self.spawners[s].alive.len() as u64 >= keep.max(1) {
                    match self.spawners[s].alive.pop_front() {
                        Some(group) => gone.extend(group),
                        None => break,
                    }
                }
                if !gone.is_empty() {
                    let mut indices: Vec<usize> = gone
                        .iter()
                        .filter_map(|&key| self.body_of_key(key))
                        .collect();
                    self.remove_indices(&mut indices);
                }
            }
            let group = self.make_copy(&def, k);
            let spawner = &mut self.spawners[s];
            spawner.made = k + 1;
            spawner.alive.push_back(group);
        }
    }

    /// Adds copy `k` of a spawn table; returns its bodies' keys. A body or joint the
    /// world refuses (possible only far out, where the offsets leave f32's range; the
    /// scene loader checks the copies it can foresee) is left out with a warning.
    fn make_copy(&mut self, def: &SpawnDef, k: u64) -> Vec<BodyKey> {
        let off = def.offset_of(k);
        let mut index = Vec::with_capacity(def.bodies.len());
        let mut keys = Vec::with_capacity(def.bodies.len());
        for b in &def.bodies {
            let mut b = b.clone();
            b.name = format!("{}#{k}", b.name);
            b.position += off;
            match World::make_body(&b, self.gravity) {
                Ok(body) => {
                    let i = self.add_made_index(body, b.awake);
                    index.push(Some(i));
                    keys.extend(self.body_key(i));
                }
                Err(e) => {
                    log::warn!("{}: copy {k} left out a body: {e}", def.name);
                    index.push(None);
                }
            }
        }
        for j in &def.joints {
            let (Some(a), Some(b)) = (index[j.bodies[0]], index[j.bodies[1]]) else {
                continue;
            };
            let mut j = j.clone();
            j.bodies = [a, b];
            j.anchor = j.anchor.map(|p| p + off);
            j.anchors = j.anchors.map(|[p, q]| [p + off, q + off]);
            j.ground_anchors = j.ground_anchors.map(|[p, q]| [p + off, q + off]);
            if let Err(e) = self.add_joint(&j) {
                log::warn!("{}: copy {k} left out a joint: {e}", def.name);
            }
        }
        keys
    }

    /// The motions and spawn progress, by body index, for a saved state.
    pub(super) fn events_state(&self) -> (Vec<MotionState>, Vec<SpawnProgress>) {
        let motions = self
            .motions
            .iter()
            .filter_map(|m| {
                Some(MotionState {
                    body: self.body_of_key(m.key)?,
                    start: m.start,
                    amplitude: m.def.amplitude,
                    angular_frequency: m.def.angular_frequency,
                    phase: m.def.phase,
                })
            })
            .collect();
        let spawns = self
            .spawners
            .iter()
            .map(|s| SpawnProgress {
                made: s.made,
                alive: s
                    .alive
                    .iter()
                    .map(|g| g.iter().filter_map(|&k| self.body_of_key(k)).collect())
                    .collect(),
            })
            .collect();
        (motions, spawns)
    }

    /// Whether a saved state's motions and spawn progress fit this world's bodies and
    /// spawn tables (checked before a restore changes anything).
    pub(super) fn check_events_state(
        &self,
        bodies: usize,
        motions: &[MotionState],
        spawns: &[SpawnProgress],
    ) -> Result<(), String> {
        for m in motions {
            if m.body >= bodies {
                return Err(format!(
                    "a motion names body #{}, but the state has {bodies} bodies",
                    m.body
                ));
            }
        }
        if !spawns.is_empty() && spawns.len() != self.spawners.len() {
            return Err(format!(
                "the state has {} spawn tables, the scene {}",
                spawns.len(),
                self.spawners.len()
            ));
        }
        for s in spawns {
            if let Some(&i) = s.alive.iter().flatten().find(|&&i| i >= bodies) {
                return Err(format!(
                    "a spawned group names body #{i}, but the state has {bodies} bodies"
                ));
            }
        }
        Ok(())
    }

    /// Puts back the motions and spawn progress of a saved state (after the bodies and
    /// their new keys). A state without spawn progress leaves the tables unstarted.
    pub(super) fn restore_events(&mut self, motions: &[MotionState], spawns: &[SpawnProgress]) {
        self.motions = motions
            .iter()
            .filter_map(|m| {
                Some(Motion {
                    key: self.body_key(m.body)?,
                    start: m.start,
                    def: MotionDef {
                        body: m.body,
                        amplitude: m.amplitude,
                        angular_frequency: m.angular_frequency,
                        phase: m.phase,
                    },
                })
            })
            .collect();
        for (i, s) in self.spawners.iter_mut().enumerate() {
            (s.made, s.alive) = (0, VecDeque::new());
            if let Some(p) = spawns.get(i) {
                s.made = p.made;
            }
        }
        for (i, p) in spawns.iter().enumerate().take(self.spawners.len()) {
            let groups: VecDeque<Vec<BodyKey>> = p
                .alive
                .iter()
                .map(|g| g.iter().filter_map(|&b| self.body_key(b)).collect())
                .collect();
            self.spawners[i].alive = groups;
        }
    }
}
