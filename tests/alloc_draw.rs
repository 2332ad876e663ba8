//! A steady frame's draw list allocates nothing: `fill_world_draw_list` reuses the
//! list's buffers (counted by a global allocator; this file holds one test so no other
//! test allocates on the same counter).

use sandbox2d::draw::{DrawList, Overlays, fill_world_draw_list};
use sandbox2d::{SolverSettings, World, scene};

#[path = "common/counting.rs"]
mod counting;

#[global_allocator]
static COUNTING: counting::Counting = counting::Counting;

#[test]
fn steady_frames_fill_the_draw_list_without_allocating() {
    // boxes (pyramid), hinges and polygons that are not boxes (ragdoll, car), circles
    // and particles (particles), with and without every overlay
    for name in ["pyramid", "ragdoll", "car", "particles", "joints"] {
        for overlays in [Overlays::NONE, Overlays::ALL] {
            let sc = scene::load(name).unwrap();
            let mut w = World::from_def(&sc.world, SolverSettings::default()).unwrap();
            let mut list = DrawList::new();
            // warm up: the list's buffers grow to the scene's size
            for _ in 0..60 {
                w.step().unwrap();
                fill_world_draw_list(&mut list, &w, &overlays);
            }
            let mut allocs = 0;
            let mut drawn = 0;
            for _ in 0..30 {
                w.step().unwrap();
                let before = counting::allocations();
                fill_world_draw_list(&mut list, &w, &overlays);
                allocs += counting::allocations() - before;
                drawn += list.boxes.len() + list.polygons.len() + list.circles.len();
            }
            // a compound body (the car's chassis) draws each of its parts
            let shapes: usize = w
                .bodies()
                .map(|(_, b)| b)
                .map(|b| b.parts.len().max(1))
                .sum();
            assert_eq!(drawn, 30 * shapes, "{name}: every body (every part) drawn");
            assert_eq!(allocs, 0, "{name} with {overlays:?}: allocations");
        }
    }
}
