//! Empty-space skipping: a coarse min/max grid over the volume (built once
//! per volume) and, per transfer function, which cells can be non-empty.
//!
//! A cell covers BLOCK^3 voxels; its range includes a one-voxel apron, since
//! trilinear interpolation anywhere inside the cell reads the neighbours. A
//! cell is empty when the table's opacity is 0 at every entry its value
//! range touches (entries are interpolated linearly, so the maximum over a
//! range is at an entry inside it or at its ends). Skipping such cells only
//! removes samples whose opacity is exactly 0: images are unchanged.

use crate::transfer::ValueMap;
use crate::volume::{sanitize, VolumeView, Voxels};

pub const BLOCK: usize = 8;

#[derive(Clone, Debug, PartialEq)]
pub struct MinMaxGrid {
    /// Cells along numpy axes (axis 2 fastest in `min`/`max`).
    pub dims: [usize; 3],
    pub min: Vec<f32>,
    pub max: Vec<f32>,
}

impl MinMaxGrid {
    pub fn build(vol: &VolumeView) -> MinMaxGrid {
        // One typed loop per stored format (the same values as
        // `Voxels::value`, NaN included: min/max ignore it).
        match vol.voxels {
            Voxels::F32(v) => Self::build_from(vol.dims, |i| sanitize(v[i])),
            Voxels::U8(v) => Self::build_from(vol.dims, |i| (v[i] as f64 / 255.0) as f32),
            Voxels::U16(v) => Self::build_from(vol.dims, |i| (v[i] as f64 / 65535.0) as f32),
        }
    }

    /// Min and max over each cell's window of voxels, [cB - 1, (c+1)B] along
    /// every axis (what a sample in the cell can read), one axis at a time:
    /// about 1.3 reads per voxel instead of the 2 of a window per cell.
    fn build_from(dims: [usize; 3], value: impl Fn(usize) -> f32) -> MinMaxGrid {
        let [s0, s1, s2] = dims;
        let g = [s0.div_ceil(BLOCK), s1.div_ceil(BLOCK), s2.div_ceil(BLOCK)];
        let window = |c: usize, n: usize| (c * BLOCK).saturating_sub(1)..((c + 1) * BLOCK + 1).min(n);
        // Along axis 2: (s0, s1, g2).
        let mut lo2 = vec![f32::INFINITY; s0 * s1 * g[2]];
        let mut hi2 = vec![f32::NEG_INFINITY; s0 * s1 * g[2]];
        for row in 0..s0 * s1 {
            for c in 0..g[2] {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for k in window(c, s2) {
                    let v = value(row * s2 + k);
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                lo2[row * g[2] + c] = lo;
                hi2[row * g[2] + c] = hi;
            }
        }
        // Along axis 1: (s0, g1, g2).
        let mut lo1 = vec![f32::INFINITY; s0 * g[1] * g[2]];
        let mut hi1 = vec![f32::NEG_INFINITY; s0 * g[1] * g[2]];
        for i in 0..s0 {
            for b in 0..g[1] {
                let out = (i * g[1] + b) * g[2];
                for j in window(b, s1) {
                    let src = (i * s1 + j) * g[2];
                    for c in 0..g[2] {
                        lo1[out + c] = lo1[out + c].min(lo2[src + c]);
                        hi1[out + c] = hi1[out + c].max(hi2[src + c]);
                    }
                }
            }
        }
        drop((lo2, hi2));
        // Along axis 0: (g0, g1, g2).
        let plane = g[1] * g[2];
        let mut min = vec![f32::INFINITY; g[0] * plane];
        let mut max = vec![f32::NEG_INFINITY; g[0] * plane];
        for a in 0..g[0] {
            for i in window(a, s0) {
                for o in 0..plane {
                    min[a * plane + o] = min[a * plane + o].min(lo1[i * plane + o]);
                    max[a * plane + o] = max[a * plane + o].max(hi1[i * plane + o]);
                }
            }
        }
        MinMaxGrid { dims: g, min, max }
    }

    /// 1 for cells where the interpolated value can reach `iso` (the
    /// isosurface model's first hit can only lie there), 0 elsewhere. The
    /// margin covers f32 interpolation rounding past a cell's maximum.
    /// `iso` is in the transfer function's domain, which `map` takes values to.
    pub fn occupancy_reaching(&self, iso: f64, map: ValueMap) -> Vec<u8> {
        let margin = 1e-6 * iso.abs().max(1.0);
        self.min
            .iter()
            .zip(&self.max)
            .map(|(&lo, &hi)| (lo <= hi && map.apply(hi as f64) >= iso - margin) as u8)
            .collect()
    }

    /// 1 for cells the table can make visible, 0 for empty ones.
    /// The table is indexed by mapped values (`map`: sample -> [0, 1]).
    pub fn occupancy(&self, lut: &[[f32; 4]], map: ValueMap) -> Vec<u8> {
        let m = lut.len();
        if m == 0 {
            return vec![0; self.min.len()];
        }
        // Prefix counts of non-zero opacities: any-in-range in O(1).
        let mut nonzero = Vec::with_capacity(m + 1);
        nonzero.push(0u32);
        for e in lut {
            let last = *nonzero.last().unwrap_or(&0);
            nonzero.push(last + (e[3] > 0.0) as u32);
        }
        let scale = (m - 1) as f64;
        self.min
            .iter()
            .zip(&self.max)
            .map(|(&lo, &hi)| {
                if lo > hi {
                    return 0; // only NaN voxels
                }
                // The device maps in f32: widen a mapped range by a rounding
                // margin (an identity map is exact, as it always was).
                let pad = if map == ValueMap::IDENTITY { 0.0 } else { 1e-3 };
                let (lo, hi) = (map.apply(lo as f64), map.apply(hi as f64));
                let i0 = (lo.clamp(0.0, 1.0) * scale - pad).max(0.0).floor() as usize;
                let i1 = ((hi.clamp(0.0, 1.0) * scale + pad).ceil() as usize).min(m - 1);
                (nonzero[i1 + 1] > nonzero[i0]) as u8
            })
            .collect()
    }
}

/// Coarser levels of an occupancy grid for hierarchical skipping: level `l`
/// has `max(1, d >> l)` cells per axis (a GPU mip chain's sizes); a cell is
/// occupied if any level-0 cell under it is. The last cell along an axis also
/// covers the remainder when `d` is not a multiple of `2^l`, so every level-0
/// cell has a parent that knows it. Returns up to `levels` levels, level 0
/// first, each with its dims.
pub fn pyramid(occ: &[u8], dims: [usize; 3], levels: usize) -> Vec<(Vec<u8>, [usize; 3])> {
    let mut out = vec![(occ.to_vec(), dims)];
    for l in 1..levels {
        let ld = dims.map(|d| (d >> l).max(1));
        // Level-0 index range under cell c of level l along an axis.
        let span = |c: usize, n: usize, d: usize| (c << l)..if c + 1 == n { d } else { ((c + 1) << l).min(d) };
        let mut level = vec![0u8; ld[0] * ld[1] * ld[2]];
        for a in 0..ld[0] {
            for b in 0..ld[1] {
                for c in 0..ld[2] {
                    let any = span(a, ld[0], dims[0]).any(|i| {
                        span(b, ld[1], dims[1])
                            .any(|j| span(c, ld[2], dims[2]).any(|k| occ[(i * dims[1] + j) * dims[2] + k] != 0))
                    });
                    level[(a * ld[1] + b) * ld[2] + c] = any as u8;
                }
            }
        }
        out.push((level, ld));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Bounds;
    use crate::volume::Voxels;

    #[test]
    fn ranges_include_the_apron_and_ignore_nan() {
        // 24 voxels along axis 2: three cells. A spike in cell 0's last voxel
        // reaches cell 1 through interpolation, not cell 2.
        let mut data = vec![0.0f32; 24];
        data[7] = 0.9;
        data[12] = f32::NAN;
        data[16] = 0.5;
        let v = VolumeView::new([1, 1, 24], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let g = MinMaxGrid::build(&v);
        assert_eq!(g.dims, [1, 1, 3]);
        assert_eq!(g.max, vec![0.9, 0.9, 0.5]);
        assert_eq!(g.min, vec![0.0, 0.0, 0.0]);
        // Cell 0 reads voxel 8 (cell 1's first) too.
        data[8] = 0.95;
        let v = VolumeView::new([1, 1, 24], Voxels::F32(&data), None, Bounds::default()).unwrap();
        assert_eq!(MinMaxGrid::build(&v).max, vec![0.95, 0.95, 0.5]);
    }

    #[test]
    fn separable_build_equals_the_window_of_every_cell() {
        // Odd sizes (remainder cells), NaN, infinities and unorm data.
        let dims = [19, 8, 27];
        let n = dims.iter().product::<usize>();
        let mut x = 12345u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        let mut f: Vec<f32> = (0..n).map(|_| (next() % 1000) as f32 / 999.0).collect();
        f[5] = f32::NAN;
        f[300] = f32::INFINITY;
        f[301] = f32::NEG_INFINITY;
        let u: Vec<u16> = (0..n).map(|_| (next() % 65536) as u16).collect();
        for voxels in [Voxels::F32(&f), Voxels::U16(&u)] {
            let v = VolumeView::new(dims, voxels, None, Bounds::default()).unwrap();
            let g = MinMaxGrid::build(&v);
            let window = |c: usize, n: usize| (c * BLOCK).saturating_sub(1)..((c + 1) * BLOCK + 1).min(n);
            for a in 0..g.dims[0] {
                for b in 0..g.dims[1] {
                    for c in 0..g.dims[2] {
                        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                        for i in window(a, dims[0]) {
                            for j in window(b, dims[1]) {
                                for k in window(c, dims[2]) {
                                    let val = v.voxels.value((i * dims[1] + j) * dims[2] + k) as f32;
                                    lo = lo.min(val);
                                    hi = hi.max(val);
                                }
                            }
                        }
                        let o = (a * g.dims[1] + b) * g.dims[2] + c;
                        assert_eq!((g.min[o], g.max[o]), (lo, hi), "cell {a} {b} {c}");
                    }
                }
            }
        }
    }

    #[test]
    fn pyramid_covers_remainders() {
        // 5 cells along one axis; only the last is occupied. Level 1 has 2
        // cells: the second covers cells 2..5 including the remainder.
        let occ = vec![0, 0, 0, 0, 1];
        let p = pyramid(&occ, [1, 1, 5], 3);
        assert_eq!(p[1], (vec![0, 1], [1, 1, 2]));
        assert_eq!(p[2], (vec![1], [1, 1, 1]));
        let p = pyramid(&[0, 1, 0, 0], [1, 1, 4], 2);
        assert_eq!(p[1].0, vec![1, 0]);
    }

    #[test]
    fn occupancy_follows_the_table() {
        let data: Vec<f32> = (0..16).map(|k| if k < 8 { 0.1 } else { 0.8 }).collect();
        let v = VolumeView::new([1, 1, 16], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let mut g = MinMaxGrid::build(&v);
        // Without the apron the two cells hold 0.1 and 0.8 only.
        g.min = vec![0.1, 0.8];
        g.max = vec![0.1, 0.8];
        let step: Vec<[f32; 4]> = (0..11).map(|i| [1.0, 1.0, 1.0, if i >= 5 { 1.0 } else { 0.0 }]).collect();
        assert_eq!(g.occupancy(&step, ValueMap::IDENTITY), vec![0, 1]);
        let empty = vec![[1.0f32, 1.0, 1.0, 0.0]; 11];
        assert_eq!(g.occupancy(&empty, ValueMap::IDENTITY), vec![0, 0]);
        // A range straddling an entry with opacity counts as occupied.
        g.min = vec![0.41, 0.0];
        g.max = vec![0.42, 0.0];
        assert_eq!(g.occupancy(&step, ValueMap::IDENTITY), vec![1, 0]);
    }

    #[test]
    fn occupancy_maps_values_to_the_table() {
        let data = vec![0.0f32; 8];
        let v = VolumeView::new([1, 1, 8], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let mut g = MinMaxGrid::build(&v);
        // Two cells in data units (e.g. Hounsfield): air and tissue.
        g.min = vec![-1000.0, 200.0];
        g.max = vec![-900.0, 560.0];
        g.dims = [1, 1, 2];
        // Opaque above the middle of the domain; the domain spans -1000..3000.
        let step: Vec<[f32; 4]> = (0..11).map(|i| [1.0, 1.0, 1.0, if i >= 5 { 1.0 } else { 0.0 }]).collect();
        // -1000..3000: tissue maps to 0.3..0.39, where the table is 0.
        let map = ValueMap::new(1.0 / 4000.0, 0.25).unwrap();
        assert_eq!(g.occupancy(&step, map), vec![0, 0]);
        // -1000..1000: tissue maps to 0.6..0.78, where it is opaque.
        let map = ValueMap::new(1.0 / 2000.0, 0.5).unwrap();
        assert_eq!(g.occupancy(&step, map), vec![0, 1]);
        assert_eq!(g.occupancy_reaching(0.75, map), vec![0, 1]);
        assert_eq!(g.occupancy_reaching(0.85, map), vec![0, 0]);
        assert_eq!(g.occupancy_reaching(0.9, ValueMap::IDENTITY), vec![0, 1]);
        assert_eq!(g.occupancy_reaching(2000.0, ValueMap::IDENTITY), vec![0, 0]);
    }
}
