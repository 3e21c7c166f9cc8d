//! A volume's values with their gradients, one texel each, for
//! gradient-shaded frames: the shader's rule takes central differences one
//! voxel apart of the interpolated field, six more fetches per lit sample;
//! from these texels a lit sample fetches once.
//!
//! The two are the same rule. Trilinear interpolation one voxel further
//! along an axis uses the same weights on the neighbouring voxels, so the
//! difference of two interpolations is the interpolation of the voxels'
//! differences. Clamp-to-edge sampling reads outside voxels as their edge
//! neighbour; so that the interpolated differences match there too, the
//! texels carry a one-voxel border holding the differences of the clamped
//! reads (0 across the face, the edge voxels' along it).

use crate::error::{try_vec, Error};

/// Gradient components are kept below this (f32's largest is 3.4e38).
const F32_SAFE: f64 = 1.0e38;

/// Texels (value, gradient) of the field whose voxel n (numpy axis order,
/// axis 2 fastest) holds `value(n)`, over a grid one voxel larger on every side: texel q (each
/// axis from -1 to d) holds v(clamp(q)) and, per axis a, (v(clamp(q + e_a))
/// - v(clamp(q - e_a))) / (2 spacing_a), all scaled by one power of two
/// where a component would pass 1e38 (the shader uses the direction only).
/// Components are in world axis order (x along numpy axis 0). Values must
/// be finite.
pub fn bordered_texels(
    value: impl Fn(usize) -> f32 + Sync,
    dims: [usize; 3],
    spacing: [f64; 3],
) -> Result<Vec<[f32; 4]>, Error> {
    let padded = dims.iter().map(|d| d + 2).product::<usize>();
    let mut out = try_vec(padded, [0.0f32; 4], "packing the volume's gradients")?;
    let inv = spacing.map(|s| 0.5 / s);
    // One pass at scale 1, which finds the largest component too; a field
    // whose differences pass 1e38 (fill values near f32's range make them)
    // is written again at a power of two that keeps them within f32.
    // Scaling every field to 1 instead would flush ordinary gradients
    // beside a fill value to 0.
    let largest = fill(&mut out, &value, dims, inv, 1.0);
    if largest > F32_SAFE {
        fill(&mut out, &value, dims, inv, (F32_SAFE / largest).log2().floor().exp2());
    }
    Ok(out)
}

/// Writes every texel of `out` (see `bordered_texels`) with its gradient
/// times `scale`, slabs of the first axis on every core (a 256^3 volume's
/// texels took over a second on one); returns the largest unscaled
/// gradient component.
fn fill(
    out: &mut [[f32; 4]],
    value: &(impl Fn(usize) -> f32 + Sync),
    dims: [usize; 3],
    inv: [f64; 3],
    scale: f64,
) -> f64 {
    let [d0, d1, d2] = dims;
    let at = |i: isize, j: isize, k: isize| {
        let c = |x: isize, d: usize| x.clamp(0, d as isize - 1) as usize;
        value((c(i, d0) * d1 + c(j, d1)) * d2 + c(k, d2)) as f64
    };
    let (row, slab) = (d2 + 2, (d1 + 2) * (d2 + 2));
    let planes = crate::cores::cores().min(d0 + 2).max(1);
    let per = (d0 + 2).div_ceil(planes);
    std::thread::scope(|s| {
        let workers: Vec<_> = out
            .chunks_mut(per * slab)
            .enumerate()
            .map(|(t, chunk)| {
                s.spawn(move || {
                    let mut largest = 0.0f64;
                    for (ii, plane) in chunk.chunks_mut(slab).enumerate() {
                        let i = (t * per + ii) as isize - 1;
                        for (jj, line) in plane.chunks_mut(row).enumerate() {
                            let j = jj as isize - 1;
                            for (kk, texel) in line.iter_mut().enumerate() {
                                let k = kk as isize - 1;
                                let g = [
                                    (at(i + 1, j, k) - at(i - 1, j, k)) * inv[0],
                                    (at(i, j + 1, k) - at(i, j - 1, k)) * inv[1],
                                    (at(i, j, k + 1) - at(i, j, k - 1)) * inv[2],
                                ];
                                largest = g.iter().fold(largest, |m, c| m.max(c.abs()));
                                *texel = [
                                    at(i, j, k) as f32,
                                    (g[0] * scale) as f32,
                                    (g[1] * scale) as f32,
                                    (g[2] * scale) as f32,
                                ];
                            }
                        }
                    }
                    largest
                })
            })
            .collect();
        // A worker indexes only within the clamped grid; were one to panic
        // anyway, the panic goes on here (the binding makes it an exception)
        // rather than leaving its texels unwritten.
        workers.into_iter().map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).fold(0.0, f64::max)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cell-centred trilinear interpolation with clamp-to-edge of channel
    /// `ch` of texels over `dims`, at voxel coordinates u (texel centres at
    /// integers), as a sampler reads it.
    fn sample(t: &[[f32; 4]], dims: [usize; 3], u: [f64; 3], ch: usize) -> f64 {
        let f = u.map(f64::floor);
        let mut out = 0.0;
        for corner in 0..8 {
            let mut w = 1.0;
            let mut idx = [0usize; 3];
            for a in 0..3 {
                let up = (corner >> a) & 1;
                w *= if up == 1 { u[a] - f[a] } else { 1.0 - (u[a] - f[a]) };
                idx[a] = (f[a] as isize + up as isize).clamp(0, dims[a] as isize - 1) as usize;
            }
            out += w * t[(idx[0] * dims[1] + idx[1]) * dims[2] + idx[2]][ch] as f64;
        }
        out
    }

    #[test]
    fn interpolated_texels_equal_the_differences_of_interpolated_values() {
        let dims = [5, 4, 6];
        let spacing = [0.5, 2.0, 1.0];
        let values: Vec<f32> = (0..120).map(|n| ((n * 37 % 11) as f32 * 0.3).sin()).collect();
        let plain: Vec<[f32; 4]> = values.iter().map(|&v| [v, 0.0, 0.0, 0.0]).collect();
        let t = bordered_texels(|n| values[n], dims, spacing).unwrap();
        let big = dims.map(|d| d + 2);
        // Points all over the box, including the half voxel past each face's
        // outermost voxel centres, where clamping matters.
        let mut worst = 0.0f64;
        let mut scale = None;
        for n in 0..400 {
            let r = |m: usize, d: usize| -0.5 + ((n * m) % 97) as f64 / 96.0 * d as f64;
            let u = [r(7, dims[0]), r(13, dims[1]), r(29, dims[2])];
            let inner = |c: usize| sample(&t, big, [u[0] + 1.0, u[1] + 1.0, u[2] + 1.0], c);
            assert!((inner(0) - sample(&plain, dims, u, 0)).abs() < 1e-6, "value at {u:?}");
            let mut want = [0.0; 3];
            for a in 0..3 {
                let (mut hi, mut lo) = (u, u);
                hi[a] += 1.0;
                lo[a] -= 1.0;
                want[a] = (sample(&plain, dims, hi, 0) - sample(&plain, dims, lo, 0)) * 0.5 / spacing[a];
            }
            let got = [inner(1), inner(2), inner(3)];
            // One positive factor relates them.
            if let Some(a) = (0..3).find(|&a| want[a].abs() > 1e-3) {
                let s = *scale.get_or_insert(got[a] / want[a]);
                assert!(s > 0.0);
                for a in 0..3 {
                    worst = worst.max((got[a] - s * want[a]).abs());
                }
            }
        }
        assert!(worst < 1e-5, "{worst}");
    }
}
