//! sRGB transfer functions (IEC 61966-2-1). Views are stored sRGB-encoded; tiltfield averages
//! in linear light unless asked to average the encoded values.

/// Encoded [0, 1] → linear [0, 1].
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear [0, 1] → encoded [0, 1].
pub fn linear_to_srgb(c: f64) -> f64 {
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear value of each 8-bit encoded level, for fast exact decoding of views.
pub fn decode_table() -> [f64; 256] {
    std::array::from_fn(|i| srgb_to_linear(i as f64 / 255.0))
}

/// Linear light → 8-bit sRGB with rounding to nearest; out-of-range input saturates and NaN
/// gives 0 (a defined value, never garbage). What the synthetic renderers store per pixel.
pub fn encode_srgb8(linear: f32) -> u8 {
    to_u8(linear_to_srgb(linear as f64))
}

/// Quantises [0, 1] to 8 bits with rounding (values outside are clamped, NaN gives 0).
pub fn to_u8(c: f64) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transfer_functions_are_inverse_and_match_known_values() {
        for i in 0..=100 {
            let c = i as f64 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-12);
        }
        assert!((linear_to_srgb(0.5) - 0.735_356_983_052_449_4).abs() < 1e-12);
        assert_eq!(to_u8(linear_to_srgb(1.0)), 255);
        assert_eq!(to_u8(-0.2), 0);
        assert_eq!(to_u8(f64::NAN), 0);
        // 18 % grey is about 46 % encoded (118/255).
        assert_eq!(encode_srgb8(0.18), 118);
        assert_eq!(encode_srgb8(f32::NAN), 0);
        assert_eq!(encode_srgb8(2.0), 255);
    }
}
