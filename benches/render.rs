//! Render + read-back of a 1280x720 frame of a 210-box and a 5050-box pyramid, off-screen.
//!
//! `cargo bench --bench render`. Honours WGPU_BACKEND (e.g. `gl`, `vulkan`); without an
//! adapter it prints why and measures nothing.
//!
//! Measured (llvmpipe via GL, 2 CPU cores shared with other builds, load average 3.5 to
//! 3.8, release), medians, before -> after (boxes as one instanced SDF quad
//! each): 210 boxes single-sampled (the default on a CPU rasteriser) 8.5 -> 5.8 ms, 4x
//! MSAA 34.3 -> 24.2 ms; 5050 boxes single-sampled 42.7 -> 13.2 ms, 4x MSAA 144.6 ->
//! 66.8 ms. Earlier, at load average about 2: 210 boxes 7.9 ms single-sampled, 32.0 ms
//! at 4x. Then, on a quiet machine (load average about 2), before -> after the shaders
//! were shaped for a CPU rasteriser (four-vertex strips, colours converted on the CPU,
//! flat varyings, the sRGB encoding a pipeline constant): 5050 boxes single-sampled
//! 10.14 -> 6.35 ms, 4x 28.65 -> 26.21 ms; 210 boxes 2.74 -> 2.22 ms, 4x 14.22 -> 12.41
//! ms. On llvmpipe most of a 4x frame is clearing and resolving the samples; every
//! shape's edge is antialiased by its distance field (polygons other than boxes by their
//! outlines), so the single-sampled frame differs little.

#[path = "../tests/common/scenes.rs"]
mod scenes;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec2;
use sandbox2d::draw::Camera;
use sandbox2d::render::{Renderer, wgpu};
use std::hint::black_box;

fn render_frame(c: &mut Criterion) {
    let mut renderer = match Renderer::new_headless() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("render bench skipped: {e}");
            return;
        }
    };
    if let Some(info) = renderer.adapter_info() {
        eprintln!("adapter: {} ({:?})", info.name, info.backend);
    }
    let samples = renderer.sample_count();
    let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all());
    // The same frames with the other sample count (4x MSAA against single-sampled).
    let other = if samples == 1 { 4 } else { 1 };
    let mut other_renderer = Renderer::new_headless_with_samples(backends, other).ok();
    // 20 rows: 210 boxes framed as the base-20 pyramid is; 100 rows: 5050 boxes (the
    // large pyramid's count), boxes about 6 px wide as the window fits that pyramid.
    for (rows, camera) in [
        (20, Camera::new(Vec2::new(0.0, 12.0), 26.0, [1280, 720])),
        (100, Camera::new(Vec2::new(0.0, 50.0), 6.5, [1280, 720])),
    ] {
        let list = scenes::bench_scene_rows(rows);
        let boxes = rows * (rows + 1) / 2;
        c.bench_function(
            &format!("render_readback_1280x720_{boxes}_boxes_default_{samples}x"),
            |b| {
                b.iter(|| {
                    renderer
                        .render_to_image(black_box(&list), black_box(&camera))
                        .expect("render")
                })
            },
        );
        if let Some(r) = other_renderer.as_mut() {
            c.bench_function(
                &format!("render_readback_1280x720_{boxes}_boxes_{other}x"),
                |b| {
                    b.iter(|| {
                        r.render_to_image(black_box(&list), black_box(&camera))
                            .expect("render")
                    })
                },
            );
        }
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = render_frame
}
criterion_main!(benches);
