//! Procedural textures, evaluated in linear-light RGB at texture coordinates (u, v) ∈ [0, 1]²
//! (u to the right along a quad's `half_u`, v along `half_v`, which the built-in scenes point
//! downwards in the image so that text reads upright).
//!
//! Everything is deterministic: pseudo-randomness comes from an integer hash of lattice
//! coordinates and a seed, never from an RNG, so a scene renders bit-identically everywhere.
//! Textures are point-sampled; anti-aliasing is the renderer's supersampling.

use glam::DVec2;

/// A linear-light RGB colour.
pub type Rgb = [f32; 3];

/// A procedural texture.
#[derive(Debug, Clone, PartialEq)]
pub enum Texture {
    /// One colour everywhere (tests of edges and coverage).
    Solid(Rgb),
    /// Two-colour checkerboard with `cells_u × cells_v` cells; cell (0, 0) has colour `a`.
    Checker {
        cells_u: u32,
        cells_v: u32,
        a: Rgb,
        b: Rgb,
    },
    /// Seven vertical colour bars (white, yellow, cyan, green, magenta, red, blue) over the top
    /// 70 %, and `stripes` black/white stripe pairs across the bottom 30 % (fine, high-contrast
    /// vertical edges that show focus at a glance).
    ColourBars { stripes: u32 },
    /// A "poster" with fine detail: paper with two octaves of value noise at `grain` cells per
    /// unit (fine grain everywhere), a thin ink frame, bold 5×7 block letters of `text` across
    /// the top (letters without a glyph are blank), and `rings` concentric black/paper ring
    /// pairs in a disk below (`rings = 0`: none).
    Detail {
        seed: u32,
        grain: u32,
        rings: u32,
        text: String,
        paper: Rgb,
        ink: Rgb,
    },
    /// A brick wall: `rows` courses of `cols` bricks, odd courses offset by half a brick, bricks
    /// varying in shade per brick and grained, separated by `mortar`.
    Bricks {
        rows: u32,
        cols: u32,
        seed: u32,
        brick: Rgb,
        mortar: Rgb,
    },
}

/// The colour bars of [`Texture::ColourBars`], linear light at 75 % (the broadcast convention,
/// which keeps them from looking garish).
const BARS: [Rgb; 7] = [
    [0.75, 0.75, 0.75],
    [0.75, 0.75, 0.0],
    [0.0, 0.75, 0.75],
    [0.0, 0.75, 0.0],
    [0.75, 0.0, 0.75],
    [0.75, 0.0, 0.0],
    [0.0, 0.0, 0.75],
];

impl Texture {
    /// Colour at texture coordinates `uv` (clamped to [0, 1]²; NaN reads as 0).
    pub fn eval(&self, uv: DVec2) -> Rgb {
        let u = clamp01(uv.x);
        let v = clamp01(uv.y);
        match self {
            Texture::Solid(c) => *c,
            Texture::Checker {
                cells_u,
                cells_v,
                a,
                b,
            } => {
                let iu = (u * (*cells_u).max(1) as f64).floor() as i64;
                let iv = (v * (*cells_v).max(1) as f64).floor() as i64;
                if (iu + iv).rem_euclid(2) == 0 {
                    *a
                } else {
                    *b
                }
            }
            Texture::ColourBars { stripes } => {
                if v < 0.7 {
                    let i = ((u * BARS.len() as f64).floor() as usize).min(BARS.len() - 1);
                    BARS[i]
                } else {
                    let k = (u * 2.0 * (*stripes).max(1) as f64).floor() as i64;
                    if k.rem_euclid(2) == 0 {
                        [0.9; 3]
                    } else {
                        [0.01; 3]
                    }
                }
            }
            Texture::Detail {
                seed,
                grain,
                rings,
                text,
                paper,
                ink,
            } => detail(u, v, *seed, *grain, *rings, text, *paper, *ink),
            Texture::Bricks {
                rows,
                cols,
                seed,
                brick,
                mortar,
            } => bricks(u, v, *rows, *cols, *seed, *brick, *mortar),
        }
    }
}

fn clamp01(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

fn scale(c: Rgb, s: f32) -> Rgb {
    [c[0] * s, c[1] * s, c[2] * s]
}

/// A 32-bit integer hash of a lattice point and a seed (multiply–xorshift finaliser), well
/// mixed enough that neighbouring cells look independent.
fn hash3(x: u32, y: u32, seed: u32) -> u32 {
    let mut h = x.wrapping_mul(0x8da6_b343)
        ^ y.wrapping_mul(0xd816_3841)
        ^ seed.wrapping_mul(0xcb1a_b31f).wrapping_add(0x9e37_79b9);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    h
}

/// Hash → [0, 1).
fn unit(h: u32) -> f64 {
    (h >> 8) as f64 / (1u32 << 24) as f64
}

/// Value noise in [0, 1): hashed lattice values at `cells` cells per unit, smoothstep-blended.
fn value_noise(u: f64, v: f64, cells: f64, seed: u32) -> f64 {
    let x = u * cells;
    let y = v * cells;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    // Wrapping casts: the lattice index only feeds the hash, so wrap-around is harmless.
    let (ix, iy) = (x0 as i64 as u32, y0 as i64 as u32);
    let h = |dx: u32, dy: u32| unit(hash3(ix.wrapping_add(dx), iy.wrapping_add(dy), seed));
    let top = h(0, 0) + (h(1, 0) - h(0, 0)) * sx;
    let bottom = h(0, 1) + (h(1, 1) - h(0, 1)) * sx;
    top + (bottom - top) * sy
}

#[allow(clippy::too_many_arguments)]
fn detail(
    u: f64,
    v: f64,
    seed: u32,
    grain: u32,
    rings: u32,
    text: &str,
    paper: Rgb,
    ink: Rgb,
) -> Rgb {
    // Frame: a sharp ink border marks the quad's outline.
    let frame = 0.015;
    if u < frame || u > 1.0 - frame || v < frame || v > 1.0 - frame {
        return ink;
    }
    if text_ink(u, v, text) {
        return ink;
    }
    if rings > 0 {
        let (du, dv) = (u - 0.5, v - 0.62);
        let r = (du * du + dv * dv).sqrt();
        let radius = 0.3;
        if r < radius {
            let phase = r / radius * rings as f64;
            if phase.fract() < 0.5 {
                return ink;
            }
        }
    }
    let g = grain.max(1) as f64;
    let n = 0.6 * value_noise(u, v, g, seed) + 0.4 * value_noise(u, v, 2.0 * g, seed ^ 0x5bd1);
    // Grain modulates brightness between 65 % and 100 % of the paper colour.
    scale(paper, (0.65 + 0.35 * n) as f32)
}

/// Whether (u, v) falls on a lit cell of the block letters of `text`, laid out as one line of
/// bold 5×7 glyphs (each stroke doubled to the right, so 6 columns wide, plus one blank column
/// between letters) centred in the band u ∈ [0.1, 0.9], v ∈ [0.07, 0.29].
fn text_ink(u: f64, v: f64, text: &str) -> bool {
    let n = text.chars().count();
    if n == 0 {
        return false;
    }
    let columns = 7 * n - 1;
    let cell = (0.8 / columns as f64).min(0.22 / 7.0);
    let u0 = 0.5 - cell * columns as f64 / 2.0;
    let v0 = 0.18 - cell * 3.5;
    let cu = ((u - u0) / cell).floor();
    let cv = ((v - v0) / cell).floor();
    if cu < 0.0 || cv < 0.0 || cu >= columns as f64 || cv >= 7.0 {
        return false;
    }
    let (cu, cv) = (cu as usize, cv as usize);
    let (letter, col) = (cu / 7, cu % 7);
    if col == 6 {
        return false;
    }
    match text.chars().nth(letter).and_then(glyph) {
        Some(rows) => {
            // Bold: column `col` is lit if the glyph has ink there or one column to the left.
            let bits = ((rows[cv] << 1) | rows[cv]) as u32;
            bits & (0b10_0000 >> col) != 0
        }
        None => false,
    }
}

/// A 5×7 bitmap glyph, rows top to bottom, bit 4 the leftmost column. Only the letters the
/// built-in scenes and typical labels need; others render blank.
fn glyph(c: char) -> Option<[u8; 7]> {
    let g = match c.to_ascii_uppercase() {
        'A' => [0x0e, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11],
        'C' => [0x0e, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0e],
        'D' => [0x1e, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1e],
        'E' => [0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x1f],
        'F' => [0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x10],
        'H' => [0x11, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11],
        'I' => [0x0e, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0e],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1f],
        'M' => [0x11, 0x1b, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x19, 0x15, 0x13, 0x11, 0x11, 0x11],
        'O' => [0x0e, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e],
        'R' => [0x1e, 0x11, 0x11, 0x1e, 0x14, 0x12, 0x11],
        'S' => [0x0f, 0x10, 0x10, 0x0e, 0x01, 0x01, 0x1e],
        'T' => [0x1f, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e],
        _ => return None,
    };
    Some(g)
}

fn bricks(u: f64, v: f64, rows: u32, cols: u32, seed: u32, brick: Rgb, mortar: Rgb) -> Rgb {
    let (rows, cols) = (rows.max(1) as f64, cols.max(1) as f64);
    let y = v * rows;
    let row = y.floor();
    let fy = y - row;
    let offset = if (row as i64).rem_euclid(2) == 1 {
        0.5
    } else {
        0.0
    };
    let x = u * cols + offset;
    let col = x.floor();
    let fx = x - col;
    // Mortar joints: 8 % of a course high; the vertical joints are as thick in u as the
    // horizontal ones are in v relative to the brick size, which looks right for bricks about
    // twice as wide as tall.
    let joint = 0.08;
    if fy < joint || fx < joint * 0.5 {
        return mortar;
    }
    let h = hash3(col as i64 as u32, row as i64 as u32, seed);
    let shade = 0.7 + 0.5 * unit(h);
    let g = value_noise(u, v, 12.0 * cols, seed ^ 0xa511);
    scale(brick, (shade * (0.8 + 0.3 * g)) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t: &Texture, u: f64, v: f64) -> Rgb {
        t.eval(DVec2::new(u, v))
    }

    #[test]
    fn checker_alternates() {
        let t = Texture::Checker {
            cells_u: 4,
            cells_v: 2,
            a: [1.0; 3],
            b: [0.0; 3],
        };
        assert_eq!(at(&t, 0.1, 0.1), [1.0; 3]);
        assert_eq!(at(&t, 0.3, 0.1), [0.0; 3]);
        assert_eq!(at(&t, 0.1, 0.6), [0.0; 3]);
        assert_eq!(at(&t, 0.3, 0.6), [1.0; 3]);
        // Boundaries and out-of-range coordinates are defined.
        assert_eq!(at(&t, 1.0, 1.0), at(&t, 0.99, 0.99));
        assert_eq!(at(&t, -3.0, f64::NAN), at(&t, 0.0, 0.0));
    }

    #[test]
    fn colour_bars_and_stripes() {
        let t = Texture::ColourBars { stripes: 10 };
        assert_eq!(at(&t, 0.01, 0.1), BARS[0]);
        assert_eq!(at(&t, 0.99, 0.1), BARS[6]);
        assert_eq!(at(&t, 1.0, 0.1), BARS[6]);
        assert_ne!(at(&t, 0.01, 0.9), at(&t, 0.06, 0.9));
    }

    #[test]
    fn detail_has_fine_features_and_text() {
        let t = Texture::Detail {
            seed: 3,
            grain: 200,
            rings: 10,
            text: "TILT".into(),
            paper: [0.8; 3],
            ink: [0.0; 3],
        };
        // Frame.
        assert_eq!(at(&t, 0.005, 0.5), [0.0; 3]);
        // Fine features: sampling on a 1/512 step finds many distinct values in a small area.
        let mut distinct = std::collections::BTreeSet::new();
        for i in 0..64 {
            let c = at(&t, 0.2 + i as f64 / 512.0, 0.95);
            distinct.insert((c[0] * 1e6) as i64);
        }
        assert!(distinct.len() > 30, "{} distinct values", distinct.len());
        // Some ink in the text band, and some paper too.
        let band: Vec<Rgb> = (0..200)
            .map(|i| at(&t, 0.1 + 0.8 * i as f64 / 200.0, 0.18))
            .collect();
        assert!(band.contains(&[0.0; 3]));
        assert!(band.iter().any(|c| c[0] > 0.3));
        // Rings alternate along a radius.
        let ring: Vec<bool> = (0..100)
            .map(|i| at(&t, 0.5 + 0.29 * i as f64 / 100.0, 0.62) == [0.0; 3])
            .collect();
        let switches = ring.windows(2).filter(|w| w[0] != w[1]).count();
        assert!(switches >= 15, "{switches} ring edges");
    }

    #[test]
    fn bricks_have_mortar_and_varying_bricks() {
        let t = Texture::Bricks {
            rows: 10,
            cols: 5,
            seed: 1,
            brick: [0.5, 0.2, 0.1],
            mortar: [0.6; 3],
        };
        assert_eq!(at(&t, 0.5, 0.001), [0.6; 3]);
        assert_ne!(at(&t, 0.1, 0.05), at(&t, 0.5, 0.05));
    }

    #[test]
    fn hash_is_deterministic_and_spread() {
        assert_eq!(hash3(1, 2, 3), hash3(1, 2, 3));
        let mean: f64 = (0..10_000).map(|i| unit(hash3(i, 7, 0))).sum::<f64>() / 10_000.0;
        assert!((mean - 0.5).abs() < 0.02, "mean {mean}");
    }
}
