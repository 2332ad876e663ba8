//! A small pool of worker threads for the step's parallel stages (narrow phase, the soft
//! step's colours, integration), written for short, frequent jobs.
//!
//! A job is a closure and a number of blocks: each block is claimed by one thread (the
//! caller, thread 0, claims too) and run once. The caller returns only when every block
//! is done, so a job may borrow from the caller's stack. Claiming, not a fixed split,
//! keeps a busy machine from stalling the step: a worker that the system has not
//! scheduled yet claims nothing, and the caller does its share. Between jobs the workers
//! spin for a few microseconds (a step posts a few dozen jobs), then yield, then sleep
//! until the next job. A pass over the soft step's colours is one job of several phases
//! (`phases_max`): the threads go from colour to colour meeting at counters of their
//! own, not through a job per colour. With two threads, the soft step's substeps run as
//! one such job in which a thread waits at a colour's end only for the other's
//! constraints that touch bodies its own share writes (`phases_ahead`).
//!
//! Results never depend on the thread count: the stages split only work whose items
//! are independent (pairs in the narrow phase, constraints of one colour that share no
//! moving body, bodies), and reductions are order-free (max) or done in a fixed order.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// The most threads a pool runs (the caller included).
pub const MAX_THREADS: usize = 64;

/// Threads a new [`crate::World`] may use: 1 unless [`set_default_threads`] said
/// otherwise (the command line sets it from `--threads`).
static DEFAULT_THREADS: AtomicUsize = AtomicUsize::new(1);

/// Threads a new world may use ([`crate::World::set_threads`] changes one world's).
pub fn default_threads() -> usize {
    DEFAULT_THREADS.load(Ordering::Relaxed)
}

/// Whether a new world measures if its extra threads pay (see [`crate::Threads`]).
static DEFAULT_ADAPTIVE: AtomicBool = AtomicBool::new(false);

/// Whether a new world measures if its extra threads pay and steps on one thread while
/// they do not ([`crate::Threads::UpTo`]; false unless the program said otherwise).
pub fn default_adaptive() -> bool {
    DEFAULT_ADAPTIVE.load(Ordering::Relaxed)
}

/// Sets whether every world made from now on adapts its threads.
pub fn set_default_adaptive(on: bool) {
    DEFAULT_ADAPTIVE.store(on, Ordering::Relaxed);
}

/// Sets the threads every world made from now on may use (clamped to 1..=[`MAX_THREADS`]).
pub fn set_default_threads(n: usize) {
    DEFAULT_THREADS.store(n.clamp(1, MAX_THREADS), Ordering::Relaxed);
}

/// The number of threads `--threads` means by default: the machine's cores.
pub fn available() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(MAX_THREADS)
}

/// How long a cache line takes to go from one core to another and back (ns), measured
/// now by a thread of its own bouncing a counter with the caller: what each hand-off of
/// the step between threads costs on this machine at this moment. The cores of a
/// virtual machine may share a cache (tens of ns) or not (hundreds), and that can change
/// as its host moves them: two threads then run the step at very different speeds. The
/// least mean of batches of 500 round trips, so a batch that the scheduler interrupted
/// (the other core busy, say with a pool's worker that has not parked yet) does not
/// count. At most about 100 ms. None where one core is all there is, or where no batch
/// finished in that time (the other core was not ours).
pub fn core_round_trip_ns() -> Option<f64> {
    if available() < 2 {
        return None;
    }
    round_trip_within(std::time::Duration::from_millis(100))
}

/// The probe of [`core_round_trip_ns`], giving up after `limit`.
fn round_trip_within(limit: std::time::Duration) -> Option<f64> {
    const STOP: u64 = u64::MAX;
    const BATCH: u64 = 500;
    const BATCHES: u64 = 40;
    let line = Slot(AtomicU64::new(0));
    let start = std::time::Instant::now();
    let mut best: Option<f64> = None;
    std::thread::scope(|s| {
        s.spawn(|| {
            // answer each odd count with the next even one, until told to stop. The
            // answer only replaces the count it answers: a plain store could overwrite
            // a STOP that the caller, tired of waiting, wrote between this thread's read
            // and its write, and this thread would then wait for ever (and the caller
            // with it, at the scope's end).
            let mut want = 1u64;
            loop {
                match line.0.compare_exchange_weak(
                    want,
                    want + 1,
                    Ordering::AcqRel,
                    Ordering::Acquire,
                ) {
                    Ok(_) => want += 2,
                    Err(STOP) => return,
                    Err(_) => std::hint::spin_loop(),
                }
            }
        });
        let mut count = 0u64;
        'batches: for _ in 0..BATCHES {
            let t = std::time::Instant::now();
            for _ in 0..BATCH {
                line.0.store(count + 1, Ordering::Release);
                let mut spins = 0u32;
                while line.0.load(Ordering::Acquire) != count + 2 {
                    std::hint::spin_loop();
                    spins = spins.wrapping_add(1);
                    if spins.is_multiple_of(1024) && start.elapsed() > limit {
                        break 'batches;
                    }
                }
                count += 2;
            }
            let ns = t.elapsed().as_nanos() as f64 / BATCH as f64;
            best = Some(best.map_or(ns, |b: f64| b.min(ns)));
            if start.elapsed() > limit {
                break;
            }
        }
        line.0.store(STOP, Ordering::Release);
    });
    best
}

/// A job's closure as the workers see it, its lifetime erased. It is alive while blocks
/// of its epoch can still be claimed.
type JobFn = *const (dyn Fn(usize, usize) + Sync + 'static);

struct Shared {
    /// The epoch of the latest job; a worker wakes when it changes.
    epoch: AtomicU32,
    /// The latest job, published before `epoch`: (epoch << 32) | blocks, and where its
    /// closure lies (a pointer to the caller's `JobFn`, on the caller's stack). A worker
    /// calls the closure only after claiming a block of that epoch, which the caller
    /// waits for: a pointer read for an epoch that has ended is never followed.
    job_info: AtomicU64,
    job_f: AtomicPtr<JobFn>,
    /// Per thread's segment of the blocks: (epoch << 32) | next block. A block is claimed
    /// by a compare-and-swap that checks the epoch, so a worker that comes late to a job
    /// claims nothing of the next one.
    claim: Vec<Slot>,
    /// Blocks of the current job finished.
    completed: AtomicUsize,
    /// Per worker: it is (about to be) parked and needs an unpark for the next job.
    parked: Vec<AtomicBool>,
    quit: AtomicBool,
    /// A job panicked on a worker: the caller panics too, once every block is done.
    panicked: AtomicBool,
    /// Threads asleep in a wait inside a job (bit t: thread t, the caller being 0): each
    /// block done wakes them (see [`Shared::pause`]).
    sleeping: Slot,
    /// The thread that posted the current job, and the workers (thread t at t), to wake.
    caller: Mutex<Option<std::thread::Thread>>,
    workers: std::sync::OnceLock<Vec<std::thread::Thread>>,
}

/// A claim counter on a cache line of its own.
#[repr(align(64))]
struct Slot(AtomicU64);

/// How long a thread with nothing to do spins, then yields, before it sleeps until the
/// work it waits for is done: a wait at a phase's end on a machine with a core for each
/// thread is a few microseconds; one that lasts longer is most likely a thread the
/// system has descheduled, and the core is better given back.
const SPIN_FOR: std::time::Duration = std::time::Duration::from_micros(50);
const YIELD_FOR: std::time::Duration = std::time::Duration::from_micros(100);
/// The longest a thread sleeps before it looks again (a wake-up is never lost; this only
/// bounds the damage if the system's wake-up were).
const SLEEP_AT_MOST: std::time::Duration = std::time::Duration::from_millis(2);

impl Shared {
    /// One round of waiting for thread `t`, idle since `since`, until `ready()`: a spin
    /// at first, then a yield, then, past [`YIELD_FOR`], a sleep until some block is
    /// done ([`Shared::wake_sleepers`]) if `ready()` is still false once the thread has
    /// said it sleeps.
    fn pause(&self, t: usize, since: std::time::Instant, ready: &dyn Fn() -> bool) {
        let waited = since.elapsed();
        if waited < SPIN_FOR {
            for _ in 0..8 {
                std::hint::spin_loop();
            }
        } else if waited < YIELD_FOR {
            std::thread::yield_now();
        } else {
            // say so, then look (a block done after the look sees the bit and wakes this
            // thread: both sides are full barriers), then sleep
            let bit = 1u64 << t;
            self.sleeping.0.fetch_or(bit, Ordering::SeqCst);
            std::sync::atomic::fence(Ordering::SeqCst);
            if !ready() {
                std::thread::park_timeout(SLEEP_AT_MOST);
            }
            self.sleeping.0.fetch_and(!bit, Ordering::SeqCst);
        }
    }

    /// Waits until `ready()` as [`Shared::pause`] does.
    fn wait(&self, t: usize, ready: &dyn Fn() -> bool) {
        let since = std::time::Instant::now();
        while !ready() {
            self.pause(t, since, ready);
        }
    }

    /// Wakes the threads asleep in a wait of the job (call after the sequentially
    /// consistent read-modify-write that publishes what they wait for).
    fn wake_sleepers(&self) {
        let mut s = self.sleeping.0.load(Ordering::SeqCst);
        while s != 0 {
            let t = s.trailing_zeros() as usize;
            s &= s - 1;
            if t == 0 {
                if let Some(c) = &*self.caller.lock().unwrap_or_else(|e| e.into_inner()) {
                    c.unpark();
                }
            } else if let Some(w) = self.workers.get().and_then(|w| w.get(t - 1)) {
                w.unpark();
            }
        }
    }

    /// Claims the next block of job `epoch` for thread `t`: from its own segment first
    /// (so each thread keeps to the same part of the data, colour after colour, and its
    /// bodies stay in its cache), then from the others'. `None` when none is left.
    fn claim(&self, t: usize, epoch: u32, blocks: usize) -> Option<usize> {
        let n = self.claim.len();
        (0..n).find_map(|k| {
            let seg = (t + k) % n;
            self.claim_in(seg, epoch, split(blocks, n, seg).end)
        })
    }

    fn claim_in(&self, seg: usize, epoch: u32, end: usize) -> Option<usize> {
        let slot = &self.claim[seg].0;
        let mut v = slot.load(Ordering::Acquire);
        loop {
            let next = (v & 0xffff_ffff) as usize;
            if (v >> 32) as u32 != epoch || next >= end {
                return None;
            }
            match slot.compare_exchange_weak(v, v + 1, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) => return Some(next),
                Err(now) => v = now,
            }
        }
    }
}

/// The i-th of `t` near-equal contiguous ranges of 0..len.
pub(crate) fn split(len: usize, t: usize, i: usize) -> Range<usize> {
    (len * i / t)..(len * (i + 1) / t)
}

/// Worker threads for the step's parallel stages; see the module docs.
pub struct Pool {
    shared: Arc<Shared>,
    workers: Vec<JoinHandle<()>>,
    /// One job at a time: worlds that share a pool (clones) take turns.
    turn: Mutex<u32>,
    /// Jobs of more than one block run so far.
    jobs: AtomicU64,
}

impl std::fmt::Debug for Pool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pool")
            .field("threads", &self.threads())
            .finish()
    }
}

/// Spins before a waiting thread starts yielding its core, and yields before it sleeps.
const SPINS: u32 = 1 << 12;
const YIELDS: u32 = 64;

impl Pool {
    /// A pool of `threads` threads in all: the caller and `threads - 1` workers
    /// (`threads` is clamped to 1..=[`MAX_THREADS`]).
    pub fn new(threads: usize) -> Pool {
        let workers = threads.clamp(1, MAX_THREADS) - 1;
        let shared = Arc::new(Shared {
            epoch: AtomicU32::new(0),
            job_info: AtomicU64::new(0),
            job_f: AtomicPtr::new(std::ptr::null_mut()),
            claim: (0..=workers).map(|_| Slot(AtomicU64::new(0))).collect(),
            completed: AtomicUsize::new(0),
            parked: (0..workers).map(|_| AtomicBool::new(false)).collect(),
            quit: AtomicBool::new(false),
            panicked: AtomicBool::new(false),
            sleeping: Slot(AtomicU64::new(0)),
            caller: Mutex::new(None),
            workers: std::sync::OnceLock::new(),
        });
        let workers = (0..workers)
            .map(|i| {
                let shared = Arc::clone(&shared);
                std::thread::Builder::new()
                    .name(format!("sandbox2d-worker-{}", i + 1))
                    .spawn(move || worker(&shared, i))
                    .expect("spawn a worker thread")
            })
            .collect::<Vec<JoinHandle<()>>>();
        let _ = shared
            .workers
            .set(workers.iter().map(|w| w.thread().clone()).collect());
        Pool {
            shared,
            workers,
            turn: Mutex::new(0),
            jobs: AtomicU64::new(0),
        }
    }

    /// Threads in all, the caller included.
    pub fn threads(&self) -> usize {
        self.workers.len() + 1
    }

    /// Jobs of more than one block this pool has run (the ones its workers could share).
    pub fn jobs(&self) -> u64 {
        self.jobs.load(Ordering::Relaxed)
    }

    /// Runs `f(thread, block)` once for every block in 0..blocks, on whichever threads
    /// claim them first (thread 0 is the caller, which claims too: a worker that is busy
    /// elsewhere or asleep delays nothing). Returns when every block is done; a panic in
    /// any of them is raised here.
    pub fn blocks(&self, blocks: usize, f: &(dyn Fn(usize, usize) + Sync)) {
        if self.workers.is_empty() || blocks <= 1 {
            for b in 0..blocks {
                f(0, b);
            }
            return;
        }
        let mut turn = self.turn.lock().unwrap_or_else(|e| e.into_inner());
        self.jobs.fetch_add(1, Ordering::Relaxed);
        *turn = turn.wrapping_add(1);
        let epoch = *turn;
        let s = &*self.shared;
        // SAFETY: the lifetime is erased only for the workers' copy; a worker calls `f`
        // only for a block of this epoch it claimed, and this function returns (or
        // unwinds) only once every block of the epoch has completed.
        let f_ptr: *const (dyn Fn(usize, usize) + Sync) = f;
        let f_ptr: JobFn = unsafe { std::mem::transmute(f_ptr) };
        let blocks32 = u32::try_from(blocks).expect("a job of fewer than 2^32 blocks");
        {
            // the thread to wake if it sleeps in this job's waits
            let mut caller = s.caller.lock().unwrap_or_else(|e| e.into_inner());
            let me = std::thread::current();
            if caller.as_ref().is_none_or(|c| c.id() != me.id()) {
                *caller = Some(me);
            }
        }
        s.completed.store(0, Ordering::SeqCst);
        // `f_ptr` stays on this frame until every block is done
        s.job_f
            .store(&f_ptr as *const JobFn as *mut JobFn, Ordering::Release);
        s.job_info
            .store(((epoch as u64) << 32) | blocks32 as u64, Ordering::Release);
        for (seg, slot) in s.claim.iter().enumerate() {
            let start = split(blocks, s.claim.len(), seg).start as u64;
            slot.0
                .store(((epoch as u64) << 32) | start, Ordering::SeqCst);
        }
        s.epoch.store(epoch, Ordering::SeqCst);
        for (flag, w) in s.parked.iter().zip(&self.workers) {
            if flag.swap(false, Ordering::SeqCst) {
                w.thread().unpark();
            }
        }
        let mut mine = Ok(());
        // the blocks this thread ran are counted as done once it finds none left: one
        // write to the shared counter per thread and job, not one per block
        let mut ran = 0usize;
        while let Some(b) = s.claim(0, epoch, blocks) {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(0, b)));
            if r.is_err() && mine.is_ok() {
                mine = r;
            }
            ran += 1;
        }
        if ran > 0 {
            s.completed.fetch_add(ran, Ordering::AcqRel);
        }
        // the workers' blocks: a worker descheduled in the middle of one is waited for
        // asleep once the wait is long
        s.wait(0, &|| s.completed.load(Ordering::Acquire) == blocks);
        if let Err(p) = mine {
            std::panic::resume_unwind(p);
        }
        if s.panicked.swap(false, Ordering::SeqCst) {
            panic!("a worker thread panicked");
        }
    }
}

/// Runs `f(thread, range)` over 0..len cut into blocks of `block` items, spread over
/// the pool's threads (on the caller alone, as one range, without a pool or with one
/// block). Returns the largest value any call returned (0 for an empty range).
pub fn ranges_max(
    pool: Option<&Pool>,
    len: usize,
    block: usize,
    f: &(dyn Fn(usize, Range<usize>) -> f32 + Sync),
) -> f32 {
    let block = block.max(1);
    let blocks = len.div_ceil(block);
    let pool = match pool {
        Some(p) if p.threads() > 1 && blocks > 1 => p,
        _ => return f(0, 0..len),
    };
    blocks_max(pool, blocks, &|t, b| {
        f(t, b * block..((b + 1) * block).min(len))
    })
}

/// Blocks that grow finer toward each thread's end: 0..len cut into `threads` equal
/// shares, each share into blocks of about `block` items but its last `2 * block` (or
/// all of it, if less) into [`TAPER`] blocks of a quarter of that, every share padded
/// with empty blocks to as many blocks as the most any has. Into `starts`: each block's
/// first item, then `len` (so block b is `starts[b]..starts[b + 1]`). Run by
/// [`blocks_max`], each thread takes its own share first (the shares line up with the
/// pool's), and the last blocks any thread takes are small: the threads end a job
/// within a small block of each other, not a whole one.
pub(crate) fn tapered_blocks(len: usize, threads: usize, block: usize, starts: &mut Vec<usize>) {
    let block = block.max(1);
    let threads = threads.max(1);
    let head_blocks = |share: &Range<usize>| {
        let head = share.len().saturating_sub(2 * block);
        head.div_ceil(block)
    };
    let per = (0..threads)
        .map(|t| head_blocks(&split(len, threads, t)) + TAPER)
        .max()
        .unwrap_or(0);
    starts.clear();
    for t in 0..threads {
        let share = split(len, threads, t);
        let heads = head_blocks(&share);
        let head = share.start..share.end - share.len().min(2 * block);
        starts.extend((0..heads).map(|k| head.start + split(head.len(), heads, k).start));
        let tail = head.end..share.end;
        starts.extend((0..TAPER).map(|k| tail.start + split(tail.len(), TAPER, k).start));
        // (padding: empty blocks at the share's end)
        starts.extend(std::iter::repeat_n(share.end, per - heads - TAPER));
    }
    starts.push(len);
}

/// The small blocks that end each share of [`tapered_blocks`].
const TAPER: usize = 8;

/// Runs `f(thread, block)` for every block in 0..blocks on the pool's threads (each
/// thread first takes its own equal run of the blocks, as [`Pool::blocks`] does);
/// returns the largest value any call returned.
pub fn blocks_max(pool: &Pool, blocks: usize, f: &(dyn Fn(usize, usize) -> f32 + Sync)) -> f32 {
    let out: [AtomicU32; MAX_THREADS] =
        std::array::from_fn(|_| AtomicU32::new(f32::NEG_INFINITY.to_bits()));
    pool.blocks(blocks, &|t, b| {
        let v = f(t, b);
        let was = f32::from_bits(out[t].load(Ordering::Relaxed));
        out[t].store(was.max(v).to_bits(), Ordering::Relaxed);
    });
    out[..pool.threads()]
        .iter()
        .map(|v| f32::from_bits(v.load(Ordering::Relaxed)))
        .fold(f32::NEG_INFINITY, f32::max)
}

/// Phases a [`Phases`] has counters for from its first job (a step's colours: a job
/// with more phases makes room for them then).
const PHASE_ROOM: usize = 64;

/// The first panic of a phased job's blocks, raised on the caller once every block is
/// done (a block that panics still counts as done, so no thread waits on it).
struct FirstPanic(Mutex<Option<Box<dyn std::any::Any + Send>>>);

impl FirstPanic {
    fn new() -> Self {
        FirstPanic(Mutex::new(None))
    }

    /// Runs `block`, folding its value into `r` (max), or keeps its panic.
    fn run(&self, r: &mut f32, block: impl FnOnce() -> f32) {
        match std::panic::catch_unwind(std::panic::AssertUnwindSafe(block)) {
            Ok(v) => *r = r.max(v),
            Err(e) => {
                let mut first = self.0.lock().unwrap_or_else(|e| e.into_inner());
                first.get_or_insert(e);
            }
        }
    }

    /// Raises the kept panic, if any.
    fn raise(self) {
        if let Some(e) = self.0.into_inner().unwrap_or_else(|e| e.into_inner()) {
            std::panic::resume_unwind(e);
        }
    }
}

/// Block b of `items` cut into `per` near-equal blocks.
fn nth_block(items: &Range<usize>, per: usize, b: usize) -> Range<usize> {
    let len = items.len();
    items.start + len * b / per..items.start + len * (b + 1) / per
}

/// How long a thread at a loose end looks only at its own share before it also takes
/// the blocks of the others' shares that nobody has claimed yet: a thread at work on its
/// share ends it sooner than this, and taking its blocks would only move its data to
/// another core; a thread that the system has descheduled is gone for much longer.
const STEAL_AFTER: std::time::Duration = std::time::Duration::from_micros(20);

/// The counters of a phased job ([`phases_max`], [`phases_ahead`]), kept from job to job
/// so that a step's jobs allocate nothing. Each counter has a cache line of its own and
/// is tagged with its job's number, so none is reset between jobs: the counters of a
/// share stay in the cache of the core that usually runs it.
#[derive(Default)]
pub(crate) struct Phases {
    /// Per share and phase (`share * room + phase`): (job << 32) | blocks claimed.
    claim: Vec<Slot>,
    /// Per share and phase: (job << 32) | `AHEAD_DONE` once the share's first block is
    /// done | `ALL_DONE` once every block is | blocks done.
    done: Vec<Slot>,
    /// Phases each share has counters for, and for how many shares.
    room: usize,
    threads: usize,
    /// The current job's number (never 0: new counters are tagged 0).
    job: u32,
    /// A test's stall: the thread of this number does nothing in a job until every
    /// block of the job is done (0: none; thread t stalls at t + 1).
    #[cfg(test)]
    pub(crate) stall: usize,
}

impl Clone for Phases {
    /// A new, empty set: the counters belong to the jobs of one owner.
    fn clone(&self) -> Self {
        Phases::default()
    }
}

impl std::fmt::Debug for Phases {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Phases")
            .field("room", &self.room)
            .field("threads", &self.threads)
            .finish()
    }
}

/// In a share's done counter: its first block (the one the others may wait for alone)
/// is done.
const AHEAD_DONE: u64 = 1 << 31;
/// In a share's done counter: every block of the share's phase is done.
const ALL_DONE: u64 = 1 << 30;

impl Phases {
    /// Numbers a new job of `phases` phases on `n` threads, with counters for it.
    fn next_job(&mut self, phases: usize, n: usize) -> u32 {
        // (new counters too once the job numbers run out: an old tag must never match)
        if self.room < phases || self.threads != n || self.job == u32::MAX {
            let room = phases.max(self.room).max(PHASE_ROOM);
            let fresh = |_| Slot(AtomicU64::new(0));
            self.claim = (0..n * room).map(fresh).collect();
            self.done = (0..n * room).map(fresh).collect();
            self.room = room;
            self.threads = n;
            self.job = 0;
        }
        self.job += 1;
        self.job
    }

    /// The value of `slot` below the tag if it is this job's, else 0.
    fn value(slot: &Slot, job: u32) -> u64 {
        let v = slot.0.load(Ordering::Acquire);
        if (v >> 32) as u32 == job {
            v & 0xffff_ffff
        } else {
            0
        }
    }

    /// Claims the next of `total` blocks of counter `i` for job `job`.
    fn claim(&self, i: usize, job: u32, total: usize) -> Option<usize> {
        let slot = &self.claim[i].0;
        let mut v = slot.load(Ordering::Acquire);
        loop {
            let next = if (v >> 32) as u32 == job {
                (v & 0xffff_ffff) as usize
            } else {
                0
            };
            if next >= total {
                return None;
            }
            let claimed = ((job as u64) << 32) | (next as u64 + 1);
            match slot.compare_exchange_weak(v, claimed, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) => return Some(next),
                Err(now) => v = now,
            }
        }
    }

    /// Blocks of counter `i` claimed so far in job `job`.
    fn claimed(&self, i: usize, job: u32) -> usize {
        Phases::value(&self.claim[i], job) as usize
    }

    /// Counts one more block done on counter `i` of `total` (and the first one's mark if
    /// `first`). A full barrier: a thread about to sleep, which said so before it looked
    /// at the counters, is seen by the caller's look for sleepers after this.
    fn finish(&self, i: usize, job: u32, total: usize, first: bool) {
        let slot = &self.done[i].0;
        let mut v = slot.load(Ordering::Relaxed);
        loop {
            let had = if (v >> 32) as u32 == job {
                v & 0xffff_ffff
            } else {
                0
            };
            let count = (had & !(AHEAD_DONE | ALL_DONE)) + 1;
            let mut now = ((job as u64) << 32) | (had & AHEAD_DONE) | count;
            if first {
                now |= AHEAD_DONE;
            }
            if count == total as u64 {
                now |= ALL_DONE;
            }
            match slot.compare_exchange_weak(v, now, Ordering::SeqCst, Ordering::Relaxed) {
                Ok(_) => return,
                Err(seen) => v = seen,
            }
        }
    }
}

/// How the phases of one phased job are cut: see [`phases_ahead`].
struct PhasedJob<'a> {
    phases: usize,
    threads: usize,
    job: u32,
    room: usize,
    state: &'a Phases,
    share: &'a (dyn Fn(usize, usize) -> Range<usize> + Sync),
    block: &'a (dyn Fn(usize) -> usize + Sync),
    full: &'a (dyn Fn(usize) -> bool + Sync),
    ahead: &'a (dyn Fn(usize, usize) -> (usize, bool) + Sync),
}

/// Share j's part of one phase: its first block (the items the other shares' next phase
/// may wait for alone; none in a full phase) and the rest, cut into `per` blocks run in
/// the share's order (from the end if `reversed`).
struct Part {
    first: Option<Range<usize>>,
    rest: Range<usize>,
    per: usize,
    reversed: bool,
}

impl Part {
    /// Blocks in all.
    fn total(&self) -> usize {
        self.per + usize::from(self.first.is_some())
    }

    /// The items of block b (in the order blocks are claimed).
    fn items(&self, b: usize) -> Range<usize> {
        let b = match &self.first {
            Some(first) if b == 0 => return first.clone(),
            Some(_) => b - 1,
            None => b,
        };
        let i = if self.reversed { self.per - 1 - b } else { b };
        nth_block(&self.rest, self.per, i)
    }
}

impl PhasedJob<'_> {
    fn at(&self, j: usize, p: usize) -> usize {
        j * self.room + p
    }

    /// Share j's part of phase p. `ahead` is asked only once share j's first phase is
    /// done (see [`phases_ahead`]).
    fn part(&self, p: usize, j: usize) -> Part {
        let items = (self.share)(p, j);
        let block = (self.block)(p).max(1);
        if (self.full)(p) {
            return Part {
                first: None,
                per: items.len().div_ceil(block),
                rest: items,
                reversed: false,
            };
        }
        let (k, reversed) = (self.ahead)(p, j);
        let k = k.min(items.len());
        let (first, rest) = if reversed {
            (items.end - k..items.end, items.start..items.end - k)
        } else {
            (items.start..items.start + k, items.start + k..items.end)
        };
        Part {
            first: Some(first),
            per: rest.len().div_ceil(block),
            rest,
            reversed,
        }
    }

    /// Every block of share j's phase p is done (the mark the last block left, or a
    /// share of no blocks).
    fn all_done(&self, j: usize, p: usize) -> bool {
        let done = Phases::value(&self.state.done[self.at(j, p)], self.job);
        done & ALL_DONE != 0 || (done == 0 && self.part(p, j).total() == 0)
    }

    /// Share j's phase p may begin: its own phase before is done, and what it may touch
    /// of the others' (all of it where either phase is full, else their first blocks).
    fn may_begin(&self, j: usize, p: usize) -> bool {
        if p == 0 {
            return true;
        }
        if !self.all_done(j, p - 1) {
            return false;
        }
        let whole = (self.full)(p) || (self.full)(p - 1);
        (0..self.threads).filter(|&k| k != j).all(|k| {
            if whole {
                self.all_done(k, p - 1)
            } else {
                let done = Phases::value(&self.state.done[self.at(k, p - 1)], self.job);
                done & (AHEAD_DONE | ALL_DONE) != 0
            }
        })
    }

    /// The next block of share j that may run now, from the phase `cursor` on (moved
    /// past the phases whose blocks are all claimed): claimed, with its phase and
    /// part, if `take`; else only whether there is one.
    fn next(&self, j: usize, cursor: &mut usize, take: bool) -> Option<(usize, Part, usize)> {
        while *cursor < self.phases {
            let p = *cursor;
            if !self.may_begin(j, p) {
                return None;
            }
            let part = self.part(p, j);
            let i = self.at(j, p);
            if !take {
                if self.state.claimed(i, self.job) < part.total() {
                    return Some((p, part, 0));
                }
            } else if let Some(b) = self.state.claim(i, self.job, part.total()) {
                return Some((p, part, b));
            }
            *cursor += 1;
        }
        None
    }
}

/// Runs `phases` phases one after another in one job of the pool. Phase p covers, for
/// each share j (one a thread), the items `share(p, j)`, every share cut into blocks of
/// about `block(p)` items; `f(thread, p, items)` runs once for each block that is not
/// empty. A phase begins only once every block of the phase before is done, whoever ran
/// it: see [`phases_ahead`] (this is it with every phase full). Returns the largest
/// value any call returned; a panic in `f` is raised here once every block is done.
pub(crate) fn phases_max(
    pool: &Pool,
    state: &mut Phases,
    phases: usize,
    share: &(dyn Fn(usize, usize) -> Range<usize> + Sync),
    block: &(dyn Fn(usize) -> usize + Sync),
    f: &(dyn Fn(usize, usize, Range<usize>) -> f32 + Sync),
) -> f32 {
    phases_ahead(
        pool,
        state,
        phases,
        share,
        block,
        &|_| true,
        &|_, _| (0, false),
        f,
    )
}

/// Runs `phases` phases in one job of the pool: phase p covers, for each share j (one
/// a thread), the items `share(p, j)`; `f(thread, p, items)` runs once for each block of
/// them that is not empty, on whichever thread claims it. One job in place of one a
/// phase: the threads meet at each phase's end through counters, and no phase waits on
/// a job being posted and found.
///
/// Thread t runs the blocks of share t first, phase after phase (so each thread keeps
/// to the same part of the data and it stays in its core's cache). When it has nothing
/// of its own that may run, it waits a few rounds, then takes the blocks of the others'
/// shares that may run and that nobody has claimed yet: a thread that the system has
/// descheduled, or that comes late to the job, holds the others up by at most the block
/// it is running; one whose own share is all claimed leaves as soon as every share's
/// is (it waits for no block it could take). A thread with nothing to do spins a
/// little, yields, then sleeps until a block is done. Which thread runs a block changes
/// nothing but the thread number `f` is given.
///
/// When a share's phase may begin: once its own phase before is done, and
/// - `full(p)`: phase p touches what any share of the phase before or after it may
///   touch (a pass over the bodies): it begins once every share has finished the phase
///   before, and the phase after it begins once every share has finished it;
/// - otherwise `ahead(p, j) = (k, reversed)`: share j's first k items of phase p (the
///   last k if `reversed`) are its first block, and the other shares may begin phase
///   p + 1 once it is done, while share j's rest runs (from the end if `reversed`). The
///   caller makes sure that none of those later items touches anything another share of
///   phase p + 1 touches, nor the other way round. `ahead(p, j)` is asked only once
///   share j's phase 0 is done (so it may come from what phase 0 worked out), and must
///   give the same answer whoever asks.
///
/// Returns the largest value any call of `f` returned; a panic in `f` is raised here
/// once every block is done (a block that panics counts as done).
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub(crate) fn phases_ahead(
    pool: &Pool,
    state: &mut Phases,
    phases: usize,
    share: &(dyn Fn(usize, usize) -> Range<usize> + Sync),
    block: &(dyn Fn(usize) -> usize + Sync),
    full: &(dyn Fn(usize) -> bool + Sync),
    ahead: &(dyn Fn(usize, usize) -> (usize, bool) + Sync),
    f: &(dyn Fn(usize, usize, Range<usize>) -> f32 + Sync),
) -> f32 {
    let n = pool.threads();
    let job = state.next_job(phases, n);
    #[cfg(test)]
    let stall = state.stall;
    let room = state.room;
    let state = &*state;
    let cut = PhasedJob {
        phases,
        threads: n,
        job,
        room,
        state,
        share,
        block,
        full,
        ahead,
    };
    let shared = &*pool.shared;
    let panic = FirstPanic::new();
    let r = blocks_max(pool, n, &|t, _| {
        let mut r = f32::NEG_INFINITY;
        // per share, the first phase that may still have blocks nobody has claimed
        let mut cursor = [0usize; MAX_THREADS];
        let cursor = &mut cursor[..n];
        #[cfg(test)]
        if stall == t + 1 {
            // a test's stalled thread: back only once the others have done every block
            let all = || (0..n).all(|j| (0..phases).all(|p| cut.all_done(j, p)));
            shared.wait(t, &all);
        }
        // idle since; and whether this thread took another's block since it last found
        // none to take (it then takes them at once: that thread is likely descheduled)
        let mut idle_since: Option<std::time::Instant> = None;
        let mut eager = false;
        let mut rounds = 0u32;
        loop {
            // this thread's own share first; the others' once it has waited a while (the
            // clock read every few rounds)
            rounds = rounds.wrapping_add(1);
            let patient = !eager
                && idle_since
                    .is_none_or(|t| !rounds.is_multiple_of(8) || t.elapsed() < STEAL_AFTER);
            let look = if patient { 1 } else { n };
            let found = (0..look).find_map(|k| {
                let j = (t + k) % n;
                cut.next(j, &mut cursor[j], true).map(|x| (j, x))
            });
            if let Some((j, (p, part, b))) = found {
                let items = part.items(b);
                if !items.is_empty() {
                    panic.run(&mut r, || f(t, p, items));
                }
                let first = b == 0 && part.first.is_some();
                state.finish(cut.at(j, p), job, part.total(), first);
                shared.wake_sleepers();
                idle_since = None;
                eager |= j != t;
                continue;
            }
            if cursor[t] == phases {
                // its own share all claimed: so may the others' be (then it is done, and
                // waits for no block it could take)
                for (j, c) in cursor.iter_mut().enumerate() {
                    if j != t {
                        let _ = cut.next(j, c, false);
                    }
                }
            }
            if cursor.iter().all(|&c| c == phases) {
                break;
            }
            // nothing may run yet: a block others run is still going
            if !patient {
                eager = false;
            }
            let since = *idle_since.get_or_insert_with(std::time::Instant::now);
            if patient {
                std::hint::spin_loop();
                continue;
            }
            let seen: [usize; MAX_THREADS] =
                std::array::from_fn(|j| cursor.get(j).copied().unwrap_or(0));
            // a block may run now, or every block is claimed
            let ready = || {
                let mut all_claimed = true;
                for (j, &c) in seen[..n].iter().enumerate() {
                    let mut c = c;
                    if cut.next(j, &mut c, false).is_some() {
                        return true;
                    }
                    all_claimed &= c == phases;
                }
                all_claimed
            };
            shared.pause(t, since, &ready);
        }
        r
    });
    panic.raise();
    r
}

/// Runs `f(thread, offset, chunk)` over `data` cut into chunks of `block` items, as
/// [`ranges_max`] does over a range. Returns the largest value any call returned.
pub fn chunks_mut<T: Send>(
    pool: Option<&Pool>,
    data: &mut [T],
    block: usize,
    f: &(dyn Fn(usize, usize, &mut [T]) -> f32 + Sync),
) -> f32 {
    let len = data.len();
    if pool.is_none_or(|p| p.threads() == 1) || len <= block {
        return f(0, 0, data);
    }
    let data = Disjoint::new(data);
    ranges_max(pool, len, block, &|t, r| {
        // SAFETY: each block takes only its own range
        f(t, r.start, unsafe { data.range(r) })
    })
}

/// [`chunks_mut`] over two slices of the same length cut at the same places:
/// `f(thread, offset, chunk of a, chunk of b)`.
#[allow(clippy::type_complexity)]
pub fn chunks_mut2<A: Send, B: Send>(
    pool: Option<&Pool>,
    a: &mut [A],
    b: &mut [B],
    block: usize,
    f: &(dyn Fn(usize, usize, &mut [A], &mut [B]) -> f32 + Sync),
) -> f32 {
    assert_eq!(a.len(), b.len(), "chunks_mut2 needs slices of one length");
    let len = a.len();
    if pool.is_none_or(|p| p.threads() == 1) || len <= block {
        return f(0, 0, a, b);
    }
    let (a, b) = (Disjoint::new(a), Disjoint::new(b));
    ranges_max(pool, len, block, &|t, r| {
        // SAFETY: each block takes only its own range of each slice
        let (ca, cb) = unsafe { (a.range(r.clone()), b.range(r.clone())) };
        f(t, r.start, ca, cb)
    })
}

/// [`chunks_mut`] over three slices of the same length cut at the same places:
/// `f(thread, offset, chunk of a, chunk of b, chunk of c)`.
#[allow(clippy::type_complexity)]
pub fn chunks_mut3<A: Send, B: Send, C: Send>(
    pool: Option<&Pool>,
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    block: usize,
    f: &(dyn Fn(usize, usize, &mut [A], &mut [B], &mut [C]) -> f32 + Sync),
) -> f32 {
    assert!(
        a.len() == b.len() && a.len() == c.len(),
        "chunks_mut3 needs slices of one length"
    );
    let len = a.len();
    if pool.is_none_or(|p| p.threads() == 1) || len <= block {
        return f(0, 0, a, b, c);
    }
    let (a, b, c) = (Disjoint::new(a), Disjoint::new(b), Disjoint::new(c));
    ranges_max(pool, len, block, &|t, r| {
        // SAFETY: each block takes only its own range of each slice
        let (ca, cb, cc) = unsafe { (a.range(r.clone()), b.range(r.clone()), c.range(r.clone())) };
        f(t, r.start, ca, cb, cc)
    })
}

/// A step's scratch, kept from step to step, that a clone starts without.
#[derive(Debug)]
pub(crate) struct Scratch<T>(pub(crate) Vec<T>);

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

/// Per-block output buffers of a parallel pass (each block fills its own; see
/// [`concat`]).
pub(crate) type BlockScratch<T> = Scratch<Mutex<Vec<T>>>;

impl<T> Scratch<Mutex<T>> {
    /// The first `blocks` entries, made by `make` where missing.
    pub(crate) fn first_with(
        &mut self,
        blocks: usize,
        mut make: impl FnMut() -> T,
    ) -> &mut [Mutex<T>] {
        if self.0.len() < blocks {
            self.0.resize_with(blocks, || Mutex::new(make()));
        }
        &mut self.0[..blocks]
    }
}

impl<T> BlockScratch<T> {
    /// The first `blocks` buffers, made where missing with room for `room` items.
    pub(crate) fn first(&mut self, blocks: usize, room: usize) -> &mut [Mutex<Vec<T>>] {
        self.first_with(blocks, || Vec::with_capacity(room))
    }
}

/// Appends the items of `blocks[skip..]` to `dst` one after another, in block order,
/// each block copied by whichever thread claims it. `starts` is scratch (each block's
/// first index).
pub(crate) fn concat<T: Copy + Send>(
    pool: Option<&Pool>,
    blocks: &mut [Mutex<Vec<T>>],
    skip: usize,
    starts: &mut Vec<usize>,
    dst: &mut Vec<T>,
) {
    // room for every block, whatever the skip: a later step may skip fewer
    starts.clear();
    starts.reserve(blocks.len());
    let skip = skip.min(blocks.len());
    let blocks = &mut blocks[skip..];
    let mut total = 0usize;
    for m in blocks.iter_mut() {
        starts.push(total);
        total += m.get_mut().unwrap_or_else(|e| e.into_inner()).len();
    }
    let kept = dst.len();
    dst.reserve(total);
    // SAFETY: `kept` items are initialised and the capacity holds `total` more
    let base = SyncPtr(unsafe { dst.as_mut_ptr().add(kept) });
    let (blocks, starts) = (&*blocks, &*starts);
    let copy = |b: usize| {
        let src = blocks[b].lock().unwrap_or_else(|e| e.into_inner());
        // SAFETY: block b's items go to starts[b]..starts[b] + len, inside the reserved
        // capacity; the blocks' ranges do not overlap.
        unsafe {
            std::ptr::copy_nonoverlapping(src.as_ptr(), base.get().add(starts[b]), src.len())
        };
    };
    match pool {
        Some(p) if p.threads() > 1 => p.blocks(blocks.len(), &|_, b| copy(b)),
        _ => (0..blocks.len()).for_each(copy),
    }
    // SAFETY: every item of kept..kept + total was written above.
    unsafe { dst.set_len(kept + total) };
}

/// A mutable slice that the blocks of one job (see [`ranges_max`]) write, each block
/// in its own range: for passes that write more slices than [`chunks_mut3`] cuts.
pub(crate) struct Disjoint<'a, T> {
    ptr: SyncPtr<T>,
    len: usize,
    /// Holds the slice's borrow (the pointer carries the element type, so the threads
    /// may share it for any `T: Send`, as each touches its own elements).
    _borrow: std::marker::PhantomData<&'a mut ()>,
}

impl<'a, T: Send> Disjoint<'a, T> {
    /// Borrows `s` mutably for the job's length.
    pub(crate) fn new(s: &'a mut [T]) -> Self {
        Disjoint {
            ptr: SyncPtr(s.as_mut_ptr()),
            len: s.len(),
            _borrow: std::marker::PhantomData,
        }
    }

    /// The slice's length.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The items in `r` (panics past the end).
    ///
    /// # Safety
    /// No two ranges taken from one `Disjoint` may overlap while both are in use: each
    /// block of a job takes only its own range.
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn range(&self, r: Range<usize>) -> &mut [T] {
        assert!(
            r.start <= r.end && r.end <= self.len,
            "range past the slice"
        );
        // SAFETY: inside the borrowed slice; the caller keeps the ranges apart.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.get().add(r.start), r.len()) }
    }

    /// Writes item `i` (panics past the end).
    ///
    /// # Safety
    /// No other block of the job may touch item `i`, nor take a range holding it.
    pub(crate) unsafe fn set(&self, i: usize, v: T) {
        assert!(i < self.len, "item past the slice");
        // SAFETY: inside the borrowed slice; the caller keeps the items apart.
        unsafe { *self.ptr.get().add(i) = v };
    }
}

/// A raw pointer the threads of one job share, each touching its own elements.
struct SyncPtr<T>(*mut T);

impl<T> Clone for SyncPtr<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for SyncPtr<T> {}

// SAFETY: used only for jobs whose threads touch disjoint elements (see each use).
unsafe impl<T: Send> Send for SyncPtr<T> {}
unsafe impl<T: Send> Sync for SyncPtr<T> {}

impl<T> SyncPtr<T> {
    fn get(self) -> *mut T {
        self.0
    }
}

fn backoff(tries: &mut u32) {
    if *tries < SPINS {
        std::hint::spin_loop();
    } else {
        std::thread::yield_now();
    }
    *tries = tries.saturating_add(1);
}

fn worker(s: &Shared, index: usize) {
    let mut seen = 0u32;
    loop {
        let mut tries = 0u32;
        loop {
            if s.quit.load(Ordering::Acquire) {
                return;
            }
            if s.epoch.load(Ordering::Acquire) != seen {
                break;
            }
            if tries < SPINS + YIELDS {
                backoff(&mut tries);
                continue;
            }
            // sleep until the next job: say so, look once more, then park (an unpark
            // that comes between the look and the park makes the park return at once)
            s.parked[index].store(true, Ordering::SeqCst);
            if s.epoch.load(Ordering::SeqCst) == seen && !s.quit.load(Ordering::SeqCst) {
                std::thread::park();
            }
            s.parked[index].store(false, Ordering::SeqCst);
        }
        // the job is published before its epoch: this one is the epoch seen or later
        let info = s.job_info.load(Ordering::Acquire);
        let (epoch, blocks) = ((info >> 32) as u32, (info & 0xffff_ffff) as usize);
        let f_at = s.job_f.load(Ordering::Acquire);
        seen = epoch;
        let mut ran = 0usize;
        while let Some(b) = s.claim(index + 1, epoch, blocks) {
            // SAFETY: a block of this epoch was claimed, so its job has not ended (the
            // blocks this thread ran are counted as completed only below), and `f_at`,
            // read after the job's info, is that job's: `Pool::blocks` is still waiting,
            // and its closure and the `JobFn` on its stack are alive.
            let f = unsafe { &**f_at };
            if std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(index + 1, b))).is_err() {
                s.panicked.store(true, Ordering::SeqCst);
            }
            ran += 1;
        }
        if ran > 0 {
            s.completed.fetch_add(ran, Ordering::SeqCst);
            s.wake_sleepers();
        }
    }
}

impl Drop for Pool {
    fn drop(&mut self) {
        self.shared.quit.store(true, Ordering::SeqCst);
        for w in &self.workers {
            w.thread().unpark();
        }
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn every_block_runs_once_and_the_caller_waits_for_all() {
        let pool = Pool::new(3);
        assert_eq!(pool.threads(), 3);
        for round in 0..300usize {
            let hits: Vec<AtomicUsize> = (0..round % 40 + 1).map(|_| AtomicUsize::new(0)).collect();
            pool.blocks(hits.len(), &|t, b| {
                assert!(t < 3);
                hits[b].fetch_add(1, Ordering::SeqCst);
            });
            assert!(hits.iter().all(|h| h.load(Ordering::SeqCst) == 1));
            if round % 100 == 0 {
                // let the workers fall asleep: the next job must still run every block
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
        }
    }

    #[test]
    fn tapered_blocks_tile_each_share_and_end_it_finely() {
        let mut starts = Vec::new();
        for &(len, threads, block) in &[
            (0, 2, 256),
            (1, 2, 256),
            (300, 2, 256),
            (14_950, 2, 256),
            (14_951, 3, 256),
            (100_000, 4, 64),
            (7, 5, 1),
        ] {
            tapered_blocks(len, threads, block, &mut starts);
            // the blocks tile 0..len in order
            assert_eq!((starts[0], *starts.last().unwrap()), (0, len));
            assert!(starts.windows(2).all(|w| w[0] <= w[1]));
            let blocks = starts.len() - 1;
            assert_eq!(blocks % threads, 0, "every share has as many blocks");
            let per = blocks / threads;
            for t in 0..threads {
                // thread t's blocks (as the pool hands them out) are its share
                let (first, last) = (
                    split(blocks, threads, t).start,
                    split(blocks, threads, t).end,
                );
                assert_eq!(starts[first]..starts[last], split(len, threads, t));
                for b in first..last {
                    let size = starts[b + 1] - starts[b];
                    assert!(size <= block.max(1), "a block holds at most `block` items");
                    // the share's last blocks (before its padding) hold a quarter block
                    if b >= first + per - TAPER {
                        assert!(size <= (2 * block).div_ceil(TAPER), "{size} at the end");
                    }
                }
            }
        }
    }

    #[test]
    fn chunks_cover_the_slice_once_and_max_reduces() {
        let pool = Pool::new(2);
        let mut v = vec![0u32; 1001];
        let m = chunks_mut(Some(&pool), &mut v, 10, &|_, off, c| {
            for (i, x) in c.iter_mut().enumerate() {
                *x += (off + i) as u32;
            }
            c.len() as f32
        });
        assert_eq!(m, 10.0);
        assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32));
        let m = ranges_max(Some(&pool), 1001, 7, &|_, r| r.end as f32);
        assert_eq!(m, 1001.0);
        // without a pool the caller does it alone, as one range
        let m = ranges_max(None, 10, 3, &|t, r| (t * 1000 + r.len()) as f32);
        assert_eq!(m, 10.0);
    }

    #[test]
    fn concat_appends_the_blocks_past_the_skipped_in_order_after_what_the_list_holds() {
        let pool = Pool::new(2);
        for (kept, skip) in [(0usize, 0usize), (3, 0), (3, 2), (0, 25), (1, 40)] {
            let mut blocks: Vec<Mutex<Vec<usize>>> = (0..40)
                .map(|b| Mutex::new((0..b % 5).map(|k| b * 10 + k).collect()))
                .collect();
            let mut dst: Vec<usize> = (0..kept).map(|k| 1000 + k).collect();
            let mut starts = Vec::new();
            concat(Some(&pool), &mut blocks, skip, &mut starts, &mut dst);
            let want: Vec<usize> = (0..kept)
                .map(|k| 1000 + k)
                .chain((skip..40).flat_map(|b| (0..b % 5).map(move |k| b * 10 + k)))
                .collect();
            assert_eq!(dst, want, "kept {kept}, skip {skip}");
        }
    }

    #[test]
    fn a_line_round_trip_takes_some_time_and_stays_in_bounds() {
        let t = std::time::Instant::now();
        if let Some(ns) = core_round_trip_ns() {
            // a round trip is two transfers of a line: more than a nanosecond, and a
            // busy machine's worst is a scheduler slice each way
            assert!(ns > 1.0 && ns < 1e8, "{ns} ns");
        }
        // the probe stops itself (100 ms of rounds at most, then the last one answered)
        assert!(t.elapsed() < std::time::Duration::from_secs(5));
    }

    #[test]
    fn a_probe_that_gives_up_mid_round_trip_still_ends() {
        // Probes of 1 ms, one after another for 2 s, with more busy threads than cores:
        // the answering thread is descheduled now and then between reading a count and
        // answering it, the caller gives up waiting meanwhile, and the answerer must
        // still see the caller's stop (a CI run once hung for ever here; with a plain
        // store for the answer this test hung 1 run in 5). A watchdog turns a hang into
        // a failure.
        let _busy = BusyThreads::new(3);
        within_30s(|| {
            let t = std::time::Instant::now();
            while t.elapsed() < std::time::Duration::from_secs(2) {
                let _ = round_trip_within(std::time::Duration::from_millis(1));
            }
        });
    }

    /// Threads that spin until dropped (with the test's, more busy threads than cores).
    struct BusyThreads {
        busy: std::sync::Arc<AtomicBool>,
        hogs: Vec<JoinHandle<()>>,
    }

    impl BusyThreads {
        fn new(n: usize) -> BusyThreads {
            let busy = std::sync::Arc::new(AtomicBool::new(true));
            let hogs = (0..n)
                .map(|_| {
                    let busy = busy.clone();
                    std::thread::spawn(move || {
                        while busy.load(Ordering::Relaxed) {
                            std::hint::spin_loop();
                        }
                    })
                })
                .collect();
            BusyThreads { busy, hogs }
        }
    }

    impl Drop for BusyThreads {
        /// Stops and joins them, also when the test fails.
        fn drop(&mut self) {
            self.busy.store(false, Ordering::Relaxed);
            for h in self.hogs.drain(..) {
                let _ = h.join();
            }
        }
    }

    /// Runs `job` on another thread and fails if it does not end within 30 s (a hang
    /// becomes a failure, not a test run that never ends).
    pub(crate) fn within_30s(job: impl FnOnce() + Send + 'static) {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            job();
            tx.send(()).unwrap();
        });
        assert!(
            rx.recv_timeout(std::time::Duration::from_secs(30)).is_ok(),
            "the job did not end (or panicked)"
        );
    }

    /// Phase p's shares for `threads` threads over `len(p)` items: near-equal, but with
    /// the first share empty in every third phase.
    fn test_share(len: usize, threads: usize, p: usize, j: usize) -> Range<usize> {
        let at = |j: usize| {
            if p.is_multiple_of(3) && j == 1 {
                0
            } else {
                len * j / threads
            }
        };
        at(j)..at(j + 1)
    }

    #[test]
    fn phases_run_every_item_once_and_one_phase_after_another() {
        within_30s(|| {
            for threads in [2, 3, 4] {
                let pool = Pool::new(threads);
                let mut state = Phases::default();
                // jobs of a growing then shrinking number of phases on the same counters
                for (job, phases) in (0..120).map(|j| (j, [3, 17, 40, 5][j % 4])) {
                    let len = |p: usize| ((p + job) % 5) * 40 + 3;
                    let runs: Vec<AtomicUsize> = (0..phases).map(|_| AtomicUsize::new(0)).collect();
                    let early = AtomicBool::new(false);
                    let seen: Vec<Vec<AtomicBool>> = (0..phases)
                        .map(|p| (0..len(p)).map(|_| AtomicBool::new(false)).collect())
                        .collect();
                    let (twice, big) = (AtomicBool::new(false), AtomicBool::new(false));
                    let share = |p: usize, j: usize| test_share(len(p), threads, p, j);
                    let r = phases_max(
                        &pool,
                        &mut state,
                        phases,
                        &share,
                        &|_| 16,
                        &|t, p, items| {
                            assert!(t < threads && !items.is_empty() && items.end <= len(p));
                            // no block crosses a share's end or is much longer than asked
                            if items.len() > 2 * 16
                                || !(0..threads).any(|j| {
                                    let s = share(p, j);
                                    s.start <= items.start && items.end <= s.end
                                })
                            {
                                big.store(true, Ordering::SeqCst);
                            }
                            // every item of the phase before is done already
                            if p > 0 && runs[p - 1].load(Ordering::SeqCst) != len(p - 1) {
                                early.store(true, Ordering::SeqCst);
                            }
                            for i in items.clone() {
                                if seen[p][i].swap(true, Ordering::SeqCst) {
                                    twice.store(true, Ordering::SeqCst);
                                }
                            }
                            runs[p].fetch_add(items.len(), Ordering::SeqCst);
                            items.end as f32
                        },
                    );
                    assert!(
                        !early.load(Ordering::SeqCst),
                        "a phase began before the last ended"
                    );
                    assert!(!twice.load(Ordering::SeqCst), "an item ran twice");
                    assert!(
                        !big.load(Ordering::SeqCst),
                        "a block crossed a share or grew"
                    );
                    for (p, n) in runs.iter().enumerate() {
                        assert_eq!(n.load(Ordering::SeqCst), len(p), "phase {p}");
                    }
                    let most = (0..phases).map(len).max().unwrap();
                    assert_eq!(r, most as f32, "the largest value returned");
                }
            }
        });
    }

    /// Items `phases_max` ran over `phases` phases of `len` items each, cut for the pool.
    fn items_run(pool: &Pool, state: &mut Phases, phases: usize, len: usize) -> usize {
        let n = AtomicUsize::new(0);
        let threads = pool.threads();
        let share = |p: usize, j: usize| test_share(len, threads, p, j);
        phases_max(pool, state, phases, &share, &|_| 8, &|_, _, items| {
            n.fetch_add(items.len(), Ordering::SeqCst);
            0.0
        });
        n.load(Ordering::SeqCst)
    }

    #[test]
    fn phases_run_whole_when_the_job_numbers_run_out() {
        within_30s(|| {
            let pool = Pool::new(2);
            let mut state = Phases::default();
            assert_eq!(items_run(&pool, &mut state, 6, 50), 6 * 50);
            // the counters hold tags of jobs 1..; the numbers wrap round to them
            state.job = u32::MAX - 2;
            for _ in 0..5 {
                assert_eq!(items_run(&pool, &mut state, 6, 50), 6 * 50);
            }
            assert!(state.job < 10, "the numbers began again");
        });
    }

    #[test]
    fn a_panic_in_a_phase_reaches_the_caller_without_a_hang_and_the_pool_goes_on() {
        within_30s(|| {
            let pool = Pool::new(2);
            let mut state = Phases::default();
            let later = AtomicUsize::new(0);
            let share = |p: usize, j: usize| test_share(64, 2, p, j);
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                phases_max(&pool, &mut state, 8, &share, &|_| 8, &|_, p, items| {
                    // the second share fails in phase 4: the phases after it still run
                    // (the block counts as done), then the panic is raised
                    assert!(!(p == 4 && items.contains(&40)), "block fails");
                    if p > 4 {
                        later.fetch_add(items.len(), Ordering::SeqCst);
                    }
                    0.0
                });
            }));
            assert!(r.is_err(), "the panic reached the caller");
            assert_eq!(later.load(Ordering::SeqCst), 3 * 64);
            assert_eq!(
                items_run(&pool, &mut state, 8, 64),
                8 * 64,
                "the next job runs whole"
            );
        });
    }

    /// Runs `jobs` jobs of `phases_ahead` over a row of cells in which each phase's items
    /// touch cells the next phase's items of the other share touch too, and returns
    /// (items run, cells touched out of phase order). Two threads share `2 * half`
    /// items; item i owns cell 2i, and the odd cell 2i + 1 is touched by item i in even
    /// phases and by item i + 1 in odd ones. So only share 0's last item and share 1's
    /// first touch a cell of the other share (cell 2 half - 1): share 0 runs from its
    /// end and each tells the other to go on after its first item. Every seventh phase
    /// is a pass over all the cells (`full`). Items spin for varied times, so the
    /// threads run ahead of each other.
    fn ahead_run(pool: &Pool, jobs: usize, half: usize, stall: usize) -> (usize, usize) {
        let mut state = Phases {
            stall,
            ..Phases::default()
        };
        let (mut ran, mut late) = (0, 0);
        for job in 0..jobs {
            let phases = 30 + job % 7;
            let items = 2 * half;
            let cells: Vec<AtomicUsize> = (0..2 * items).map(|_| AtomicUsize::new(0)).collect();
            let (count, bad) = (AtomicUsize::new(0), AtomicUsize::new(0));
            let full = |p: usize| p % 7 == 6;
            // touch cell c in phase p: the last phase that touched it was an earlier one
            let touch = |c: usize, p: usize| {
                let was = cells[c].swap(p + 1, Ordering::SeqCst);
                if was > p {
                    bad.fetch_add(1, Ordering::SeqCst);
                }
            };
            phases_ahead(
                pool,
                &mut state,
                phases,
                &|_, j| j * half..(j + 1) * half,
                &|_| 3,
                &full,
                &|_, t| (1, t == 0),
                &|_, p, r| {
                    for i in r {
                        // 0 to about 2 microseconds of work, varied by phase and item
                        for _ in 0..(i * 7 + p * 13 + job) % 23 * 8 {
                            std::hint::spin_loop();
                        }
                        touch(2 * i, p);
                        // (a pass over all the cells touches the odd ones too)
                        if full(p) || p % 2 == 0 {
                            touch(2 * i + 1, p);
                        } else if i > 0 {
                            touch(2 * i - 1, p);
                        }
                        count.fetch_add(1, Ordering::SeqCst);
                    }
                    0.0
                },
            );
            ran += count.into_inner();
            late += bad.into_inner();
        }
        (ran, late)
    }

    #[test]
    fn phases_ahead_keep_every_cell_in_phase_order() {
        within_30s(|| {
            let pool = Pool::new(2);
            for half in [1, 2, 5, 40] {
                let jobs = 60;
                let (ran, late) = ahead_run(&pool, jobs, half, 0);
                let phases: usize = (0..jobs).map(|j| 30 + j % 7).sum();
                assert_eq!(ran, phases * 2 * half, "every item once a phase");
                assert_eq!(late, 0, "a cell was touched out of phase order");
            }
        });
    }

    #[test]
    fn a_thread_told_to_go_on_too_early_touches_a_cell_out_of_order() {
        // the check above can fail: share 0 tells share 1 to go on before its one item
        // (0 items first), then waits for share 1's next phase to touch the cell they
        // share before it touches it itself; the cell sees phase 1 before phase 0
        within_30s(|| {
            let pool = Pool::new(2);
            let mut state = Phases::default();
            let cell = AtomicUsize::new(0);
            let late = AtomicBool::new(false);
            phases_ahead(
                &pool,
                &mut state,
                2,
                &|_, j| j..j + 1,
                &|_| 1,
                &|_| false,
                &|_, _| (0, false),
                &|_, p, items| {
                    // (share j's one item is j)
                    let j = items.start;
                    if j == 0 && p == 0 {
                        let start = std::time::Instant::now();
                        while cell.load(Ordering::SeqCst) == 0
                            && start.elapsed() < std::time::Duration::from_secs(10)
                        {
                            std::thread::yield_now();
                        }
                    }
                    if j == p {
                        // share 1 in phase 1 or share 0 in phase 0: the shared cell
                        if cell.swap(p + 1, Ordering::SeqCst) > p {
                            late.store(true, Ordering::SeqCst);
                        }
                    }
                    0.0
                },
            );
            assert!(late.into_inner(), "the cell saw phase 1 before phase 0");
        });
    }

    #[test]
    fn phases_ahead_end_when_the_workers_are_starved_of_cores() {
        // a descheduled worker's share is taken by the caller, and the cells still keep
        // their order
        let _busy = BusyThreads::new(3);
        within_30s(|| {
            let pool = Pool::new(2);
            let t = std::time::Instant::now();
            while t.elapsed() < std::time::Duration::from_secs(1) {
                assert_eq!(ahead_run(&pool, 5, 5, 0).1, 0);
            }
        });
    }

    #[test]
    fn a_panic_in_a_phase_ahead_reaches_the_caller_and_the_pool_goes_on() {
        within_30s(|| {
            let pool = Pool::new(2);
            let mut state = Phases::default();
            let ran = AtomicUsize::new(0);
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                phases_ahead(
                    &pool,
                    &mut state,
                    9,
                    &|_, j| j * 50..(j + 1) * 50,
                    &|_| 8,
                    &|p| p == 4,
                    &|_, t| (3, t == 0),
                    &|_, p, r| {
                        ran.fetch_add(r.len(), Ordering::SeqCst);
                        assert!(!(p == 2 && r.contains(&70)), "block fails");
                        0.0
                    },
                )
            }));
            assert!(r.is_err(), "the panic reached the caller");
            // every block ran, the one that panicked too
            assert_eq!(ran.into_inner(), 9 * 100);
            assert_eq!(ahead_run(&pool, 3, 5, 0), ((30 + 31 + 32) * 10, 0));
        });
    }

    #[test]
    fn phases_end_when_the_workers_are_starved_of_cores() {
        // more busy threads than cores: a worker may be descheduled for a long time, and
        // the caller must take its share rather than wait for it
        let _busy = BusyThreads::new(3);
        within_30s(|| {
            let pool = Pool::new(3);
            let mut state = Phases::default();
            let t = std::time::Instant::now();
            while t.elapsed() < std::time::Duration::from_secs(1) {
                assert_eq!(items_run(&pool, &mut state, 12, 30), 12 * 30);
            }
        });
    }

    #[test]
    fn phases_complete_on_the_others_while_a_thread_is_stalled() {
        // the stalled thread does nothing until every block of the job is done: only
        // the others can do them, its share included, phases in order
        within_30s(|| {
            for (threads, stall) in [(2, 2), (2, 1), (3, 2), (3, 3)] {
                let pool = Pool::new(threads);
                let mut state = Phases {
                    stall,
                    ..Phases::default()
                };
                for _ in 0..20 {
                    assert_eq!(items_run(&pool, &mut state, 9, 40), 9 * 40);
                }
            }
            let pool = Pool::new(2);
            for stall in [1, 2] {
                for half in [1, 5, 40] {
                    let (ran, late) = ahead_run(&pool, 10, half, stall);
                    let phases: usize = (0..10).map(|j| 30 + j % 7).sum();
                    assert_eq!(ran, phases * 2 * half, "every item once a phase");
                    assert_eq!(late, 0, "a cell was touched out of phase order");
                }
            }
        });
    }

    #[test]
    fn a_stalled_thread_is_waited_for_only_through_its_blocks() {
        // the caller takes the stalled worker's share in every phase: the worker runs
        // nothing (the check of the test above could not tell)
        within_30s(|| {
            let pool = Pool::new(2);
            let mut state = Phases {
                stall: 2,
                ..Phases::default()
            };
            let by_worker = AtomicUsize::new(0);
            let share = |p: usize, j: usize| test_share(64, 2, p, j);
            phases_max(&pool, &mut state, 12, &share, &|_| 8, &|t, _, items| {
                if t == 1 {
                    by_worker.fetch_add(items.len(), Ordering::SeqCst);
                }
                0.0
            });
            assert_eq!(by_worker.into_inner(), 0);
        });
    }

    #[test]
    fn a_panic_in_a_block_reaches_the_caller_and_the_pool_goes_on() {
        let pool = Pool::new(2);
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pool.blocks(64, &|_, b| assert!(b != 17, "block fails"));
        }));
        assert!(r.is_err());
        let n = AtomicUsize::new(0);
        pool.blocks(50, &|_, _| {
            n.fetch_add(1, Ordering::SeqCst);
        });
        assert_eq!(n.load(Ordering::SeqCst), 50);
    }
}
