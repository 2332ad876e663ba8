// Instanced circles: one screen-space quad per circle, shaded by a signed distance
// field so the rim, the outline and the radius line are antialiased.

struct CircleIn {
    @builtin(vertex_index) vertex: u32,
    @location(0) center: vec2<f32>,
    @location(1) radius: f32,
    // Radians; only used when has_angle > 0.5.
    @location(2) angle: f32,
    @location(3) has_angle: f32,
    @location(4) fill: vec4<f32>,
    @location(5) outline: vec4<f32>,
};

struct CircleOut {
    @builtin(position) position: vec4<f32>,
    @location(0) pixel: vec2<f32>,
    @location(1) @interpolate(flat, either) center_px: vec2<f32>,
    @location(2) @interpolate(flat, either) radius_px: f32,
    // Screen-space end of the radius line, relative to the centre; zero for none.
    @location(3) @interpolate(flat, either) spoke: vec2<f32>,
    @location(4) @interpolate(flat, either) fill: vec4<f32>,
    @location(5) @interpolate(flat, either) outline: vec4<f32>,
};

@vertex
fn vs_main(in: CircleIn) -> CircleOut {
    var out: CircleOut;
    let c = to_screen(in.center);
    let r = in.radius * g.scale;
    // One pixel of margin for the antialiased rim.
    let p = c + quad_corner(in.vertex) * (r + 1.0);
    out.position = screen_to_clip(p);
    out.pixel = p;
    out.center_px = c;
    out.radius_px = r;
    // y flips on screen: the world direction (cos a, sin a) is (cos a, -sin a) in pixels.
    out.spoke = select(vec2<f32>(0.0), vec2<f32>(cos(in.angle), -sin(in.angle)) * r, in.has_angle > 0.5);
    out.fill = in.fill;
    out.outline = in.outline;
    return out;
}

@fragment
fn fs_main(in: CircleOut) -> @location(0) vec4<f32> {
    let d = length(in.pixel - in.center_px);
    let r = in.radius_px;
    // Coverage of the disc: 1 inside, 0 outside, a one-pixel ramp across the rim.
    let coverage = clamp(r - d + 0.5, 0.0, 1.0);
    if coverage <= 0.0 {
        discard;
    }
    // Level of detail: no outline nor radius line on a circle narrower than LOD_PX.
    let w = select(min(g.outline_px, r), 0.0, 2.0 * r < LOD_PX);
    // 1 in the outline band [r - w, r], 0 inside it.
    let band = select(clamp(d - (r - w) + 0.5, 0.0, 1.0), 0.0, w <= 0.0);
    var color = over(in.outline * band, in.fill);
    if dot(in.spoke, in.spoke) > 0.0 && w > 0.0 {
        let ds = segment_distance(in.pixel, in.center_px, in.center_px + in.spoke);
        let spoke = clamp(0.5 * w - ds + 0.5, 0.0, 1.0) * min(w, 1.0);
        color = over(in.outline * spoke, color);
    }
    return finish(color * coverage);
}
