//! Float frames to 8-bit images.

/// Converts premultiplied float RGBA to 8-bit. `straight` divides colour by
/// alpha (unassociated output); values are clamped to [0, 1] and rounded.
pub fn to_u8(rgba: &[f32], straight: bool, out: &mut [u8]) {
    // Branch-free, so that the loop is vectorised: rounded (half up) and
    // clamped after scaling, which gives the same codes as clamping to
    // [0, 1] first; max(NaN, 0) is 0.
    let q = |v: f32| -> u8 { (v * 255.0 + 0.5).max(0.0).min(255.0) as u8 };
    for (px, o) in rgba.chunks_exact(4).zip(out.chunks_exact_mut(4)) {
        let a = px[3];
        let s = if straight && a > 0.0 { 1.0 / a } else { 1.0 };
        o[0] = q(px[0] * s);
        o[1] = q(px[1] * s);
        o[2] = q(px[2] * s);
        o[3] = q(a);
    }
}

/// `to_u8` on every core, in runs of whole pixels: a 2048x2048 frame took
/// 45-51 ms on one core of the 2-core VM, longer than the GPU's frame.
pub fn to_u8_parallel(rgba: &[f32], straight: bool, out: &mut [u8]) {
    const MIN_PIXELS: usize = 1 << 16;
    let pixels = rgba.len() / 4;
    let threads = crate::cores::cores().min(pixels / MIN_PIXELS).max(1);
    if threads == 1 {
        return to_u8(rgba, straight, out);
    }
    let run = pixels.div_ceil(threads) * 4;
    std::thread::scope(|s| {
        for (src, dst) in rgba.chunks(run).zip(out.chunks_mut(run)) {
            s.spawn(move || to_u8(src, straight, dst));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::{to_u8, to_u8_parallel};

    #[test]
    fn every_core_gives_the_codes_of_one() {
        // Pixels in runs that do not divide evenly, values around every code.
        let n = (1 << 18) + 3;
        let rgba: Vec<f32> = (0..4 * n).map(|i| ((i * 7919) % 1021) as f32 / 1000.0 - 0.01).collect();
        for straight in [false, true] {
            let (mut one, mut all) = (vec![0u8; 4 * n], vec![1u8; 4 * n]);
            to_u8(&rgba, straight, &mut one);
            to_u8_parallel(&rgba, straight, &mut all);
            assert!(one == all);
        }
    }

    #[test]
    fn rounds_clamps_and_unassociates() {
        let mut out = [0u8; 8];
        to_u8(&[0.25, 0.5, f32::NAN, 0.5, 2.0, -1.0, 0.0, 1.0], true, &mut out);
        assert_eq!(out, [128, 255, 0, 128, 255, 0, 0, 255]);
        to_u8(&[0.25, 0.5, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0], false, &mut out);
        assert_eq!(out, [64, 128, 0, 128, 0, 0, 0, 0]);
    }

    /// Clamping after scaling gives the codes of clamping to [0, 1] first,
    /// at every code's half-way point and around it.
    #[test]
    fn codes_are_those_of_clamping_first() {
        let first = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        let mut values: Vec<f32> = (0..=120_000).map(|k| -0.1 + 1.2 * k as f32 / 120_000.0).collect();
        for c in 0..=256 {
            let mid = (c as f32 - 0.5) / 255.0;
            values.extend([mid, f32::from_bits(mid.to_bits() + 1), f32::from_bits(mid.to_bits().wrapping_sub(1))]);
        }
        values.extend([f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, 1e-45, -1e-45]);
        let rgba: Vec<f32> = values.iter().flat_map(|&v| [v, v, v, v]).collect();
        let mut out = vec![0u8; rgba.len()];
        to_u8(&rgba, false, &mut out);
        for (v, px) in values.iter().zip(out.chunks_exact(4)) {
            assert_eq!(px, [first(*v); 4], "{v}");
        }
    }
}
