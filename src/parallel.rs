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
}

/// A claim counter on a cache line of its own.
#[repr(align(64))]
struct Slot(AtomicU64);

impl Shared {
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
        });
        let workers = (0..workers)
            .map(|i| {
                let shared = Arc::clone(&shared);
                std::thread::Builder::new()
                    .name(format!("sandbox2d-worker-{}", i + 1))
                    .spawn(move || worker(&shared, i))
                    .expect("spawn a worker thread")
            })
            .collect();
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
        let mut tries = 0u32;
        while s.completed.load(Ordering::Acquire) != blocks {
            backoff(&mut tries);
        }
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

/// Spins a thread waits at a phase's end before it takes the blocks others have not
/// claimed yet (and again after as many more).
const STEAL_AFTER: u32 = 16;

/// The counters of a phased job ([`phases_max`]), kept from job to job so that a step's
/// jobs allocate nothing. Each counter has a cache line of its own and is tagged with its
/// job's number, so none is reset between jobs: a thread's counters stay in its core's
/// cache, and a phase ends without any word going through the pool.
#[derive(Default)]
pub(crate) struct Phases {
    /// Per thread and phase (`thread * room + phase`): (job << 32) | the next block of
    /// that thread's share of the phase.
    claim: Vec<Slot>,
    /// Per thread and phase: (job << 32) | blocks that thread finished in the phase.
    done: Vec<Slot>,
    /// Phases each thread has counters for, and for how many threads.
    room: usize,
    threads: usize,
    /// The current job's number (never 0: new counters are tagged 0).
    job: u32,
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

    /// The count in `slot` if it is this job's, else 0.
    fn count(slot: &Slot, job: u32) -> usize {
        let v = slot.0.load(Ordering::Acquire);
        if (v >> 32) as u32 == job {
            (v & 0xffff_ffff) as usize
        } else {
            0
        }
    }

    /// Claims the next of `per` blocks of counter `i` for job `job`.
    fn claim(&self, i: usize, job: u32, per: usize) -> Option<usize> {
        let slot = &self.claim[i].0;
        let mut v = slot.load(Ordering::Acquire);
        loop {
            let next = if (v >> 32) as u32 == job {
                (v & 0xffff_ffff) as usize
            } else {
                0
            };
            if next >= per {
                return None;
            }
            let claimed = ((job as u64) << 32) | (next as u64 + 1);
            match slot.compare_exchange_weak(v, claimed, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) => return Some(next),
                Err(now) => v = now,
            }
        }
    }
}

/// Runs `phases` phases one after another in one job of the pool. Phase p covers, for
/// each thread j, the items `share(p, j)`, every share cut into as many blocks of about
/// `block(p)` items; `f(thread, p, items)` runs once for each block that is not empty,
/// thread t taking the blocks of share t first and then, if they are slow to come, what
/// is left of the others' (so each thread keeps to the same part of the data, phase
/// after phase, and it stays in its core's cache). A thread goes on to phase p + 1 only
/// once every block of phase p is done, whoever ran it. One job in place of one a phase:
/// the threads meet at each phase's end through counters each writes alone, and no phase
/// waits on a job being posted and found. A thread waiting at a phase's end claims what
/// is left every few spins, so it never waits long for a block nobody has claimed: a
/// worker that comes late, or not at all, only leaves its share to the others. Returns
/// the largest value any call returned; a panic in `f` is raised here once every block
/// is done.
pub(crate) fn phases_max(
    pool: &Pool,
    state: &mut Phases,
    phases: usize,
    share: &(dyn Fn(usize, usize) -> Range<usize> + Sync),
    block: &(dyn Fn(usize) -> usize + Sync),
    f: &(dyn Fn(usize, usize, Range<usize>) -> f32 + Sync),
) -> f32 {
    let n = pool.threads();
    let job = state.next_job(phases, n);
    let (room, state) = (state.room, &*state);
    let panic = FirstPanic::new();
    // blocks a share of phase p is cut into: as many for every share
    let per = |p: usize| {
        let block = block(p).max(1);
        (0..n)
            .map(|j| share(p, j).len().div_ceil(block))
            .max()
            .unwrap_or(0)
            .max(1)
    };
    let r = blocks_max(pool, n, &|t, _| {
        let mut r = f32::NEG_INFINITY;
        // runs the blocks of share j in phase p that nobody has claimed yet; how many
        let run = |p: usize, per: usize, j: usize, r: &mut f32| {
            let mut ran = 0;
            while let Some(b) = state.claim(j * room + p, job, per) {
                let items = nth_block(&share(p, j), per, b);
                if !items.is_empty() {
                    panic.run(r, || f(t, p, items));
                }
                ran += 1;
            }
            ran
        };
        // this thread alone writes its counters (threads run their blocks one after
        // another, and thread numbers are the pool's)
        let publish = |p: usize, ran: usize| {
            let slot = &state.done[t * room + p];
            let had = Phases::count(slot, job);
            slot.0
                .store(((job as u64) << 32) | (had + ran) as u64, Ordering::Release);
        };
        for p in 0..phases {
            let per = per(p);
            let mine = run(p, per, t, &mut r);
            if mine > 0 {
                publish(p, mine);
            }
            // then wait for the others' shares, and take what is left of them once
            // they seem slow to come (a look at another thread's counter takes its line
            // from that thread's cache: not done while they are likely at work)
            let all = per * n;
            let mut tries = 0u32;
            while (0..n)
                .map(|k| Phases::count(&state.done[k * room + p], job))
                .sum::<usize>()
                != all
            {
                if tries >= STEAL_AFTER && tries.is_multiple_of(STEAL_AFTER) {
                    let ran: usize = (1..n).map(|k| run(p, per, (t + k) % n, &mut r)).sum();
                    if ran > 0 {
                        publish(p, ran);
                    }
                }
                backoff(&mut tries);
            }
        }
        r
    });
    panic.raise();
    r
}

/// A thread's mark in a phase of [`phases_ahead`]: the blocks the others wait for are
/// done (`AHEAD`), and all of its blocks are (`ALL`, with `AHEAD`).
const AHEAD: usize = 1;
const ALL: usize = 3;

/// Runs a phased job as [`phases_max`] does, but a thread need not wait at the end of a
/// phase for every other thread's share of it: only for the blocks of theirs that its
/// next phase may touch. Each thread runs its own share of each phase, and no thread
/// takes another's blocks (a thread that comes late holds the others up; it never
/// leaves a block undone).
///
/// `full(p)`: phase p touches what any thread's share of the phase before or after it
/// may touch (a pass over the bodies), so it begins once every thread has finished the
/// phase before, and the phase after it begins once every thread has finished it.
/// Otherwise `ahead(p, t) = (k, reversed)`, asked only by thread t (so it may come from
/// what t worked out in an earlier phase): t runs the first k items of its share of
/// phase p (the last k if `reversed`) as one block, then the others may begin phase
/// p + 1, while t runs the rest of its share a block at a time (from the end if
/// `reversed`). The caller makes sure that none of those later items touches anything
/// another thread's share of phase p + 1 touches, nor the other way round.
/// Returns the largest value any call of `f` returned; a panic in `f` is raised here
/// once every block is done.
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
    let (room, state) = (state.room, &*state);
    let panic = FirstPanic::new();
    let r = blocks_max(pool, n, &|t, _| {
        let mut r = f32::NEG_INFINITY;
        let mark = |p: usize, what: usize| {
            state.done[t * room + p]
                .0
                .store(((job as u64) << 32) | what as u64, Ordering::Release);
        };
        for p in 0..phases {
            // wait for what this phase may touch of the others' last phase
            if p > 0 {
                let need = if full(p) || full(p - 1) { ALL } else { AHEAD };
                let mut tries = 0u32;
                while (0..n)
                    .filter(|&k| k != t)
                    .any(|k| Phases::count(&state.done[k * room + p - 1], job) & need != need)
                {
                    backoff(&mut tries);
                }
            }
            let items = share(p, t);
            // the items the others wait for first, as one block (all of them in a phase
            // over the bodies), then the rest a block at a time, in the thread's order
            let (k, reversed) = if full(p) { (0, false) } else { ahead(p, t) };
            let k = k.min(items.len());
            let (first, rest) = if reversed {
                (items.end - k..items.end, items.start..items.end - k)
            } else {
                (items.start..items.start + k, items.start + k..items.end)
            };
            let per = rest.len().div_ceil(block(p).max(1));
            let mut run = |range: Range<usize>| {
                if !range.is_empty() {
                    panic.run(&mut r, || f(t, p, range));
                }
            };
            if !full(p) {
                run(first);
                mark(p, AHEAD);
            }
            for i in 0..per {
                let b = if reversed { per - 1 - i } else { i };
                run(nth_block(&rest, per, b));
            }
            mark(p, ALL);
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
            s.completed.fetch_add(ran, Ordering::AcqRel);
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
mod tests {
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
    fn within_30s(job: impl FnOnce() + Send + 'static) {
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
    fn ahead_run(pool: &Pool, jobs: usize, half: usize) -> (usize, usize) {
        let mut state = Phases::default();
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
                let (ran, late) = ahead_run(&pool, jobs, half);
                let phases: usize = (0..jobs).map(|j| 30 + j % 7).sum();
                assert_eq!(ran, phases * 2 * half, "every item once a phase");
                assert_eq!(late, 0, "a cell was touched out of phase order");
            }
        });
    }

    #[test]
    fn a_thread_told_to_go_on_too_early_touches_a_cell_out_of_order() {
        // the check above can fail: thread 0 tells thread 1 to go on before its one
        // item (0 items first), then waits for thread 1's next phase to touch the cell
        // they share before it touches it itself; the cell sees phase 1 before phase 0
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
                &|t, p, _| {
                    if t == 0 && p == 0 {
                        let start = std::time::Instant::now();
                        while cell.load(Ordering::SeqCst) == 0
                            && start.elapsed() < std::time::Duration::from_secs(10)
                        {
                            std::thread::yield_now();
                        }
                    }
                    if t == p {
                        // thread 1 in phase 1 or thread 0 in phase 0: the shared cell
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
        // nobody takes another thread's share: a descheduled worker holds the caller up
        // until it runs again, and the cells still keep their order
        let _busy = BusyThreads::new(3);
        within_30s(|| {
            let pool = Pool::new(2);
            let t = std::time::Instant::now();
            while t.elapsed() < std::time::Duration::from_secs(1) {
                assert_eq!(ahead_run(&pool, 5, 5).1, 0);
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
            assert_eq!(ahead_run(&pool, 3, 5), ((30 + 31 + 32) * 10, 0));
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
