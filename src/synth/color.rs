//! sRGB transfer functions (IEC 61966-2-1), shared by the synthetic renderer and anyone else
//! who needs to move between linear light and sRGB-encoded values on the CPU.
//!
//! Both curves are the exact piecewise definitions of the standard (a linear toe plus a 2.4
//! power segment), not the 2.2 gamma approximation, so that CPU references agree with what
//! Vulkan's `*_SRGB` formats do when they decode before filtering.

/// Linear light → sRGB-encoded value (both nominally in [0, 1]).
///
/// Values outside [0, 1] follow the same formulas (negative values stay on the linear toe);
/// clamp before quantising. NaN stays NaN.
pub fn linear_to_srgb(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB-encoded value → linear light (both nominally in [0, 1]); the inverse of
/// [`linear_to_srgb`].
pub fn srgb_to_linear(encoded: f32) -> f32 {
    if encoded <= 0.040_45 {
        encoded / 12.92
    } else {
        ((encoded + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light → 8-bit sRGB with rounding to nearest. Out-of-range input saturates; NaN gives
/// 0 (a defined value rather than garbage).
pub fn encode_srgb8(linear: f32) -> u8 {
    let e = linear_to_srgb(linear).clamp(0.0, 1.0) * 255.0;
    // `as u8` saturates and maps NaN to 0, so this cannot panic or wrap.
    e.round() as u8
}

/// 8-bit sRGB → linear light.
pub fn decode_srgb8(encoded: u8) -> f32 {
    srgb_to_linear(encoded as f32 / 255.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        assert!((linear_to_srgb(0.5) - 0.735_356_9).abs() < 1e-6);
        assert!((srgb_to_linear(0.735_356_9) - 0.5).abs() < 1e-6);
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // On the linear toe.
        assert!((linear_to_srgb(0.001) - 0.012_92).abs() < 1e-7);
        // 18 % grey is about 46 % encoded (118/255).
        assert_eq!(encode_srgb8(0.18), 118);
    }

    #[test]
    fn curves_are_continuous_at_the_breakpoints() {
        let a = 0.003_130_8_f32;
        assert!((linear_to_srgb(a) - linear_to_srgb(a * (1.0 + 1e-6))).abs() < 1e-5);
        let b = 0.040_45_f32;
        assert!((srgb_to_linear(b) - srgb_to_linear(b * (1.0 + 1e-6))).abs() < 1e-5);
    }

    #[test]
    fn round_trips() {
        for v in 0..=255u8 {
            assert_eq!(encode_srgb8(decode_srgb8(v)), v, "8-bit value {v}");
        }
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            assert!(
                (srgb_to_linear(linear_to_srgb(x)) - x).abs() < 2e-6,
                "x = {x}"
            );
        }
    }

    #[test]
    fn quantisation_saturates_and_handles_nan() {
        assert_eq!(encode_srgb8(-1.0), 0);
        assert_eq!(encode_srgb8(7.0), 255);
        assert_eq!(encode_srgb8(f32::NAN), 0);
    }
}
