// Instanced boxes (rectangles, rotated): one screen-space quad per box, shaded by the
// box's signed distance so the edge and the outline band are antialiased in the shader
// (no MSAA needed, no separate outline pass).

struct BoxIn {
    @builtin(vertex_index) vertex: u32,
    @location(0) center: vec2<f32>,
    // Half width and half height (m).
    @location(1) half_size: vec2<f32>,
    // (cos, sin) of the box's angle.
    @location(2) rot: vec2<f32>,
    @location(3) fill: vec4<f32>,
    @location(4) outline: vec4<f32>,
};

struct BoxOut {
    @builtin(position) position: vec4<f32>,
    // The fragment's position in the box's frame, in pixels from its centre.
    @location(0) local: vec2<f32>,
    @location(1) @interpolate(flat, either) half_px: vec2<f32>,
    // Half the outline's width in pixels (0: a small box drawn as a plain fill).
    @location(2) @interpolate(flat, either) half_band: f32,
    @location(3) @interpolate(flat, either) fill: vec4<f32>,
    @location(4) @interpolate(flat, either) outline: vec4<f32>,
};

@vertex
fn vs_main(in: BoxIn) -> BoxOut {
    var out: BoxOut;
    let c = to_screen(in.center);
    let h = in.half_size * g.scale;
    // Level of detail: a box narrower than LOD_PX pixels has no outline (nor has one
    // whose outline is transparent). Otherwise the outline is centred on the edge, as
    // the line along a polygon's edge is.
    let small = 2.0 * min(h.x, h.y) < LOD_PX;
    let e = select(0.5 * g.outline_px, 0.0, small || in.outline.a <= 0.0);
    // The half outline and one pixel of margin for the antialiased edge.
    let local = quad_corner(in.vertex) * (h + vec2<f32>(e + 1.0));
    // y flips on screen: the world axes (cos, sin) and (-sin, cos) in pixels.
    let ax = vec2<f32>(in.rot.x, -in.rot.y);
    let ay = vec2<f32>(-in.rot.y, -in.rot.x);
    let p = c + ax * local.x + ay * local.y;
    out.position = screen_to_clip(p);
    out.local = local;
    out.half_px = h;
    out.half_band = e;
    out.fill = in.fill;
    out.outline = in.outline;
    return out;
}

@fragment
fn fs_main(in: BoxOut) -> @location(0) vec4<f32> {
    // Signed distance to the rectangle's edge: negative inside.
    let q = abs(in.local) - in.half_px;
    let d = length(max(q, vec2<f32>(0.0))) + min(max(q.x, q.y), 0.0);
    let c = edge_shade(d, in.half_band, in.fill, in.outline);
    if c.a <= 0.0 {
        discard;
    }
    return finish(c);
}
