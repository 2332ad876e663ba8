// Instanced convex shapes of 2 to 8 points grown by a radius: polygons (radius 0),
// rounded polygons and capsules (2 points). One screen-space quad per shape, shaded by
// the shape's signed distance so the edge and the outline band are antialiased in the
// shader, as boxes are.
//
// The points come padded to eight by repeating the last one: the padding adds edges of
// zero length at that point, which is on the outline already, and the edge from the
// eighth point back to the first is the real closing edge. So every shape runs the same
// eight edges, with no loop over a count.

struct ShapeIn {
    @builtin(vertex_index) vertex: u32,
    // The shape's centre (m, world), its radius (m), unused.
    @location(0) center_radius: vec4<f32>,
    // The points relative to the centre (m, world axes), counter-clockwise, two a slot.
    @location(1) p01: vec4<f32>,
    @location(2) p23: vec4<f32>,
    @location(3) p45: vec4<f32>,
    @location(4) p67: vec4<f32>,
    @location(5) fill: vec4<f32>,
    @location(6) outline: vec4<f32>,
};

struct ShapeOut {
    @builtin(position) position: vec4<f32>,
    // The fragment's position relative to the centre, in pixels along the world's axes
    // (y up), where the points are.
    @location(0) local: vec2<f32>,
    @location(1) @interpolate(flat, either) p01: vec4<f32>,
    @location(2) @interpolate(flat, either) p23: vec4<f32>,
    @location(3) @interpolate(flat, either) p45: vec4<f32>,
    @location(4) @interpolate(flat, either) p67: vec4<f32>,
    // The radius and half the outline's width, in pixels (a band of 0: no outline).
    @location(5) @interpolate(flat, either) radius_band: vec2<f32>,
    @location(6) @interpolate(flat, either) fill: vec4<f32>,
    @location(7) @interpolate(flat, either) outline: vec4<f32>,
};

@vertex
fn vs_main(in: ShapeIn) -> ShapeOut {
    var out: ShapeOut;
    let s = g.scale;
    let p01 = in.p01 * s;
    let p23 = in.p23 * s;
    let p45 = in.p45 * s;
    let p67 = in.p67 * s;
    let lo = min(min(min(p01.xy, p01.zw), min(p23.xy, p23.zw)), min(min(p45.xy, p45.zw), min(p67.xy, p67.zw)));
    let hi = max(max(max(p01.xy, p01.zw), max(p23.xy, p23.zw)), max(max(p45.xy, p45.zw), max(p67.xy, p67.zw)));
    let r = in.center_radius.z * s;
    // Level of detail as for boxes: a shape narrower than LOD_PX has no outline.
    let size = hi - lo + vec2<f32>(2.0 * r);
    let small = min(size.x, size.y) < LOD_PX;
    let e = select(0.5 * g.outline_px, 0.0, small || in.outline.a <= 0.0);
    // The bounding box grown by the radius, the half outline and a pixel for the edge.
    let m = vec2<f32>(r + e + 1.0);
    let local = mix(lo - m, hi + m, quad_corner(in.vertex) * 0.5 + vec2<f32>(0.5));
    let c = to_screen(in.center_radius.xy);
    // y flips on screen
    out.position = screen_to_clip(vec2<f32>(c.x + local.x, c.y - local.y));
    out.local = local;
    out.p01 = p01;
    out.p23 = p23;
    out.p45 = p45;
    out.p67 = p67;
    out.radius_band = vec2<f32>(r, e);
    out.fill = in.fill;
    out.outline = in.outline;
    return out;
}

// One edge a -> b: the least squared distance to the edges so far and to this one, and
// the least of p's sides so far and of this one (>= 0: left of every edge, inside).
fn edge(p: vec2<f32>, a: vec2<f32>, b: vec2<f32>, acc: vec2<f32>) -> vec2<f32> {
    let ab = b - a;
    let ap = p - a;
    let t = clamp(dot(ap, ab) / max(dot(ab, ab), 1e-12), 0.0, 1.0);
    let q = ap - ab * t;
    return vec2<f32>(min(acc.x, dot(q, q)), min(acc.y, ab.x * ap.y - ab.y * ap.x));
}

@fragment
fn fs_main(in: ShapeOut) -> @location(0) vec4<f32> {
    let p = in.local;
    var acc = vec2<f32>(3.0e38, 3.0e38);
    acc = edge(p, in.p01.xy, in.p01.zw, acc);
    acc = edge(p, in.p01.zw, in.p23.xy, acc);
    acc = edge(p, in.p23.xy, in.p23.zw, acc);
    acc = edge(p, in.p23.zw, in.p45.xy, acc);
    acc = edge(p, in.p45.xy, in.p45.zw, acc);
    acc = edge(p, in.p45.zw, in.p67.xy, acc);
    acc = edge(p, in.p67.xy, in.p67.zw, acc);
    acc = edge(p, in.p67.zw, in.p01.xy, acc);
    // Signed distance to the core (negative inside), then to the grown shape.
    let core = sqrt(acc.x);
    let d = select(core, -core, acc.y >= 0.0) - in.radius_band.x;
    let c = edge_shade(d, in.radius_band.y, in.fill, in.outline);
    if c.a <= 0.0 {
        discard;
    }
    return finish(c);
}
