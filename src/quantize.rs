//! Premultiplied float frames as `render` returns them: 8-bit codes, or
//! float straight colour.

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

/// Straight colour from premultiplied, in place, as numpy's
/// `clip(where(a > 0, c / a, c), 0, 1)` gives it bit for bit: colour over
/// alpha where alpha is above 0, kept where not (nothing there, or the
/// emission model's additive glow), then clamped to [0, 1].
/// Alpha is left as it is.
pub fn straighten(rgba: &mut [f32]) {
    for px in rgba.chunks_exact_mut(4) {
        let a = px[3];
        // (clamp, as numpy's clip, keeps NaN and -0.)
        let c: [f32; 3] = std::array::from_fn(|k| (if a > 0.0 { px[k] / a } else { px[k] }).clamp(0.0, 1.0));
        // Written only where it changes: a frame's empty pixels may lie in
        // pages never written (zeroed memory), which a write would fault in.
        if c.map(f32::to_bits) != [px[0], px[1], px[2]].map(f32::to_bits) {
            px[..3].copy_from_slice(&c);
        }
    }
}

/// The pixels in each core's run, or None where one core does it all
/// (small frames). One core took 45-51 ms to quantize a 2048x2048 frame on
/// the 2-core VM, longer than the GPU's frame.
fn run_pixels(pixels: usize) -> Option<usize> {
    const MIN_PIXELS: usize = 1 << 16;
    let threads = crate::cores::cores().min(pixels / MIN_PIXELS);
    (threads > 1).then(|| pixels.div_ceil(threads))
}

/// `to_u8` on every core, in runs of whole pixels.
pub fn to_u8_parallel(rgba: &[f32], straight: bool, out: &mut [u8]) {
    let Some(run) = run_pixels(rgba.len() / 4) else {
        return to_u8(rgba, straight, out);
    };
    std::thread::scope(|s| {
        for (src, dst) in rgba.chunks(4 * run).zip(out.chunks_mut(4 * run)) {
            s.spawn(move || to_u8(src, straight, dst));
        }
    });
}

/// `straighten` on every core, in runs of whole pixels.
pub fn straighten_parallel(rgba: &mut [f32]) {
    let Some(run) = run_pixels(rgba.len() / 4) else {
        return straighten(rgba);
    };
    std::thread::scope(|s| {
        for part in rgba.chunks_mut(4 * run) {
            s.spawn(move || straighten(part));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::{straighten, straighten_parallel, to_u8, to_u8_parallel};

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
    fn straight_colour_on_every_core_is_that_of_one() {
        let n: usize = (1 << 18) + 5;
        let rgba: Vec<f32> = (0..4 * n).map(|i| ((i * 7919) % 1021) as f32 / 900.0 - 0.05).collect();
        let (mut one, mut all) = (rgba.clone(), rgba);
        straighten(&mut one);
        straighten_parallel(&mut all);
        assert!(one.iter().zip(&all).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn straightens_clamps_and_keeps_what_has_no_alpha() {
        let nan = f32::NAN;
        let mut px = [0.25, 0.5, 2.0, 0.5, 0.3, -0.2, -0.0, 0.0, nan, 0.2, 0.1, 0.4, 0.1, 0.2, 0.3, nan];
        straighten(&mut px);
        let want = [0.5, 1.0, 1.0, 0.5, 0.3, 0.0, -0.0, 0.0, nan, 0.5, 0.25, 0.4, 0.1, 0.2, 0.3, nan];
        let bits = |x: &[f32]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&px), bits(&want));
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
