//! Render + read-back of a 1280x720 frame of a 210-box pyramid, off-screen.
//!
//! `cargo bench --bench render`. Honours WGPU_BACKEND (e.g. `gl`, `vulkan`); without an
//! adapter it prints why and measures nothing.
//!
//! Measured once (llvmpipe via GL, 2 shared CPU cores, `--profile dev` with dependencies at
//! opt-level 3): median 19.7 ms a frame (mean 19.5 ms).

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
    let list = scenes::bench_scene();
    let camera = Camera::new(Vec2::new(0.0, 12.0), 26.0, [1280, 720]);
    let samples = renderer.sample_count();
    c.bench_function(
        &format!("render_readback_1280x720_210_boxes_default_{samples}x"),
        |b| {
            b.iter(|| {
                renderer
                    .render_to_image(black_box(&list), black_box(&camera))
                    .expect("render")
            })
        },
    );
    // The same frame with the other sample count (4x MSAA against single-sampled).
    let other = if samples == 1 { 4 } else { 1 };
    let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all());
    let Ok(mut renderer) = Renderer::new_headless_with_samples(backends, other) else {
        return;
    };
    c.bench_function(
        &format!("render_readback_1280x720_210_boxes_{other}x"),
        |b| {
            b.iter(|| {
                renderer
                    .render_to_image(black_box(&list), black_box(&camera))
                    .expect("render")
            })
        },
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = render_frame
}
criterion_main!(benches);
