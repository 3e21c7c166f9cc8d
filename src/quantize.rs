//! Float frames to 8-bit images.

/// Converts premultiplied float RGBA to 8-bit. `straight` divides colour by
/// alpha (unassociated output); values are clamped to [0, 1] and rounded.
pub fn to_u8(rgba: &[f32], straight: bool, out: &mut [u8]) {
    let q = |v: f32| -> u8 {
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        (v * 255.0 + 0.5) as u8
    };
    for (px, o) in rgba.chunks_exact(4).zip(out.chunks_exact_mut(4)) {
        let a = px[3];
        let s = if straight && a > 0.0 { 1.0 / a } else { 1.0 };
        o[0] = q(px[0] * s);
        o[1] = q(px[1] * s);
        o[2] = q(px[2] * s);
        o[3] = q(a);
    }
}

#[cfg(test)]
mod tests {
    use super::to_u8;

    #[test]
    fn rounds_clamps_and_unassociates() {
        let mut out = [0u8; 8];
        to_u8(&[0.25, 0.5, f32::NAN, 0.5, 2.0, -1.0, 0.0, 1.0], true, &mut out);
        assert_eq!(out, [128, 255, 0, 128, 255, 0, 0, 255]);
        to_u8(&[0.25, 0.5, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0], false, &mut out);
        assert_eq!(out, [64, 128, 0, 128, 0, 0, 0, 0]);
    }
}
