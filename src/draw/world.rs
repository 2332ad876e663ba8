//! Filling a [`DrawList`] from a [`World`]: bodies (filled and outlined polygons,
//! circles with a radius line showing rotation, particles without one), static bodies in
//! their own colour, scene colours honoured, and optional overlays (contact points with
//! normals scaled by their impulse, bounding boxes, velocities).
//!
//! Plain data and math, no GPU: it builds without the `render` feature.

use glam::Vec2;

use crate::body::Body;
use crate::defs::{BodyModel, BodyType, CameraDef, Color};
use crate::draw::{Camera, DrawList, Rect};
use crate::shape::Shape;
use crate::world::World;

/// Which debug overlays to draw over the bodies, and how long their arrows are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Overlays {
    /// Contact points (dots) and their normals (lines from the point along the normal,
    /// from body A to body B, as long as the point's normal impulse lambda says).
    pub contacts: bool,
    /// Each body's axis-aligned bounding box.
    pub aabbs: bool,
    /// Each moving body's velocity, a line from its centre of mass.
    pub velocities: bool,
    /// Metres of normal line per N s of normal impulse. `None` scales the frame's
    /// largest impulse to [`Overlays::AUTO_CONTACT_BODIES`] times the mean body size.
    pub contact_scale: Option<f32>,
    /// A velocity v is drawn `|v| * velocity_scale` metres long (seconds).
    pub velocity_scale: f32,
    /// The camera's scale (pixels per metre) when the caller knows it: joint and
    /// contact marks then shrink with the zoom ([`mark_sizes_px`]) so that, zoomed out,
    /// they never hide the bodies they sit on. `None`: their fixed pixel sizes.
    pub pixels_per_meter: Option<f32>,
    /// Sleeping bodies drawn dimmed (half their colour, on the way to the background).
    pub sleeping: bool,
    /// Bodies coloured by a measure instead of their own colour ([`Tint`]).
    pub tint: Tint,
}

/// What the tint overlay colours each body by, on a ramp from blue (0) through green
/// and yellow to red (at [`Tint::full`] and beyond).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tint {
    /// Bodies keep their own colours.
    #[default]
    Off,
    /// Speed: |v| + |w| r (m/s), the fastest point's; red from 5 m/s.
    Speed,
    /// Constraint error: the deepest overlap of the body's contacts and the largest
    /// anchor separation of its joints (m); red from 5 cm (ten PGS slops).
    Error,
}

impl Tint {
    /// The value drawn red.
    pub fn full(self) -> f32 {
        match self {
            Tint::Off => 1.0,
            Tint::Speed => 5.0,
            Tint::Error => 0.05,
        }
    }

    /// The next in the cycle off, speed, error (the window's V key).
    pub fn next(self) -> Tint {
        match self {
            Tint::Off => Tint::Speed,
            Tint::Speed => Tint::Error,
            Tint::Error => Tint::Off,
        }
    }

    /// Each body's value under this tint (0 for static bodies and for `Off`).
    pub fn values(self, world: &World, out: &mut Vec<f32>) {
        out.clear();
        out.resize(world.bodies.len(), 0.0);
        match self {
            Tint::Off => {}
            Tint::Speed => {
                for (v, b) in out.iter_mut().zip(&world.bodies) {
                    if b.body_type != BodyType::Static {
                        *v = b.velocity.length() + b.angular_velocity.abs() * b.shape.radius();
                    }
                }
            }
            Tint::Error => {
                for c in world.contacts() {
                    let deepest = c
                        .manifold
                        .points()
                        .iter()
                        .fold(0.0f32, |m, p| m.max(-p.separation));
                    for i in [c.a as usize, c.b as usize] {
                        out[i] = out[i].max(deepest);
                    }
                }
                for j in &world.joints {
                    let e = j.position_error(&world.bodies);
                    for i in [j.a, j.b] {
                        out[i] = out[i].max(e);
                    }
                }
                for (v, b) in out.iter_mut().zip(&world.bodies) {
                    if b.body_type == BodyType::Static {
                        *v = 0.0;
                    }
                }
            }
        }
    }
}

/// The tint ramp at t in [0, 1] (clamped): blue, cyan, green, yellow, red.
pub fn tint_color(t: f32) -> Color {
    const STOPS: [[f32; 3]; 5] = [
        [40.0, 90.0, 220.0],
        [40.0, 200.0, 220.0],
        [60.0, 200.0, 80.0],
        [230.0, 210.0, 50.0],
        [230.0, 50.0, 40.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let x = t * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c = |k: usize| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])).round() as u8;
    [c(0), c(1), c(2), 255]
}

impl Default for Overlays {
    fn default() -> Self {
        Self::NONE
    }
}

impl Overlays {
    /// No overlays.
    pub const NONE: Overlays = Overlays {
        contacts: false,
        aabbs: false,
        velocities: false,
        contact_scale: None,
        velocity_scale: 0.1,
        pixels_per_meter: None,
        sleeping: false,
        tint: Tint::Off,
    };
    /// Every overlay.
    pub const ALL: Overlays = Overlays {
        contacts: true,
        aabbs: true,
        velocities: true,
        contact_scale: None,
        velocity_scale: 0.1,
        pixels_per_meter: None,
        sleeping: true,
        tint: Tint::Off,
    };
    /// With `contact_scale: None`, the largest normal impulse of the frame is drawn this
    /// many mean body radii long.
    pub const AUTO_CONTACT_BODIES: f32 = 1.5;
}

/// The colours bodies and overlays are drawn in.
pub mod colors {
    use crate::defs::Color;

    /// Static bodies (ground, walls).
    pub const STATIC: Color = [86, 92, 104, 255];
    /// Kinematic bodies.
    pub const KINEMATIC: Color = [120, 110, 160, 255];
    /// Dynamic bodies without a scene colour take one of these, by body index.
    pub const PALETTE: [Color; 6] = [
        [222, 98, 78, 255],
        [235, 166, 68, 255],
        [98, 176, 110, 255],
        [78, 148, 214, 255],
        [156, 110, 206, 255],
        [226, 196, 92, 255],
    ];
    /// Contact points.
    pub const CONTACT_POINT: Color = [255, 64, 64, 255];
    /// Contact normals.
    pub const CONTACT_NORMAL: Color = [255, 235, 90, 255];
    /// Bounding boxes.
    pub const AABB: Color = [90, 230, 140, 170];
    /// Velocities.
    pub const VELOCITY: Color = [80, 220, 255, 255];
    /// Joints (see [`super::push_joint_lines`]).
    pub const JOINT: Color = [235, 200, 60, 255];
}

/// Width in pixels of joint lines.
pub const JOINT_WIDTH_PX: f32 = 2.0;
/// Diameter in pixels of the dots at joint anchors and contact points.
pub const DOT_PX: f32 = 5.0;

/// At most this many metres across a joint or contact dot is drawn in the world.
pub const DOT_MAX_M: f32 = 0.25;
/// At most this many metres wide a joint line is drawn in the world.
pub const JOINT_WIDTH_MAX_M: f32 = 0.08;

/// (dot diameter, joint line width) in pixels at a camera scale of `ppm` pixels per
/// metre: [`DOT_PX`] and [`JOINT_WIDTH_PX`], shrunk once the zoom would make them
/// larger than [`DOT_MAX_M`] and [`JOINT_WIDTH_MAX_M`] in the world (never below 1 px).
/// Zoomed out on Box2D's joint grid (19,800 hinges, 6.5 px per metre) fixed 5 px dots
/// covered the 0.8 m circles; here they are 1.6 px.
pub fn mark_sizes_px(ppm: Option<f32>) -> (f32, f32) {
    match ppm {
        Some(s) if s.is_finite() && s > 0.0 => (
            DOT_PX.min(DOT_MAX_M * s).max(1.0),
            JOINT_WIDTH_PX.min(JOINT_WIDTH_MAX_M * s).max(1.0),
        ),
        _ => (DOT_PX, JOINT_WIDTH_PX),
    }
}

/// The fill colour a body is drawn with: its scene colour, else the static or kinematic
/// colour, else a palette colour picked by its index.
pub fn body_fill(index: usize, body: &Body) -> Color {
    if let Some(c) = body.color {
        return c;
    }
    match body.body_type {
        BodyType::Static => colors::STATIC,
        BodyType::Kinematic => colors::KINEMATIC,
        BodyType::Dynamic => colors::PALETTE[index % colors::PALETTE.len()],
    }
}

/// The outline colour for a fill: the same hue, darker, opaque.
pub fn outline_for(fill: Color) -> Color {
    let d = |v: u8| (v as u16 * 9 / 20) as u8;
    [d(fill[0]), d(fill[1]), d(fill[2]), 255]
}

/// A new draw list of the world's bodies and the chosen overlays.
pub fn world_draw_list(world: &World, overlays: &Overlays) -> DrawList {
    let mut list = DrawList::new();
    fill_world_draw_list(&mut list, world, overlays);
    list
}

/// Clears `list` (keeping its allocations, background and outline width) and fills it
/// with the world's bodies and the chosen overlays.
pub fn fill_world_draw_list(list: &mut DrawList, world: &World, overlays: &Overlays) {
    list.clear();
    if overlays.tint == Tint::Off {
        for (i, b) in world.bodies.iter().enumerate() {
            push_body_dimmed(list, i, b, overlays.sleeping && b.asleep);
        }
    } else {
        let mut values = std::mem::take(&mut list.scratch);
        overlays.tint.values(world, &mut values);
        let full = overlays.tint.full();
        for ((i, b), &v) in world.bodies.iter().enumerate().zip(&values) {
            let fill = if b.body_type == BodyType::Static {
                body_fill(i, b)
            } else {
                tint_color(v / full)
            };
            push_body_colored(list, b, fill, overlays.sleeping && b.asleep);
        }
        list.scratch = values;
    }
    // joints: a line between the two anchors (a thread, a rope link) and a dot at each
    // (where a hinge or weld holds), a pulley's two ropes from their ground points; the
    // mouse joint from the grabbed point to its target
    let (dot, width) = mark_sizes_px(overlays.pixels_per_meter);
    push_joint_lines_sized(
        list,
        world.joints.iter().flat_map(|j| {
            let (pa, pb) = j.world_anchors(&world.bodies);
            if j.kind == crate::defs::JointKind::Pulley {
                [Some((j.ground[0], pa)), Some((j.ground[1], pb))]
            } else {
                [Some((pa, pb)), None]
            }
            .into_iter()
            .flatten()
        }),
        dot,
        width,
    );
    if let Some(m) = world.mouse()
        && let Some(b) = world.bodies.get(m.body)
    {
        // the mouse joint is the user's hand: always full size
        push_joint_lines(
            list,
            std::iter::once((b.position + b.rot.rotate(m.local), m.target)),
        );
    }
    if overlays.aabbs {
        push_aabbs(list, world);
    }
    if overlays.velocities {
        push_velocities(list, world, overlays.velocity_scale);
    }
    if overlays.contacts {
        push_contacts(list, world, overlays.contact_scale, dot);
    }
}

/// Adds one body: a polygon (filled and outlined) or a circle, with a radius line for a
/// rigid circle and none for a particle.
pub fn push_body(list: &mut DrawList, index: usize, body: &Body) {
    push_body_dimmed(list, index, body, false);
}

/// [`push_body`], with `dim`: half its fill (a sleeping body).
pub fn push_body_dimmed(list: &mut DrawList, index: usize, body: &Body, dim: bool) {
    push_body_colored(list, body, body_fill(index, body), dim);
}

/// Adds one body filled with `fill` (halved with `dim`).
pub fn push_body_colored(list: &mut DrawList, body: &Body, fill: Color, dim: bool) {
    let mut fill = fill;
    if dim {
        for c in &mut fill[..3] {
            *c /= 2;
        }
    }
    let outline = outline_for(fill);
    let xf = body.transform();
    if !body.parts.is_empty() {
        // a compound: each part in the body's colour, a sensor part see-through
        for p in &body.parts {
            let pxf = xf.compose(&p.local());
            let angle = pxf.q.s.atan2(pxf.q.c);
            let (mut f, mut o) = (fill, outline);
            if p.sensor && !body.sensor {
                f[3] = (f[3] as u16 * 2 / 5) as u8;
                o[3] = (o[3] as u16 * 2 / 5) as u8;
            }
            push_shape(list, &p.shape, &pxf, Some(angle), f, o);
        }
        return;
    }
    let angle = (body.model != BodyModel::Particle).then_some(body.angle);
    push_shape(list, &body.shape, &xf, angle, fill, outline);
}

/// Adds one shape placed by `xf`; a circle gets a radius line at `angle` (none for a
/// particle).
fn push_shape(
    list: &mut DrawList,
    shape: &Shape,
    xf: &crate::math::Transform,
    angle: Option<f32>,
    fill: Color,
    outline: Color,
) {
    match shape {
        Shape::Compound { .. } => {}
        Shape::Circle { radius } => {
            list.push_circle(xf.p, *radius, angle, fill, outline);
        }
        Shape::Polygon(poly) if poly.radius > 0.0 => {
            list.push_rounded_polygon(
                poly.verts().iter().map(|&v| xf.apply(v)),
                poly.radius,
                fill,
                outline,
            );
        }
        Shape::Chain(c) => {
            let (a, b) = (xf.apply(c.a), xf.apply(c.b));
            list.push_line(a, b, 2.0 * list.outline_width_px, fill);
        }
        Shape::Polygon(poly) if poly.count < 3 => {
            let (a, b) = (xf.apply(poly.vertices[0]), xf.apply(poly.vertices[1]));
            list.push_line(a, b, 2.0 * list.outline_width_px, fill);
        }
        Shape::Polygon(poly) => match rect_of(poly.verts()) {
            Some((center, half_size, axis)) => list.boxes.push(Rect {
                center: xf.apply(center),
                half_size,
                rot: xf.q.rotate(axis),
                fill,
                outline,
            }),
            None => {
                list.push_polygon(poly.verts().iter().map(|&v| xf.apply(v)), fill, outline);
            }
        },
    }
}

/// When counter-clockwise `verts` form a rectangle: its centre, its half width and
/// half height, and the unit direction of its first edge (the width axis), all in the
/// vertices' frame. `None` for any other polygon.
pub fn rect_of(verts: &[Vec2]) -> Option<(Vec2, Vec2, Vec2)> {
    let [a, b, c, d] = *verts else {
        return None;
    };
    let (ab, bc) = (b - a, c - b);
    let (w, h) = (ab.length(), bc.length());
    let tol = 1e-4 * w.max(h);
    // A parallelogram (the diagonals share their midpoint) with a right angle at b.
    let square = ((a + c) - (b + d)).length() <= tol && ab.dot(bc).abs() <= tol * w.max(h);
    (square && w > 0.0 && h > 0.0).then(|| ((a + c) * 0.5, Vec2::new(w, h) * 0.5, ab / w))
}

/// Adds each body's bounding box as four lines.
pub fn push_aabbs(list: &mut DrawList, world: &World) {
    for b in &world.bodies {
        let bb = b.aabb();
        let c = [
            bb.min,
            Vec2::new(bb.max.x, bb.min.y),
            bb.max,
            Vec2::new(bb.min.x, bb.max.y),
        ];
        for k in 0..4 {
            list.push_line(c[k], c[(k + 1) % 4], 1.0, colors::AABB);
        }
    }
}

/// Adds a line along each moving body's velocity: `|v| * scale` metres from its centre
/// of mass.
pub fn push_velocities(list: &mut DrawList, world: &World, scale: f32) {
    for b in world
        .bodies
        .iter()
        .filter(|b| b.body_type != BodyType::Static)
    {
        if b.velocity != Vec2::ZERO {
            list.push_line(
                b.position,
                b.position + b.velocity * scale,
                1.5,
                colors::VELOCITY,
            );
        }
    }
}

/// The metres of normal line per N s that `contact_scale: None` picks for this world:
/// the largest normal impulse drawn [`Overlays::AUTO_CONTACT_BODIES`] mean body radii
/// long. `None` when no point pushes.
pub fn auto_contact_scale(world: &World) -> Option<f32> {
    let max_lambda = world
        .contacts()
        .iter()
        .flat_map(|c| c.manifold.points().iter().map(|p| p.normal_impulse))
        .fold(0.0f32, f32::max);
    if !(max_lambda > 0.0) || world.bodies.is_empty() {
        return None;
    }
    // (summed in place: the draw list is filled every frame without allocating)
    let (sum, count) = world
        .bodies
        .iter()
        .filter(|b| b.body_type != BodyType::Static)
        .fold((0.0f32, 0usize), |(s, n), b| (s + b.shape.radius(), n + 1));
    let mean = if count == 0 { 1.0 } else { sum / count as f32 };
    Some(Overlays::AUTO_CONTACT_BODIES * mean / max_lambda)
}

/// Adds each contact point as a dot and its normal as a line from the point, pointing
/// from body A to body B, `lambda * scale` metres long (lambda: the point's normal
/// impulse, N s). `scale: None` picks [`auto_contact_scale`].
pub fn push_contacts(list: &mut DrawList, world: &World, scale: Option<f32>, dot_px: f32) {
    let scale = scale.or_else(|| auto_contact_scale(world)).unwrap_or(0.0);
    for c in world.contacts() {
        let n = c.manifold.normal;
        for p in c.manifold.points() {
            let len = p.normal_impulse.max(0.0) * scale;
            if len > 0.0 && len.is_finite() {
                list.push_line(p.point, p.point + n * len, 2.0, colors::CONTACT_NORMAL);
            }
            // A zero-length segment draws a round dot `dot_px` wide.
            list.push_line(p.point, p.point, dot_px, colors::CONTACT_POINT);
        }
    }
}

#[cfg(test)]
mod mark_tests {
    use super::*;

    #[test]
    fn marks_keep_their_pixel_size_until_the_zoom_makes_them_too_big_in_the_world() {
        // 40 px a metre: 5 px is 0.125 m, under the cap
        assert_eq!(mark_sizes_px(Some(40.0)), (DOT_PX, JOINT_WIDTH_PX));
        assert_eq!(mark_sizes_px(None), (DOT_PX, JOINT_WIDTH_PX));
        // 6.5 px a metre (the joint grid fitted to 1280 px): capped in metres
        let (dot, width) = mark_sizes_px(Some(6.5));
        assert!(
            (dot - DOT_MAX_M * 6.5).abs() < 1e-6 && dot < DOT_PX,
            "{dot}"
        );
        assert_eq!(width, 1.0, "0.52 px is floored to a pixel");
        // 16 px a metre: dots 4 px (0.25 m), lines 1.28 px (0.08 m)
        let (dot, width) = mark_sizes_px(Some(16.0));
        assert!(
            (dot - 4.0).abs() < 1e-6 && (width - 1.28).abs() < 1e-6,
            "{dot} {width}"
        );
        // never below a pixel, and a bad scale falls back to the fixed sizes
        assert_eq!(mark_sizes_px(Some(0.01)), (1.0, 1.0));
        assert_eq!(mark_sizes_px(Some(f32::NAN)), (DOT_PX, JOINT_WIDTH_PX));
    }
}

/// Adds a joint line per pair of world anchors `(on body A, on body B)`, with a dot at
/// each anchor.
pub fn push_joint_lines(list: &mut DrawList, anchors: impl Iterator<Item = (Vec2, Vec2)>) {
    push_joint_lines_sized(list, anchors, DOT_PX, JOINT_WIDTH_PX);
}

/// [`push_joint_lines`] with dots `dot_px` across and lines `width_px` wide.
pub fn push_joint_lines_sized(
    list: &mut DrawList,
    anchors: impl Iterator<Item = (Vec2, Vec2)>,
    dot_px: f32,
    width_px: f32,
) {
    for (a, b) in anchors {
        list.push_line(a, b, width_px, colors::JOINT);
        list.push_line(a, a, dot_px, colors::JOINT);
        list.push_line(b, b, dot_px, colors::JOINT);
    }
}

/// A box worth framing: the moving bodies' bounding boxes, plus the parts of static
/// bodies near them (so a 200 m ground does not shrink a small pyramid to a line).
/// With no moving bodies, all bodies. `None` for an empty world.
pub fn world_bounds(world: &World) -> Option<(Vec2, Vec2)> {
    let union = |filter: &dyn Fn(&Body) -> bool| {
        let mut lo = Vec2::splat(f32::INFINITY);
        let mut hi = Vec2::splat(f32::NEG_INFINITY);
        for b in world.bodies.iter().filter(|b| filter(b)) {
            let bb = b.aabb();
            lo = lo.min(bb.min);
            hi = hi.max(bb.max);
        }
        (lo.x <= hi.x && lo.y <= hi.y && lo.is_finite() && hi.is_finite()).then_some((lo, hi))
    };
    let Some((lo, hi)) = union(&|b| b.body_type != BodyType::Static) else {
        return union(&|_| true);
    };
    // Static parts within a quarter of the moving box's size (at least 1 m) of it.
    let grow = ((hi - lo) * 0.25).max(Vec2::ONE);
    let (glo, ghi) = (lo - grow, hi + grow);
    let (mut out_lo, mut out_hi) = (lo, hi);
    for b in world
        .bodies
        .iter()
        .filter(|b| b.body_type == BodyType::Static)
    {
        let bb = b.aabb();
        let clo = bb.min.max(glo);
        let chi = bb.max.min(ghi);
        if clo.x <= chi.x && clo.y <= chi.y {
            out_lo = out_lo.min(clo);
            out_hi = out_hi.max(chi);
        }
    }
    Some((out_lo, out_hi))
}

/// The camera to show a scene with at `size` pixels: the scene's `[camera]` scaled to
/// the size (the zoom follows the smaller of the width and height ratios, so what the
/// scene frames stays in view), or, for a scene without a `[camera]` table (its camera
/// equals [`CameraDef::default`]), one fitted to [`world_bounds`] with a 5 % margin.
pub fn scene_camera(def: &CameraDef, size: [u32; 2], world: &World) -> Camera {
    let size = [size[0].max(1), size[1].max(1)];
    if *def == CameraDef::default() {
        let mut cam = Camera::new(def.center, def.pixels_per_meter, size);
        if let Some((lo, hi)) = world_bounds(world) {
            let margin = 0.05 * size[0].min(size[1]) as f32;
            cam.fit(lo, hi, margin);
        }
        return cam;
    }
    let ratio = (size[0] as f32 / def.size[0].max(1) as f32)
        .min(size[1] as f32 / def.size[1].max(1) as f32);
    let ppm = (def.pixels_per_meter * ratio)
        .clamp(Camera::MIN_PIXELS_PER_METER, Camera::MAX_PIXELS_PER_METER);
    Camera::new(def.center, ppm, size)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::defs::{BodyDef, ShapeDef, SolverSettings};

    fn world() -> World {
        let mut w = World::new(Some(Vec2::new(0.0, -10.0)), SolverSettings::pgs());
        w.add_body(&BodyDef {
            name: "ground".into(),
            body_type: BodyType::Static,
            shape: ShapeDef::Box {
                width: 200.0,
                height: 1.0,
            },
            position: Vec2::new(0.0, -0.5),
            ..Default::default()
        })
        .unwrap();
        w.add_body(&BodyDef {
            name: "box".into(),
            shape: ShapeDef::Box {
                width: 1.0,
                height: 1.0,
            },
            position: Vec2::new(0.0, 0.5),
            angle: 0.3,
            color: Some([1, 2, 3, 255]),
            ..Default::default()
        })
        .unwrap();
        w.add_body(&BodyDef {
            name: "wheel".into(),
            shape: ShapeDef::Circle { radius: 0.5 },
            position: Vec2::new(3.0, 0.5),
            angle: 0.7,
            ..Default::default()
        })
        .unwrap();
        w.add_body(&BodyDef {
            name: "dot".into(),
            model: BodyModel::Particle,
            shape: ShapeDef::Circle { radius: 0.25 },
            position: Vec2::new(-3.0, 0.25),
            velocity: Vec2::new(2.0, 0.0),
            friction: 0.0,
            ..Default::default()
        })
        .unwrap();
        w
    }

    #[test]
    fn bodies_become_shapes_in_their_colours() {
        let w = world();
        let list = world_draw_list(&w, &Overlays::NONE);
        // Boxes are rectangles, drawn as instances; no general polygons here.
        assert_eq!(list.boxes.len(), 2);
        assert!(list.polygons.is_empty());
        assert_eq!(list.circles.len(), 2);
        assert!(list.lines.is_empty());
        // The ground is static grey; the box keeps its scene colour.
        assert_eq!(list.boxes[0].fill, colors::STATIC);
        assert_eq!(list.boxes[0].half_size, Vec2::new(100.0, 0.5));
        assert_eq!(list.boxes[1].fill, [1, 2, 3, 255]);
        assert_eq!(list.boxes[1].outline, outline_for([1, 2, 3, 255]));
        // The rotated box's corners are where the transform puts them.
        let corner = Vec2::new(0.0, 0.5) + Vec2::from_angle(0.3).rotate(Vec2::new(-0.5, -0.5));
        assert!((list.boxes[1].corners()[0] - corner).length() < 1e-5);
        // The rigid wheel shows its rotation; the particle does not.
        assert_eq!(list.circles[0].angle, Some(0.7));
        assert_eq!(list.circles[1].angle, None);
        assert_eq!(list.circles[1].radius, 0.25);
    }

    #[test]
    fn rectangles_are_recognised_and_other_polygons_are_not() {
        let r = Vec2::from_angle(0.4);
        let off = Vec2::new(0.3, -0.2);
        let rect = [(-1.0, -0.25), (1.0, -0.25), (1.0, 0.25), (-1.0, 0.25)]
            .map(|(x, y)| off + r.rotate(Vec2::new(x, y)));
        let (c, h, axis) = rect_of(&rect).unwrap();
        assert!((c - off).length() < 1e-6 && (h - Vec2::new(1.0, 0.25)).length() < 1e-6);
        assert!((axis - r).length() < 1e-6);
        // A parallelogram, a kite, a triangle and a pentagon are not rectangles.
        let sheared = [(-1.0, 0.0), (1.0, 0.0), (1.5, 1.0), (-0.5, 1.0)].map(Vec2::from);
        let kite = [(0.0, -1.0), (1.0, 0.0), (0.0, 2.0), (-1.0, 0.0)].map(Vec2::from);
        assert_eq!(rect_of(&sheared), None);
        assert_eq!(rect_of(&kite), None);
        assert_eq!(rect_of(&rect[..3]), None);
        let pentagon: Vec<Vec2> = (0..5)
            .map(|i| Vec2::from_angle(i as f32 * 1.2566))
            .collect();
        assert_eq!(rect_of(&pentagon), None);
    }

    #[test]
    fn overlays_add_lines() {
        let mut w = world();
        for _ in 0..30 {
            w.step().unwrap();
        }
        let none = world_draw_list(&w, &Overlays::NONE);
        let aabbs = world_draw_list(
            &w,
            &Overlays {
                aabbs: true,
                ..Overlays::NONE
            },
        );
        assert_eq!(aabbs.lines.len(), 4 * w.bodies.len());
        assert_eq!(aabbs.boxes, none.boxes);

        let vel = world_draw_list(
            &w,
            &Overlays {
                velocities: true,
                ..Overlays::NONE
            },
        );
        // The sliding particle moves; its line starts at its centre and points along v.
        let dot = &w.bodies[3];
        let line = vel.lines.iter().find(|l| l.a == dot.position).unwrap();
        assert!(((line.b - line.a) - dot.velocity * 0.1).length() < 1e-6);

        let points: usize = w.contacts().iter().map(|c| c.manifold.count).sum();
        assert!(points >= 3, "resting bodies touch the ground");
        let contacts = world_draw_list(
            &w,
            &Overlays {
                contacts: true,
                contact_scale: Some(2.0),
                ..Overlays::NONE
            },
        );
        let dots = contacts.lines.iter().filter(|l| l.a == l.b).count();
        assert_eq!(dots, points);

        // zoomed out to 4 px a metre, a contact dot is at most DOT_MAX_M across in the
        // world (1 px), not DOT_PX (1.25 m, wider than the 1 m boxes it marks)
        let far = world_draw_list(
            &w,
            &Overlays {
                contacts: true,
                contact_scale: Some(2.0),
                pixels_per_meter: Some(4.0),
                ..Overlays::NONE
            },
        );
        for l in far.lines.iter().filter(|l| l.a == l.b) {
            assert!(l.width_px <= DOT_MAX_M * 4.0 + 1e-6, "{}", l.width_px);
        }
        // A normal line is lambda * scale long, along the manifold normal.
        let c = &w.contacts()[0];
        let p = c.manifold.points()[0];
        assert!(p.normal_impulse > 0.0);
        let normal = contacts
            .lines
            .iter()
            .find(|l| l.a == p.point && l.a != l.b)
            .unwrap();
        let d = normal.b - normal.a;
        assert!((d.length() - 2.0 * p.normal_impulse).abs() < 1e-5);
        assert!(d.normalize().dot(c.manifold.normal) > 0.999);
    }

    #[test]
    fn auto_contact_scale_maps_the_largest_impulse_to_body_size() {
        let mut w = world();
        assert_eq!(auto_contact_scale(&w), None);
        for _ in 0..30 {
            w.step().unwrap();
        }
        let s = auto_contact_scale(&w).unwrap();
        let max = w
            .contacts()
            .iter()
            .flat_map(|c| c.manifold.points().iter().map(|p| p.normal_impulse))
            .fold(0.0f32, f32::max);
        let mean_radius = (w.bodies[1].shape.radius() + 0.5 + 0.25) / 3.0;
        assert!((s * max - Overlays::AUTO_CONTACT_BODIES * mean_radius).abs() < 1e-4);
    }

    #[test]
    fn joint_lines_one_per_pair_with_dots() {
        let mut list = DrawList::new();
        let pairs = [
            (Vec2::ZERO, Vec2::new(1.0, 2.0)),
            (Vec2::new(-1.0, 0.0), Vec2::new(-1.0, -3.0)),
        ];
        push_joint_lines(&mut list, pairs.into_iter());
        let segments: Vec<_> = list.lines.iter().filter(|l| l.a != l.b).collect();
        assert_eq!(segments.len(), 2);
        for ((a, b), l) in pairs.iter().zip(&segments) {
            assert_eq!((l.a, l.b), (*a, *b));
            assert_eq!(l.color, colors::JOINT);
            assert_eq!(l.width_px, JOINT_WIDTH_PX);
        }
        assert_eq!(list.lines.len(), 6, "a dot at each anchor");
        push_joint_lines(&mut list, std::iter::empty());
        assert_eq!(list.lines.len(), 6);
    }

    #[test]
    fn bounds_ignore_far_static_parts() {
        let w = world();
        let (lo, hi) = world_bounds(&w).unwrap();
        // Moving bodies span x in [-3.25, 3.5]; the 200 m ground is clipped near them.
        assert!(lo.x > -10.0 && hi.x < 10.0, "{lo} {hi}");
        assert!(lo.y <= -0.5, "the ground near the bodies is in: {lo}");
        assert!(hi.x >= 3.5 - 1e-4);
        let empty = World::new(None, SolverSettings::pgs());
        assert_eq!(world_bounds(&empty), None);
    }

    #[test]
    fn scene_camera_scales_or_fits() {
        let w = world();
        let def = CameraDef {
            center: Vec2::new(1.0, 2.0),
            pixels_per_meter: 40.0,
            size: [1280, 720],
        };
        let cam = scene_camera(&def, [640, 720], &w);
        assert_eq!(cam.center, def.center);
        assert_eq!(cam.size, [640, 720]);
        assert!((cam.pixels_per_meter - 20.0).abs() < 1e-5);
        // No [camera]: fitted, so every moving body is on screen.
        let cam = scene_camera(&CameraDef::default(), [400, 300], &w);
        let (lo, hi) = cam.visible_world_rect();
        for b in &w.bodies[1..] {
            assert!(b.position.cmpge(lo).all() && b.position.cmple(hi).all());
        }
        assert!(cam.pixels_per_meter > 20.0, "{}", cam.pixels_per_meter);
    }

    #[test]
    fn fill_reuses_the_list() {
        let w = world();
        let mut list = world_draw_list(&w, &Overlays::ALL);
        list.background = [1, 1, 1, 255];
        fill_world_draw_list(&mut list, &w, &Overlays::NONE);
        assert_eq!(list.background, [1, 1, 1, 255]);
        assert_eq!(list, {
            let mut l = world_draw_list(&w, &Overlays::NONE);
            l.background = [1, 1, 1, 255];
            l
        });
    }

    #[test]
    fn the_tint_colours_by_speed_and_by_error() {
        // the ramp: blue at 0, red at 1 and beyond, red rising along the ramp
        assert_eq!(tint_color(0.0), [40, 90, 220, 255]);
        assert_eq!(tint_color(1.0), [230, 50, 40, 255]);
        assert_eq!(tint_color(7.0), tint_color(1.0));
        let reds: Vec<u8> = (0..=10).map(|k| tint_color(k as f32 / 10.0)[0]).collect();
        assert!(reds.windows(2).all(|w| w[0] <= w[1]), "{reds:?}");
        // speed: |v| + |w| r of the body; the static ground 0
        let mut w = world();
        w.bodies[1].velocity = Vec2::new(3.0, 4.0);
        w.bodies[1].angular_velocity = 2.0;
        let mut v = Vec::new();
        Tint::Speed.values(&w, &mut v);
        let r = w.bodies[1].shape.radius();
        assert_eq!(v[0], 0.0);
        assert!((v[1] - (5.0 + 2.0 * r)).abs() < 1e-5, "{}", v[1]);
        // error: the box pushed 3 cm into the ground carries its contact's overlap
        let mut w = world();
        w.bodies[1].position.y = 0.47;
        w.step().unwrap();
        Tint::Error.values(&w, &mut v);
        let deepest = w
            .contacts()
            .iter()
            .flat_map(|c| c.manifold.points().iter().map(|p| -p.separation))
            .fold(0.0f32, f32::max);
        assert!(deepest > 0.01, "the box overlaps: {deepest}");
        assert_eq!(v[1], deepest);
        assert_eq!(v[0], 0.0, "static bodies are not tinted");
        // drawn: the tinted list fills the box with the ramp's colour of its value
        let list = world_draw_list(
            &w,
            &Overlays {
                tint: Tint::Error,
                ..Overlays::NONE
            },
        );
        let want = tint_color(deepest / Tint::Error.full());
        assert!(list.boxes.iter().any(|b| b.fill == want), "{want:?}");
    }
}
