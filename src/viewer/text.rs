//! The on-screen text and marks: an RGBA canvas the size of the window, drawn on the CPU with
//! 8×8 bitmap glyphs (font8x8's public-domain Basic Latin and Latin-1 tables) and composited
//! over the panels with straight alpha. The canvas remembers which rows changed, so a frame
//! uploads only the status strip when only the status changed.

use font8x8::legacy::{BASIC_LEGACY, LATIN_LEGACY};

/// An sRGB-encoded RGBA colour with straight alpha.
pub type Rgba = [u8; 4];

pub const TEXT: Rgba = [235, 235, 235, 255];
pub const WARN: Rgba = [255, 190, 60, 255];
pub const PANEL_BG: Rgba = [16, 16, 20, 225];
pub const CLEAR: Rgba = [0, 0, 0, 0];

/// Width (and height) of a glyph at scale 1.
pub const GLYPH: u32 = 8;

/// A window-sized RGBA canvas.
#[derive(Debug, Clone)]
pub struct Canvas {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<u8>,
    dirty: Option<(u32, u32)>,
}

fn glyph(c: char) -> [u8; 8] {
    let code = c as u32;
    match code {
        0..=127 => BASIC_LEGACY[code as usize],
        0xA0..=0xFF => LATIN_LEGACY[(code - 0xA0) as usize],
        // Characters outside the tables: a few common ones by their ASCII look-alike.
        _ => match c {
            '−' | '–' => BASIC_LEGACY[b'-' as usize],
            '→' => BASIC_LEGACY[b'>' as usize],
            _ => BASIC_LEGACY[b'?' as usize],
        },
    }
}

impl Canvas {
    /// A transparent canvas, entirely dirty.
    pub fn new(width: u32, height: u32) -> Self {
        Canvas {
            width,
            height,
            pixels: vec![0; width as usize * height as usize * 4],
            dirty: Some((0, height)),
        }
    }

    fn touch(&mut self, y0: u32, y1: u32) {
        let (y0, y1) = (y0.min(self.height), y1.min(self.height));
        if y0 >= y1 {
            return;
        }
        self.dirty = Some(match self.dirty {
            Some((a, b)) => (a.min(y0), b.max(y1)),
            None => (y0, y1),
        });
    }

    /// The rows changed since the last call (start, end), and forgets them.
    pub fn take_dirty(&mut self) -> Option<(u32, u32)> {
        self.dirty.take()
    }

    /// Fills a rectangle (clipped to the canvas).
    pub fn fill(&mut self, x: i64, y: i64, w: i64, h: i64, colour: Rgba) {
        let x0 = x.clamp(0, self.width as i64) as u32;
        let x1 = (x + w).clamp(0, self.width as i64) as u32;
        let y0 = y.clamp(0, self.height as i64) as u32;
        let y1 = (y + h).clamp(0, self.height as i64) as u32;
        for yy in y0..y1 {
            let row = (yy * self.width) as usize * 4;
            for xx in x0..x1 {
                let i = row + xx as usize * 4;
                self.pixels[i..i + 4].copy_from_slice(&colour);
            }
        }
        self.touch(y0, y1);
    }

    /// Draws `text` with its top-left corner at (x, y), glyphs `scale` times 8 pixels; returns
    /// the width drawn.
    pub fn text(&mut self, x: i64, y: i64, scale: u32, text: &str, colour: Rgba) -> i64 {
        let s = scale.max(1) as i64;
        let mut cx = x;
        for c in text.chars() {
            let rows = glyph(c);
            for (gy, bits) in rows.iter().enumerate() {
                for gx in 0..8 {
                    if bits & (1 << gx) != 0 {
                        self.fill(cx + gx as i64 * s, y + gy as i64 * s, s, s, colour);
                    }
                }
            }
            cx += GLYPH as i64 * s;
        }
        cx - x
    }

    /// A cross of half-size `r` centred on (x, y), `thick` pixels wide.
    pub fn cross(&mut self, x: f64, y: f64, r: i64, colour: Rgba) {
        let (x, y) = (x.floor() as i64, y.floor() as i64);
        self.fill(x - r, y - 1, 2 * r + 1, 3, [0, 0, 0, 200]);
        self.fill(x - 1, y - r, 3, 2 * r + 1, [0, 0, 0, 200]);
        self.fill(x - r, y, 2 * r + 1, 1, colour);
        self.fill(x, y - r, 1, 2 * r + 1, colour);
    }

    /// The RGBA bytes of rows `y0..y1`.
    pub fn rows(&self, y0: u32, y1: u32) -> &[u8] {
        let w = self.width as usize * 4;
        &self.pixels[y0 as usize * w..y1 as usize * w]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_draws_glyph_pixels_and_tracks_dirty_rows() {
        let mut c = Canvas::new(64, 32);
        assert_eq!(c.take_dirty(), Some((0, 32)));
        assert_eq!(c.take_dirty(), None);
        let w = c.text(2, 10, 2, "I°", TEXT);
        assert_eq!(w, 32);
        assert_eq!(
            c.take_dirty().map(|(a, b)| (a >= 10, b <= 26)),
            Some((true, true))
        );
        let lit = c.pixels.chunks(4).filter(|p| p[3] == 255).count();
        // 'I' and '°' have lit pixels; each font pixel is 2×2 at scale 2.
        assert!(lit > 0 && lit % 4 == 0, "{lit}");
        // Nothing outside the glyph rows.
        assert!(c.rows(0, 10).iter().all(|&b| b == 0));
        // Entirely above the canvas: nothing changes.
        c.fill(-5, -5, 1000, 3, PANEL_BG);
        assert_eq!(c.take_dirty(), None);
        c.fill(-5, 0, 1000, 3, PANEL_BG);
        assert_eq!(c.take_dirty(), Some((0, 3)));
        assert_eq!(&c.pixels[..4], &PANEL_BG);
    }
}
