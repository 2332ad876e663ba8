// Instanced thick segments with round caps: one screen-space quad per segment, shaded
// by the distance to the segment so the edges are antialiased. Widths are in pixels.

struct LineIn {
    @builtin(vertex_index) vertex: u32,
    @location(0) a: vec2<f32>,
    @location(1) b: vec2<f32>,
    @location(2) width_px: f32,
    @location(3) color: vec4<f32>,
};

struct LineOut {
    @builtin(position) position: vec4<f32>,
    @location(0) pixel: vec2<f32>,
    @location(1) @interpolate(flat, either) a_px: vec2<f32>,
    @location(2) @interpolate(flat, either) b_px: vec2<f32>,
    @location(3) @interpolate(flat, either) half_width: f32,
    // Lines thinner than a pixel are drawn one pixel wide and fainter.
    @location(4) @interpolate(flat, either) fade: f32,
    @location(5) @interpolate(flat, either) color: vec4<f32>,
};

@vertex
fn vs_main(in: LineIn) -> LineOut {
    var out: LineOut;
    let a = to_screen(in.a);
    let b = to_screen(in.b);
    let ab = b - a;
    let len = length(ab);
    var t = vec2<f32>(1.0, 0.0);
    if len > 1e-6 {
        t = ab / len;
    }
    let n = vec2<f32>(-t.y, t.x);
    let hw = max(0.5 * in.width_px, 0.5);
    // Reach past the caps by the half width plus a pixel for the antialiased edge.
    let reach = hw + 1.0;
    let corner = quad_corner(in.vertex);
    let along = select(-reach, len + reach, corner.x > 0.0);
    let p = a + t * along + n * (corner.y * reach);
    out.position = screen_to_clip(p);
    out.pixel = p;
    out.a_px = a;
    out.b_px = b;
    out.half_width = hw;
    out.fade = clamp(in.width_px, 0.0, 1.0);
    out.color = in.color;
    return out;
}

@fragment
fn fs_main(in: LineOut) -> @location(0) vec4<f32> {
    let d = segment_distance(in.pixel, in.a_px, in.b_px);
    let coverage = clamp(in.half_width - d + 0.5, 0.0, 1.0) * in.fade;
    if coverage <= 0.0 {
        discard;
    }
    return finish(in.color * coverage);
}
