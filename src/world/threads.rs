//! Whether a world's extra threads pay: a world allowed several threads may measure
//! its own steps and run them on one thread while the others do not pay.
//!
//! Two threads beat one only when each has a core: when another program holds a core,
//! the system deschedules one of the step's threads now and then, and the other waits
//! for the block it was running (a scheduler slice, milliseconds, where a step's phase is
//! microseconds). So a world that adapts times each step and, from time to time, tries
//! the other choice for a few steps (a probe), keeping many threads only while they are
//! clearly faster: where the two are alike, one thread steps (its time is the steadier,
//! and a probe of a few steps on many threads may catch a lucky moment). A probe of
//! one thread is cheap (one thread is never much slower than its own time), so it comes
//! early whenever the steps on many threads are no longer clearly faster than one thread
//! was; a probe of many threads stops at the first step that shows it cannot win, and
//! comes less and less often while it keeps losing. The results are the same to the bit
//! whichever choice a step takes.

use std::time::Duration;

/// How many threads a world's steps use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Threads {
    /// Exactly this many (1: the caller alone).
    Fixed(usize),
    /// Up to this many: all of them while they pay, one while they do not (measured
    /// as the world steps).
    UpTo(usize),
}

impl Threads {
    /// The most threads a step may use.
    pub fn most(self) -> usize {
        match self {
            Threads::Fixed(n) | Threads::UpTo(n) => n,
        }
    }
}

/// Steps a probe runs at most.
const PROBE_STEPS: u32 = 4;
/// Many threads are taken when a probe of them takes less than this share of one
/// thread's time, and kept while they take less than `KEEP` of it: in between, and when
/// the two are alike (a busy machine), one thread steps, whose time is the steadier.
const WIN: f64 = 0.92;
const KEEP: f64 = 0.95;
/// Steps between probes right after a switch, and at most.
const FIRST_INTERVAL: u32 = 16;
const LONGEST_INTERVAL: u32 = 1024;
/// Steps measured before the first probe (the first steps build the caches).
const WARMUP: u32 = 3;
/// Weight of a new step in the current choice's running mean.
const ALPHA: f64 = 1.0 / 8.0;

/// How a world's steps were shared between one thread and many, for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ThreadUse {
    /// Steps run on one thread and on all the threads allowed.
    pub steps_on_one: u64,
    /// Steps run on all the threads allowed.
    pub steps_on_many: u64,
    /// Times the choice changed.
    pub switches: u32,
}

/// The measuring and the choice (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct ThreadTuner {
    /// Steps run on many threads now (else one).
    many: bool,
    /// The running mean of a step's time on one thread and on many (s), as last
    /// measured (NaN: not yet).
    mean: [f64; 2],
    /// The probe under way: steps run and their time in all.
    probe: Option<(u32, f64)>,
    /// Steps until the next probe, and the interval between probes.
    until_probe: u32,
    interval: u32,
    warmup: u32,
    used: ThreadUse,
    /// Said once that the extra threads did not pay.
    said: bool,
}

impl Default for ThreadTuner {
    fn default() -> Self {
        ThreadTuner {
            many: true,
            mean: [f64::NAN; 2],
            probe: None,
            // (the running mean of many threads from a couple of steps, then one thread
            // tried at once: a busy machine is found within the first ten steps)
            until_probe: 2,
            interval: FIRST_INTERVAL,
            warmup: WARMUP,
            used: ThreadUse::default(),
            said: false,
        }
    }
}

impl ThreadTuner {
    /// Whether the next step runs on many threads.
    pub(crate) fn choose(&self) -> bool {
        self.many != self.probe.is_some()
    }

    /// Steps so far on each choice.
    pub(crate) fn used(&self) -> ThreadUse {
        self.used
    }

    /// Takes the time of a step that ran on many threads or on one, `threads` allowed.
    pub(crate) fn record(&mut self, many: bool, took: Duration, threads: usize) {
        if many {
            self.used.steps_on_many += 1;
        } else {
            self.used.steps_on_one += 1;
        }
        let t = took.as_secs_f64();
        if self.warmup > 0 {
            self.warmup -= 1;
            return;
        }
        let (cur, other) = (usize::from(self.many), usize::from(!self.many));
        if let Some((k, sum)) = self.probe {
            let (k, sum) = (k + 1, sum + t);
            let base = self.mean[cur];
            // the share of the current choice's time the probe must beat
            let share = if many { WIN } else { 1.0 / KEEP };
            // the probe cannot win once its steps so far took more than that share of the
            // current choice's whole probe (and, trying one thread, once a step took half
            // as long again: one thread's time hardly varies)
            let lost = sum > PROBE_STEPS as f64 * base * share || (!many && t > 1.5 * base);
            if lost || k == PROBE_STEPS {
                self.probe = None;
                self.mean[other] = sum / k as f64;
                if !lost && sum / (k as f64) < base * share {
                    self.switch(threads);
                } else {
                    self.interval = (self.interval * 2).min(LONGEST_INTERVAL);
                    self.until_probe = self.interval;
                }
            } else {
                self.probe = Some((k, sum));
            }
            return;
        }
        let m = self.mean[cur];
        let m = if m.is_nan() { t } else { m + ALPHA * (t - m) };
        self.mean[cur] = m;
        // many threads no longer clearly faster than one thread was: try one at once
        let one = self.mean[0];
        if self.many && !one.is_nan() && m > one * KEEP && self.until_probe > 2 {
            self.until_probe = 0;
        }
        if self.until_probe == 0 {
            self.probe = Some((0, 0.0));
        } else {
            self.until_probe -= 1;
        }
    }

    fn switch(&mut self, threads: usize) {
        self.many = !self.many;
        self.used.switches += 1;
        self.interval = FIRST_INTERVAL;
        self.until_probe = self.interval;
        if !self.many && !self.said {
            self.said = true;
            log::info!(
                "{threads} threads do not pay here now ({:.3} ms a step against {:.3} on one): \
                 stepping on one thread, and trying {threads} again now and then",
                self.mean[1] * 1e3,
                self.mean[0] * 1e3
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps a tuner through `steps` steps whose time on one thread and on many is given
    /// per step; returns the steps run on many threads.
    fn run(tuner: &mut ThreadTuner, steps: usize, time: impl Fn(usize, bool) -> f64) -> (u64, f64) {
        let mut on_many = 0;
        let mut total = 0.0;
        for i in 0..steps {
            let many = tuner.choose();
            let t = time(i, many);
            total += t;
            on_many += u64::from(many);
            tuner.record(many, Duration::from_secs_f64(t), 2);
        }
        (on_many, total)
    }

    #[test]
    fn the_faster_choice_takes_nearly_every_step() {
        // two threads at 0.6 of one: nearly every step on both
        let mut t = ThreadTuner::default();
        let (many, total) = run(&mut t, 1000, |_, many| if many { 0.6e-3 } else { 1e-3 });
        assert!(many > 980, "{many}");
        assert!(total < 1000.0 * 0.6e-3 * 1.01, "{total}");
        // two threads at 3 times one (a core held elsewhere): nearly every step on one,
        // and the time within 10% of one thread's
        let mut t = ThreadTuner::default();
        let (many, total) = run(&mut t, 1000, |_, many| if many { 3e-3 } else { 1e-3 });
        assert!(many < 30, "{many}");
        assert!(total < 1000.0 * 1e-3 * 1.1, "{total}");
    }

    #[test]
    fn threads_no_faster_than_one_leave_the_steps_to_one() {
        // a busy machine where two threads take one thread's time, give or take 15% a
        // step (a fixed scramble of the step's index): two threads gain nothing, and one
        // thread's time is the steadier, so nearly every step is on one
        let noise = |i: usize, many: bool| {
            let h = (i as u64 * 2 + u64::from(many)).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
            1.0 + 0.3 * (h as f64 / (1u64 << 24) as f64 - 0.5)
        };
        let mut t = ThreadTuner::default();
        let (many, _) = run(&mut t, 2000, |i, m| 1e-3 * noise(i, m));
        assert!(many < 100, "{many} of 2000 steps on two threads");
    }

    #[test]
    fn a_core_taken_and_given_back_is_followed() {
        // steps 300..700: another program holds a core, and two threads take 2.5 times
        // one thread's time, with a step now and then ten times as long
        let busy = |i: usize| (300..700).contains(&i);
        let time = |i: usize, many: bool| match (many, busy(i)) {
            (false, _) => 1e-3,
            (true, false) => 0.6e-3,
            (true, true) if i.is_multiple_of(7) => 10e-3,
            (true, true) => 2.5e-3,
        };
        let mut t = ThreadTuner::default();
        let mut on_many_busy = 0;
        let mut on_many_after = 0;
        for i in 0..2000 {
            let many = t.choose();
            if busy(i) {
                on_many_busy += u64::from(many);
            }
            if i >= 1700 {
                on_many_after += u64::from(many);
            }
            t.record(many, Duration::from_secs_f64(time(i, many)), 2);
        }
        assert!(
            on_many_busy < 60,
            "{on_many_busy} of 400 busy steps on two threads"
        );
        assert!(
            on_many_after > 290,
            "{on_many_after} of the last 300 on two threads"
        );
        assert!(t.used().switches >= 2);
        assert_eq!(t.used().steps_on_one + t.used().steps_on_many, 2000);
    }
}
