//! Snapshot tests of the renderer: draw lists rendered off-screen on the GL backend
//! (Mesa llvmpipe without a GPU) and compared with golden PNGs in tests/snapshots/.
//!
//! - `UPDATE_SNAPSHOTS=1 cargo test --test snapshots` rewrites the golden images.
//! - A mismatch writes `<name>.actual.png` and `<name>.diff.png` under
//!   `<target dir>/snapshot-failures/` and the panic names both.
//! - Without any GL adapter the tests print why and pass, unless
//!   `SANDBOX2D_REQUIRE_ADAPTER=1` is set (then they fail).
#![cfg(feature = "render")]

mod common;

use glam::Vec2;
use image::{Rgba, RgbaImage};
use sandbox2d::draw::{Camera, DrawList};
use sandbox2d::render::{RenderError, Renderer, save_png};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// A pixel differs when one of its channels differs by more than this (3% of full
/// scale: antialiased edges may move by a few levels between Mesa versions; any drawn
/// feature differs from what is under it by far more).
const CHANNEL_TOLERANCE: u8 = 8;
/// A snapshot fails when more than this many pixels differ. The smallest feature of the
/// golden scenes, the pendulum's anchor dot (radius 0.08 m at 48 px/m, about 46 px), is
/// larger: a renderer that drops any one feature fails, whatever the image size.
const MAX_DIFFERING_PIXELS: usize = 24;
/// The samples per pixel of the golden images (4x MSAA): pinned, so that neither the
/// `SANDBOX2D_MSAA` environment variable nor the adapter's kind changes the bytes
/// (single-sampled frames differ at polygon edges by up to 34 levels, on 57 pixels of
/// the 640x400 golden and 801 of the 1001x701 one).
const SAMPLES: u32 = 4;

/// One renderer for the whole test binary, pinned to GL so bytes match across machines
/// (a machine with Vulkan's lavapipe would otherwise pick it and rasterise differently).
fn renderer() -> Option<std::sync::MutexGuard<'static, Renderer>> {
    static RENDERER: OnceLock<Result<Mutex<Renderer>, String>> = OnceLock::new();
    let r = RENDERER.get_or_init(|| {
        Renderer::new_headless_with_samples(wgpu::Backends::GL, SAMPLES)
            .map(Mutex::new)
            .map_err(|e| e.to_string())
    });
    match r {
        Ok(m) => {
            let r = m.lock().unwrap_or_else(|p| p.into_inner());
            assert_eq!(r.sample_count(), SAMPLES, "the golden images' samples");
            Some(r)
        }
        Err(e) => {
            if std::env::var_os("SANDBOX2D_REQUIRE_ADAPTER").is_some() {
                panic!("no renderer and SANDBOX2D_REQUIRE_ADAPTER is set: {e}");
            }
            eprintln!("SKIPPED: no GL adapter for the snapshot tests: {e}");
            None
        }
    }
}

fn render(list: &DrawList, camera: &Camera) -> Option<RgbaImage> {
    let mut r = renderer()?;
    Some(r.render_to_image(list, camera).expect("render_to_image"))
}

fn snapshot_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("snapshots")
}

fn failure_dir() -> PathBuf {
    // CARGO_TARGET_TMPDIR is <target dir>/tmp.
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR"));
    tmp.parent().unwrap_or(tmp).join("snapshot-failures")
}

/// Compares `actual` with tests/snapshots/`name`.png (or rewrites it with UPDATE_SNAPSHOTS=1).
fn assert_snapshot(name: &str, actual: &RgbaImage) {
    let golden_path = snapshot_dir().join(format!("{name}.png"));
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some_and(|v| v != "0") {
        std::fs::create_dir_all(snapshot_dir()).unwrap();
        save_png(&golden_path, actual).unwrap();
        eprintln!("updated {}", golden_path.display());
        return;
    }
    let fail = |why: String, diff: Option<RgbaImage>| -> ! {
        let dir = failure_dir();
        std::fs::create_dir_all(&dir).unwrap();
        let actual_path = dir.join(format!("{name}.actual.png"));
        save_png(&actual_path, actual).unwrap();
        let diff_path = dir.join(format!("{name}.diff.png"));
        if let Some(diff) = diff {
            save_png(&diff_path, &diff).unwrap();
        }
        panic!(
            "snapshot {name}: {why}\n  golden: {}\n  actual: {}\n  diff:   {}\n  \
             (UPDATE_SNAPSHOTS=1 rewrites the golden image)",
            golden_path.display(),
            actual_path.display(),
            diff_path.display()
        );
    };
    let golden = match image::open(&golden_path) {
        Ok(img) => img.to_rgba8(),
        Err(e) => fail(format!("cannot read the golden image ({e})"), None),
    };
    if golden.dimensions() != actual.dimensions() {
        fail(
            format!(
                "size {:?} != golden {:?}",
                actual.dimensions(),
                golden.dimensions()
            ),
            None,
        );
    }
    // The diff: differing pixels in red over a dimmed copy of the golden image.
    let mut diff = RgbaImage::new(actual.width(), actual.height());
    let mut differing = 0usize;
    let mut worst = 0u8;
    for ((g, a), d) in golden.pixels().zip(actual.pixels()).zip(diff.pixels_mut()) {
        let delta = (0..4).map(|c| g[c].abs_diff(a[c])).max().unwrap_or(0);
        worst = worst.max(delta);
        *d = if delta > CHANNEL_TOLERANCE {
            differing += 1;
            Rgba([255, 0, 0, 255])
        } else {
            Rgba([g[0] / 4, g[1] / 4, g[2] / 4, 255])
        };
    }
    let total = actual.width() * actual.height();
    eprintln!("snapshot {name}: {differing} of {total} pixels differ (worst by {worst})");
    if differing > MAX_DIFFERING_PIXELS {
        fail(
            format!(
                "{differing} of {total} pixels differ by more than {CHANNEL_TOLERANCE} \
                 (at most {MAX_DIFFERING_PIXELS} may; worst {worst})"
            ),
            Some(diff),
        );
    }
}

#[test]
fn pyramid_scene() {
    let list = common::scenes::small_scene();
    let camera = Camera::new(Vec2::new(0.0, 3.0), 48.0, [640, 400]);
    let Some(img) = render(&list, &camera) else {
        return;
    };
    assert_eq!(img.dimensions(), (640, 400));
    assert_snapshot("pyramid", &img);
}

/// The pixels where `a` and `b` differ by more than [`CHANNEL_TOLERANCE`], as pixel
/// centres in screen coordinates.
fn differing_pixels(a: &RgbaImage, b: &RgbaImage) -> Vec<Vec2> {
    a.enumerate_pixels()
        .zip(b.pixels())
        .filter(|((_, _, p), q)| (0..4).any(|c| p[c].abs_diff(q[c]) > CHANNEL_TOLERANCE))
        .map(|((x, y, _), _)| Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
        .collect()
}

/// Distance from `p` to the segment `a`-`b`.
fn segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + t * ab)
}

/// One feature of a draw list checked in isolation: `with` and `without` differ only by
/// the feature, so the pixels where their renders differ are the feature's. They must
/// lie within `reach` px of the segment `a`-`b` (screen px; a disc has a = b), and there
/// must be at least `min_pixels` of them.
fn assert_feature_drawn(
    what: &str,
    with: &RgbaImage,
    without: &RgbaImage,
    (a, b, reach): (Vec2, Vec2, f32),
    min_pixels: f32,
) {
    let px = differing_pixels(with, without);
    let stray: Vec<&Vec2> = px
        .iter()
        .filter(|p| segment_distance(**p, a, b) > reach)
        .collect();
    assert!(
        stray.is_empty(),
        "{what}: {} of its {} pixels lie more than {reach} px from where it should be \
         ({a} to {b}), e.g. {:?}",
        stray.len(),
        px.len(),
        &stray[..stray.len().min(5)]
    );
    assert!(
        px.len() as f32 >= min_pixels,
        "{what}: {} pixels drawn, expected at least {min_pixels} around {a} to {b}",
        px.len()
    );
}

#[test]
fn small_scene_features_are_drawn_where_they_should_be() {
    // Each small feature of the golden scene (the particle, the thin debug line, the
    // pendulum's anchor dot, two balls' rotation lines): rendered with and without it,
    // the difference is the feature's own pixels, at the place and of the size the
    // camera says. A renderer that drops, moves or shrinks one fails here.
    let list = common::scenes::small_scene();
    let camera = Camera::new(Vec2::new(0.0, 3.0), 48.0, [640, 400]);
    let Some(full) = render(&list, &camera) else {
        return;
    };
    let s = camera.pixels_per_meter;
    let at = |w: Vec2| camera.world_to_screen(w);
    let outline = list.outline_width_px;
    let pi = std::f32::consts::PI;

    let without_circle = |i: usize| {
        let mut l = list.clone();
        l.circles.remove(i);
        render(&l, &camera).unwrap()
    };
    // The particle: a circle with no rotation line, radius 0.15 m (7.2 px).
    let (pi_idx, particle) = list
        .circles
        .iter()
        .enumerate()
        .find(|(_, c)| c.angle.is_none() && c.radius == 0.15)
        .expect("the scene has the particle");
    let r = particle.radius * s;
    let c = at(particle.center);
    assert_feature_drawn(
        "particle",
        &full,
        &without_circle(pi_idx),
        (c, c, r + 1.0),
        0.8 * pi * r * r,
    );
    // its centre is its fill colour (opaque, so the bytes come back within a level)
    let p = full.get_pixel(c.x as u32, c.y as u32).0;
    assert!(
        p.iter().zip(particle.fill).all(|(a, b)| a.abs_diff(b) <= 2),
        "particle centre {p:?}, fill {:?}",
        particle.fill
    );

    // The pendulum's anchor dot: radius 0.08 m (3.8 px), partly under the thread.
    let (ai, dot) = list
        .circles
        .iter()
        .enumerate()
        .find(|(_, c)| c.radius == 0.08)
        .expect("the scene has the anchor dot");
    let r = dot.radius * s;
    let c = at(dot.center);
    assert_feature_drawn(
        "anchor dot",
        &full,
        &without_circle(ai),
        (c, c, r + 1.0),
        0.5 * pi * r * r,
    );

    // The thin debug line: 0.75 px wide, 1.77 m (85 px) long, partly over a ball.
    let (li, line) = list
        .lines
        .iter()
        .enumerate()
        .find(|(_, l)| l.width_px < 1.0)
        .expect("the scene has the debug line");
    let mut l = list.clone();
    l.lines.remove(li);
    let (a, b) = (at(line.a), at(line.b));
    assert_feature_drawn(
        "debug line",
        &full,
        &render(&l, &camera).unwrap(),
        (a, b, 0.5 * line.width_px + 1.5),
        0.8 * a.distance(b),
    );

    // Rotation lines: the same ball drawn with no angle differs only along the radius
    // at its angle (counter-clockwise from +x, y up: the screen's y is flipped).
    let mut spokes = 0;
    for (i, ball) in list.circles.iter().enumerate() {
        let Some(angle) = ball.angle else { continue };
        if ball.fill[3] < 255 || ball.radius < 0.3 {
            continue;
        }
        let mut l = list.clone();
        l.circles[i].angle = None;
        let c = at(ball.center);
        let r = ball.radius * s;
        let tip = c + r * Vec2::new(angle.cos(), -angle.sin());
        assert_feature_drawn(
            &format!("rotation line of the ball at {}", ball.center),
            &full,
            &render(&l, &camera).unwrap(),
            (c, tip, 0.5 * outline + 1.5),
            0.8 * (r - outline),
        );
        spokes += 1;
    }
    assert!(spokes >= 3, "{spokes} balls with rotation lines checked");
}

#[test]
fn odd_size_padded_rows() {
    // 1001 * 4 = 4004 bytes a row, padded to 4096 for the copy: rows must not shear.
    let list = common::scenes::small_scene();
    let mut camera = Camera::new(Vec2::ZERO, 1.0, [1001, 701]);
    let (lo, hi) = list.bounds().unwrap();
    camera.fit(lo, hi, 20.0);
    let Some(img) = render(&list, &camera) else {
        return;
    };
    assert_eq!(img.dimensions(), (1001, 701));
    // The ground's top edge is a horizontal line: the same row in every column it spans.
    let ground_top = camera.world_to_screen(Vec2::new(0.0, 0.0)).y;
    let bg = list.background;
    for wx in [-4.5f32, 0.0, 4.5] {
        let x = camera.world_to_screen(Vec2::new(wx, 0.0)).x as u32;
        let p = *img.get_pixel(x, (ground_top + 4.0) as u32);
        assert_ne!(
            p.0, bg,
            "column {x} below the ground's top should be ground"
        );
    }
    assert_snapshot("pyramid_1001x701", &img);
}

#[test]
fn background_bytes_survive_the_srgb_round_trip() {
    let mut list = DrawList::new();
    list.background = [24, 26, 33, 255];
    let Some(img) = render(&list, &Camera::new(Vec2::ZERO, 10.0, [67, 33])) else {
        return;
    };
    assert!(
        img.pixels().all(|p| p.0 == [24, 26, 33, 255]),
        "got {:?}",
        img.get_pixel(0, 0)
    );
    // An opaque fill comes out as the same sRGB bytes too.
    list.push_box(Vec2::ZERO, 100.0, 100.0, 0.0, [200, 100, 50, 255], [0; 4]);
    let img = render(&list, &Camera::new(Vec2::ZERO, 10.0, [67, 33])).unwrap();
    let p = img.get_pixel(30, 15).0;
    assert!(
        p.iter()
            .zip([200, 100, 50, 255])
            .all(|(a, b)| a.abs_diff(b) <= 1),
        "got {p:?}"
    );
}

/// Intensity-weighted centroid of the image, in pixel coordinates (pixel centres at +0.5).
fn centroid(img: &RgbaImage) -> Vec2 {
    let mut sum = Vec2::ZERO;
    let mut weight = 0.0;
    for (x, y, p) in img.enumerate_pixels() {
        let w = p[0] as f32 + p[1] as f32 + p[2] as f32;
        sum += Vec2::new(x as f32 + 0.5, y as f32 + 0.5) * w;
        weight += w;
    }
    sum / weight
}

#[test]
fn camera_puts_a_point_where_world_to_screen_says() {
    let camera = Camera::new(Vec2::new(0.3, 1.9), 40.0, [320, 240]);
    for world in [
        Vec2::new(1.237, 2.613),
        Vec2::new(-2.71, -0.4),
        Vec2::new(0.3, 1.9),
    ] {
        let mut list = DrawList::new();
        list.background = [0, 0, 0, 255];
        // 0.8 px radius: only the pixel nearest the centre is fully bright.
        list.push_circle(world, 0.02, None, [255, 255, 255, 255], [0, 0, 0, 0]);
        let Some(img) = render(&list, &camera) else {
            return;
        };
        let expected = camera.world_to_screen(world);
        let (bx, by, _) = img
            .enumerate_pixels()
            .max_by_key(|(x, y, p)| (p[0] as u32 + p[1] as u32 + p[2] as u32, u32::MAX - (x + y)))
            .unwrap();
        let brightest = Vec2::new(bx as f32 + 0.5, by as f32 + 0.5);
        assert!(
            (brightest - expected).abs().max_element() <= 1.0,
            "{world}: brightest pixel centre {brightest}, world_to_screen {expected}"
        );
        let c = centroid(&img);
        assert!(
            (c - expected).abs().max_element() <= 0.25,
            "{world}: centroid {c}, expected {expected}"
        );
    }
}

#[test]
fn y_is_up_and_circles_are_round() {
    let camera = Camera::new(Vec2::ZERO, 20.0, [200, 200]);
    let mut list = DrawList::new();
    list.background = [0, 0, 0, 255];
    list.push_circle(Vec2::new(0.0, 2.0), 1.0, None, [255, 0, 0, 255], [0; 4]);
    list.push_circle(Vec2::new(0.0, -2.0), 1.0, None, [0, 255, 0, 255], [0; 4]);
    let Some(img) = render(&list, &camera) else {
        return;
    };
    // Red (world y = +2) is in the top half of the image, green in the bottom half.
    assert!(
        img.get_pixel(100, 60)[0] > 250,
        "red circle should be above the centre"
    );
    assert!(
        img.get_pixel(100, 140)[1] > 250,
        "green circle should be below the centre"
    );
    // Round: as wide as tall (20 px radius), within antialiasing.
    let count = |f: &dyn Fn(&Rgba<u8>) -> bool| img.pixels().filter(|p| f(p)).count() as f32;
    // Half coverage in linear light is 188 in sRGB.
    let red_area = count(&|p| p[0] >= 188);
    let expected = std::f32::consts::PI * 20.0 * 20.0;
    assert!(
        (red_area - expected).abs() / expected < 0.02,
        "area {red_area} vs {expected}"
    );
    let row: Vec<u32> = (0..200)
        .filter(|&x| img.get_pixel(x, 60)[0] >= 188)
        .collect();
    let col: Vec<u32> = (0..200)
        .filter(|&y| img.get_pixel(100, y)[0] >= 188)
        .collect();
    assert!(
        row.len().abs_diff(col.len()) <= 1,
        "width {} height {}",
        row.len(),
        col.len()
    );
    // Antialiased rim: some pixels are strictly between background and fill.
    assert!(img.pixels().any(|p| p[0] > 20 && p[0] < 235 && p[1] == 0));
}

/// The covered area of convex shapes against their closed forms: a hexagon, a triangle
/// and a rounded box and a capsule (polygons grown by a radius: area of the core, plus
/// perimeter times r, plus pi r^2), each drawn both ways the renderer has (one
/// instance of up to eight points shaded by its distance, and fan triangles with
/// outline segments for more points: a 12-gon and a rounded 12-gon), and each where
/// it should be.
#[test]
fn polygons_rounded_polygons_and_capsules_cover_their_area() {
    let s = 20.0; // px/m
    let camera = Camera::new(Vec2::ZERO, s, [400, 400]);
    let ngon = |n: usize, r: f32| -> Vec<Vec2> {
        (0..n)
            .map(|i| Vec2::from_angle(std::f32::consts::TAU * i as f32 / n as f32) * r)
            .collect()
    };
    let ngon_area =
        |n: usize, r: f32| 0.5 * n as f32 * r * r * (std::f32::consts::TAU / n as f32).sin();
    let ngon_perimeter =
        |n: usize, r: f32| 2.0 * n as f32 * r * (std::f32::consts::PI / n as f32).sin();
    let pi = std::f32::consts::PI;
    // (name, points, radius, area in m^2)
    let cases: Vec<(&str, Vec<Vec2>, f32, f32)> = vec![
        ("hexagon", ngon(6, 3.0), 0.0, ngon_area(6, 3.0)),
        (
            "triangle",
            vec![
                Vec2::new(-3.0, -2.0),
                Vec2::new(4.0, -2.0),
                Vec2::new(0.0, 3.0),
            ],
            0.0,
            0.5 * 7.0 * 5.0,
        ),
        (
            "rounded box",
            vec![
                Vec2::new(-3.0, -2.0),
                Vec2::new(3.0, -2.0),
                Vec2::new(3.0, 2.0),
                Vec2::new(-3.0, 2.0),
            ],
            1.0,
            6.0 * 4.0 + 20.0 * 1.0 + pi,
        ),
        (
            "capsule",
            vec![Vec2::new(-3.0, -1.0), Vec2::new(3.0, 1.0)],
            1.5,
            2.0 * 1.5 * 40f32.sqrt() + pi * 1.5 * 1.5,
        ),
        ("12-gon (fan)", ngon(12, 3.0), 0.0, ngon_area(12, 3.0)),
        (
            "rounded 12-gon (fan)",
            ngon(12, 2.5),
            1.0,
            ngon_area(12, 2.5) + ngon_perimeter(12, 2.5) + pi,
        ),
    ];
    for (name, points, radius, area) in cases {
        let mut list = DrawList::new();
        list.background = [0, 0, 0, 255];
        let offset = Vec2::new(1.0, 1.5);
        list.push_rounded_polygon(
            points.iter().map(|p| *p + offset),
            radius,
            [255, 0, 0, 255],
            [0; 4],
        );
        let Some(img) = render(&list, &camera) else {
            return;
        };
        // Half coverage in linear light is 188 in sRGB.
        let covered = img.pixels().filter(|p| p[0] >= 188).count() as f32;
        let expected = area * s * s;
        assert!(
            (covered - expected).abs() / expected < 0.02,
            "{name}: {covered} px covered, the closed form {expected}"
        );
        let c = centroid(&img);
        let want = camera.world_to_screen(offset);
        // (every case is symmetric about the offset but the triangle: its centroid)
        let want = if name == "triangle" {
            camera.world_to_screen(offset + Vec2::new(1.0 / 3.0, -1.0 / 3.0))
        } else {
            want
        };
        assert!(
            (c - want).length() < 1.0,
            "{name}: centroid {c}, expected {want}"
        );
    }
}

#[test]
fn invalid_size_is_an_error_not_a_panic() {
    let Some(mut r) = renderer() else { return };
    let err = r.render_to_image(&DrawList::new(), &Camera::new(Vec2::ZERO, 1.0, [0, 10]));
    assert!(
        matches!(err, Err(RenderError::InvalidSize { .. })),
        "{err:?}"
    );
}

#[test]
fn png_and_gif_files_round_trip() {
    use image::AnimationDecoder;
    use sandbox2d::render::GifWriter;
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("capture-test");
    std::fs::create_dir_all(&dir).unwrap();
    let camera = Camera::new(Vec2::new(0.0, 3.0), 30.0, [160, 100]);
    let mut gif = GifWriter::create_with_speed(dir.join("anim.gif"), 20.0, 30).unwrap();
    let mut first = None;
    for i in 0..3 {
        let mut list = common::scenes::small_scene();
        list.push_circle(
            Vec2::new(i as f32, 5.0),
            0.5,
            Some(i as f32),
            [255, 255, 255, 255],
            [0, 0, 0, 255],
        );
        let Some(img) = render(&list, &camera) else {
            return;
        };
        first.get_or_insert_with(|| img.clone());
        gif.push(img).unwrap();
    }
    let wrong = gif.push(RgbaImage::new(10, 10));
    assert!(
        matches!(wrong, Err(RenderError::FrameSize { .. })),
        "{wrong:?}"
    );
    assert_eq!(gif.frame_count(), 3);
    gif.finish().unwrap();
    let file = std::io::BufReader::new(std::fs::File::open(dir.join("anim.gif")).unwrap());
    let frames = image::codecs::gif::GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
    assert_eq!(frames.len(), 3);
    assert_eq!(frames[0].buffer().dimensions(), (160, 100));

    let first = first.unwrap();
    save_png(dir.join("frame.png"), &first).unwrap();
    assert_eq!(
        image::open(dir.join("frame.png")).unwrap().to_rgba8(),
        first
    );
}

/// `render --compare`'s frame: the pyramid in 2 panes (PGS with 4 sweeps, the soft
/// step) after 20 steps in lock step, each labelled with its settings and figures in
/// anti-aliased text over a dark box inside its pane, a divider between them. The ms per step, a wall time, is pinned to
/// 0.25 so the golden image holds; the other figures are the run's own.
#[test]
fn compare_two_panes() {
    use sandbox2d::compare::{Pane, figure_lines};
    use sandbox2d::render::compare::{PaneView, label_box, pane_width, render_panes};
    use sandbox2d::{SolverKind, SolverOverrides};
    let sc = sandbox2d::scene::load("pyramid").expect("the built-in pyramid");
    let settings = [
        (
            "--solver pgs --iterations 4",
            SolverOverrides {
                kind: Some(SolverKind::Pgs),
                iterations: Some(4),
                ..Default::default()
            },
        ),
        (
            "--solver soft",
            SolverOverrides {
                kind: Some(SolverKind::Soft),
                ..Default::default()
            },
        ),
    ];
    let mut panes: Vec<Pane> = settings
        .iter()
        .map(|(label, o)| {
            let settings = sc.world.solver.merged(*o).resolve();
            Pane::new(
                *label,
                sandbox2d::World::from_def(&sc.world, settings).expect("builds"),
            )
        })
        .collect();
    for _ in 0..20 {
        for p in &mut panes {
            p.step().expect("steps");
        }
    }
    let size = [640u32, 300];
    let pane_w = pane_width(size[0], panes.len());
    let camera =
        sandbox2d::draw::world::scene_camera(&sc.camera, [pane_w, size[1]], &panes[0].world);
    let views: Vec<PaneView> = panes
        .iter()
        .map(|p| {
            let mut f = p.figures();
            f.ms_per_step = Some(0.25);
            let mut lines = vec![p.label.clone()];
            lines.extend(figure_lines(&f));
            PaneView {
                world: &p.world,
                lines,
            }
        })
        .collect();
    let Some(mut r) = renderer() else {
        return;
    };
    let mut list = DrawList::new();
    let img = render_panes(
        &mut r,
        &mut list,
        &views,
        &camera,
        &sandbox2d::draw::world::Overlays::NONE,
    )
    .expect("render_panes");
    drop(r);
    assert_eq!(img.dimensions(), (640, 300));
    // the labels: light text at each pane's top-left, its edges anti-aliased (many
    // shades between the box and the text), over a box that lies inside the pane and
    // darkens what is under it; the divider at the boundary
    for (k, view) in views.iter().enumerate() {
        let x0 = k as u32 * pane_w;
        let [bw, bh] = label_box(&view.lines, [pane_w, size[1]]);
        assert!(bw + 2 < pane_w && bh < size[1] / 2, "box {bw}x{bh}");
        let text: Vec<u8> = (x0 + 1..x0 + bw - 1)
            .flat_map(|x| (1..bh - 1).map(move |y| (x, y)))
            .map(|(x, y)| img.get_pixel(x, y).0[0])
            .collect();
        let lit = text.iter().filter(|&&r| r > 200).count();
        assert!(lit > 60, "pane {k}: {lit} label pixels");
        let mut shades: Vec<u8> = text.iter().copied().filter(|&r| r > 40).collect();
        shades.sort_unstable();
        shades.dedup();
        assert!(
            shades.len() > 16,
            "pane {k}: {} shades of text",
            shades.len()
        );
        // the sky just inside the box's right edge is darker than just outside it
        let sum = |x: u32| {
            img.get_pixel(x, 1).0[..3]
                .iter()
                .map(|&c| u32::from(c))
                .sum::<u32>()
        };
        let (inside, outside) = (sum(x0 + bw - 1), sum(x0 + bw + 1));
        assert!(
            inside + 30 < outside,
            "pane {k}: box edge {inside} vs {outside}"
        );
    }
    assert!(img.get_pixel(pane_w, 150).0[0] > 150, "the divider");
    assert_snapshot("compare_pyramid_2_panes", &img);
}

#[test]
fn the_feature_scenes_draw_each_moving_body_where_the_physics_puts_it() {
    // The extreme scenes, stepped 1 s under the default solver (the joint grid 0.25 s) and
    // rendered through their own camera: every moving body whose centre of mass lies
    // inside its shape and on screen, at least 1.5 px across, has a pixel at that centre
    // that is not the background; and some background shows, so a frame painted all
    // over would fail too.
    use sandbox2d::draw::Overlays;
    use sandbox2d::draw::world::{scene_camera, world_draw_list};
    for (name, steps) in [
        ("joint_grid", 15),
        ("sensor_gate", 60),
        ("car", 60),
        ("compound", 60),
        ("shapes", 60),
        ("machines", 60),
    ] {
        let sc = sandbox2d::scene::builtin(name)
            .expect("exists")
            .expect("parses");
        let settings = sc.world.solver.resolve();
        assert_eq!(settings.kind, sandbox2d::SolverKind::default(), "{name}");
        let mut w = sandbox2d::World::from_def(&sc.world, settings).expect("builds");
        for _ in 0..steps {
            w.step().expect("steps");
        }
        let camera = scene_camera(&sc.camera, [640, 360], &w);
        let list = world_draw_list(&w, &Overlays::NONE);
        let Some(img) = render(&list, &camera) else {
            return;
        };
        let bg = list.background;
        let is_bg = |x: u32, y: u32| {
            let p = img.get_pixel(x, y).0;
            (0..3).all(|c| p[c].abs_diff(bg[c]) <= CHANNEL_TOLERANCE)
        };
        let mut checked = 0;
        for b in w.bodies().map(|(_, b)| b).filter(|b| b.is_dynamic()) {
            let c = camera.world_to_screen(b.position);
            let size = 2.0 * b.shape.radius() * camera.pixels_per_meter;
            if !b.contains_local(Vec2::ZERO)
                || size < 1.5
                || c.x < 1.0
                || c.y < 1.0
                || c.x > 639.0
                || c.y > 359.0
            {
                continue;
            }
            assert!(
                !is_bg(c.x as u32, c.y as u32),
                "{name}: body {:?} at {} (screen {c}) is not drawn there",
                b.name,
                b.position
            );
            checked += 1;
        }
        let background = (0..640)
            .flat_map(|x| (0..360).map(move |y| (x, y)))
            .filter(|&(x, y)| is_bg(x, y))
            .count();
        eprintln!("{name}: {checked} bodies found where they are, {background} px of background");
        assert!(checked >= 3, "{name}: only {checked} bodies on screen");
        assert!(
            background > 640 * 360 / 10,
            "{name}: {background} px of background"
        );
    }
}

/// A renderer of one sample a pixel: what `render` uses on a CPU rasteriser
/// (llvmpipe), where the shapes' edges are antialiased by their distance fields alone.
fn renderer_1x() -> Option<std::sync::MutexGuard<'static, Renderer>> {
    static RENDERER: OnceLock<Result<Mutex<Renderer>, String>> = OnceLock::new();
    let r = RENDERER.get_or_init(|| {
        Renderer::new_headless_with_samples(wgpu::Backends::GL, 1)
            .map(Mutex::new)
            .map_err(|e| e.to_string())
    });
    match r {
        Ok(m) => {
            let r = m.lock().unwrap_or_else(|p| p.into_inner());
            assert_eq!(r.sample_count(), 1);
            Some(r)
        }
        Err(e) => {
            if std::env::var_os("SANDBOX2D_REQUIRE_ADAPTER").is_some() {
                panic!("no renderer and SANDBOX2D_REQUIRE_ADAPTER is set: {e}");
            }
            eprintln!("SKIPPED: no GL adapter for the snapshot tests: {e}");
            None
        }
    }
}

fn render_1x(list: &DrawList, camera: &Camera) -> Option<RgbaImage> {
    let mut r = renderer_1x()?;
    Some(r.render_to_image(list, camera).expect("render_to_image"))
}

/// The one-sample path (what `render` uses on llvmpipe) against its own reference
/// image, as the four-sample path is against `pyramid.png`.
#[test]
fn pyramid_scene_one_sample() {
    let list = common::scenes::small_scene();
    let camera = Camera::new(Vec2::new(0.0, 3.0), 48.0, [640, 400]);
    let Some(img) = render_1x(&list, &camera) else {
        return;
    };
    assert_snapshot("pyramid_1_sample", &img);
}

/// `list` with every length multiplied by `k` (positions, sizes, radii, points).
fn scaled(list: &DrawList, k: f32) -> DrawList {
    let mut l = list.clone();
    for b in &mut l.boxes {
        b.center *= k;
        b.half_size *= k;
    }
    for c in &mut l.circles {
        c.center *= k;
        c.radius *= k;
    }
    for p in &mut l.polygon_points {
        *p *= k;
    }
    for p in &mut l.polygons {
        p.radius *= k;
    }
    for line in &mut l.lines {
        line.a *= k;
        line.b *= k;
    }
    l
}

/// The same scene drawn at every scale from 1e-6 to 1e9 (every length and the camera's
/// metres per pixel multiplied alike) gives the same picture: no size is clamped away
/// and no f32 or rasteriser range is passed, on either sample count.
#[test]
fn bodies_from_a_micron_to_a_million_km_draw_the_same() {
    let list = common::scenes::small_scene();
    let camera = Camera::new(Vec2::new(0.0, 3.0), 48.0, [640, 400]);
    for one in [false, true] {
        let draw = |l: &DrawList, c: &Camera| {
            if one { render_1x(l, c) } else { render(l, c) }
        };
        let Some(base) = draw(&list, &camera) else {
            return;
        };
        for k in [1e-6f32, 1e-3, 1e3, 1e6, 1e9] {
            let cam = Camera::new(camera.center * k, camera.pixels_per_meter / k, camera.size);
            let img = draw(&scaled(&list, k), &cam).unwrap();
            let differing = differing_pixels(&base, &img).len();
            assert!(
                differing <= MAX_DIFFERING_PIXELS,
                "scale {k:e} ({} sample): {differing} pixels differ",
                if one { 1 } else { 4 }
            );
        }
        // and a fitted camera frames a micron-sized scene as it frames the metre one
        let (lo, hi) = list.bounds().unwrap();
        let mut fit = Camera::new(Vec2::ZERO, 1.0, [640, 400]);
        fit.fit(lo, hi, 20.0);
        let small = scaled(&list, 1e-6);
        let (slo, shi) = small.bounds().unwrap();
        let mut fit_small = Camera::new(Vec2::ZERO, 1.0, [640, 400]);
        fit_small.fit(slo, shi, 20.0);
        let a = draw(&list, &fit).unwrap();
        let b = draw(&small, &fit_small).unwrap();
        assert!(differing_pixels(&a, &b).len() <= MAX_DIFFERING_PIXELS);
    }
}

/// A static box or circle of 1e9 m covering the view fills all of it (it was drawn on
/// the left half only: its corners 2e10 pixels out passed the rasteriser's range), a
/// rim far from its centre is drawn where it is, and a 1e9 m box's edge through the
/// view lies where a small box's would.
#[test]
fn bodies_of_a_million_km_cover_the_view_and_show_their_edges() {
    let camera = Camera::new(Vec2::ZERO, 40.0, [320, 200]);
    let blue = [48, 128, 255, 255];
    let red = [255, 48, 48, 255];
    let outline = common::scenes::OUTLINE;
    for one in [false, true] {
        let draw = |l: &DrawList, c: &Camera| {
            if one { render_1x(l, c) } else { render(l, c) }
        };
        // covering the view, with a small circle over it
        let covered = |mut l: DrawList| {
            l.push_circle(Vec2::ZERO, 1.0, None, red, outline);
            l
        };
        let mut huge = DrawList::new();
        huge.push_box(Vec2::ZERO, 1e9, 1e9, 0.3, blue, outline);
        let mut modest = DrawList::new();
        modest.push_box(Vec2::ZERO, 100.0, 100.0, 0.3, blue, outline);
        let Some(a) = draw(&covered(huge), &camera) else {
            return;
        };
        let b = draw(&covered(modest), &camera).unwrap();
        assert!(differing_pixels(&a, &b).len() <= MAX_DIFFERING_PIXELS);
        assert_eq!(a.get_pixel(5, 5).0, blue);
        assert_eq!(a.get_pixel(315, 195).0, blue);
        // a circle of 1e9 m over the view
        let mut huge = DrawList::new();
        huge.push_circle(Vec2::new(3e8, -2e8), 1e9, Some(0.5), blue, outline);
        let img = draw(&huge, &camera).unwrap();
        assert!(img.pixels().all(|p| p.0 == blue), "the view is all circle");
        // a box of 1e9 m whose top edge is y = 0 (its centre at -5e8, which f32 holds
        // exactly), against one of 100 m
        let mut huge = DrawList::new();
        huge.push_box(Vec2::new(0.0, -5e8), 1e9, 1e9, 0.0, blue, outline);
        let mut modest = DrawList::new();
        modest.push_box(Vec2::new(0.0, -50.0), 100.0, 100.0, 0.0, blue, outline);
        let a = draw(&huge, &camera).unwrap();
        let b = draw(&modest, &camera).unwrap();
        assert!(differing_pixels(&a, &b).len() <= MAX_DIFFERING_PIXELS);
        // rims: a circle of 100 m (4000 px) and one of 1e6 m (4e7 px), their tops at
        // y = 0, the image's middle row: each column turns from background to circle
        // where the circle's own equation says (within a pixel)
        for r in [100.0f32, 1e6] {
            let mut l = DrawList::new();
            l.push_circle(Vec2::new(0.0, -r), r, Some(0.0), blue, [0, 0, 0, 0]);
            let img = draw(&l, &camera).unwrap();
            for x in (0..320).step_by(16) {
                let wx = (x as f64 + 0.5 - 160.0) / 40.0;
                let top = -(r as f64) + ((r as f64).powi(2) - wx * wx).sqrt();
                let row = 100.0 - top * 40.0;
                // the first pixel nearer the circle's colour than the background's
                let near = |p: [u8; 4], q: [u8; 4]| -> u32 {
                    (0..3).map(|c| p[c].abs_diff(q[c]) as u32).sum()
                };
                let first = (0..200)
                    .find(|&y| {
                        let p = img.get_pixel(x, y).0;
                        near(p, blue) < near(p, l.background)
                    })
                    .expect("the circle shows");
                assert!(
                    (first as f64 + 0.5 - row).abs() <= 1.0,
                    "r {r}: column {x}: circle from row {first}, expected {row:.2}"
                );
            }
        }
    }
}
