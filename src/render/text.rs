//! Text drawn into off-screen frames (`render --compare`'s pane labels): lines of the
//! Hack monospace font (the one egui's window uses for code, compiled into the program
//! from `epaint_default_fonts`) rasterised by `ab_glyph` on the CPU and blended,
//! anti-aliased, into an [`image::RgbaImage`].

use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use image::RgbaImage;

/// The font: Hack Regular, parsed once.
fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| {
        FontRef::try_from_slice(epaint_default_fonts::HACK_REGULAR)
            .expect("the compiled-in Hack font parses")
    })
}

/// The distance from one line's top to the next's at `px` pixels (the font's ascent,
/// descent and line gap, rounded up to whole pixels).
pub fn line_height(px: f32) -> u32 {
    let f = font().as_scaled(PxScale::from(px));
    (f.ascent() - f.descent() + f.line_gap()).ceil().max(1.0) as u32
}

/// The width in pixels of `text` at `px` pixels: its glyphs' advances and kerning.
pub fn line_width(text: &str, px: f32) -> f32 {
    let f = font().as_scaled(PxScale::from(px));
    let mut w = 0.0;
    let mut prev = None;
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = prev {
            w += f.kern(p, id);
        }
        w += f.h_advance(id);
        prev = Some(id);
    }
    w
}

/// The size in pixels of `lines` drawn at `px` pixels: the widest line by the lines'
/// heights.
pub fn text_size(lines: &[String], px: f32) -> [u32; 2] {
    let w = lines.iter().map(|l| line_width(l, px)).fold(0.0, f32::max);
    [w.ceil() as u32, lines.len() as u32 * line_height(px)]
}

/// Draws `text` at `px` pixels (the font's height, ascent to descent) with the top of its line at (`x`, `y`) in `color` (sRGB,
/// straight alpha): each pixel blended with the glyphs' coverage of it, so edges are
/// anti-aliased; what falls outside the image is clipped.
pub fn draw_text(img: &mut RgbaImage, x: f32, y: f32, px: f32, color: [u8; 4], text: &str) {
    let scale = PxScale::from(px);
    let f = font().as_scaled(scale);
    let baseline = y + f.ascent();
    let mut caret = x;
    let mut prev = None;
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = prev {
            caret += f.kern(p, id);
        }
        prev = Some(id);
        let glyph = id.with_scale_and_position(scale, point(caret, baseline));
        caret += f.h_advance(id);
        let Some(outline) = font().outline_glyph(glyph) else {
            continue; // a space
        };
        let bounds = outline.px_bounds();
        let (x0, y0) = (bounds.min.x as i64, bounds.min.y as i64);
        outline.draw(|gx, gy, coverage| {
            let alpha = (coverage.clamp(0.0, 1.0) * f32::from(color[3])).round() as u8;
            blend(
                img,
                x0 + i64::from(gx),
                y0 + i64::from(gy),
                [color[0], color[1], color[2], alpha],
            );
        });
    }
}

/// Blends `color` (sRGB, straight alpha) over one pixel, if it lies in the image; the
/// pixel ends opaque.
fn blend(img: &mut RgbaImage, x: i64, y: i64, color: [u8; 4]) {
    if x < 0 || y < 0 || x >= i64::from(img.width()) || y >= i64::from(img.height()) {
        return;
    }
    let p = img.get_pixel_mut(x as u32, y as u32);
    let a = u32::from(color[3]);
    for (out, &c) in p.0.iter_mut().zip(&color).take(3) {
        let under = u32::from(*out);
        *out = ((u32::from(c) * a + under * (255 - a) + 127) / 255) as u8;
    }
    p.0[3] = 255;
}

/// Blends `color` (sRGB, straight alpha) over the rectangle, clipped to the image.
pub fn fill_rect(img: &mut RgbaImage, x: i64, y: i64, w: u32, h: u32, color: [u8; 4]) {
    let x0 = x.clamp(0, i64::from(img.width()));
    let y0 = y.clamp(0, i64::from(img.height()));
    let x1 = (x + i64::from(w)).clamp(0, i64::from(img.width()));
    let y1 = (y + i64::from(h)).clamp(0, i64::from(img.height()));
    for py in y0..y1 {
        for px in x0..x1 {
            blend(img, px, py, color);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_font_is_monospaced_and_sized_by_its_px() {
        // Hack: every character advances the same, about 0.6 em
        let one = line_width("m", 20.0);
        assert!((line_width("i", 20.0) - one).abs() < 1e-3);
        assert!((line_width("0.25 mm", 20.0) - 7.0 * one).abs() < 1e-2);
        assert!((10.0..14.0).contains(&one), "advance {one} px at 20 px");
        // lines a little taller than the size, in proportion to it
        let h = line_height(20.0);
        assert!((20..28).contains(&h), "line height {h}");
        assert!(line_height(40.0).abs_diff(2 * h) <= 2);
        let lines = vec!["ab".to_owned(), "abcd".to_owned()];
        assert_eq!(text_size(&lines, 20.0), [(4.0 * one).ceil() as u32, 2 * h]);
    }

    #[test]
    fn text_is_anti_aliased_and_drawn_where_it_is_measured() {
        let lines = vec!["pgs 0.25 mm".to_owned()];
        let px = 16.0;
        let [w, h] = text_size(&lines, px);
        let mut img = RgbaImage::from_pixel(w + 20, h + 20, image::Rgba([0, 0, 0, 255]));
        draw_text(&mut img, 10.0, 10.0, px, [255, 255, 255, 255], &lines[0]);
        let lit: Vec<(u32, u32, u8)> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0[0] > 0)
            .map(|(x, y, p)| (x, y, p.0[0]))
            .collect();
        assert!(lit.len() > 50, "{} pixels lit", lit.len());
        // inside the measured box (one pixel of slack for the edges' coverage)
        assert!(
            lit.iter()
                .all(|&(x, y, _)| (9..11 + w).contains(&x) && (9..11 + h).contains(&y)),
            "a pixel outside {w}x{h} at (10, 10)"
        );
        // edges partly covered: many shades between black and white, and full white
        let mut shades: Vec<u8> = lit.iter().map(|&(_, _, v)| v).collect();
        shades.sort_unstable();
        shades.dedup();
        assert!(shades.len() > 20, "{} shades", shades.len());
        assert!(lit.iter().any(|&(_, _, v)| v == 255));
        // every pixel stays grey (the colour's channels blended alike) and opaque
        assert!(img.pixels().all(|p| p.0[0] == p.0[1] && p.0[3] == 255));
    }

    #[test]
    fn drawing_past_the_edges_is_clipped() {
        let mut img = RgbaImage::new(30, 12);
        draw_text(&mut img, 20.0, -8.0, 24.0, [255, 0, 0, 255], "mmm");
        draw_text(&mut img, -50.0, 5.0, 24.0, [255, 0, 0, 255], "mmm");
        fill_rect(&mut img, -5, -5, 100, 8, [0, 255, 0, 128]);
        assert!(img.get_pixel(29, 0).0[1] > 100);
    }
}
