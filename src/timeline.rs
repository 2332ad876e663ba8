//! A world's recent past, kept so that it can be gone back to exactly: [`Timeline`]
//! holds keyframes ([`WorldState`]s) every `stride` steps over the last stretch of
//! steps, and the input each step was taken with (in the window: the mouse's drag and
//! the force emitter). Going to step K restores the last keyframe at or before K and
//! steps again from there with the recorded inputs; the steps are deterministic, so
//! the world at K is the one the run had at K, bit for bit (the same
//! [`World::state_hash`]).
//!
//! Memory is bounded: the keyframes are counted in bytes ([`WorldState::heap_bytes`]),
//! and when they pass the bound the stride doubles (every other keyframe goes), so a
//! timeline of a large world keeps fewer states further apart and going back costs
//! more steps again, never more memory. Keyframes older than the horizon go too. A
//! change to the world between steps that is not a recorded input (a body spawned or
//! deleted, other settings, a state loaded) is marked with [`Timeline::edited`]: a
//! keyframe is taken of the world as it is after the change and pinned (never thinned
//! out), because stepping from an earlier keyframe could not cross the change.
//!
//! [`SavedRun`] is the file form of a headless run (`simulate --save-run`,
//! `simulate --run FILE --from-step K`, `render --run FILE --from-step K`): its
//! keyframes and the state hash at the end.

use std::collections::VecDeque;
use std::sync::Arc;

use crate::world::{StateError, StepError, World, WorldState};

/// One kept state.
#[derive(Clone, Debug)]
pub struct Keyframe {
    /// The step the state was taken at (the world's step count).
    pub step: u64,
    /// The state (shared with the timelines of branches made from this one).
    pub state: Arc<WorldState>,
    /// Its estimated size in memory.
    pub bytes: usize,
    /// Taken after an edit: never thinned out.
    pub pinned: bool,
}

/// Why a step could not be reached.
#[derive(Debug, thiserror::Error)]
pub enum SeekError {
    /// The step is not kept (before the oldest keyframe or after the newest step).
    #[error("step {step} is not kept: the timeline holds steps {oldest} to {newest}")]
    OutOfRange {
        /// The step asked for.
        step: u64,
        /// The oldest keyframe's step.
        oldest: u64,
        /// The newest step kept.
        newest: u64,
    },
    /// Nothing is kept yet (or the world's state alone is over the memory bound).
    #[error("the timeline is empty")]
    Empty,
    /// A keyframe could not be put back.
    #[error(transparent)]
    State(#[from] StateError),
    /// A step on the way failed.
    #[error(transparent)]
    Step(#[from] StepError),
}

/// A world's recent steps (see the module docs); `I` is what each step was given
/// besides the world (the window's mouse; `()` for a headless run).
#[derive(Clone, Debug)]
pub struct Timeline<I> {
    keyframes: VecDeque<Keyframe>,
    /// `(s, input)`: the input the step from s - 1 to s was taken with, for every s
    /// after the oldest keyframe up to the newest step, in order.
    inputs: VecDeque<(u64, I)>,
    /// The newest step recorded.
    newest: u64,
    /// Keyframes are taken at the steps that are multiples of this.
    stride: u64,
    /// Steps back from the newest that are kept reachable.
    horizon: u64,
    /// The most bytes the keyframes may take.
    budget: usize,
    /// The bytes the keyframes take now.
    bytes: usize,
    /// The step the caller's world is at, if it is that of the timeline (so seeking
    /// forward from it needs no restore).
    at: Option<u64>,
    /// Why the timeline keeps nothing (one state is over the bound), if so.
    off: Option<String>,
}

impl<I: Clone> Timeline<I> {
    /// An empty timeline keeping `horizon` steps back within `budget` bytes.
    pub fn new(horizon: u64, budget: usize) -> Timeline<I> {
        Timeline {
            keyframes: VecDeque::new(),
            inputs: VecDeque::new(),
            newest: 0,
            stride: 1,
            horizon: horizon.max(1),
            budget,
            bytes: 0,
            at: None,
            off: None,
        }
    }

    /// Forgets everything (a new scene, a reset); the bound and horizon stay.
    pub fn clear(&mut self) {
        *self = Timeline::new(self.horizon, self.budget);
    }

    /// The oldest step that can be gone to, if any.
    pub fn oldest(&self) -> Option<u64> {
        self.keyframes.front().map(|k| k.step)
    }

    /// The newest step recorded, if any.
    pub fn newest(&self) -> Option<u64> {
        (!self.keyframes.is_empty()).then_some(self.newest)
    }

    /// Steps between keyframes (edits add pinned keyframes between).
    pub fn stride(&self) -> u64 {
        self.stride
    }

    /// Keyframes kept.
    pub fn keyframes(&self) -> usize {
        self.keyframes.len()
    }

    /// The keyframes, oldest first.
    pub fn keyframe_list(&self) -> impl Iterator<Item = &Keyframe> {
        self.keyframes.iter()
    }

    /// The bytes the keyframes take (estimated; states shared with a branch are counted
    /// in each) and the bound.
    pub fn memory(&self) -> (usize, usize) {
        (
            self.bytes + self.inputs.len() * std::mem::size_of::<(u64, I)>(),
            self.budget,
        )
    }

    /// Steps back from the newest that are kept.
    pub fn horizon(&self) -> u64 {
        self.horizon
    }

    /// Keeps `horizon` steps back from now on (the world's dt changed, say).
    pub fn set_horizon(&mut self, horizon: u64) {
        self.horizon = horizon.max(1);
        self.trim();
    }

    /// Why nothing is kept, when a single state is over the memory bound.
    pub fn off(&self) -> Option<&str> {
        self.off.as_deref()
    }

    /// Call before stepping `world` (at step s): the steps recorded after s are
    /// dropped (the run goes another way from here), and a keyframe is taken at s when
    /// s is a multiple of the stride or nothing is kept yet.
    pub fn before_step(&mut self, world: &World) {
        let s = world.step_count();
        if self.at != Some(s) {
            // not the world this timeline follows (it was replaced or changed without
            // a word): start again from it
            if !self.keyframes.is_empty() || self.off.is_none() {
                self.clear();
            }
        } else if self.newest > s {
            self.truncate_after(s);
        }
        if self.off.is_some() {
            // one state is over the bound: nothing is kept until an edit changes that
            return;
        }
        let have = self.keyframes.back().is_some_and(|k| k.step == s);
        if !have && (self.keyframes.is_empty() || s.is_multiple_of(self.stride)) {
            self.push(world, false);
        }
    }

    /// Call after the step that took `world` to its step count with `input`.
    pub fn after_step(&mut self, world: &World, input: I) {
        let s = world.step_count();
        if self.keyframes.is_empty() {
            return;
        }
        self.inputs.push_back((s, input));
        self.newest = s;
        self.at = Some(s);
        self.trim();
    }

    /// The world was changed between steps by something that is not a step's input
    /// (a body added or removed, the settings, a loaded state): the steps after its
    /// step are dropped and it is kept as it is now, pinned.
    pub fn edited(&mut self, world: &World) {
        let s = world.step_count();
        self.truncate_after(s);
        while self.keyframes.back().is_some_and(|k| k.step == s) {
            let k = self.keyframes.pop_back().expect("checked");
            self.bytes -= k.bytes;
        }
        // the inputs up to s stay: they lead to s from the keyframes before it, and
        // the keyframe at s (taken now) is where anything after starts
        self.push(world, true);
        self.newest = s;
    }

    /// Drops every step after `s` (and the keyframes taken after it).
    fn truncate_after(&mut self, s: u64) {
        while self.keyframes.back().is_some_and(|k| k.step > s) {
            let k = self.keyframes.pop_back().expect("checked");
            self.bytes -= k.bytes;
        }
        while self.inputs.back().is_some_and(|(t, _)| *t > s) {
            self.inputs.pop_back();
        }
        if self.keyframes.is_empty() {
            self.inputs.clear();
            self.newest = 0;
        } else {
            self.newest = self.newest.min(s);
        }
    }

    fn push(&mut self, world: &World, pinned: bool) {
        // the size first, so that a world too large is never copied; two keyframes must
        // fit, or going back would mean stepping again from ever further back
        let bytes = world.state_bytes();
        if bytes > self.budget / 2 {
            self.keyframes.clear();
            self.inputs.clear();
            self.bytes = 0;
            self.newest = 0;
            self.at = None;
            self.off = Some(format!(
                "one state takes {}, over half the bound of {} (two must fit)",
                mib(bytes),
                mib(self.budget)
            ));
            return;
        }
        self.off = None;
        self.keyframes.push_back(Keyframe {
            step: world.step_count(),
            state: Arc::new(world.snapshot()),
            bytes,
            pinned,
        });
        self.bytes += bytes;
        self.newest = world.step_count();
        self.at = Some(world.step_count());
        self.trim();
    }

    /// Keeps the horizon and the memory bound: old keyframes go once a later one
    /// covers the horizon; over the bound, the stride doubles (up to the horizon: going
    /// back never steps more than that again) and the keyframes off it go; when that
    /// cannot help (pinned keyframes, or the stride at the horizon), the oldest go.
    fn trim(&mut self) {
        let cutoff = self.newest.saturating_sub(self.horizon);
        while self.keyframes.len() > 1 && self.keyframes[1].step <= cutoff {
            let k = self.keyframes.pop_front().expect("checked");
            self.bytes -= k.bytes;
        }
        while self.bytes > self.budget && self.keyframes.len() > 1 {
            if self.stride * 2 > self.horizon {
                let k = self.keyframes.pop_front().expect("more than one");
                self.bytes -= k.bytes;
                continue;
            }
            let stride = self.stride * 2;
            let before = self.keyframes.len();
            // the newest keyframe stays whatever its step (it is where the run goes on)
            let last = self.keyframes.len() - 1;
            let mut i = 0;
            let mut bytes = self.bytes;
            self.keyframes.retain(|k| {
                let keep = k.pinned || k.step.is_multiple_of(stride) || i == last || i == 0;
                i += 1;
                if !keep {
                    bytes -= k.bytes;
                }
                keep
            });
            self.bytes = bytes;
            self.stride = stride;
            if self.keyframes.len() == before {
                // nothing thinned: the oldest goes
                let k = self.keyframes.pop_front().expect("more than one");
                self.bytes -= k.bytes;
            }
        }
        let first = self.oldest().unwrap_or(0);
        while self.inputs.front().is_some_and(|(t, _)| *t <= first) {
            self.inputs.pop_front();
        }
    }

    /// The input recorded for the step that ended at `s`.
    fn input(&self, s: u64) -> Option<&I> {
        let first = self.inputs.front()?.0;
        let (t, i) = self
            .inputs
            .get(usize::try_from(s.checked_sub(first)?).ok()?)?;
        (*t == s).then_some(i)
    }

    /// Puts `world` at step `target`: restores the last keyframe at or before it and
    /// steps from there, each step by `step(world, input)` with the input it was
    /// recorded with (or goes on from the world itself, when it is on this timeline
    /// at or after that keyframe and before the target). The world then has the state
    /// hash it had at `target` when the steps were first taken.
    pub fn seek(
        &mut self,
        world: &mut World,
        target: u64,
        mut step: impl FnMut(&mut World, &I) -> Result<(), StepError>,
    ) -> Result<(), SeekError> {
        let (Some(oldest), Some(newest)) = (self.oldest(), self.newest()) else {
            return Err(SeekError::Empty);
        };
        if !(oldest..=newest).contains(&target) {
            return Err(SeekError::OutOfRange {
                step: target,
                oldest,
                newest,
            });
        }
        let k = self
            .keyframes
            .iter()
            .rev()
            .find(|k| k.step <= target)
            .expect("the oldest is at or before the target");
        let here = world.step_count();
        let from_here = self.at == Some(here) && k.step <= here && here <= target;
        if !from_here {
            world.restore(&k.state)?;
        }
        self.at = None;
        for s in world.step_count() + 1..=target {
            let input = self
                .input(s)
                .expect("every step after the oldest keyframe has its input");
            step(world, input)?;
        }
        self.at = Some(target);
        Ok(())
    }

    /// A timeline for a branch made at step `at` (the world there): the keyframes
    /// and inputs up to `at`, sharing their states with this one.
    pub fn branch(&self, at: u64) -> Timeline<I> {
        let mut t = self.clone();
        t.truncate_after(at);
        // the world the branch starts from is this timeline's at `at` only if the
        // caller's world was
        t.at = self.at.filter(|&a| a == at);
        t
    }
}

/// Bytes as MiB for a line of text.
pub fn mib(bytes: usize) -> String {
    format!("{:.1} MiB", bytes as f64 / (1024.0 * 1024.0))
}

/// The `format` field of a saved run.
pub const RUN_FORMAT: &str = "sandbox2d-run";
/// The version of the saved-run format this build writes and reads.
pub const RUN_VERSION: u32 = 1;

/// A headless run in a file: where it started, keyframes along it, and where it
/// ended, so that any of its steps can be gone to (restore the last keyframe at or
/// before it, step on with the run's settings). See `docs/timeline.md`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SavedRun {
    /// Always [`RUN_FORMAT`].
    pub format: String,
    /// [`RUN_VERSION`] when written by this build.
    pub version: u32,
    /// The scene's source (a file path or `builtin:NAME`), for messages.
    pub scene: String,
    /// The first and the last step of the run.
    pub first_step: u64,
    /// The last step of the run (the world's step count when it ended).
    pub last_step: u64,
    /// Steps between keyframes.
    pub every: u64,
    /// The state hash (hex) after the last step.
    pub last_hash: String,
    /// The keyframes, first step first: each its step, its state hash (hex) and the
    /// state ([`WorldState`], the `--save-state` form).
    pub keyframes: Vec<RunKeyframe>,
}

/// One keyframe of a [`SavedRun`].
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct RunKeyframe {
    /// The step it was taken at (the world's step count).
    pub step: u64,
    /// The world's state hash at that step, in hex.
    pub hash: String,
    /// The whole state, to restore.
    pub state: WorldState,
}

/// Why a saved run could not be read or used. Each message is one line.
#[derive(Debug, thiserror::Error)]
pub enum RunFileError {
    /// The text is not a run file (not JSON of its form, or not its format): why.
    #[error("not a sandbox2d run file: {0}")]
    Parse(String),
    /// The file's format version, which this build does not read.
    #[error("run format version {0} is not supported (this build reads version {RUN_VERSION})")]
    Version(u32),
    /// The file parses but does not hold together (no keyframe, a keyframe whose state
    /// fails its checks or its recorded hash, steps out of order, ...): what is wrong.
    #[error("the run is damaged: {0}")]
    Invalid(String),
    /// The step asked for is outside the run.
    #[error("step {step} is not in the run (it holds steps {first} to {last})")]
    OutOfRange {
        /// The step asked for.
        step: u64,
        /// The run's first step.
        first: u64,
        /// The run's last step.
        last: u64,
    },
    /// A step taken to reach the one asked for failed.
    #[error(transparent)]
    Step(#[from] StepError),
}

impl SavedRun {
    /// A run starting from `world` as it is, keyframes every `every` steps.
    pub fn start(scene: &str, world: &World, every: u64) -> SavedRun {
        let s = world.step_count();
        SavedRun {
            format: RUN_FORMAT.into(),
            version: RUN_VERSION,
            scene: scene.into(),
            first_step: s,
            last_step: s,
            every: every.max(1),
            last_hash: hex(world.state_hash()),
            keyframes: vec![RunKeyframe {
                step: s,
                hash: hex(world.state_hash()),
                state: world.snapshot(),
            }],
        }
    }

    /// Records `world` after one of the run's steps: a keyframe when its step is a
    /// multiple of `every` past the first.
    pub fn record(&mut self, world: &World) {
        let s = world.step_count();
        self.last_step = s;
        self.last_hash = hex(world.state_hash());
        if (s - self.first_step).is_multiple_of(self.every) {
            self.keyframes.push(RunKeyframe {
                step: s,
                hash: self.last_hash.clone(),
                state: world.snapshot(),
            });
        }
    }

    /// The run as JSON bytes (refused when a state is not finite).
    pub fn to_json(&self) -> Result<Vec<u8>, StateError> {
        for k in &self.keyframes {
            // the same check as a saved state's
            k.state.to_json()?;
        }
        serde_json::to_vec(self).map_err(|e| StateError::NotFinite(e.to_string()))
    }

    /// Reads a run written by [`SavedRun::to_json`] and checks it: its format and
    /// version, each keyframe's state ([`WorldState::check`]) and that each one's
    /// state hash is the one recorded with it.
    pub fn from_json(bytes: &[u8]) -> Result<SavedRun, RunFileError> {
        #[derive(serde::Deserialize)]
        struct Header {
            format: Option<String>,
            version: Option<u32>,
        }
        let parse = |e: serde_json::Error| {
            RunFileError::Parse(e.to_string().chars().flat_map(char::escape_debug).collect())
        };
        let h: Header = serde_json::from_slice(bytes).map_err(parse)?;
        if h.format.as_deref() != Some(RUN_FORMAT) {
            return Err(RunFileError::Parse(format!(
                "no \"format\": \"{RUN_FORMAT}\" field"
            )));
        }
        match h.version {
            Some(RUN_VERSION) => {}
            Some(v) => return Err(RunFileError::Version(v)),
            None => return Err(RunFileError::Parse("no \"version\" field".into())),
        }
        let run: SavedRun = serde_json::from_slice(bytes).map_err(parse)?;
        let bad = |m: String| Err(RunFileError::Invalid(m));
        if run.keyframes.is_empty() {
            return bad("it has no keyframe".into());
        }
        if run.every == 0 {
            return bad("\"every\" is 0".into());
        }
        if run.keyframes[0].step != run.first_step || run.last_step < run.first_step {
            return bad(format!(
                "its steps ({} to {}) do not start at its first keyframe (step {})",
                run.first_step, run.last_step, run.keyframes[0].step
            ));
        }
        let mut prev: Option<u64> = None;
        for k in &run.keyframes {
            if prev.is_some_and(|p| p >= k.step) || k.step > run.last_step {
                return bad(format!("keyframe at step {} is out of order", k.step));
            }
            prev = Some(k.step);
            if k.state.step_count != k.step {
                return bad(format!(
                    "the keyframe at step {} holds the state of step {}",
                    k.step, k.state.step_count
                ));
            }
            k.state
                .check()
                .map_err(|e| RunFileError::Invalid(format!("keyframe at step {}: {e}", k.step)))?;
            let w = World::from_state(&k.state)
                .map_err(|e| RunFileError::Invalid(format!("keyframe at step {}: {e}", k.step)))?;
            if hex(w.state_hash()) != k.hash {
                return bad(format!(
                    "the keyframe at step {} has state hash {}, not the {} recorded with it",
                    k.step,
                    hex(w.state_hash()),
                    k.hash
                ));
            }
        }
        Ok(run)
    }

    /// The world at step `k` of the run: the last keyframe at or before it, stepped on
    /// with its own settings. `on_step` sees each step taken to get there.
    pub fn world_at(&self, k: u64) -> Result<World, RunFileError> {
        if !(self.first_step..=self.last_step).contains(&k) {
            return Err(RunFileError::OutOfRange {
                step: k,
                first: self.first_step,
                last: self.last_step,
            });
        }
        let key = self
            .keyframes
            .iter()
            .rev()
            .find(|f| f.step <= k)
            .expect("the first keyframe is the first step");
        let mut w = World::from_state(&key.state)
            .map_err(|e| RunFileError::Invalid(format!("keyframe at step {}: {e}", key.step)))?;
        while w.step_count() < k {
            w.step()?;
        }
        Ok(w)
    }
}

/// A state hash as 16 hex digits (as `simulate` prints it).
pub fn hex(h: u64) -> String {
    format!("{h:016x}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::defs::{SolverKind, SolverSettings};

    fn pyramid(kind: SolverKind) -> World {
        let sc = crate::scene::load("pyramid").unwrap();
        World::from_def(&sc.world, SolverSettings::defaults(kind)).unwrap()
    }

    /// An input that pushes body 5 sideways on some steps: recorded inputs matter.
    fn push(w: &mut World, i: &f32) -> Result<(), StepError> {
        if *i != 0.0 {
            let at = w.bodies[5].position;
            w.apply_force_index(5, crate::math::Vec2::new(*i, 0.0), at);
        }
        w.step()
    }

    fn input_at(s: u64) -> f32 {
        if s % 7 == 3 { 400.0 } else { 0.0 }
    }

    #[test]
    fn seeking_back_restores_and_restepping_gives_each_steps_hash() {
        let mut w = pyramid(SolverKind::Soft);
        let mut t: Timeline<f32> = Timeline::new(1000, usize::MAX);
        let mut hashes = vec![w.state_hash()];
        for s in 1..=60u64 {
            t.before_step(&w);
            // record this step's stride: 5 steps between keyframes
            if s == 1 {
                t.stride = 5;
            }
            push(&mut w, &input_at(s)).unwrap();
            t.after_step(&w, input_at(s));
            hashes.push(w.state_hash());
        }
        assert_eq!((t.oldest(), t.newest()), (Some(0), Some(60)));
        for target in [59u64, 0, 33, 34, 35, 12, 60, 1] {
            t.seek(&mut w, target, push).unwrap();
            assert_eq!(w.step_count(), target);
            assert_eq!(w.state_hash(), hashes[target as usize], "step {target}");
        }
        assert!(matches!(
            t.seek(&mut w, 61, push),
            Err(SeekError::OutOfRange { .. })
        ));
    }

    #[test]
    fn memory_stays_within_the_bound_by_thinning_keyframes() {
        let mut w = pyramid(SolverKind::Pgs);
        for _ in 0..30 {
            w.step().unwrap();
        }
        let one = w.snapshot().heap_bytes();
        let mut t: Timeline<f32> = Timeline::new(10_000, 8 * one);
        let mut hashes = std::collections::HashMap::new();
        for s in 31..=130u64 {
            t.before_step(&w);
            push(&mut w, &input_at(s)).unwrap();
            t.after_step(&w, input_at(s));
            hashes.insert(s, w.state_hash());
            let (bytes, bound) = t.memory();
            assert!(bytes <= bound + 256 * 1024, "{bytes} > {bound}");
            assert!(t.keyframes() <= 9, "{}", t.keyframes());
        }
        assert!(t.stride() >= 8, "stride {}", t.stride());
        // the oldest keyframe is kept: the whole run is still reachable
        assert_eq!(t.oldest(), Some(30));
        for target in [130u64, 31, 77, 100] {
            t.seek(&mut w, target, push).unwrap();
            assert_eq!(w.state_hash(), hashes[&target], "step {target}");
        }
    }

    #[test]
    fn a_bound_of_few_states_keeps_going_back_within_the_horizon() {
        // room for 3 states: the stride stops doubling at the horizon (40 steps), and
        // then the oldest keyframe goes; what is reachable stays near the newest
        let mut w = pyramid(SolverKind::Soft);
        let one = w.state_bytes();
        let mut t: Timeline<f32> = Timeline::new(40, 3 * one + one / 2);
        let mut hashes = std::collections::HashMap::new();
        for s in 1..=200u64 {
            t.before_step(&w);
            push(&mut w, &input_at(s)).unwrap();
            t.after_step(&w, input_at(s));
            hashes.insert(s, w.state_hash());
            assert!(t.memory().0 <= t.memory().1 + 64 * 1024);
        }
        assert!(t.stride() <= 40, "stride {}", t.stride());
        let oldest = t.oldest().unwrap();
        assert!((120..=160).contains(&oldest), "oldest {oldest}");
        for k in [oldest, 199, 170] {
            t.seek(&mut w, k, push).unwrap();
            assert_eq!(w.state_hash(), hashes[&k], "step {k}");
        }
    }

    #[test]
    fn the_horizon_drops_old_steps_and_an_edit_pins_a_keyframe() {
        let mut w = pyramid(SolverKind::Xpbd);
        let mut t: Timeline<f32> = Timeline::new(20, usize::MAX);
        for s in 1..=50u64 {
            t.before_step(&w);
            push(&mut w, &0.0).unwrap();
            t.after_step(&w, 0.0);
            if s == 40 {
                // a body spawned between steps 40 and 41
                w.add_body(&crate::defs::BodyDef {
                    name: "spawned".into(),
                    shape: crate::defs::ShapeDef::Circle { radius: 0.3 },
                    position: crate::math::Vec2::new(0.0, 30.0),
                    ..Default::default()
                })
                .unwrap();
                t.edited(&w);
            }
        }
        let oldest = t.oldest().unwrap();
        assert!((25..=30).contains(&oldest), "oldest {oldest}");
        assert!(t.keyframe_list().any(|k| k.pinned && k.step == 40));
        let n = w.bodies.len();
        let hash = w.state_hash();
        t.seek(&mut w, 39, push).unwrap();
        assert_eq!(w.bodies.len(), n - 1, "before the spawn");
        t.seek(&mut w, 50, push).unwrap();
        assert_eq!((w.bodies.len(), w.state_hash()), (n, hash));
        // going back and stepping drops what came after
        t.seek(&mut w, 45, push).unwrap();
        t.before_step(&w);
        push(&mut w, &100.0).unwrap();
        t.after_step(&w, 100.0);
        assert_eq!(t.newest(), Some(46));
    }

    #[test]
    fn a_state_over_the_bound_turns_the_timeline_off() {
        let w = pyramid(SolverKind::Soft);
        let mut t: Timeline<()> = Timeline::new(100, 1000);
        t.before_step(&w);
        assert_eq!(t.keyframes(), 0);
        assert!(
            t.off().unwrap().contains("over half the bound"),
            "{:?}",
            t.off()
        );
    }

    #[test]
    fn a_saved_run_reads_back_and_reaches_every_step() {
        let mut w = pyramid(SolverKind::Soft);
        let mut run = SavedRun::start("builtin:pyramid", &w, 25);
        let mut hashes = vec![w.state_hash()];
        for _ in 0..60 {
            w.step().unwrap();
            run.record(&w);
            hashes.push(w.state_hash());
        }
        let back = SavedRun::from_json(&run.to_json().unwrap()).unwrap();
        assert_eq!(back.keyframes.len(), 3);
        assert_eq!(back.last_hash, hex(hashes[60]));
        for k in [0u64, 24, 25, 26, 59, 60] {
            assert_eq!(back.world_at(k).unwrap().state_hash(), hashes[k as usize]);
        }
        assert!(matches!(
            back.world_at(61),
            Err(RunFileError::OutOfRange { .. })
        ));
        // a keyframe whose state does not hash to its recorded hash is refused
        let mut bad = run.clone();
        bad.keyframes[1].hash = hex(1);
        let e = SavedRun::from_json(&bad.to_json().unwrap()).unwrap_err();
        assert!(e.to_string().contains("state hash"), "{e}");
        let e = SavedRun::from_json(b"{\"format\":\"sandbox2d-run\",\"version\":9}").unwrap_err();
        assert!(matches!(e, RunFileError::Version(9)), "{e}");
    }
}
