use super::kept::*;
use super::*;

#[test]
fn floor_i64_is_the_clamped_floor() {
    const LIMIT: f64 = (1u64 << 40) as f64;
    let reference = |x: f32| -> i64 {
        if x.is_nan() {
            0
        } else {
            (x as f64).floor().clamp(-LIMIT, LIMIT) as i64
        }
    };
    let mut cases = vec![
        0.0f32,
        -0.0,
        0.5,
        -0.5,
        1.0,
        -1.0,
        1.5,
        -1.5,
        2.999_999_8,
        -2.999_999_8,
        1e10,
        -1e10,
        1.1e12,
        -1.1e12,
        1e30,
        -1e30,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        8_388_607.5,
        -8_388_607.5,
        16_777_217.0,
    ];
    // and a spread of bit patterns
    let mut bits = 0x1234_5678u32;
    for _ in 0..100_000 {
        bits = bits.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        cases.push(f32::from_bits(bits));
    }
    for x in cases {
        assert_eq!(floor_i64(x), reference(x), "floor of {x:e}");
    }
}

fn aabb(x0: f32, y0: f32, x1: f32, y1: f32) -> Aabb {
    Aabb {
        min: Vec2::new(x0, y0),
        max: Vec2::new(x1, y1),
    }
}

#[test]
fn matches_all_pairs() {
    // A deterministic scatter of boxes of mixed sizes, plus one huge one.
    let mut boxes = vec![aabb(-100.0, -2.0, 100.0, 0.0)];
    let mut rnd = unit(lcg(12345));
    for _ in 0..300 {
        let x = rnd() * 40.0 - 20.0;
        let y = rnd() * 20.0 - 3.0;
        let s = 0.2 + rnd() * 2.0;
        boxes.push(aabb(x, y, x + s, y + s * rnd()));
    }
    // two more large boxes, moving, that overlap each other, the ground and many
    // small ones: each large-large pair is found once
    boxes.push(aabb(-30.0, -1.0, 30.0, 1.0));
    boxes.push(aabb(-10.0, -5.0, 10.0, 25.0));
    let moves: Vec<bool> = (0..boxes.len()).map(|i| i != 0).collect();
    let mut bp = BroadPhase::default();
    bp.find_pairs(&boxes, &moves, |_, _| true);
    let mut brute = Vec::new();
    for a in 0..boxes.len() {
        for b in a + 1..boxes.len() {
            if (moves[a] || moves[b]) && boxes[a].overlaps(&boxes[b]) {
                brute.push((a as u32, b as u32));
            }
        }
    }
    assert!(brute.contains(&(301, 302)) && brute.contains(&(0, 301)));
    assert_eq!(bp.pairs, brute);
}

#[test]
fn sparse_grid_matches_all_pairs() {
    // two clusters far apart: too many cells for the dense grid, so entries are sorted
    let mut boxes = Vec::new();
    for k in 0..40 {
        let x = (k % 8) as f32 * 0.7 + if k < 20 { 0.0 } else { 1.0e5 };
        let y = (k / 8) as f32 * 0.7;
        boxes.push(aabb(x, y, x + 1.0, y + 1.0));
    }
    let moves = vec![true; boxes.len()];
    let mut bp = BroadPhase::default();
    bp.find_pairs(&boxes, &moves, |_, _| true);
    let mut brute = Vec::new();
    for a in 0..boxes.len() {
        for b in a + 1..boxes.len() {
            if boxes[a].overlaps(&boxes[b]) {
                brute.push((a as u32, b as u32));
            }
        }
    }
    assert!(!brute.is_empty());
    assert_eq!(bp.pairs, brute);
}

/// A ground, then `count` boxes in rows of `columns` at 1.1 m, each `smallest` to
/// 1.25 m wide: a heap packed closely enough to touch.
fn ground_and_heap(
    rnd: &mut impl FnMut() -> f32,
    count: usize,
    columns: usize,
    smallest: f32,
) -> Vec<Aabb> {
    let mut boxes = vec![aabb(-60.0, -2.0, 60.0, 0.0)];
    for k in 0..count {
        let (x, y) = (
            (k % columns) as f32 * 1.1 - 22.0,
            (k / columns) as f32 * 1.1,
        );
        let s = smallest + rnd() * (1.25 - smallest);
        boxes.push(aabb(x, y, x + s, y + s));
    }
    boxes
}

/// One step of the kept pairs against pairs found afresh: the same list, not
/// empty, under a filter that changes every 50 steps; the kept boxes made anew reach
/// ahead along `motion`.
fn kept_against_fresh(
    kept: &mut BroadPhase,
    fresh: &mut BroadPhase,
    boxes: &[Aabb],
    moves: &[bool],
    may_move: &[bool],
    motion: impl Fn(usize) -> Vec2,
    step: u32,
) {
    let phase = step / 50;
    let can = |a: u32, b: u32| !(a + b + phase).is_multiple_of(7);
    kept.find_pairs_kept(boxes, moves, |i| may_move[i], motion, can);
    fresh.find_pairs(boxes, moves, can);
    assert!(!fresh.pairs.is_empty());
    assert_eq!(kept.pairs, fresh.pairs, "step {step}");
}

#[test]
fn kept_pairs_are_the_pairs_found_afresh_every_step() {
    let mut rnd = unit(lcg(777));
    let mut boxes = ground_and_heap(&mut rnd, 400, 40, 0.05);
    let n = boxes.len();
    let mut may_move: Vec<bool> = (0..n).map(|i| i != 0).collect();
    let mut moves = may_move.clone();
    let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
    let steps = 300u32;
    for step in 0..steps {
        // small motions every step, now and then a jump, a body falling asleep or
        // waking, a body becoming static or dynamic
        for b in boxes.iter_mut().skip(1) {
            let d = Vec2::new(rnd() - 0.5, rnd() - 0.5) * 0.004;
            (b.min, b.max) = (b.min + d, b.max + d);
        }
        if step % 23 == 5 {
            let i = 1 + (rnd() * (n - 1) as f32) as usize % (n - 1);
            let d = Vec2::new(rnd() - 0.5, rnd() - 0.5) * 3.0;
            (boxes[i].min, boxes[i].max) = (boxes[i].min + d, boxes[i].max + d);
        }
        if step % 17 == 3 {
            let i = 1 + (rnd() * (n - 1) as f32) as usize % (n - 1);
            moves[i] = may_move[i] && !moves[i];
        }
        if step % 61 == 11 {
            let i = 1 + (rnd() * (n - 1) as f32) as usize % (n - 1);
            may_move[i] = !may_move[i];
            moves[i] = may_move[i];
        }
        kept_against_fresh(
            &mut kept,
            &mut fresh,
            &boxes,
            &moves,
            &may_move,
            |_| Vec2::ZERO,
            step,
        );
    }
    // the kept pairs were used (most steps move nothing out of its fattened box) and
    // renewed, body by body (the drift, the jumps and the changes of who may move
    // take a few bodies out of their kept boxes at a time)
    assert!(
        kept.updates > 5 && kept.rebuilds + kept.updates < u64::from(steps / 3),
        "{} rebuilds, {} updates",
        kept.rebuilds,
        kept.updates
    );
}

/// Steps `steps` of 60 bodies falling side by side, ever faster, past a column of still
/// boxes and above a heap that jostles within its kept boxes, with the kept pairs
/// checked against pairs found afresh every step; the kept boxes reach ahead along the
/// fallers' motions where `reach`. Returns how many refreshes made kept boxes anew
/// (rebuilds and updates).
fn falling_past_a_column(steps: u32, reach: bool) -> u64 {
    let mut rnd = unit(lcg(31337));
    let mut boxes = ground_and_heap(&mut rnd, 200, 20, 0.3);
    let heap = boxes.len();
    // still boxes the first faller brushes past on its way down
    for k in 0..30 {
        let y = k as f32;
        boxes.push(aabb(-30.0, y, -29.5, y + 0.5));
    }
    let fallers = boxes.len();
    for k in 0..60 {
        let x = -29.7 + k as f32 * 0.5;
        boxes.push(aabb(x, 40.0, x + 0.2, 40.2));
    }
    let n = boxes.len();
    let may_move: Vec<bool> = (0..n)
        .map(|i| i != 0 && !(heap..fallers).contains(&i))
        .collect();
    let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
    let mut touched = 0;
    for step in 0..steps {
        for b in &mut boxes[1..heap] {
            let d = Vec2::new(rnd() - 0.5, rnd() - 0.5) * 0.004;
            (b.min, b.max) = (b.min + d, b.max + d);
        }
        let fall = Vec2::new(0.0, -0.1 - 0.01 * step as f32);
        for b in &mut boxes[fallers..] {
            (b.min, b.max) = (b.min + fall, b.max + fall);
        }
        let motion = |i: usize| {
            if reach && i >= fallers {
                fall
            } else {
                Vec2::ZERO
            }
        };
        kept_against_fresh(
            &mut kept, &mut fresh, &boxes, &may_move, &may_move, motion, step,
        );
        touched += fresh
            .pairs
            .iter()
            .filter(|&&(_, b)| b as usize == fallers)
            .count();
    }
    assert!(touched > 10, "the first faller met {touched} still boxes");
    kept.rebuilds + kept.updates
}

#[test]
fn kept_boxes_reaching_ahead_of_bodies_in_flight_hold_longer_and_keep_every_pair() {
    // without reach every faller leaves its kept box every step; with it their kept
    // boxes reach 1, 2, 4 then 8 steps ahead and hold that long
    let steps = 60;
    let (reaching, not) = (
        falling_past_a_column(steps, true),
        falling_past_a_column(steps, false),
    );
    assert!(not >= u64::from(steps) - 1, "{not} refreshes without reach");
    assert!(
        3 * reaching < not,
        "{reaching} refreshes with reach against {not}"
    );
}

#[test]
fn a_kept_box_reaches_further_while_its_body_goes_on_as_it_went() {
    // held past its reach: twice as far (one step from none), at most eight
    assert_eq!(next_ahead(0, 1), 1);
    assert_eq!(next_ahead(1, 2), 2);
    assert_eq!(next_ahead(4, 5), 8);
    assert_eq!(next_ahead(8, 9), 8);
    // left before its reach was used up (it turned, was hit, stopped): half as far
    assert_eq!(next_ahead(8, 3), 4);
    assert_eq!(next_ahead(2, 2), 1);
    assert_eq!(next_ahead(1, 1), 0);
}

#[test]
fn sleepers_keep_no_pairs_among_themselves_and_far_ones_stay_out_of_the_grid() {
    let mut rnd = unit(lcg(4242));
    // a ground, a heap of 300 bodies that move, and far off 640 sleepers in ten whole
    // blocks, packed so that each touches its neighbours
    let mut boxes = ground_and_heap(&mut rnd, 300, 30, 0.3);
    let far = boxes.len().next_multiple_of(AWAKE_BLOCK);
    while boxes.len() < far {
        let x = boxes.len() as f32 * 2.0;
        boxes.push(aabb(x, 50.0, x + 0.5, 50.5));
    }
    for k in 0..10 * AWAKE_BLOCK {
        let (x, y) = (1000.0 + (k % 32) as f32 * 0.9, (k / 32) as f32 * 0.9);
        boxes.push(aabb(x, y, x + 1.0, y + 1.0));
    }
    let n = boxes.len();
    // as the world has it: a body may move exactly while it is awake and dynamic
    let mut moves: Vec<bool> = (0..n).map(|i| i != 0 && i < far).collect();
    let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
    let steps = 400u32;
    let pick = |r: f32, lo: usize, hi: usize| lo + (r * (hi - lo) as f32) as usize % (hi - lo);
    // the far sleepers woken at some step
    let mut woken = Vec::new();
    for step in 0..steps {
        // the heap jostles; every 9th step most of it leaves its kept boxes (a rebuild)
        let jump = if step % 9 == 4 { 0.5 } else { 0.004 };
        for (b, _) in boxes.iter_mut().zip(&moves).filter(|(_, m)| **m) {
            let d = Vec2::new(rnd() - 0.5, rnd() - 0.5) * jump;
            (b.min, b.max) = (b.min + d, b.max + d);
        }
        // a body of the heap falls asleep or wakes; a far sleeper of the first far
        // block wakes, jostles, and may fall asleep again some steps later
        if step % 7 == 2 {
            let i = pick(rnd(), 1, 301);
            moves[i] = !moves[i];
        }
        if step % 13 == 6 {
            let i = pick(rnd(), far, far + AWAKE_BLOCK);
            moves[i] = !moves[i];
            woken.push(i);
        }
        kept_against_fresh(
            &mut kept,
            &mut fresh,
            &boxes,
            &moves,
            &moves,
            |_| Vec2::ZERO,
            step,
        );
        // a pair of two bodies kept as still ones is never kept
        assert!(
            kept.kept_pairs()
                .iter()
                .all(|&(a, b)| kept.kept_moves[a as usize] || kept.kept_moves[b as usize]),
            "step {step}"
        );
    }
    assert!(kept.rebuilds > 20, "{} rebuilds", kept.rebuilds);
    // the far sleepers kept no pair among themselves but those of the few ever woken
    // (each touches at most eight): not the 2,400 of all their touching neighbours
    woken.sort_unstable();
    woken.dedup();
    let far_pairs = kept
        .kept_pairs()
        .iter()
        .filter(|&&(a, _)| a as usize >= far)
        .count();
    assert!(
        far_pairs <= 8 * woken.len() && woken.len() < 40,
        "{far_pairs} pairs among the far sleepers, {} woken",
        woken.len()
    );
    // a rebuild's grid left the far blocks out: its last one held the heap's boxes
    // and the ground's, and at most the first two far blocks (the woken ones' and
    // the next, which their boxes may reach)
    assert!(kept.ranges.len() + kept.large.len() <= far + 2 * AWAKE_BLOCK);
    assert!(kept.left_out[far / AWAKE_BLOCK + 2..].iter().all(|&o| o));
}

#[test]
fn filters_that_let_no_two_bodies_touch_are_seen_as_such() {
    let group = |g: i32| Filter {
        group: g,
        ..Filter::default()
    };
    let only = |category: u32, mask: u32| Filter {
        category,
        mask,
        ..Filter::default()
    };
    // one negative group: nothing; a body outside it touches them
    assert!(!any_pair_may_touch(&[group(-1); 5]));
    assert!(any_pair_may_touch(&[
        group(-1),
        group(-1),
        Filter::default()
    ]));
    // one default body alone touches nothing; two do
    assert!(!any_pair_may_touch(&[Filter::default()]));
    assert!(any_pair_may_touch(&[Filter::default(); 2]));
    // categories that leave each other out, and one that takes the other in
    assert!(!any_pair_may_touch(&[only(1, 2), only(4, 8), only(4, 8)]));
    assert!(!any_pair_may_touch(&[only(1, 2), only(2, 2)]));
    assert!(any_pair_may_touch(&[only(1, 2), only(2, 1)]));
    // a positive group always touches itself
    assert!(any_pair_may_touch(&[group(3), group(3)]));
    // many distinct filters: the grid decides
    let many: Vec<Filter> = (1..=12).map(|k| only(1 << k, 0)).collect();
    assert!(any_pair_may_touch(&many));
}

/// Bodies whose filters keep them apart cost no kept pairs however much their boxes
/// overlap, and a filter changed between steps still gives the pairs found afresh.
#[test]
fn kept_pairs_leave_out_what_the_filters_refuse() {
    // a category that touches none
    let apart = Filter {
        category: 2,
        mask: 0,
        group: 0,
    };
    // 30 x 30 large boxes, every one overlapping every other
    let boxes: Vec<Aabb> = (0..900)
        .map(|k| {
            let (x, y) = ((k % 30) as f32 * 0.1, (k / 30) as f32 * 0.1);
            aabb(x, y, x + 100.0, y + 100.0)
        })
        .collect();
    let n = boxes.len();
    let moves = vec![true; n];
    let mut filters = vec![apart; n];
    let mut bp = BroadPhase::default();
    let step = |bp: &mut BroadPhase, filters: &[Filter]| {
        let left = left_of(bp, &boxes, &moves, filters);
        step_filtered(bp, &boxes, &moves, &left, filters, None);
    };
    step(&mut bp, &filters);
    assert!(bp.pairs.is_empty());
    assert!(
        bp.kept_pairs().is_empty(),
        "{} pairs kept that can never touch",
        bp.kept_pairs().len()
    );
    // two bodies that touch each other only: their pair is found, as afresh
    let pair = Filter {
        category: 4,
        mask: 4,
        group: 0,
    };
    (filters[10], filters[500]) = (pair, pair);
    step(&mut bp, &filters);
    assert_eq!(bp.pairs.len(), 1);
    assert_eq!(bp.pairs, vec![(10, 500)]);
    assert_eq!(bp.kept_pairs(), &[(10, 500)]);
    assert_eq!(bp.rebuilds, 2);
    // unfiltered, every pair of boxes is kept
    let mut all = BroadPhase::default();
    all.refresh_kept(&boxes, Left::All, |_| true, &|_| Vec2::ZERO, None, None);
    assert_eq!(all.kept_pairs().len(), n * (n - 1) / 2);
}

/// The bodies whose kept box or filter no longer holds, as the collide's pass lists
/// them (`None` before the first rebuild: every body). [`Left`] of it by [`as_left`].
fn left_of(
    bp: &BroadPhase,
    boxes: &[Aabb],
    moves: &[bool],
    filters: &[Filter],
) -> Option<Vec<u32>> {
    let n = boxes.len();
    (bp.kept_count() == n).then(|| {
        (0..n)
            .filter(|&i| leaves(bp, boxes, moves, filters, i))
            .map(|i| i as u32)
            .collect()
    })
}

/// One step of `bp`'s kept pairs under `filters`, the bodies that left as `left`
/// lists them, with `moves` as whether each may move.
fn step_filtered(
    bp: &mut BroadPhase,
    boxes: &[Aabb],
    moves: &[bool],
    left: &Option<Vec<u32>>,
    filters: &[Filter],
    pool: Option<&Pool>,
) {
    let of = |i: usize| filters[i];
    bp.find_pairs_kept_checked(
        boxes,
        moves,
        as_left(left),
        |i| moves[i],
        &|_| Vec2::ZERO,
        Some(&of),
        |a, b| filters[a as usize].collides(&filters[b as usize]),
        pool,
    );
}

fn as_left(listed: &Option<Vec<u32>>) -> Left<'_> {
    listed.as_deref().map_or(Left::All, Left::These)
}

/// Whether body `i` left its kept box (or changed whether it moves, or its filter).
fn leaves(bp: &BroadPhase, boxes: &[Aabb], moves: &[bool], filters: &[Filter], i: usize) -> bool {
    !(bp.kept_holds(i, &boxes[i], moves[i]) && bp.kept_filter_holds(i, &filters[i]))
}

/// One of three filters by `k`: the third touches only the first.
fn three_filters(k: usize) -> Filter {
    Filter {
        category: 1 << (k % 3),
        mask: if k % 3 == 2 { 1 } else { 0xffff },
        group: 0,
    }
}

/// A fixed scramble of numbers from `seed` (a linear congruential generator).
fn lcg(mut seed: u32) -> impl FnMut() -> usize {
    move || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as usize
    }
}

/// The numbers of `next` (below 2^24, as [`lcg`]'s) scaled into [0, 1).
fn unit(mut next: impl FnMut() -> usize) -> impl FnMut() -> f32 {
    move || next() as f32 / (1u32 << 24) as f32
}

/// Boxes scattered over a 40 x 20 m field, mixed sizes, one of them huge.
fn scatter(seed: u32, count: usize) -> Vec<Aabb> {
    let mut rnd = unit(lcg(seed));
    let mut boxes = vec![aabb(-100.0, -2.0, 100.0, 0.0)];
    for _ in 0..count {
        let (x, y, s) = (rnd() * 40.0 - 20.0, rnd() * 20.0 - 3.0, 0.2 + rnd() * 2.0);
        boxes.push(aabb(x, y, x + s, y + s * rnd()));
    }
    boxes
}

#[test]
fn threads_sharing_the_grid_and_the_sort_find_the_pairs_of_a_brute_force_scan() {
    // enough boxes, crowded enough, for the threads to share the cells' tests and
    // the pairs' sort; every third box still, some pairs refused
    let boxes = scatter(777, 3000);
    let n = boxes.len();
    let moves: Vec<bool> = (0..n).map(|i| !i.is_multiple_of(3)).collect();
    let can = |a: u32, b: u32| !(a + 3 * b).is_multiple_of(7);
    let mut brute = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            if (moves[a] || moves[b]) && boxes[a].overlaps(&boxes[b]) && can(a as u32, b as u32) {
                brute.push((a as u32, b as u32));
            }
        }
    }
    let mut one = BroadPhase::default();
    one.find_pairs_sized(&boxes, &moves, &moves, &[], can, None);
    assert_eq!(one.pairs, brute, "one thread");
    assert!(
        one.pairs.len() >= PARALLEL_SORT_PAIRS,
        "{} pairs",
        one.pairs.len()
    );
    assert!(one.cell_bodies.len() >= PARALLEL_CELL_ENTRIES);
    for threads in [2, 3] {
        let pool = Pool::new(threads);
        let mut shared = BroadPhase::default();
        // twice: the second time on the buffers the first left
        for _ in 0..2 {
            shared.find_pairs_sized(&boxes, &moves, &moves, &[], can, Some(&pool));
            assert_eq!(shared.pairs, brute, "{threads} threads");
        }
    }
}

#[test]
fn a_crowded_cell_and_boxes_that_only_touch_give_the_pairs_of_a_brute_force_scan() {
    // 300 unit boxes on a 0.25 m lattice: each cell holds far more than the 64 boxes
    // one body is tested against at a time, and many boxes meet only along an edge
    // or at a corner (which counts as overlapping); 60 small boxes spread around
    // them, every fourth box still
    let mut rnd = unit(lcg(99));
    let mut boxes = Vec::new();
    for k in 0..300 {
        let (x, y) = ((k % 20) as f32 * 0.25, (k / 20) as f32 * 0.25);
        boxes.push(aabb(x, y, x + 1.0, y + 1.0));
    }
    for _ in 0..60 {
        let (x, y) = (rnd() * 8.0 - 2.0, rnd() * 8.0 - 2.0);
        boxes.push(aabb(x, y, x + 0.1, y + 0.1));
    }
    let n = boxes.len();
    let moves: Vec<bool> = (0..n).map(|i| !i.is_multiple_of(4)).collect();
    let mut brute = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            if (moves[a] || moves[b]) && boxes[a].overlaps(&boxes[b]) {
                brute.push((a as u32, b as u32));
            }
        }
    }
    let mut one = BroadPhase::default();
    one.find_pairs(&boxes, &moves, |_, _| true);
    assert_eq!(one.pairs, brute, "one thread");
    let cells = one.cell_start.windows(2).map(|w| w[1] - w[0]);
    assert!(
        cells.max().unwrap_or(0) > 2 * 64,
        "a cell holds over 128 boxes"
    );
    let touching = |a: &Aabb, b: &Aabb| a.max.x == b.min.x || a.max.y == b.min.y;
    assert!(
        brute
            .iter()
            .any(|&(a, b)| touching(&boxes[a as usize], &boxes[b as usize])),
        "some pairs only touch"
    );
    let pool = Pool::new(2);
    let mut shared = BroadPhase::default();
    shared.find_pairs_sized(&boxes, &moves, &moves, &[], |_, _| true, Some(&pool));
    assert_eq!(shared.pairs, brute, "two threads");
}

#[test]
fn a_few_movers_find_the_pairs_of_a_brute_force_scan() {
    let boxes = scatter(4242, 400);
    let n = boxes.len();
    // movers: none, the huge box, a handful, as many as are looked up one by one,
    // and one more (the grid's side of the line)
    for count in [0, 1, 7, ONE_BY_ONE, ONE_BY_ONE + 1] {
        let mut moves = vec![false; n];
        for k in 0..count {
            moves[(k * 37) % n] = true;
        }
        let can = |a: u32, b: u32| !(a + 2 * b).is_multiple_of(5);
        let mut bp = BroadPhase::default();
        bp.find_pairs(&boxes, &moves, can);
        let mut brute = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                if (moves[a] || moves[b]) && boxes[a].overlaps(&boxes[b]) && can(a as u32, b as u32)
                {
                    brute.push((a as u32, b as u32));
                }
            }
        }
        assert!(count < 2 || !brute.is_empty(), "{count} movers");
        assert_eq!(bp.pairs, brute, "{count} movers");
    }
}

#[test]
fn a_few_movers_pass_over_the_blocks_their_boxes_miss_and_find_the_same_pairs() {
    // four blocks of boxes: the first holds the movers; the second lies beside them
    // (its bounds reached), the third far off (missed), the fourth far off too but
    // with one box reaching back to the movers (its bounds reached again)
    let b = AWAKE_BLOCK;
    let mut boxes = scatter(31, 4 * b - 1);
    for (i, bx) in boxes.iter_mut().enumerate() {
        if i >= 2 * b {
            bx.min.x += 1000.0;
            bx.max.x += 1000.0;
        }
    }
    boxes[3 * b + 9] = aabb(-5.0, -5.0, 5.0, 5.0);
    let n = boxes.len();
    let mut moves = vec![false; n];
    for k in 0..9 {
        moves[k * 7 + 1] = true;
    }
    let bounds: Vec<Option<Aabb>> = (0..4)
        .map(|k| {
            let run = &boxes[k * b..((k + 1) * b).min(n)];
            (k > 0).then(|| run.iter().copied().reduce(|x, y| x.union(&y)).unwrap())
        })
        .collect();
    let can = |a: u32, b: u32| !(a + b).is_multiple_of(7);
    let mut plain = BroadPhase::default();
    plain.find_pairs(&boxes, &moves, can);
    let mut bounded = BroadPhase::default();
    bounded.find_pairs_sized(&boxes, &moves, &moves, &bounds, can, None);
    let mut brute = Vec::new();
    for a in 0..n {
        for c in a + 1..n {
            if (moves[a] || moves[c]) && boxes[a].overlaps(&boxes[c]) && can(a as u32, c as u32) {
                brute.push((a as u32, c as u32));
            }
        }
    }
    assert!(brute.iter().any(|&(_, c)| c as usize == 3 * b + 9));
    assert!(
        brute
            .iter()
            .any(|&(_, c)| (b..2 * b).contains(&(c as usize)))
    );
    assert!(!boxes[..b].iter().any(|x| x.overlaps(&bounds[2].unwrap())));
    assert_eq!(plain.pairs, brute);
    assert_eq!(bounded.pairs, brute);
}

#[test]
fn splice_sorted_edits_a_sorted_list_as_a_set() {
    // lists of pairs from a fixed scramble; each edit takes a random part out and
    // puts random pairs in (some of them pairs it took out): the result is the set
    // difference and union, sorted
    let mut next = lcg(3);
    let mut rnd = move |m: u32| next() as u32 % m;
    let mut scratch = Vec::new();
    for round in 0..200 {
        let mut list: Vec<Pair> = (0..rnd(60)).map(|_| (rnd(20), rnd(20))).collect();
        list.sort_unstable();
        list.dedup();
        let gone: Vec<Pair> = list.iter().copied().filter(|_| rnd(4) == 0).collect();
        let mut added: Vec<Pair> = (0..rnd(8)).map(|_| (rnd(20), rnd(20))).collect();
        added.extend(gone.iter().copied().filter(|_| rnd(2) == 0));
        added.sort_unstable();
        added.dedup();
        added.retain(|p| gone.contains(p) || !list.contains(p));
        let mut want: Vec<Pair> = list
            .iter()
            .copied()
            .filter(|p| !gone.contains(p))
            .chain(added.iter().copied())
            .collect();
        want.sort_unstable();
        splice_sorted(&mut list, &gone, &added, &mut scratch);
        assert_eq!(list, want, "round {round}");
    }
}

#[test]
fn a_few_bodies_wandering_through_a_grid_keep_the_pairs_a_rebuild_finds() {
    // 40 rows of 16 boxes in row order, so each awake block of 64 is four rows and
    // a few movers' kept boxes miss most blocks' bounds; three of them wander
    // through the grid, jumping up to two rows a step: the kept pairs stay every
    // pair of kept boxes (the pairs a rebuild finds) and the step's pairs those
    // found afresh
    let (rows, cols) = (40usize, 16usize);
    let mut boxes: Vec<Aabb> = (0..rows * cols)
        .map(|i| {
            let (x, y) = ((i % cols) as f32, (i / cols) as f32);
            aabb(x, y, x + 0.9, y + 0.9)
        })
        .collect();
    let n = boxes.len();
    let moves = vec![true; n];
    let filters = vec![Filter::default(); n];
    let mut rnd = unit(lcg(17));
    let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
    for step in 0..300 {
        for i in [5, 300, 630] {
            let d = Vec2::new(rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0);
            let c = (boxes[i].min + d).clamp(Vec2::ZERO, Vec2::new(15.0, 39.0));
            (boxes[i].min, boxes[i].max) = (c, c + Vec2::splat(0.9));
        }
        let left = left_of(&kept, &boxes, &moves, &filters);
        kept.find_pairs_kept_checked(
            &boxes,
            &moves,
            as_left(&left),
            |i| moves[i],
            &|_| Vec2::ZERO,
            None,
            |_, _| true,
            None,
        );
        fresh.find_pairs(&boxes, &moves, |_, _| true);
        assert_eq!(kept.pairs, fresh.pairs, "step {step}");
        let fat: Vec<Aabb> = kept.kept_boxes.clone();
        let mut rebuilt = BroadPhase::default();
        rebuilt.find_pairs(&fat, &moves, |_, _| true);
        assert_eq!(kept.kept_pairs(), &rebuilt.pairs[..], "step {step}");
    }
    assert_eq!(kept.rebuilds, 1, "only the first step rebuilds");
    assert!(kept.updates > 250, "{} updates", kept.updates);
}

#[test]
fn some_bodies_jumping_about_keep_the_pairs_a_rebuild_finds() {
    // 600 boxes of mixed sizes over a ground, under filters; each step 40 to 140 of
    // them (more than are looked up one by one, at most a quarter) jump, now and then
    // one of them swelling past the grid's cells or a filter changing: the kept
    // pairs stay every pair of kept boxes the filters let touch, and the step's
    // pairs those found afresh; on one thread or two, the kept pairs are the same
    let mut boxes = scatter(7, 599);
    let n = boxes.len();
    let moves: Vec<bool> = (0..n).map(|i| i != 0).collect();
    let mut filters: Vec<Filter> = (0..n).map(three_filters).collect();
    let mut rnd = lcg(11);
    let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
    // (the second shares its pass over the boxes between two threads)
    let (mut listed, pool) = (BroadPhase::default(), Pool::new(2));
    let mut some_steps = 0;
    for step in 0..150 {
        let count = 40 + rnd() % 100;
        for _ in 0..count {
            let i = 1 + rnd() % (n - 1);
            let d = Vec2::new(
                (rnd() % 100) as f32 * 0.04 - 2.0,
                (rnd() % 100) as f32 * 0.04 - 2.0,
            );
            (boxes[i].min, boxes[i].max) = (boxes[i].min + d, boxes[i].max + d);
            if rnd().is_multiple_of(50) {
                boxes[i].max = boxes[i].min + Vec2::new(15.0, 12.0);
            }
        }
        if step % 4 == 0 {
            filters[1 + rnd() % (n - 1)] = three_filters(rnd());
        }
        let left = left_of(&kept, &boxes, &moves, &filters);
        let these = left_of(&listed, &boxes, &moves, &filters);
        let count = these.as_ref().map_or(0, Vec::len);
        some_steps += usize::from(count > ONE_BY_ONE && count <= n / SOME_SHARE);
        let can = |a: u32, b: u32| filters[a as usize].collides(&filters[b as usize]);
        step_filtered(&mut kept, &boxes, &moves, &left, &filters, None);
        step_filtered(&mut listed, &boxes, &moves, &these, &filters, Some(&pool));
        fresh.find_pairs(&boxes, &moves, can);
        assert_eq!(kept.pairs, fresh.pairs, "step {step}");
        assert_eq!(listed.pairs, fresh.pairs, "step {step}");
        assert_eq!(listed.kept_pairs(), kept.kept_pairs(), "step {step}");
        let fat = kept.kept_boxes.clone();
        let mut rebuilt = BroadPhase::default();
        rebuilt.find_pairs(&fat, &kept.kept_moves.clone(), |a, b| {
            kept.kept_filters[a as usize].collides(&kept.kept_filters[b as usize])
        });
        assert_eq!(kept.kept_pairs(), &rebuilt.pairs[..], "step {step}");
    }
    assert!(
        some_steps > 100,
        "{some_steps} steps with some bodies leaving"
    );
    assert_eq!(kept.rebuilds, 1, "only the first step rebuilds");
    assert_eq!(
        (listed.rebuilds, listed.updates),
        (kept.rebuilds, kept.updates)
    );
}

#[test]
fn kept_pairs_redone_body_by_body_under_filters_are_the_pairs_found_afresh() {
    let mut boxes = scatter(99, 300);
    let n = boxes.len();
    let moves: Vec<bool> = (0..n).map(|i| i != 0).collect();
    let mut filters: Vec<Filter> = (0..n).map(three_filters).collect();
    let mut rnd = lcg(5);
    let (mut kept, mut fresh) = (BroadPhase::default(), BroadPhase::default());
    for step in 0..200 {
        // one body jumps, and now and then another takes a new filter
        let i = 1 + rnd() % (n - 1);
        let d = Vec2::new(
            (rnd() % 100) as f32 * 0.05 - 2.5,
            (rnd() % 100) as f32 * 0.05,
        );
        (boxes[i].min, boxes[i].max) = (boxes[i].min + d, boxes[i].max + d);
        if step % 3 == 0 {
            filters[1 + rnd() % (n - 1)] = three_filters(rnd());
        }
        let left = left_of(&kept, &boxes, &moves, &filters);
        let can = |a: u32, b: u32| filters[a as usize].collides(&filters[b as usize]);
        step_filtered(&mut kept, &boxes, &moves, &left, &filters, None);
        fresh.find_pairs(&boxes, &moves, can);
        assert!(!fresh.pairs.is_empty());
        assert_eq!(kept.pairs, fresh.pairs, "step {step}");
        // the kept pairs are every pair of kept boxes the filters let touch, sorted
        assert!(kept.kept_pairs().windows(2).all(|w| w[0] < w[1]));
    }
    assert_eq!(kept.rebuilds, 1, "only the first step rebuilds");
    assert!(kept.updates > 100, "{} updates", kept.updates);
}
