//! An indexed-colour raster with the few drawing operations previews need, written out as PNG or GIF frames.

use super::font::{ink, GLYPH_H, GLYPH_W};

/// The fixed palette (RGB); indices are the `Color` constants.
pub const PALETTE: [[u8; 3]; 14] = [
    [255, 255, 255], // white
    [20, 20, 20],    // ink
    [150, 150, 150], // grey
    [225, 225, 225], // light grey
    [40, 90, 200],   // left limbs
    [210, 50, 40],   // right limbs
    [245, 150, 20],  // beat orange
    [60, 60, 60],    // centre limbs
    [250, 235, 205], // beat highlight
    [30, 150, 80],   // green
    [130, 60, 170],  // purple
    [20, 150, 160],  // teal
    [140, 90, 40],   // brown
    [220, 90, 160],  // pink
];

pub type Color = u8;
pub const WHITE: Color = 0;
pub const INK: Color = 1;
pub const GREY: Color = 2;
pub const LIGHT: Color = 3;
pub const LEFT: Color = 4;
pub const RIGHT: Color = 5;
pub const ORANGE: Color = 6;
pub const CENTRE: Color = 7;
pub const HIGHLIGHT: Color = 8;
pub const GREEN: Color = 9;
pub const PURPLE: Color = 10;
pub const TEAL: Color = 11;
pub const BROWN: Color = 12;
pub const PINK: Color = 13;
/// Distinct colours for plot series, in order.
pub const SERIES: [Color; 8] = [LEFT, RIGHT, GREEN, ORANGE, PURPLE, TEAL, BROWN, PINK];

#[derive(Debug, Clone)]
pub struct Canvas {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Color>,
}

impl Canvas {
    pub fn new(width: usize, height: usize, bg: Color) -> Self {
        Canvas {
            width,
            height,
            pixels: vec![bg; width * height],
        }
    }

    pub fn set(&mut self, x: i64, y: i64, c: Color) {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            self.pixels[y as usize * self.width + x as usize] = c;
        }
    }

    pub fn fill_rect(&mut self, x0: i64, y0: i64, w: i64, h: i64, c: Color) {
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                self.set(x, y, c);
            }
        }
    }

    pub fn rect(&mut self, x0: i64, y0: i64, w: i64, h: i64, thick: i64, c: Color) {
        self.fill_rect(x0, y0, w, thick, c);
        self.fill_rect(x0, y0 + h - thick, w, thick, c);
        self.fill_rect(x0, y0, thick, h, c);
        self.fill_rect(x0 + w - thick, y0, thick, h, c);
    }

    /// A line of the given width (pixels within width/2 of the segment).
    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), width: f64, c: Color) {
        let r = (width / 2.0).max(0.5);
        let (x0, x1) = (a.0.min(b.0) - r, a.0.max(b.0) + r);
        let (y0, y1) = (a.1.min(b.1) - r, a.1.max(b.1) + r);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        for y in y0.floor() as i64..=y1.ceil() as i64 {
            for x in x0.floor() as i64..=x1.ceil() as i64 {
                let (px, py) = (x as f64 + 0.5 - a.0, y as f64 + 0.5 - a.1);
                let t = if len2 > 0.0 {
                    ((px * dx + py * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (px - t * dx, py - t * dy);
                if ex * ex + ey * ey <= r * r {
                    self.set(x, y, c);
                }
            }
        }
    }

    pub fn disc(&mut self, centre: (f64, f64), radius: f64, c: Color) {
        self.line(centre, centre, 2.0 * radius, c);
    }

    /// Text with its top-left corner at (x, y); `scale` pixels per font pixel.
    pub fn text(&mut self, x: i64, y: i64, s: &str, scale: i64, c: Color) {
        for (i, ch) in s.chars().enumerate() {
            let gx = x + i as i64 * (GLYPH_W as i64 + 1) * scale;
            for row in 0..GLYPH_H {
                for col in 0..GLYPH_W {
                    if ink(ch, row, col) {
                        self.fill_rect(
                            gx + col as i64 * scale,
                            y + row as i64 * scale,
                            scale,
                            scale,
                            c,
                        );
                    }
                }
            }
        }
    }

    pub fn text_width(s: &str, scale: i64) -> i64 {
        s.chars().count() as i64 * (GLYPH_W as i64 + 1) * scale
    }

    /// Copy `other` into this canvas at (x, y).
    pub fn blit(&mut self, other: &Canvas, x: i64, y: i64) {
        for oy in 0..other.height {
            for ox in 0..other.width {
                self.set(
                    x + ox as i64,
                    y + oy as i64,
                    other.pixels[oy * other.width + ox],
                );
            }
        }
    }

    /// Encode as an indexed-colour PNG.
    pub fn to_png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
            enc.set_color(png::ColorType::Indexed);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_palette(PALETTE.iter().flatten().copied().collect::<Vec<u8>>());
            let mut w = enc.write_header().expect("in-memory PNG header");
            w.write_image_data(&self.pixels)
                .expect("in-memory PNG data");
        }
        out
    }
}
