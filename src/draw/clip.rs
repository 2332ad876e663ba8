//! Keeping what a renderer draws within the range its floats and its rasteriser handle.
//!
//! A shape is handed to the GPU in f32 world coordinates and turned into pixels there;
//! a static box or circle of 1e9 m at 40 px/m reaches 2e10 pixels from the image, far
//! beyond what a rasteriser's fixed-point coordinates hold (it drew such a box on half
//! the image, or not at all), and beyond where f32 resolves a pixel (a rim there lands
//! thousands of pixels off). So before upload, every shape that reaches past a guard
//! band around the image is cut down to the part that can show, in f64 world
//! coordinates: a box to the box of its own axes that still covers the image (the same
//! pixels inside the image; its cut edges lie outside), a polygon to its intersection
//! with the widened image, a line to its part inside it, and a circle to a circle that
//! covers the image, to nothing, or (its rim crossing the image) to the polygon of its
//! part inside the widened image, the rim sampled finely enough to stay within
//! [`RIM_TOLERANCE_PX`]. A shape within the guard band is left exactly as it is.

use glam::{DVec2, Vec2};

use super::{Camera, Circle, Rect};

/// How far past the image (pixels) a shape may reach and still be drawn as it is.
pub const GUARD_PX: f64 = 2048.0;

/// How far past the image (pixels) a cut shape still reaches: beyond any outline, so
/// the edges the cut makes never show.
pub const CUT_MARGIN_PX: f64 = 64.0;

/// The most a sampled rim may stray from the circle (pixels).
pub const RIM_TOLERANCE_PX: f64 = 0.05;

/// The image widened by `margin` pixels, as a world rectangle `(lo, hi)` in f64.
pub fn view_rect(camera: &Camera, margin: f64) -> (DVec2, DVec2) {
    let s = camera.pixels_per_meter as f64;
    let half = DVec2::new(camera.size[0] as f64, camera.size[1] as f64) * 0.5 + margin;
    let c = camera.center.as_dvec2();
    (c - half / s, c + half / s)
}

/// Whether the world box `(lo, hi)` stays within [`GUARD_PX`] of the image.
pub fn within_guard(camera: &Camera, lo: DVec2, hi: DVec2) -> bool {
    let (a, b) = view_rect(camera, GUARD_PX);
    lo.x >= a.x && lo.y >= a.y && hi.x <= b.x && hi.y <= b.y
}

/// A box cut to the part of it that can show: `Ok(None)` when it stays within the
/// guard band (draw it as it is), `Ok(Some(r))` a box along the same axes with the same
/// pixels inside the image, `Err(())` when no part of it reaches the image.
#[allow(clippy::result_unit_err)]
pub fn cut_box(r: &Rect, camera: &Camera) -> Result<Option<Rect>, ()> {
    let c = r.center.as_dvec2();
    let u = r.rot.as_dvec2();
    let v = DVec2::new(-u.y, u.x);
    let h = r.half_size.as_dvec2();
    let reach = (u * h.x).abs() + (v * h.y).abs();
    if within_guard(camera, c - reach, c + reach) {
        return Ok(None);
    }
    // the widened image projected on the box's axes, about its centre
    let (lo, hi) = view_rect(camera, CUT_MARGIN_PX);
    let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    let span = |axis: DVec2, half: f64| {
        let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in corners {
            let t = (p - c).dot(axis);
            (a, b) = (a.min(t), b.max(t));
        }
        (a.max(-half), b.min(half))
    };
    let (u0, u1) = span(u, h.x);
    let (v0, v1) = span(v, h.y);
    if u0 >= u1 || v0 >= v1 {
        return Err(());
    }
    let center = c + u * (0.5 * (u0 + u1)) + v * (0.5 * (v0 + v1));
    Ok(Some(Rect {
        center: center.as_vec2(),
        half_size: DVec2::new(0.5 * (u1 - u0), 0.5 * (v1 - v0)).as_vec2(),
        ..*r
    }))
}

/// The convex polygon `points` cut to the world rectangle `(lo, hi)` (Sutherland and
/// Hodgman, in f64), into `out` (cleared first).
pub fn clip_convex(points: &[DVec2], lo: DVec2, hi: DVec2, out: &mut Vec<DVec2>) {
    out.clear();
    out.extend_from_slice(points);
    let mut next = Vec::with_capacity(points.len() + 4);
    // each edge of the rectangle: inside when dot(p, n) <= d
    let planes = [
        (DVec2::new(-1.0, 0.0), -lo.x),
        (DVec2::new(1.0, 0.0), hi.x),
        (DVec2::new(0.0, -1.0), -lo.y),
        (DVec2::new(0.0, 1.0), hi.y),
    ];
    for (n, d) in planes {
        next.clear();
        let k = out.len();
        for i in 0..k {
            let (a, b) = (out[i], out[(i + 1) % k]);
            let (da, db) = (a.dot(n) - d, b.dot(n) - d);
            if da <= 0.0 {
                next.push(a);
            }
            if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
                next.push(a + (b - a) * (da / (da - db)));
            }
        }
        std::mem::swap(out, &mut next);
        if out.is_empty() {
            return;
        }
    }
}

/// A polygon (world points, counter-clockwise, convex) cut to what can show: `None`
/// when it stays within the guard band (draw it as it is); else its part within the
/// widened image, as f32 world points in `out` (empty: nothing shows).
pub fn cut_polygon(points: &[Vec2], camera: &Camera, out: &mut Vec<Vec2>) -> Option<()> {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.min(p.as_dvec2());
        hi = hi.max(p.as_dvec2());
    }
    if within_guard(camera, lo, hi) {
        return None;
    }
    let (a, b) = view_rect(camera, CUT_MARGIN_PX);
    let wide: Vec<DVec2> = points.iter().map(|p| p.as_dvec2()).collect();
    let mut cut = Vec::new();
    clip_convex(&wide, a, b, &mut cut);
    out.clear();
    out.extend(cut.iter().map(|p| p.as_vec2()));
    Some(())
}

/// The segment `a`-`b` cut to what can show: `None` when it stays within the guard
/// band; `Some(None)` when none of it reaches the widened image; else its part there.
#[allow(clippy::option_option)]
pub fn cut_segment(a: Vec2, b: Vec2, camera: &Camera) -> Option<Option<(Vec2, Vec2)>> {
    let (a, b) = (a.as_dvec2(), b.as_dvec2());
    if within_guard(camera, a.min(b), a.max(b)) {
        return None;
    }
    let (lo, hi) = view_rect(camera, CUT_MARGIN_PX);
    // Liang and Barsky
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d.x, a.x - lo.x),
        (d.x, hi.x - a.x),
        (-d.y, a.y - lo.y),
        (d.y, hi.y - a.y),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return Some(None);
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    if t0 > t1 {
        return Some(None);
    }
    Some(Some(((a + d * t0).as_vec2(), (a + d * t1).as_vec2())))
}

/// What to draw of a circle.
#[derive(Clone, Debug, PartialEq)]
pub enum CircleCut {
    /// It stays within the guard band: draw it as it is.
    Keep,
    /// No part of it reaches the image.
    Nothing,
    /// It covers the widened image: this circle, about the image, covers it the same.
    Cover(Circle),
    /// Its rim crosses the image: its part within the widened image, as a convex
    /// polygon (f32 world points).
    Polygon(Vec<Vec2>),
}

/// A circle cut to what can show (see the module docs).
pub fn cut_circle(c: &Circle, camera: &Camera) -> CircleCut {
    let center = c.center.as_dvec2();
    let r = c.radius as f64;
    if within_guard(camera, center - r, center + r) {
        return CircleCut::Keep;
    }
    let (lo, hi) = view_rect(camera, CUT_MARGIN_PX);
    let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    // nearest and farthest points of the rectangle from the centre
    let near = center.clamp(lo, hi).distance(center);
    let far = corners
        .iter()
        .map(|p| p.distance(center))
        .fold(0.0f64, f64::max);
    if near >= r {
        return CircleCut::Nothing;
    }
    if far <= r {
        let mid = (lo + hi) * 0.5;
        return CircleCut::Cover(Circle {
            center: mid.as_vec2(),
            radius: (mid.distance(hi) * 1.01) as f32,
            angle: None,
            ..*c
        });
    }
    // the rim crosses the rectangle: sample it over the angles the rectangle spans as
    // seen from the centre (all of them when the centre is inside it), with the centre
    // closing the sector, then cut
    let s = camera.pixels_per_meter as f64;
    let r_px = r * s;
    let step = 2.0 * (2.0 * RIM_TOLERANCE_PX / r_px).sqrt().min(0.5);
    let inside = near == 0.0;
    let (a0, a1) = if inside {
        (0.0, std::f64::consts::TAU)
    } else {
        let base = (corners[0] - center).to_angle();
        let (mut a, mut b) = (0.0f64, 0.0f64);
        for p in corners {
            let mut t = (p - center).to_angle() - base;
            // within (-pi, pi] of the first corner: the rectangle spans less than pi
            while t > std::f64::consts::PI {
                t -= std::f64::consts::TAU;
            }
            while t <= -std::f64::consts::PI {
                t += std::f64::consts::TAU;
            }
            (a, b) = (a.min(t), b.max(t));
        }
        (base + a, base + b)
    };
    let n = (((a1 - a0) / step).ceil() as usize).clamp(2, 1 << 14);
    let mut sector: Vec<DVec2> = (0..=n)
        .map(|k| center + DVec2::from_angle(a0 + (a1 - a0) * k as f64 / n as f64) * r)
        .collect();
    if inside {
        sector.pop();
    } else {
        sector.push(center);
    }
    let mut cut = Vec::new();
    clip_convex(&sector, lo, hi, &mut cut);
    CircleCut::Polygon(cut.iter().map(|p| p.as_vec2()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(ppm: f32) -> Camera {
        Camera::new(Vec2::ZERO, ppm, [320, 200])
    }

    #[test]
    fn a_box_within_the_guard_is_left_and_a_huge_one_is_cut_to_the_image() {
        let c = cam(40.0);
        let small = Rect {
            center: Vec2::new(1.0, 0.5),
            half_size: Vec2::new(2.0, 1.0),
            rot: Vec2::X,
            fill: [0; 4],
            outline: [0; 4],
        };
        assert_eq!(cut_box(&small, &c), Ok(None));
        // its top edge at y = 0 (-5e8 is exact in f32)
        let huge = Rect {
            half_size: Vec2::splat(5e8),
            center: Vec2::new(0.0, -5e8),
            ..small
        };
        let cut = cut_box(&huge, &c).unwrap().unwrap();
        // its top edge stays at y = 0, its other edges beyond the widened image
        assert!((cut.center.y + cut.half_size.y).abs() < 1e-6, "{cut:?}");
        let (lo, hi) = view_rect(&c, 0.0);
        assert!(cut.center.x - cut.half_size.x < lo.x as f32);
        assert!(cut.center.x + cut.half_size.x > hi.x as f32);
        assert!(cut.center.y - cut.half_size.y < lo.y as f32);
        assert!(cut.half_size.x * 40.0 < 1000.0, "small enough: {cut:?}");
        // one that misses the image
        let away = Rect {
            center: Vec2::new(2e9, 0.0),
            ..huge
        };
        assert_eq!(cut_box(&away, &c), Err(()));
    }

    #[test]
    fn a_huge_circle_covers_the_image_or_is_cut_along_its_rim() {
        let c = cam(40.0);
        let base = Circle {
            center: Vec2::ZERO,
            radius: 1.0,
            angle: Some(0.3),
            fill: [0; 4],
            outline: [0; 4],
        };
        assert_eq!(cut_circle(&base, &c), CircleCut::Keep);
        let over = Circle {
            radius: 1e9,
            ..base
        };
        match cut_circle(&over, &c) {
            CircleCut::Cover(k) => {
                assert!(k.radius * 40.0 < 1000.0 && k.angle.is_none(), "{k:?}")
            }
            other => panic!("{other:?}"),
        }
        // rim through the middle of the image: a circle of 1e9 m whose top is at y = 0
        let rim = Circle {
            center: Vec2::new(0.0, -1e9),
            radius: 1e9,
            ..base
        };
        let CircleCut::Polygon(p) = cut_circle(&rim, &c) else {
            panic!("cut")
        };
        // the top edge of the cut lies on y = 0 within f32 at 1e9 (the rim's own
        // precision) and the polygon reaches down past the image
        let top = p.iter().map(|q| q.y).fold(f32::MIN, f32::max);
        assert!(top.abs() < 1e-3 * 40.0, "{top}");
        assert!(p.iter().any(|q| q.y * 40.0 < -100.0));
        // a rim with curvature across the image: r = 100 m at 40 px/m is 4000 px
        let near = Circle {
            center: Vec2::new(0.0, -99.0),
            radius: 100.0,
            ..base
        };
        let CircleCut::Polygon(p) = cut_circle(&near, &c) else {
            panic!("cut")
        };
        assert!(p.len() > 10, "the rim sampled: {}", p.len());
        for q in &p {
            let d = q.distance(near.center);
            // every point on or inside the circle (the rim's within f32 of it)
            assert!(d <= 100.0 + 1e-4, "{q} at {d}");
        }
        let away = Circle {
            center: Vec2::new(3e9, 0.0),
            ..over
        };
        assert_eq!(cut_circle(&away, &c), CircleCut::Nothing);
    }

    #[test]
    fn segments_and_polygons_are_cut_to_the_widened_image() {
        let c = cam(40.0);
        assert_eq!(cut_segment(Vec2::ZERO, Vec2::ONE, &c), None);
        let (lo, hi) = view_rect(&c, CUT_MARGIN_PX);
        let (a, b) = cut_segment(Vec2::new(-1e9, 0.5), Vec2::new(1e9, 0.5), &c)
            .unwrap()
            .unwrap();
        assert!((a.x as f64 - lo.x).abs() < 1e-3 && (b.x as f64 - hi.x).abs() < 1e-3);
        assert_eq!((a.y, b.y), (0.5, 0.5));
        assert_eq!(
            cut_segment(Vec2::new(-1e9, 1e6), Vec2::new(1e9, 1e6), &c),
            Some(None)
        );
        let mut out = Vec::new();
        let tri = [
            Vec2::new(-1e9, -1e9),
            Vec2::new(1e9, -1e9),
            Vec2::new(0.0, 1e9),
        ];
        cut_polygon(&tri, &c, &mut out).unwrap();
        assert_eq!(out.len(), 4, "{out:?}: the whole widened image");
        assert!(cut_polygon(&[Vec2::ZERO, Vec2::X, Vec2::Y], &c, &mut out).is_none());
    }
}
