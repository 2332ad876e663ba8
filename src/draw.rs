//! What to draw, in world space, and the camera that maps it to pixels.
//!
//! This module is plain data and math (no GPU): the engine fills a [`DrawList`] from
//! its world each frame, and a renderer (see `crate::render`, feature `render`) maps
//! it to the screen through a [`Camera`].
//!
//! World space is y-up metres; screen space is y-down pixels with the origin at the
//! top-left corner of the image, pixel `(i, j)` covering `[i, i + 1) x [j, j + 1)`
//! (so its centre is at `(i + 0.5, j + 0.5)`).

use crate::defs::Color;
use glam::Vec2;

pub mod clip;
pub mod world;

pub use world::{Overlays, Tint, fill_world_draw_list, push_joint_lines, world_draw_list};

/// Maps y-up world metres to y-down pixels.
///
/// The screen transform is `X = [[s, 0, px], [0, -s, py], [0, 0, 1]]` with
/// `s = pixels_per_meter` and `(px, py)` chosen so that `center` lands on the image
/// centre `(size[0] / 2, size[1] / 2)`.
///
/// f32 note: pixel positions are computed as `s * x + px`; with `s` around 40 and
/// world coordinates within a few kilometres of the origin the error stays far below a
/// pixel. Far from the origin (|x| around 1e5 m and up) f32 spacing (~0.008 m) times
/// `s` reaches a fraction of a pixel and shapes start to jitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// World point (m) at the image centre.
    pub center: Vec2,
    /// The scale s of the screen transform (zoom), pixels per metre. Must be > 0.
    pub pixels_per_meter: f32,
    /// Image size in pixels, `[width, height]`.
    pub size: [u32; 2],
}

impl Default for Camera {
    /// The same framing as [`crate::CameraDef::default`]: centre (0, 5), 40 px/m, 1280x720.
    fn default() -> Self {
        Self::from(crate::defs::CameraDef::default())
    }
}

impl From<crate::defs::CameraDef> for Camera {
    fn from(def: crate::defs::CameraDef) -> Self {
        Self {
            center: def.center,
            pixels_per_meter: def.pixels_per_meter,
            size: def.size,
        }
    }
}

impl Camera {
    /// Smallest zoom [`Camera::zoom_about`] and [`Camera::fit`] will produce (px/m): a
    /// body of 1e9 m still fits an image.
    pub const MIN_PIXELS_PER_METER: f32 = 1e-9;
    /// Largest zoom [`Camera::zoom_about`] and [`Camera::fit`] will produce (px/m): a
    /// body of 1e-6 m still fills an image.
    pub const MAX_PIXELS_PER_METER: f32 = 1e10;

    /// A camera centred on `center` at `pixels_per_meter`, for an image of `size` pixels.
    pub fn new(center: Vec2, pixels_per_meter: f32, size: [u32; 2]) -> Self {
        Self {
            center,
            pixels_per_meter,
            size,
        }
    }

    /// The image centre in pixels: `(width / 2, height / 2)`.
    pub fn screen_center(&self) -> Vec2 {
        Vec2::new(self.size[0] as f32, self.size[1] as f32) * 0.5
    }

    /// The translation `(px, py)` of the screen transform.
    pub fn offset(&self) -> Vec2 {
        let s = self.pixels_per_meter;
        let c = self.screen_center();
        // px = w/2 - s cx,  py = h/2 + s cy  (so that X * center = image centre)
        Vec2::new(c.x - s * self.center.x, c.y + s * self.center.y)
    }

    /// The screen transform `X = [[s, 0, px], [0, -s, py], [0, 0, 1]]`, row-major.
    pub fn matrix(&self) -> [[f32; 3]; 3] {
        let s = self.pixels_per_meter;
        let p = self.offset();
        [[s, 0.0, p.x], [0.0, -s, p.y], [0.0, 0.0, 1.0]]
    }

    /// World point (m) to screen point (px): `X * (x, y, 1)`.
    pub fn world_to_screen(&self, world: Vec2) -> Vec2 {
        let s = self.pixels_per_meter;
        let c = self.screen_center();
        // Written relative to the centre (not s x + px) to keep precision far from the origin.
        Vec2::new(
            c.x + s * (world.x - self.center.x),
            c.y - s * (world.y - self.center.y),
        )
    }

    /// Screen point (px) to world point (m): `X^-1 * (u, v, 1)`; the inverse of
    /// [`Camera::world_to_screen`], for the mouse.
    pub fn screen_to_world(&self, screen: Vec2) -> Vec2 {
        let s = self.pixels_per_meter;
        let c = self.screen_center();
        Vec2::new(
            self.center.x + (screen.x - c.x) / s,
            self.center.y - (screen.y - c.y) / s,
        )
    }

    /// A length in metres, in pixels.
    pub fn meters_to_pixels(&self, meters: f32) -> f32 {
        meters * self.pixels_per_meter
    }

    /// Multiplies the zoom by `factor` (> 1 zooms in) keeping the world point under the
    /// screen point `screen` fixed (zoom about the cursor). The zoom is clamped to
    /// [`Camera::MIN_PIXELS_PER_METER`], [`Camera::MAX_PIXELS_PER_METER`]; a factor that
    /// is not finite and positive does nothing.
    pub fn zoom_about(&mut self, screen: Vec2, factor: f32) {
        if !(factor.is_finite() && factor > 0.0) {
            return;
        }
        let anchor = self.screen_to_world(screen);
        self.pixels_per_meter = (self.pixels_per_meter * factor)
            .clamp(Self::MIN_PIXELS_PER_METER, Self::MAX_PIXELS_PER_METER);
        // Solve world_to_screen(anchor) == screen for the centre:
        // center = anchor - (screen - c) * (1/s, -1/s)
        let c = self.screen_center();
        let s = self.pixels_per_meter;
        self.center = Vec2::new(
            anchor.x - (screen.x - c.x) / s,
            anchor.y + (screen.y - c.y) / s,
        );
    }

    /// Moves the view by a drag of `delta` pixels: the world follows the mouse
    /// (dragging right moves the camera centre left in the world).
    pub fn pan_pixels(&mut self, delta: Vec2) {
        let s = self.pixels_per_meter;
        // A screen drag (dx, dy) is a world move (dx / s, -dy / s) of the content.
        self.center -= Vec2::new(delta.x / s, -delta.y / s);
    }

    /// Centres on the box `[min, max]` (m) and zooms so that it fits the image with
    /// `margin` pixels left free on every side. A degenerate box keeps the current zoom
    /// along its empty axis; a box with no extent at all keeps the zoom entirely.
    pub fn fit(&mut self, min: Vec2, max: Vec2, margin: f32) {
        let lo = min.min(max);
        let hi = min.max(max);
        self.center = (lo + hi) * 0.5;
        let extent = hi - lo;
        let avail = Vec2::new(
            (self.size[0] as f32 - 2.0 * margin).max(1.0),
            (self.size[1] as f32 - 2.0 * margin).max(1.0),
        );
        let sx = if extent.x > 0.0 {
            avail.x / extent.x
        } else {
            f32::INFINITY
        };
        let sy = if extent.y > 0.0 {
            avail.y / extent.y
        } else {
            f32::INFINITY
        };
        let s = sx.min(sy);
        if s.is_finite() {
            self.pixels_per_meter = s.clamp(Self::MIN_PIXELS_PER_METER, Self::MAX_PIXELS_PER_METER);
        }
    }

    /// The world-space rectangle `(min, max)` the image shows.
    pub fn visible_world_rect(&self) -> (Vec2, Vec2) {
        let a = self.screen_to_world(Vec2::ZERO);
        let b = self.screen_to_world(Vec2::new(self.size[0] as f32, self.size[1] as f32));
        (a.min(b), a.max(b))
    }
}

/// A filled circle with an outline, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    /// Centre (m).
    pub center: Vec2,
    /// Radius (m).
    pub radius: f32,
    /// `Some(angle)` (radians, counter-clockwise from +x) draws a radius line in the
    /// outline colour showing the body's rotation; `None` draws none (particles).
    pub angle: Option<f32>,
    /// Interior colour.
    pub fill: Color,
    /// Outline (and radius line) colour; alpha 0 for none.
    pub outline: Color,
}

/// A filled convex polygon with an outline, in world space, optionally grown by a
/// radius (rounded corners; with two points, a capsule).
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    /// Where its vertices lie in [`DrawList::polygon_points`] (see
    /// [`DrawList::points_of`]): counter-clockwise, convex, in metres. Without a radius,
    /// fewer than 3 draw only the outline.
    pub points: std::ops::Range<usize>,
    /// The shape is every point within `radius` (m) of the points' polygon: 0 for the
    /// polygon itself; with two points, a capsule.
    pub radius: f32,
    /// Interior colour.
    pub fill: Color,
    /// Outline colour; alpha 0 for none.
    pub outline: Color,
}

/// A filled rectangle with an outline, in world space: a box body, drawn as one
/// instance (see [`DrawList::push_box`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Centre (m).
    pub center: Vec2,
    /// Half the width and half the height (m), along the rectangle's own axes.
    pub half_size: Vec2,
    /// `(cos, sin)` of the angle of the rectangle's width axis, counter-clockwise from +x.
    pub rot: Vec2,
    /// Interior colour.
    pub fill: Color,
    /// Outline colour; alpha 0 for none.
    pub outline: Color,
}

impl Rect {
    /// The four corners (m), counter-clockwise from the one at `(-w/2, -h/2)` in the
    /// rectangle's frame.
    pub fn corners(&self) -> [Vec2; 4] {
        let h = self.half_size;
        [
            Vec2::new(-h.x, -h.y),
            Vec2::new(h.x, -h.y),
            Vec2::new(h.x, h.y),
            Vec2::new(-h.x, h.y),
        ]
        .map(|c| self.center + self.rot.rotate(c))
    }
}

/// A segment drawn with a constant width in pixels (independent of zoom), round caps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// First end (m).
    pub a: Vec2,
    /// Second end (m).
    pub b: Vec2,
    /// Width in pixels.
    pub width_px: f32,
    /// Colour.
    pub color: Color,
}

/// Everything one frame shows, in world space: plain data the engine fills from its
/// world and a renderer draws.
///
/// Draw order: the background, then rectangles (each with its outline), polygon fills,
/// polygon outlines, circles, and lines last (joints over bodies). Within a kind, later
/// items draw over earlier ones.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawList {
    /// Filled rectangles (box bodies).
    pub boxes: Vec<Rect>,
    /// Filled circles.
    pub circles: Vec<Circle>,
    /// Filled convex polygons.
    pub polygons: Vec<Polygon>,
    /// The vertices of every polygon, one after another (one buffer, reused frame to
    /// frame, rather than one allocation per polygon).
    pub polygon_points: Vec<Vec2>,
    /// Segments (joints, springs, debug vectors).
    pub lines: Vec<Line>,
    /// The colour the frame is cleared to.
    pub background: Color,
    /// Width in pixels of circle and polygon outlines (and of circles' radius lines).
    pub outline_width_px: f32,
    /// Per-body values of the tint overlay (scratch kept between frames).
    pub(crate) scratch: Vec<f32>,
}

/// Appends the outline of the counter-clockwise convex `points` grown by `radius`
/// (rounded corners; two points give a capsule): each corner's arc in steps of at most
/// 15 degrees, counter-clockwise.
pub fn rounded_points(points: &[Vec2], radius: f32, out: &mut Vec<Vec2>) {
    let n = points.len();
    // the outward normal of the edge from point i to the next
    let normal = |i: usize| {
        let e = points[(i + 1) % n] - points[i];
        Vec2::new(e.y, -e.x).normalize_or_zero()
    };
    for (i, &point) in points.iter().enumerate() {
        // the arc at point i runs from the previous edge's normal to this edge's
        let from = normal((i + n - 1) % n);
        let to = normal(i);
        let mut angle = crate::math::cross(from, to).atan2(from.dot(to));
        if angle < 0.0 {
            angle += std::f32::consts::TAU;
        }
        let steps = ((angle / 15f32.to_radians()).ceil() as usize).max(1);
        for k in 0..=steps {
            let (s, c) = (angle * k as f32 / steps as f32).sin_cos();
            let dir = Vec2::new(c * from.x - s * from.y, s * from.x + c * from.y);
            out.push(point + radius * dir);
        }
    }
}

impl Default for DrawList {
    fn default() -> Self {
        Self::new()
    }
}

impl DrawList {
    /// The default background: a dark blue-grey.
    pub const DEFAULT_BACKGROUND: Color = [24, 26, 33, 255];
    /// The default outline width in pixels.
    pub const DEFAULT_OUTLINE_WIDTH_PX: f32 = 1.5;

    /// An empty list with the default background and outline width.
    pub fn new() -> Self {
        Self {
            boxes: Vec::new(),
            circles: Vec::new(),
            polygons: Vec::new(),
            polygon_points: Vec::new(),
            lines: Vec::new(),
            background: Self::DEFAULT_BACKGROUND,
            outline_width_px: Self::DEFAULT_OUTLINE_WIDTH_PX,
            scratch: Vec::new(),
        }
    }

    /// Appends `other`'s items moved by `offset` (m): a compare pane drawn beside
    /// another in one list (the background and outline width are kept).
    pub fn append_translated(&mut self, other: &DrawList, offset: Vec2) {
        self.append_within(other, offset, f32::NEG_INFINITY..f32::INFINITY);
    }

    /// [`Self::append_translated`], keeping only the items whose centre lands (once
    /// moved) at an x inside `x` (m): a compare pane's bodies stay in their pane (a body
    /// that left it is not drawn over the neighbour; one across the divider overhangs it
    /// by less than half its size). Polygons go by the mean of their points, lines by
    /// their midpoint.
    pub fn append_within(&mut self, other: &DrawList, offset: Vec2, x: std::ops::Range<f32>) {
        let keep = |p: Vec2| x.contains(&(p.x + offset.x));
        self.boxes
            .extend(other.boxes.iter().filter(|r| keep(r.center)).map(|r| Rect {
                center: r.center + offset,
                ..*r
            }));
        self.circles.extend(
            other
                .circles
                .iter()
                .filter(|c| keep(c.center))
                .map(|c| Circle {
                    center: c.center + offset,
                    ..*c
                }),
        );
        for p in &other.polygons {
            let points = &other.polygon_points[p.points.clone()];
            let mean = points.iter().copied().sum::<Vec2>() / points.len().max(1) as f32;
            if !keep(mean) {
                continue;
            }
            let base = self.polygon_points.len();
            self.polygon_points
                .extend(points.iter().map(|q| *q + offset));
            self.polygons.push(Polygon {
                points: base..base + points.len(),
                ..p.clone()
            });
        }
        self.lines.extend(
            other
                .lines
                .iter()
                .filter(|l| keep(0.5 * (l.a + l.b)))
                .map(|l| Line {
                    a: l.a + offset,
                    b: l.b + offset,
                    ..*l
                }),
        );
    }

    /// Empties the lists, keeping their allocations, the background and outline width.
    pub fn clear(&mut self) {
        self.boxes.clear();
        self.circles.clear();
        self.polygons.clear();
        self.polygon_points.clear();
        self.lines.clear();
    }

    /// True when there is nothing to draw but the background.
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
            && self.circles.is_empty()
            && self.polygons.is_empty()
            && self.lines.is_empty()
    }

    /// Adds a circle; `angle: Some(a)` draws a radius line at angle `a`.
    pub fn push_circle(
        &mut self,
        center: Vec2,
        radius: f32,
        angle: Option<f32>,
        fill: Color,
        outline: Color,
    ) {
        self.circles.push(Circle {
            center,
            radius,
            angle,
            fill,
            outline,
        });
    }

    /// Adds a convex polygon from world points given counter-clockwise.
    pub fn push_polygon(
        &mut self,
        points: impl IntoIterator<Item = Vec2>,
        fill: Color,
        outline: Color,
    ) {
        let start = self.polygon_points.len();
        self.polygon_points.extend(points);
        self.polygons.push(Polygon {
            points: start..self.polygon_points.len(),
            radius: 0.0,
            fill,
            outline,
        });
    }

    /// Adds a convex polygon from world points given counter-clockwise, grown by
    /// `radius` (m): rounded corners, or with two points a capsule.
    pub fn push_rounded_polygon(
        &mut self,
        points: impl IntoIterator<Item = Vec2>,
        radius: f32,
        fill: Color,
        outline: Color,
    ) {
        self.push_polygon(points, fill, outline);
        if let Some(p) = self.polygons.last_mut() {
            p.radius = radius;
        }
    }

    /// The vertices of `polygon`, one of this list's.
    pub fn points_of(&self, polygon: &Polygon) -> &[Vec2] {
        &self.polygon_points[polygon.points.clone()]
    }

    /// Adds a box of full size `width` x `height` (m) centred on `center`, rotated by
    /// `angle` radians counter-clockwise (a [`Rect`]).
    pub fn push_box(
        &mut self,
        center: Vec2,
        width: f32,
        height: f32,
        angle: f32,
        fill: Color,
        outline: Color,
    ) {
        self.boxes.push(Rect {
            center,
            half_size: Vec2::new(width, height) * 0.5,
            rot: Vec2::from_angle(angle),
            fill,
            outline,
        });
    }

    /// Adds a segment `width_px` pixels wide.
    pub fn push_line(&mut self, a: Vec2, b: Vec2, width_px: f32, color: Color) {
        self.lines.push(Line {
            a,
            b,
            width_px,
            color,
        });
    }

    /// The world-space bounding box `(min, max)` of everything in the list (lines'
    /// pixel widths ignored), or `None` when the list is empty.
    pub fn bounds(&self) -> Option<(Vec2, Vec2)> {
        let mut lo = Vec2::splat(f32::INFINITY);
        let mut hi = Vec2::splat(f32::NEG_INFINITY);
        for r in &self.boxes {
            for q in r.corners() {
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        for c in &self.circles {
            lo = lo.min(c.center - Vec2::splat(c.radius));
            hi = hi.max(c.center + Vec2::splat(c.radius));
        }
        for &q in &self.polygon_points {
            lo = lo.min(q);
            hi = hi.max(q);
        }
        for l in &self.lines {
            lo = lo.min(l.a).min(l.b);
            hi = hi.max(l.a).max(l.b);
        }
        (lo.x <= hi.x && lo.y <= hi.y).then_some((lo, hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pane_keeps_only_the_items_whose_centre_lands_inside_it() {
        let (f, o) = ([200, 0, 0, 255], [0, 0, 0, 255]);
        let mut pane = DrawList::new();
        pane.push_box(Vec2::new(0.5, 0.0), 1.0, 1.0, 0.0, f, o);
        pane.push_box(Vec2::new(2.5, 0.0), 1.0, 1.0, 0.0, f, o);
        pane.push_circle(Vec2::new(1.5, 0.0), 0.4, None, f, o);
        pane.push_circle(Vec2::new(-0.5, 0.0), 0.4, None, f, o);
        // a triangle around x = 3 (outside), one around x = 1 (inside)
        let tri = |x: f32| {
            [
                Vec2::new(x - 0.5, 0.0),
                Vec2::new(x + 0.5, 0.0),
                Vec2::new(x, 1.0),
            ]
        };
        pane.push_polygon(tri(3.0), f, o);
        pane.push_polygon(tri(1.0), f, o);
        pane.push_line(Vec2::new(-1.0, 0.0), Vec2::new(1.4, 0.0), 1.0, o);
        pane.push_line(Vec2::new(1.0, 0.0), Vec2::new(5.0, 0.0), 1.0, o);

        let mut all = DrawList::new();
        all.append_within(&pane, Vec2::new(10.0, 0.0), 10.0..12.0);
        let xs = |v: Vec<f32>| v;
        assert_eq!(xs(all.boxes.iter().map(|b| b.center.x).collect()), [10.5]);
        assert_eq!(xs(all.circles.iter().map(|c| c.center.x).collect()), [11.5]);
        assert_eq!(all.polygons.len(), 1);
        let kept = all.points_of(&all.polygons[0]);
        assert_eq!(kept, tri(11.0));
        assert_eq!(all.lines.len(), 1);
        assert_eq!(all.lines[0].a.x, 9.0);

        // without a range everything moves over
        let mut moved = DrawList::new();
        moved.append_translated(&pane, Vec2::new(10.0, 0.0));
        assert_eq!(
            (
                moved.boxes.len(),
                moved.circles.len(),
                moved.polygons.len(),
                moved.lines.len()
            ),
            (2, 2, 2, 2)
        );
        assert_eq!(moved.points_of(&moved.polygons[1]), tri(11.0));
    }

    fn cam() -> Camera {
        Camera::new(Vec2::new(1.5, 4.0), 40.0, [1280, 720])
    }

    fn close(a: Vec2, b: Vec2, eps: f32) -> bool {
        (a - b).abs().max_element() <= eps
    }

    #[test]
    fn center_lands_on_image_center() {
        let c = cam();
        assert_eq!(c.world_to_screen(c.center), Vec2::new(640.0, 360.0));
    }

    #[test]
    fn known_point_lands_on_known_pixel() {
        let c = cam();
        // 2 m right and 1 m up of the centre: 80 px right, 40 px up.
        let p = c.world_to_screen(Vec2::new(3.5, 5.0));
        assert!(close(p, Vec2::new(720.0, 320.0), 1e-4), "{p}");
    }

    #[test]
    fn matrix_matches_world_to_screen() {
        let c = cam();
        let m = c.matrix();
        let w = Vec2::new(-2.25, 7.5);
        let by_matrix = Vec2::new(
            m[0][0] * w.x + m[0][1] * w.y + m[0][2],
            m[1][0] * w.x + m[1][1] * w.y + m[1][2],
        );
        assert!(close(by_matrix, c.world_to_screen(w), 1e-3));
        assert_eq!(m[1][1], -40.0);
        assert_eq!(m[2], [0.0, 0.0, 1.0]);
    }

    #[test]
    fn y_flips() {
        let c = cam();
        let low = c.world_to_screen(Vec2::new(0.0, 0.0));
        let high = c.world_to_screen(Vec2::new(0.0, 1.0));
        assert!(
            high.y < low.y,
            "higher world y must be higher on screen (smaller pixel y)"
        );
        assert_eq!(low.x, high.x);
    }

    #[test]
    fn round_trip() {
        let c = cam();
        for w in [
            Vec2::ZERO,
            Vec2::new(-13.0, 2.5),
            Vec2::new(100.0, -50.0),
            Vec2::new(1.5, 4.0),
        ] {
            let back = c.screen_to_world(c.world_to_screen(w));
            assert!(close(back, w, 1e-4), "{w} -> {back}");
        }
        for s in [
            Vec2::ZERO,
            Vec2::new(1279.0, 719.0),
            Vec2::new(10.5, 600.25),
        ] {
            let back = c.world_to_screen(c.screen_to_world(s));
            assert!(close(back, s, 1e-3), "{s} -> {back}");
        }
    }

    #[test]
    fn zoom_about_keeps_the_point_fixed() {
        let mut c = cam();
        let cursor = Vec2::new(200.0, 150.0);
        let under = c.screen_to_world(cursor);
        c.zoom_about(cursor, 1.7);
        assert!((c.pixels_per_meter - 68.0).abs() < 1e-4);
        assert!(close(c.world_to_screen(under), cursor, 1e-3));
        c.zoom_about(cursor, 0.25);
        assert!(close(c.world_to_screen(under), cursor, 1e-3));
        let before = c;
        c.zoom_about(cursor, f32::NAN);
        assert_eq!(c, before);
    }

    #[test]
    fn pan_moves_content_with_the_mouse() {
        let mut c = cam();
        let w = Vec2::new(2.0, 3.0);
        let before = c.world_to_screen(w);
        c.pan_pixels(Vec2::new(30.0, -12.0));
        assert!(close(
            c.world_to_screen(w),
            before + Vec2::new(30.0, -12.0),
            1e-3
        ));
    }

    #[test]
    fn fit_frames_the_box() {
        let mut c = Camera::new(Vec2::ZERO, 1.0, [1000, 500]);
        c.fit(Vec2::new(-10.0, 0.0), Vec2::new(10.0, 4.0), 50.0);
        // width limits: (1000 - 100) / 20 = 45 px/m; height allows (500 - 100) / 4 = 100.
        assert!((c.pixels_per_meter - 45.0).abs() < 1e-4);
        assert_eq!(c.center, Vec2::new(0.0, 2.0));
        let left = c.world_to_screen(Vec2::new(-10.0, 2.0));
        assert!((left.x - 50.0).abs() < 1e-3);
        // A point box keeps the zoom.
        c.fit(Vec2::ONE, Vec2::ONE, 10.0);
        assert!((c.pixels_per_meter - 45.0).abs() < 1e-4);
        assert_eq!(c.center, Vec2::ONE);
    }

    #[test]
    fn draw_list_helpers() {
        let mut d = DrawList::new();
        assert!(d.is_empty() && d.bounds().is_none());
        d.push_box(Vec2::new(0.0, 0.5), 2.0, 1.0, 0.0, [255; 4], [0, 0, 0, 255]);
        d.push_circle(Vec2::new(3.0, 1.0), 0.5, Some(0.0), [255; 4], [0; 4]);
        d.push_line(Vec2::new(-2.0, 0.0), Vec2::ZERO, 2.0, [255; 4]);
        d.push_polygon([Vec2::ZERO, Vec2::X, Vec2::Y], [255; 4], [0; 4]);
        assert_eq!(d.points_of(&d.polygons[0]), &[Vec2::ZERO, Vec2::X, Vec2::Y]);
        assert_eq!(d.boxes.len(), 1);
        assert!(close(d.boxes[0].corners()[2], Vec2::new(1.0, 1.0), 1e-6));
        let (lo, hi) = d.bounds().unwrap();
        assert!(close(lo, Vec2::new(-2.0, 0.0), 1e-6) && close(hi, Vec2::new(3.5, 1.5), 1e-6));
        d.clear();
        assert!(d.is_empty());
        assert_eq!(d.background, DrawList::DEFAULT_BACKGROUND);
    }
}
