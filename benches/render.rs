//! Render + read-back of a 1280x720 frame of a 210-box and a 5050-box pyramid, off-screen.
//!
//! `cargo bench --bench render`. Honours WGPU_BACKEND (e.g. `gl`, `vulkan`); without an
//! adapter it prints why and measures nothing.
//!
//! Measured (llvmpipe via GL, 2 CPU cores shared with other builds, load average about
//! 2, release): single-sampled (the default on a CPU rasteriser) median 7.9 ms a frame;
//! 4x MSAA median 32.0 ms (8.4 ms and 34.2 ms at load average 4.5). Earlier, 4x MSAA on a quiet machine in `--profile dev`: median
//! 19.7 ms. On llvmpipe most of a 4x frame is clearing and resolving the samples; the
//! single-sampled frame matches it within 1/255 a channel, since every shape's edge is
//! antialiased by its distance field (polygons by their outlines).

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
