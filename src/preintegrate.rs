//! Pre-integrated transfer functions (Engel, Kraus and Ertl, "High-Quality
//! Pre-Integrated Volume Rendering Using Hardware-Accelerated Pixel
//! Shading", 2001). A segment's value is taken to run linearly from its
//! front value to its back value; its colour and optical depth are the
//! emission–absorption integral along that ramp, tabulated over (front,
//! back) for one segment length. A sharp transfer-function peak that falls
//! between two samples is then still integrated, which midpoint sampling
//! misses at large steps.

use crate::config::OpacityCorrection;
use crate::integrate::{extinction, one_minus_exp_neg};
use crate::transfer::eval_lut;

/// Largest table side: 512^2 entries of 16 bytes (4 MiB).
pub const MAX_TABLE: usize = 512;

/// The integral along a ramp from `vf` to `vb` over `len_over_ref`
/// reference steps, by `substeps` pieces each treated as homogeneous
/// (exact Beer–Lambert within a piece): unlit premultiplied colour
/// `∫ T σ c ds / ref` in [0..3] and optical depth `∫ σ ds / ref` in [3].
pub fn segment(lut: &[[f32; 4]], vf: f64, vb: f64, len_over_ref: f64, form: OpacityCorrection, substeps: usize) -> [f64; 4] {
    let k = substeps.max(1);
    let piece = len_over_ref / k as f64;
    let mut out = [0.0f64; 4];
    // Transmittance to the piece's front as a running product: one
    // exponential a piece instead of two, and in f64 a product of even
    // thousands of factors stays exact to ~1e-12.
    let mut trans = 1.0f64;
    for s in 0..k {
        let v = vf + (vb - vf) * ((s as f64 + 0.5) / k as f64);
        let rgba = eval_lut(lut, v);
        let x = extinction(rgba[3], form) * piece;
        if x > 0.0 {
            // 1 - exp(-x) without cancellation, and exp(-x) from it.
            let absorbed = one_minus_exp_neg(x);
            let w = trans * absorbed;
            for c in 0..3 {
                out[c] += w * rgba[c];
            }
            out[3] += x;
            trans *= 1.0 - absorbed;
        }
    }
    out
}

/// Pieces that resolve the table between `vf` and `vb`: one per table
/// interval the ramp crosses, plus one.
pub fn substeps_for(lut_len: usize, vf: f64, vb: f64) -> usize {
    let span = (vb - vf).abs().min(1.0) * lut_len.saturating_sub(1) as f64;
    span.ceil() as usize + 1
}

/// Side of the table for a lookup table of `lut_len` entries.
pub fn table_side(lut_len: usize) -> usize {
    lut_len.clamp(2, MAX_TABLE)
}

/// `side x side` entries, row `b` (back value `b / (side - 1)`) after row
/// `b - 1`, column `f` the front value: RGB premultiplied colour and the
/// optical depth (clamped to 1e30, which is opaque) of one segment of
/// `len_over_ref` reference steps.
pub fn table(lut: &[[f32; 4]], len_over_ref: f64, form: OpacityCorrection) -> Vec<[f32; 4]> {
    let n = table_side(lut.len());
    let mut out = vec![[0.0f32; 4]; n * n];
    let threads = std::thread::available_parallelism().map(|t| t.get()).unwrap_or(1);
    let rows_per = n.div_ceil(threads).max(1);
    std::thread::scope(|s| {
        for (chunk, rows) in out.chunks_mut(rows_per * n).enumerate() {
            s.spawn(move || {
                for (idx, e) in rows.iter_mut().enumerate() {
                    let b = chunk * rows_per + idx / n;
                    let f = idx % n;
                    let (vf, vb) = (f as f64 / (n - 1) as f64, b as f64 / (n - 1) as f64);
                    let r = segment(lut, vf, vb, len_over_ref, form, substeps_for(lut.len(), vf, vb));
                    *e = [r[0] as f32, r[1] as f32, r[2] as f32, r[3].min(1e30) as f32];
                }
            });
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_ramp_is_beer_lambert() {
        let lut = [[0.8f32, 0.4, 0.2, 0.3]; 4];
        let r = segment(&lut, 0.5, 0.5, 7.0, OpacityCorrection::Exponential, 1);
        let a = 1.0 - (-(0.3f32 as f64) * 7.0).exp();
        assert!((r[0] - 0.8f32 as f64 * a).abs() < 1e-12);
        assert!((r[3] - 0.3f32 as f64 * 7.0).abs() < 1e-12);
    }

    #[test]
    fn a_peak_between_samples_is_integrated() {
        // Opacity only in a narrow band around 0.5; a ramp from 0 to 1
        // crosses it, while its midpoint sample (0.5) would not see the
        // band's true width. The table's optical depth must equal the band's
        // integral over value times the length: ∫σ dv * len.
        let m = 256;
        let lut: Vec<[f32; 4]> = (0..m)
            .map(|i| {
                let v = i as f64 / (m - 1) as f64;
                [1.0, 1.0, 1.0, if (v - 0.5).abs() < 0.02 { 1.0 } else { 0.0 }]
            })
            .collect();
        let t = table(&lut, 3.0, OpacityCorrection::Exponential);
        let n = table_side(m);
        let e = t[(n - 1) * n]; // front 0, back 1
        let band: f64 = (0..100_000)
            .map(|i| eval_lut(&lut, (i as f64 + 0.5) / 100_000.0)[3])
            .sum::<f64>()
            / 100_000.0;
        assert!((e[3] as f64 - band * 3.0).abs() < 1e-4, "{} vs {}", e[3], band * 3.0);
        // Symmetric in the optical depth, not in colour order (only one colour here).
        let back = t[n - 1];
        assert!((back[3] - e[3]).abs() < 1e-6);
    }
}
