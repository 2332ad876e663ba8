// Shared by every pipeline: the camera uniform, the screen transform and colour helpers.
// Colours arrive linear and premultiplied (converted once per instance on the CPU).
// Prepended to box.wgsl, circle.wgsl, line.wgsl, polygon.wgsl and shape.wgsl at pipeline
// creation.

struct Globals {
    // World point at the image centre (m).
    center: vec2<f32>,
    // Image centre in pixels: (width / 2, height / 2).
    screen_center: vec2<f32>,
    // Image size in pixels.
    viewport: vec2<f32>,
    // The screen transform's scale s (pixels per metre).
    scale: f32,
    // Outline width in pixels.
    outline_px: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
    _pad3: f32,
};

@group(0) @binding(0) var<uniform> g: Globals;

// True when the target format is not sRGB: encode to sRGB in the shader. A constant of
// the pipeline, not a uniform, so a CPU rasteriser (llvmpipe) compiles the encoding away
// where it is not wanted instead of running it masked for every fragment.
override ENCODE_SRGB: bool = false;

// Level of detail: a box or circle narrower than this many pixels is drawn as a plain
// fill, without its outline (which would otherwise cover most of it).
const LOD_PX: f32 = 4.0;

// X = [[s, 0, px], [0, -s, py], [0, 0, 1]], written relative to the centre for precision.
fn to_screen(w: vec2<f32>) -> vec2<f32> {
    let d = (w - g.center) * g.scale;
    return vec2<f32>(g.screen_center.x + d.x, g.screen_center.y - d.y);
}

// Pixels (y down, origin top-left) to clip space (y up, [-1, 1]).
fn screen_to_clip(p: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(p.x / g.viewport.x * 2.0 - 1.0, 1.0 - p.y / g.viewport.y * 2.0, 0.0, 1.0);
}

// The four corners of a quad in [-1, 1]^2, in triangle-strip order: the two triangles
// (1,-1) (-1,-1) (1,1) and (-1,-1) (1,1) (-1,1) share the diagonal from (-1,-1) to (1,1).
fn quad_corner(i: u32) -> vec2<f32> {
    var corners = array<vec2<f32>, 4>(
        vec2<f32>(1.0, -1.0), vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    return corners[i];
}

// sRGB transfer function, encode: l <= 0.0031308 ? 12.92 l : 1.055 l^(1/2.4) - 0.055
fn linear_to_srgb(l: vec3<f32>) -> vec3<f32> {
    let lo = l * 12.92;
    let hi = 1.055 * pow(max(l, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - vec3<f32>(0.055);
    return select(hi, lo, l <= vec3<f32>(0.0031308));
}

// `top` over `bottom`, both premultiplied.
fn over(top: vec4<f32>, bottom: vec4<f32>) -> vec4<f32> {
    return top + bottom * (1.0 - top.a);
}

// A shape's colour at signed distance `d` (pixels, negative inside) from its edge, with
// an outline band of half width `e` centred on the edge (0: none): the fill, the
// outline over it in the band, and a one-pixel ramp across the outer edge. Premultiplied,
// before `finish`; fully transparent outside.
fn edge_shade(d: f32, e: f32, fill: vec4<f32>, outline: vec4<f32>) -> vec4<f32> {
    // Coverage: 1 inside the outline's outer edge, 0 outside, a one-pixel ramp across it.
    let coverage = clamp(e + 0.5 - d, 0.0, 1.0);
    // 1 in the outline band [-e, e] about the edge, 0 deeper in; none without a band.
    let band = select(clamp(d + e + 0.5, 0.0, 1.0), 0.0, e <= 0.0);
    return over(outline * band, fill) * coverage;
}

// The fragment output: premultiplied linear, or sRGB-encoded for a non-sRGB target.
fn finish(c: vec4<f32>) -> vec4<f32> {
    if ENCODE_SRGB && c.a > 0.0 {
        return vec4<f32>(linear_to_srgb(c.rgb / c.a) * c.a, c.a);
    }
    return c;
}

// Distance from p to the segment [a, b].
fn segment_distance(p: vec2<f32>, a: vec2<f32>, b: vec2<f32>) -> f32 {
    let ab = b - a;
    let len2 = dot(ab, ab);
    var t = 0.0;
    if len2 > 0.0 {
        t = clamp(dot(p - a, ab) / len2, 0.0, 1.0);
    }
    return length(p - (a + ab * t));
}
