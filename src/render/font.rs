//! A small bitmap font for labels drawn into off-screen frames (`render --compare`):
//! 5x7 pixel glyphs in a 6x9 cell, scaled by whole pixels, drawn on the CPU into an
//! [`image::RgbaImage`]. Digits, lower-case letters and the punctuation of settings and
//! figures; upper-case letters are drawn as lower-case, anything else as `?`.

use image::RgbaImage;

/// Glyph width in font pixels.
const GLYPH_W: u32 = 5;
/// Glyph height in font pixels.
const GLYPH_H: u32 = 7;
/// The advance from one character to the next (font pixels).
pub const CELL_W: u32 = GLYPH_W + 1;
/// The advance from one line to the next (font pixels).
pub const CELL_H: u32 = GLYPH_H + 2;

/// Each glyph as 7 rows of 5 cells, `#` set.
#[rustfmt::skip]
const GLYPHS: &[(char, [&str; 7])] = &[
    ('0', [".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."]),
    ('1', ["..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."]),
    ('2', [".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"]),
    ('3', ["#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###."]),
    ('4', ["...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."]),
    ('5', ["#####", "#....", "####.", "....#", "....#", "#...#", ".###."]),
    ('6', ["..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."]),
    ('7', ["#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."]),
    ('8', [".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."]),
    ('9', [".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."]),
    ('a', [".....", ".....", ".###.", "....#", ".####", "#...#", ".####"]),
    ('b', ["#....", "#....", "#.##.", "##..#", "#...#", "#...#", "####."]),
    ('c', [".....", ".....", ".###.", "#....", "#....", "#...#", ".###."]),
    ('d', ["....#", "....#", ".##.#", "#..##", "#...#", "#...#", ".####"]),
    ('e', [".....", ".....", ".###.", "#...#", "#####", "#....", ".###."]),
    ('f', ["..##.", ".#..#", ".#...", "###..", ".#...", ".#...", ".#..."]),
    ('g', [".....", ".####", "#...#", "#...#", ".####", "....#", ".###."]),
    ('h', ["#....", "#....", "#.##.", "##..#", "#...#", "#...#", "#...#"]),
    ('i', ["..#..", ".....", ".##..", "..#..", "..#..", "..#..", ".###."]),
    ('j', ["...#.", ".....", "..##.", "...#.", "...#.", "#..#.", ".##.."]),
    ('k', ["#....", "#....", "#..#.", "#.#..", "##...", "#.#..", "#..#."]),
    ('l', [".##..", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."]),
    ('m', [".....", ".....", "##.#.", "#.#.#", "#.#.#", "#...#", "#...#"]),
    ('n', [".....", ".....", "#.##.", "##..#", "#...#", "#...#", "#...#"]),
    ('o', [".....", ".....", ".###.", "#...#", "#...#", "#...#", ".###."]),
    ('p', [".....", ".....", "####.", "#...#", "####.", "#....", "#...."]),
    ('q', [".....", ".....", ".##.#", "#..##", ".####", "....#", "....#"]),
    ('r', [".....", ".....", "#.##.", "##..#", "#....", "#....", "#...."]),
    ('s', [".....", ".....", ".####", "#....", ".###.", "....#", "####."]),
    ('t', [".#...", ".#...", "###..", ".#...", ".#...", ".#..#", "..##."]),
    ('u', [".....", ".....", "#...#", "#...#", "#...#", "#..##", ".##.#"]),
    ('v', [".....", ".....", "#...#", "#...#", "#...#", ".#.#.", "..#.."]),
    ('w', [".....", ".....", "#...#", "#...#", "#.#.#", "#.#.#", ".#.#."]),
    ('x', [".....", ".....", "#...#", ".#.#.", "..#..", ".#.#.", "#...#"]),
    ('y', [".....", ".....", "#...#", "#...#", ".####", "....#", ".###."]),
    ('z', [".....", ".....", "#####", "...#.", "..#..", ".#...", "#####"]),
    (' ', [".....", ".....", ".....", ".....", ".....", ".....", "....."]),
    ('-', [".....", ".....", ".....", ".###.", ".....", ".....", "....."]),
    ('.', [".....", ".....", ".....", ".....", ".....", ".##..", ".##.."]),
    (',', [".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."]),
    (':', [".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."]),
    ('/', [".....", "....#", "...#.", "..#..", ".#...", "#....", "....."]),
    ('=', [".....", ".....", "#####", ".....", "#####", ".....", "....."]),
    ('+', [".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."]),
    ('%', ["##...", "##..#", "...#.", "..#..", ".#...", "#..##", "...##"]),
    ('(', ["...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."]),
    (')', [".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."]),
    ('[', [".###.", ".#...", ".#...", ".#...", ".#...", ".#...", ".###."]),
    (']', [".###.", "...#.", "...#.", "...#.", "...#.", "...#.", ".###."]),
    ('_', [".....", ".....", ".....", ".....", ".....", ".....", "#####"]),
    ('\'', ["..#..", "..#..", ".#...", ".....", ".....", ".....", "....."]),
    ('"', [".#.#.", ".#.#.", ".....", ".....", ".....", ".....", "....."]),
    ('!', ["..#..", "..#..", "..#..", "..#..", "..#..", ".....", "..#.."]),
    ('?', [".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.."]),
];

/// A glyph's rows, bit 4 the leftmost cell.
fn glyph(c: char) -> [u8; 7] {
    let c = c.to_ascii_lowercase();
    let rows = GLYPHS
        .iter()
        .find(|(g, _)| *g == c)
        .or_else(|| GLYPHS.iter().find(|(g, _)| *g == '?'))
        .map(|(_, rows)| rows)
        .expect("the font has '?'");
    let mut bits = [0u8; 7];
    for (b, row) in bits.iter_mut().zip(rows) {
        for (i, cell) in row.bytes().enumerate() {
            if cell == b'#' {
                *b |= 1 << (GLYPH_W as usize - 1 - i);
            }
        }
    }
    bits
}

/// The size in pixels of `lines` drawn at `scale`: the widest line's cells by the lines'.
pub fn text_size(lines: &[String], scale: u32) -> [u32; 2] {
    let cols = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32;
    [
        (cols * CELL_W).saturating_sub(1) * scale,
        (lines.len() as u32 * CELL_H).saturating_sub(2) * scale,
    ]
}

/// Draws `text` with its top-left corner at (`x`, `y`) in `color`, each font pixel a
/// `scale` by `scale` square; what falls outside the image is clipped.
pub fn draw_text(img: &mut RgbaImage, x: i64, y: i64, scale: u32, color: [u8; 4], text: &str) {
    let s = i64::from(scale.max(1));
    for (k, c) in text.chars().enumerate() {
        let gx = x + k as i64 * i64::from(CELL_W) * s;
        if gx >= i64::from(img.width()) {
            break;
        }
        for (row, bits) in glyph(c).iter().enumerate() {
            for col in 0..GLYPH_W as i64 {
                if bits & (1 << (GLYPH_W as i64 - 1 - col)) != 0 {
                    fill_rect(
                        img,
                        gx + col * s,
                        y + row as i64 * s,
                        s as u32,
                        s as u32,
                        color,
                    );
                }
            }
        }
    }
}

/// The lit font pixels of `text` (one line) as horizontal runs `[first column, end
/// column, row]`, in font pixels from the text's top-left corner: for drawing the text
/// as segments (the window's pane labels) instead of into an image.
pub fn text_runs(text: &str, out: &mut Vec<[u32; 3]>) {
    for (k, c) in text.chars().enumerate() {
        let x = k as u32 * CELL_W;
        for (row, bits) in glyph(c).iter().enumerate() {
            let mut col = 0;
            while col < GLYPH_W {
                if bits & (1 << (GLYPH_W - 1 - col)) == 0 {
                    col += 1;
                    continue;
                }
                let start = col;
                while col < GLYPH_W && bits & (1 << (GLYPH_W - 1 - col)) != 0 {
                    col += 1;
                }
                out.push([x + start, x + col, row as u32]);
            }
        }
    }
}

/// Blends `color` (sRGB, straight alpha) over the rectangle, clipped to the image.
pub fn fill_rect(img: &mut RgbaImage, x: i64, y: i64, w: u32, h: u32, color: [u8; 4]) {
    let x0 = x.clamp(0, i64::from(img.width())) as u32;
    let y0 = y.clamp(0, i64::from(img.height())) as u32;
    let x1 = (x + i64::from(w)).clamp(0, i64::from(img.width())) as u32;
    let y1 = (y + i64::from(h)).clamp(0, i64::from(img.height())) as u32;
    let a = u32::from(color[3]);
    for py in y0..y1 {
        for px in x0..x1 {
            let p = img.get_pixel_mut(px, py);
            for (out, &c) in p.0.iter_mut().zip(&color).take(3) {
                let under = u32::from(*out);
                *out = ((u32::from(c) * a + under * (255 - a) + 127) / 255) as u8;
            }
            p.0[3] = 255;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_glyph_is_5_by_7_and_known_once() {
        for (i, (c, rows)) in GLYPHS.iter().enumerate() {
            assert!(rows.iter().all(|r| r.len() == GLYPH_W as usize), "{c:?}");
            assert!(!GLYPHS[..i].iter().any(|(d, _)| d == c), "{c:?} twice");
        }
        assert_eq!(glyph('A'), glyph('a'));
        assert_eq!(glyph('~'), glyph('?'));
    }

    #[test]
    fn text_runs_cover_exactly_the_pixels_draw_text_lights() {
        let text = "soft 4: -0.31% ms/step";
        let [w, h] = text_size(&[text.to_owned()], 1);
        let mut img = RgbaImage::new(w + 2, h + 2);
        draw_text(&mut img, 0, 0, 1, [255, 255, 255, 255], text);
        let mut runs = Vec::new();
        text_runs(text, &mut runs);
        let mut from_runs = RgbaImage::new(w + 2, h + 2);
        for &[x0, x1, y] in &runs {
            assert!(x0 < x1, "empty run");
            for x in x0..x1 {
                assert_eq!(from_runs.get_pixel(x, y).0[0], 0, "pixel ({x}, {y}) twice");
                from_runs.put_pixel(x, y, image::Rgba([255, 255, 255, 255]));
            }
        }
        assert!(!runs.is_empty());
        assert_eq!(img, from_runs);
    }

    #[test]
    fn text_is_drawn_where_it_is_measured() {
        let mut img = RgbaImage::new(40, 20);
        let lines = vec!["a1".to_owned()];
        let [w, h] = text_size(&lines, 2);
        assert_eq!([w, h], [22, 14]);
        draw_text(&mut img, 1, 1, 2, [255, 255, 255, 255], "a1");
        let lit: Vec<(u32, u32)> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0[0] > 0)
            .map(|(x, y, _)| (x, y))
            .collect();
        assert!(!lit.is_empty());
        assert!(
            lit.iter()
                .all(|&(x, y)| (1..1 + w).contains(&x) && (1..1 + h).contains(&y))
        );
        // clipped, not a panic, past the edges
        draw_text(&mut img, 35, -3, 3, [255, 0, 0, 255], "mmm");
    }
}
