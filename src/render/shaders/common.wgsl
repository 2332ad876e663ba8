// Shared by every pipeline: the camera uniform, the screen transform and colour helpers.
// Prepended to box.wgsl, circle.wgsl, line.wgsl and polygon.wgsl at pipeline creation.

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
    // 1 when the target format is not sRGB: encode to sRGB in the shader.
    encode_srgb: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
};

@group(0) @binding(0) var<uniform> g: Globals;

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

// The six corners of a quad, two triangles, in [-1, 1]^2.
fn quad_corner(i: u32) -> vec2<f32> {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    return corners[i];
}

// sRGB transfer function, decode: c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055)^2.4
fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

// sRGB transfer function, encode: l <= 0.0031308 ? 12.92 l : 1.055 l^(1/2.4) - 0.055
fn linear_to_srgb(l: vec3<f32>) -> vec3<f32> {
    let lo = l * 12.92;
    let hi = 1.055 * pow(max(l, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - vec3<f32>(0.055);
    return select(hi, lo, l <= vec3<f32>(0.0031308));
}

// An sRGB colour with straight alpha to linear, premultiplied.
fn premultiplied_linear(c: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(srgb_to_linear(c.rgb) * c.a, c.a);
}

// `top` over `bottom`, both premultiplied.
fn over(top: vec4<f32>, bottom: vec4<f32>) -> vec4<f32> {
    return top + bottom * (1.0 - top.a);
}

// The fragment output: premultiplied linear, or sRGB-encoded for a non-sRGB target.
fn finish(c: vec4<f32>) -> vec4<f32> {
    if g.encode_srgb > 0.5 && c.a > 0.0 {
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
