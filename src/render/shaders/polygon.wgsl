// Polygon fills: triangles (fans of convex polygons, built on the CPU) in world space.
// Their edges are antialiased by MSAA; outlines are drawn over them by line.wgsl.

struct PolygonIn {
    @location(0) position: vec2<f32>,
    @location(1) color: vec4<f32>,
};

struct PolygonOut {
    @builtin(position) position: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vs_main(in: PolygonIn) -> PolygonOut {
    var out: PolygonOut;
    out.position = screen_to_clip(to_screen(in.position));
    out.color = in.color;
    return out;
}

@fragment
fn fs_main(in: PolygonOut) -> @location(0) vec4<f32> {
    return finish(in.color);
}
