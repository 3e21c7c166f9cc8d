//! Empty-space skipping: a coarse min/max grid over the volume (built once
//! per volume) and, per transfer function, which cells can be non-empty and
//! how far each empty cell is from one that is not (`empty_radius`).
//!
//! A cell covers BLOCK^3 voxels; its range includes a one-voxel apron, since
//! trilinear interpolation anywhere inside the cell reads the neighbours. A
//! cell is empty when the table's opacity is 0 at every entry its value
//! range touches (entries are interpolated linearly, so the maximum over a
//! range is at an entry inside it or at its ends). Skipping such cells only
//! removes samples whose opacity is exactly 0: images are unchanged.

mod radii;
pub use radii::*;

use crate::config::OpacityCorrection;
use crate::integrate::extinction;
use crate::transfer::ValueMap;
use crate::volume::{sanitize, VolumeView, Voxels};
use std::borrow::Cow;

pub const BLOCK: usize = 8;

/// Voxels each set of wide ranges reaches past a cell's apron: one voxel
/// for segments up to 3 voxels long, half a cell for those up to 9. Past
/// what an apron holds, ranges widen by whole cells, which more than
/// doubles a cell's window: 8 + 2 * 9 voxels where 8 + 2 * 2 or 8 + 2 * 5
/// would do.
pub const WIDE_APRONS: [usize; 2] = [1, BLOCK / 2];

/// Which ranges hold the values of every pre-integrated segment centred in
/// a cell (its two ends and the ramp between them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentRanges {
    /// The cell's own: a sample up to half a voxel outside the cell reads
    /// only voxels of its apron.
    Plain,
    /// The wide ranges of apron `WIDE_APRONS[apron]`, widened to the hull
    /// of the neighbours' within `cells` cells along each axis.
    Wide { apron: usize, cells: [usize; 3] },
}

/// The apron of each set of ranges a grid holds (1: what a sample in a
/// cell can read; then the wide ranges).
const APRONS: [usize; 3] = [1, 1 + WIDE_APRONS[0], 1 + WIDE_APRONS[1]];
const _: () = assert!(APRONS[0] < APRONS[1] && APRONS[1] < APRONS[2] && APRONS[2] <= BLOCK);

/// Cell c's window of voxels along an axis of n: its own and `apron` more
/// on each side.
fn window(c: usize, n: usize, apron: usize) -> std::ops::Range<usize> {
    (c * BLOCK).saturating_sub(apron)..((c + 1) * BLOCK + apron).min(n)
}

// Plain comparisons (NaN is gone from the rows they see): f32::min's NaN
// rule costs more than the comparison itself.
fn lower(a: f32, b: f32) -> f32 {
    if b < a {
        b
    } else {
        a
    }
}

fn higher(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// The largest of `m` and |a - b| over the pairs (NaN pairs left out), in
/// eight independent lanes: as one chain, each comparison waited on the
/// last, and it took most of a volume's grid.
fn steepest(m: f32, a: &[f32], b: &[f32]) -> f32 {
    let mut lanes = [m; 8];
    let (pa, pb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail = pa.remainder().iter().zip(pb.remainder()).fold(m, |m, (&x, &y)| higher(m, (x - y).abs()));
    for (x, y) in pa.zip(pb) {
        for k in 0..8 {
            lanes[k] = higher(lanes[k], (x[k] - y[k]).abs());
        }
    }
    lanes.into_iter().fold(tail, higher)
}

/// Slices `slices` of axis 0 reduced along axes 2 and 1 into `slice_lo[t]`
/// and `slice_hi[t]` (from slice `slices.start` on: (slices, g1, g2) for
/// apron t); returns whether a voxel is NaN and the slopes along each axis
/// within the slab (along axis 0 from the slice before it on).
fn slab(
    dims: [usize; 3],
    fill: &impl Fn(usize, &mut [f32]),
    slices: std::ops::Range<usize>,
    slice_lo: &mut [&mut [f32]],
    slice_hi: &mut [&mut [f32]],
) -> (bool, [f32; 3]) {
    let [_, s1, s2] = dims;
    let g = dims.map(|s| s.div_ceil(BLOCK));
    // One slice's rows reduced along axis 2: (s1, g2) per apron.
    let mut rows_lo = vec![vec![0.0f32; s1 * g[2]]; APRONS.len()];
    let mut rows_hi = vec![vec![0.0f32; s1 * g[2]]; APRONS.len()];
    // A row's values, and the same padded by the widest apron on both
    // sides, with NaN and the padding as +inf (for minima) and -inf (for
    // maxima), so that ranges ignore them and windows need no clamping.
    const PAD: usize = APRONS[APRONS.len() - 1];
    let mut row = vec![0.0f32; s2];
    let mut row_lo = vec![f32::INFINITY; g[2] * BLOCK + 2 * PAD];
    let mut row_hi = vec![f32::NEG_INFINITY; g[2] * BLOCK + 2 * PAD];
    let (mut lo, mut hi) = (vec![0.0f32; g[2]], vec![0.0f32; g[2]]);
    let mut has_nan = false;
    // This slice's rows and the one before, for the differences along
    // axes 1 and 0.
    let (mut slice, mut before) = (vec![0.0f32; s1 * s2], vec![0.0f32; s1 * s2]);
    let mut slopes = [0.0f32; 3];
    if slices.start > 0 {
        // The slice before the slab, for the differences along axis 0.
        for j in 0..s1 {
            fill((slices.start - 1) * s1 + j, &mut before[j * s2..(j + 1) * s2]);
        }
    }
    let first = slices.start;
    for i in slices {
        for j in 0..s1 {
            fill(i * s1 + j, &mut row);
            has_nan |= row.iter().fold(false, |a, v| a | v.is_nan());
            slopes[2] = steepest(slopes[2], &row[1..], &row[..s2 - 1]);
            if j > 0 {
                slopes[1] = steepest(slopes[1], &row, &slice[(j - 1) * s2..j * s2]);
            }
            if i > 0 {
                slopes[0] = steepest(slopes[0], &row, &before[j * s2..(j + 1) * s2]);
            }
            slice[j * s2..(j + 1) * s2].copy_from_slice(&row);
            for ((l, h), &v) in row_lo[PAD..].iter_mut().zip(&mut row_hi[PAD..]).zip(&row) {
                (*l, *h) = if v.is_nan() { (f32::INFINITY, f32::NEG_INFINITY) } else { (v, v) };
            }
            // Each cell's own voxels (contiguous: a vector's reduction),
            // then for every cell at once one voxel further out on each
            // side at a time (iterators, so no index is checked).
            let own = PAD..PAD + g[2] * BLOCK;
            let cells = row_lo[own.clone()].chunks_exact(BLOCK).zip(row_hi[own].chunks_exact(BLOCK));
            for ((l, h), (cl, ch)) in lo.iter_mut().zip(&mut hi).zip(cells) {
                *l = cl.iter().fold(f32::INFINITY, |a, &b| lower(a, b));
                *h = ch.iter().fold(f32::NEG_INFINITY, |a, &b| higher(a, b));
            }
            let mut t = 0;
            for d in 1..=PAD {
                // Each cell's voxel d before its first and d after its last.
                let (before, after) = (PAD - d, PAD + BLOCK + d - 1);
                let lows = row_lo[before..].iter().step_by(BLOCK).zip(row_lo[after..].iter().step_by(BLOCK));
                let highs = row_hi[before..].iter().step_by(BLOCK).zip(row_hi[after..].iter().step_by(BLOCK));
                for ((l, h), ((&lb, &la), (&hb, &ha))) in lo.iter_mut().zip(&mut hi).zip(lows.zip(highs)) {
                    *l = lower(*l, lower(lb, la));
                    *h = higher(*h, higher(hb, ha));
                }
                if APRONS[t] == d {
                    rows_lo[t][j * g[2]..(j + 1) * g[2]].copy_from_slice(&lo);
                    rows_hi[t][j * g[2]..(j + 1) * g[2]].copy_from_slice(&hi);
                    t += 1;
                }
            }
        }
        std::mem::swap(&mut slice, &mut before);
        for (t, &apron) in APRONS.iter().enumerate() {
            for b in 0..g[1] {
                let out = ((i - first) * g[1] + b) * g[2];
                let (lo, hi) = (&mut slice_lo[t][out..out + g[2]], &mut slice_hi[t][out..out + g[2]]);
                for j in window(b, s1, apron) {
                    let src = j * g[2]..(j + 1) * g[2];
                    lo.iter_mut().zip(&rows_lo[t][src.clone()]).for_each(|(x, &y)| *x = lower(*x, y));
                    hi.iter_mut().zip(&rows_hi[t][src]).for_each(|(x, &y)| *x = higher(*x, y));
                }
            }
        }
    }
    (has_nan, slopes)
}

#[derive(Clone, Debug, PartialEq)]
pub struct MinMaxGrid {
    /// Cells along numpy axes (axis 2 fastest in `min`/`max`).
    pub dims: [usize; 3],
    pub min: Vec<f32>,
    pub max: Vec<f32>,
    /// The same over windows `WIDE_APRONS[i]` voxels wider on every side:
    /// (min, max) for each entry, or none where not built.
    pub wide: Vec<(Vec<f32>, Vec<f32>)>,
    /// Whether any voxel is NaN (min and max ignore NaN, so a cell's range
    /// does not say whether a sample in it can be NaN).
    pub has_nan: bool,
    /// Along each numpy axis, the largest difference between neighbouring
    /// voxels (NaN pairs left out): trilinear interpolation changes by at
    /// most this per voxel moved along that axis, so a ray's values change
    /// at most by the sum over axes of these times the voxels it crosses.
    pub slopes: [f32; 3],
}

impl MinMaxGrid {
    pub fn build(vol: &VolumeView) -> MinMaxGrid {
        // One typed copy per stored format into a row of f32 (the same
        // values as `Voxels::value`, NaN included: min/max ignore it).
        let row_of = |i: usize, n: usize| i * n..(i + 1) * n;
        match vol.voxels {
            Voxels::F32(v) => Self::build_from(vol.dims, |i, row| {
                let src = &v[row_of(i, row.len())];
                row.iter_mut().zip(src).for_each(|(r, &x)| *r = sanitize(x));
            }),
            Voxels::U8(v) => Self::build_from(vol.dims, |i, row| {
                let src = &v[row_of(i, row.len())];
                row.iter_mut().zip(src).for_each(|(r, &x)| *r = (x as f64 / 255.0) as f32);
            }),
            Voxels::U16(v) => Self::build_from(vol.dims, |i, row| {
                let src = &v[row_of(i, row.len())];
                row.iter_mut().zip(src).for_each(|(r, &x)| *r = (x as f64 / 65535.0) as f32);
            }),
        }
    }

    /// Min and max over each cell's window of voxels, [cB - apron, (c+1)B +
    /// apron - 1] along every axis, for each of APRONS (1: what a sample in
    /// the cell can read; then the wide ranges), one axis at a time and one
    /// slice of axis 0 at a time, so that what is held besides the grid is a
    /// slice's rows and a 64th of the voxels' count per apron. `fill(r,
    /// row)` writes the values of row r (axis 2). Slabs of slices go to
    /// every core: one core took 0.6 s of a 512^3 volume's load.
    fn build_from(dims: [usize; 3], fill: impl Fn(usize, &mut [f32]) + Sync) -> MinMaxGrid {
        // Small volumes stay on one core (a thread costs more than its share).
        let threads = if dims.iter().product::<usize>() < 1 << 21 { 1 } else { crate::cores::cores() };
        Self::build_on(dims, &fill, threads)
    }

    fn build_on(dims: [usize; 3], fill: &(impl Fn(usize, &mut [f32]) + Sync), threads: usize) -> MinMaxGrid {
        let s0 = dims[0];
        let g = dims.map(|s| s.div_ceil(BLOCK));
        let plane = g[1] * g[2];
        // Per apron, (s0, g1, g2): each slice reduced along axes 2 and 1.
        let mut slice_lo = vec![vec![f32::INFINITY; s0 * plane]; APRONS.len()];
        let mut slice_hi = vec![vec![f32::NEG_INFINITY; s0 * plane]; APRONS.len()];
        let per = s0.div_ceil(threads.clamp(1, s0.max(1))).max(1);
        let mut lo_parts: Vec<_> = slice_lo.iter_mut().map(|v| v.chunks_mut(per * plane)).collect();
        let mut hi_parts: Vec<_> = slice_hi.iter_mut().map(|v| v.chunks_mut(per * plane)).collect();
        let slabs: Vec<_> = (0..s0.div_ceil(per))
            .map(|k| {
                let lo: Vec<&mut [f32]> = lo_parts.iter_mut().map(|p| p.next().expect("a chunk a slab")).collect();
                let hi: Vec<&mut [f32]> = hi_parts.iter_mut().map(|p| p.next().expect("a chunk a slab")).collect();
                (k * per..((k + 1) * per).min(s0), lo, hi)
            })
            .collect();
        let found: Vec<(bool, [f32; 3])> = if slabs.len() == 1 {
            slabs.into_iter().map(|(slices, mut lo, mut hi)| slab(dims, fill, slices, &mut lo, &mut hi)).collect()
        } else {
            std::thread::scope(|s| {
                let workers: Vec<_> = slabs
                    .into_iter()
                    .map(|(slices, mut lo, mut hi)| s.spawn(move || slab(dims, fill, slices, &mut lo, &mut hi)))
                    .collect();
                workers.into_iter().map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
            })
        };
        let has_nan = found.iter().any(|f| f.0);
        let slopes = found.iter().fold([0.0f32; 3], |m, f| std::array::from_fn(|k| higher(m[k], f.1[k])));
        // Along axis 0: (g0, g1, g2).
        let mut ranges = slice_lo.into_iter().zip(slice_hi).zip(APRONS).map(|((slo, shi), apron)| {
            let (mut min, mut max) = (vec![f32::INFINITY; g[0] * plane], vec![f32::NEG_INFINITY; g[0] * plane]);
            for a in 0..g[0] {
                let (lo, hi) = (&mut min[a * plane..(a + 1) * plane], &mut max[a * plane..(a + 1) * plane]);
                for i in window(a, s0, apron) {
                    let src = i * plane..(i + 1) * plane;
                    lo.iter_mut().zip(&slo[src.clone()]).for_each(|(x, &y)| *x = lower(*x, y));
                    hi.iter_mut().zip(&shi[src]).for_each(|(x, &y)| *x = higher(*x, y));
                }
            }
            (min, max)
        });
        let (min, max) = ranges.next().expect("the plain ranges");
        MinMaxGrid { dims: g, min, max, wide: ranges.collect(), has_nan, slopes }
    }

    /// The ranges of the segments centred in each cell ([`segment_ranges`]):
    /// an empty cell of this grid empties every segment centred in it.
    /// Without wide ranges, the plain ones widened by one cell more (no
    /// apron is wider than a cell).
    pub fn for_segments(&self, ranges: SegmentRanges) -> Cow<'_, MinMaxGrid> {
        match ranges {
            SegmentRanges::Plain => Cow::Borrowed(self),
            SegmentRanges::Wide { apron, cells } => {
                let (min, max, cells) = match self.wide.get(apron) {
                    Some((min, max)) => (min.clone(), max.clone(), cells),
                    None => (self.min.clone(), self.max.clone(), cells.map(|r| r + 1)),
                };
                let wide = MinMaxGrid { min, max, wide: Vec::new(), ..*self };
                Cow::Owned(wide.widened(cells))
            }
        }
    }

    /// Each cell's range widened to the hull of its neighbours' within
    /// `reach` cells along each axis.
    pub fn widened(self, reach: [usize; 3]) -> MinMaxGrid {
        let mut out = self;
        let d = out.dims;
        for (axis, &r) in reach.iter().enumerate() {
            if r == 0 {
                continue;
            }
            // Lines of cells along `axis`, `stride` apart.
            let stride: usize = d[axis + 1..].iter().product();
            let outer: usize = d[..axis].iter().product();
            let n = d[axis];
            let (lo, hi) = (out.min.clone(), out.max.clone());
            for o in 0..outer {
                for inner in 0..stride {
                    let base = o * n * stride + inner;
                    for c in 0..n {
                        let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
                        for k in c.saturating_sub(r)..(c + r + 1).min(n) {
                            a = a.min(lo[base + k * stride]);
                            b = b.max(hi[base + k * stride]);
                        }
                        out.min[base + c * stride] = a;
                        out.max[base + c * stride] = b;
                    }
                }
            }
        }
        out
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

    /// Per cell, the largest (`upper`) or smallest value a sample in it can
    /// read, mapped by `map`, moved outwards by 1e-5 of the cell's mapped
    /// range: the march interpolates in f32, and rounding moves an
    /// interpolated value past its corners' range by no more than about
    /// 1e-7 of that range (a uniform cell's samples are its value).
    /// `stored`: a value as the texels hold it (float16 and 16-bit fixed
    /// point round it; the rounding keeps order, so the cell's extremes stay
    /// its extremes). The march maps in f32 too, which moves a value by about
    /// 1e-7 of the map's terms: a projection leaps where its value so far
    /// passes a bound less 1e-6 of those. Cells holding only
    /// NaN: -inf (`upper`) or +inf, which every value passes.
    pub fn value_bounds(&self, map: ValueMap, upper: bool, stored: impl Fn(f32) -> f64) -> Vec<f32> {
        let (nothing, outwards) = if upper { (f32::NEG_INFINITY, 1.0) } else { (f32::INFINITY, -1.0) };
        self.min
            .iter()
            .zip(&self.max)
            .map(|(&lo, &hi)| {
                if lo > hi {
                    return nothing;
                }
                let (lo, hi) = (map.apply(stored(lo)), map.apply(stored(hi)));
                let b = if upper { hi } else { lo };
                (b + outwards * 1e-5 * (hi - lo)) as f32
            })
            .collect()
    }

    /// 1 for cells the table can make visible, 0 for empty ones.
    /// The table is indexed by mapped values (`map`: sample -> [0, 1]).
    pub fn occupancy(&self, lut: &[[f32; 4]], map: ValueMap) -> Vec<u8> {
        let m = lut.len();
        // Prefix counts of non-zero opacities: any-in-range in O(1).
        let mut nonzero = Vec::with_capacity(m + 1);
        nonzero.push(0u32);
        for e in lut {
            let last = *nonzero.last().unwrap_or(&0);
            nonzero.push(last + (e[3] > 0.0) as u32);
        }
        self.per_cell(m, map, |i0, i1| (nonzero[i1 + 1] > nonzero[i0]) as u8)
    }

    /// Per cell, the largest extinction per reference step the table
    /// reaches over the cell's range, as a code: 0 where it is 0 (the cells
    /// `occupancy` leaves empty), else `majorant_code` of it. Unbiased
    /// frames draw each segment's Poisson points at the rate of the code of
    /// the cell holding its midpoint.
    pub fn majorants(&self, lut: &[[f32; 4]], map: ValueMap, form: OpacityCorrection) -> Vec<u8> {
        let m = lut.len();
        // Sparse table of range maxima: level k holds the max of 2^k entries.
        let mut levels = vec![lut.iter().map(|e| extinction(e[3] as f64, form)).collect::<Vec<f64>>()];
        while 1usize << levels.len() <= m {
            let half = 1usize << (levels.len() - 1);
            let prev = levels.last().map_or(&[][..], |v| &v[..]);
            let next = (0..prev.len() - half).map(|i| prev[i].max(prev[i + half])).collect();
            levels.push(next);
        }
        self.per_cell(m, map, |i0, i1| {
            let k = (usize::BITS - 1 - (i1 - i0 + 1).leading_zeros()) as usize;
            let e = levels[k][i0].max(levels[k][i1 + 1 - (1 << k)]);
            if e > 0.0 {
                majorant_code(e)
            } else {
                0
            }
        })
    }

    /// Per cell, a key above 0 where every sample in the cell takes the
    /// same colour and opacity above 0 from the table; else 0. That is so
    /// where the cell holds one value, or where the table's entries are
    /// equal over the cell's range. Cells of one key take the same colour
    /// and opacity. A ray may then composite the segments it has in such a
    /// cell in one step. The ranges ignore NaN: keys of a volume holding any
    /// mean nothing. `visible`: 0 for the cells `occupancy` (or `majorants`)
    /// leaves empty.
    pub fn uniform_keys(&self, lut: &[[f32; 4]], map: ValueMap, visible: &[u8]) -> Vec<u32> {
        let m = lut.len();
        // First entry of the run of equal entries each one lies in.
        let mut run = Vec::with_capacity(m);
        for (i, e) in lut.iter().enumerate() {
            let start = match run.last() {
                Some(&prev) if lut[i - 1] == *e => prev,
                _ => i,
            };
            run.push(start);
        }
        // Keys 1..=m: runs; above m: single values, one key per value.
        let runs = self.per_cell(m, map, |i0, i1| if run[i1] <= i0 { run[i1] as u32 + 1 } else { 0 });
        let mut values = std::collections::HashMap::new();
        (0..runs.len())
            .map(|i| match (visible[i], self.min[i] == self.max[i], runs[i]) {
                (0, _, _) => 0,
                (_, true, _) => {
                    let next = m as u32 + 1 + values.len() as u32;
                    *values.entry(self.min[i].to_bits()).or_insert(next)
                }
                (_, false, k) => k,
            })
            .collect()
    }

    /// `f(i0, i1)` per cell: the table entries [i0, i1] the cell's mapped
    /// range touches (the default for cells holding only NaN, or an empty
    /// table).
    fn per_cell<T: Copy + Default>(&self, m: usize, map: ValueMap, f: impl Fn(usize, usize) -> T) -> Vec<T> {
        if m == 0 {
            return vec![T::default(); self.min.len()];
        }
        let scale = (m - 1) as f64;
        self.min
            .iter()
            .zip(&self.max)
            .map(|(&lo, &hi)| {
                if lo > hi {
                    return T::default(); // only NaN voxels
                }
                // The device maps in f32: widen a mapped range by a rounding
                // margin (an identity map is exact, as it always was).
                let pad = if map == ValueMap::IDENTITY { 0.0 } else { 1e-3 };
                let (lo, hi) = (map.apply(lo as f64), map.apply(hi as f64));
                let i0 = (lo.clamp(0.0, 1.0) * scale - pad).max(0.0).floor() as usize;
                let i1 = ((hi.clamp(0.0, 1.0) * scale + pad).ceil() as usize).min(m - 1);
                f(i0.min(i1), i1)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Bounds;
    use crate::volume::Voxels;

    /// Slabs of slices on several cores give the grid of one core: ranges
    /// at every apron, NaN, and slopes across the slabs' seams.
    #[test]
    fn slabs_on_every_core_build_the_grid_of_one() {
        let dims = [37, 21, 30];
        let mut data: Vec<f32> =
            (0..dims.iter().product::<usize>()).map(|i| ((i * 7919) % 1009) as f32 / 1009.0).collect();
        // The steepest step along axis 0 lies across a seam (slices 12 | 13 for 3 slabs of 13).
        let at = |i: usize, j: usize, k: usize| (i * dims[1] + j) * dims[2] + k;
        data[at(12, 4, 5)] = -3.0;
        data[at(13, 4, 5)] = 4.0;
        data[at(30, 2, 2)] = f32::NAN;
        let fill = |r: usize, row: &mut [f32]| row.copy_from_slice(&data[r * dims[2]..(r + 1) * dims[2]]);
        let one = MinMaxGrid::build_on(dims, &fill, 1);
        for threads in [2, 3, 5, 64] {
            assert_eq!(MinMaxGrid::build_on(dims, &fill, threads), one, "{threads} slabs");
        }
        assert!(one.has_nan && one.slopes[0] == 7.0 && one.wide.len() == 2);
    }

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
    fn slopes_are_the_largest_neighbour_differences_along_each_axis() {
        // The grid's (built from rows and slices) against the f64
        // integrator's (voxel by voxel), with NaN pairs left out; each axis
        // gets its own steepest pair, so swapped axes would show. Rows of 29
        // are taken eight pairs at a time and then one by one (the tail).
        let dims = [6, 5, 29];
        let n = dims.iter().product::<usize>();
        let mut data: Vec<f32> = (0..n).map(|i| ((i * 37 % 11) as f32) * 0.01).collect();
        let at = |i: usize, j: usize, k: usize| (i * dims[1] + j) * dims[2] + k;
        data[at(2, 1, 3)] = 0.9; // steep along every axis ...
        data[at(3, 1, 3)] = -0.6; // ... steepest along axis 0 (1.5)
        data[at(4, 4, 0)] = 1.3; // axis 1: 1.3 - data[at(4, 3, 0)]
        data[at(4, 3, 0)] = 0.0;
        data[at(0, 0, 5)] = f32::NAN;
        data[at(1, 2, 27)] = 0.7; // axis 2, in a row's tail: 1.4
        data[at(1, 2, 28)] = -0.7;
        let v = VolumeView::new(dims, Voxels::F32(&data), None, Bounds::default()).unwrap();
        let g = MinMaxGrid::build(&v);
        let f = crate::integrate::voxel_slopes(&v);
        for a in 0..3 {
            assert!((g.slopes[a] as f64 - f[a]).abs() < 1e-6, "axis {a}: {:?} vs {f:?}", g.slopes);
        }
        assert!((g.slopes[0] - 1.5).abs() < 1e-6 && g.slopes[1] >= 1.3 - 1e-6, "{:?}", g.slopes);
        assert!((g.slopes[2] - 1.4).abs() < 1e-6, "{:?}", g.slopes);
        assert!(g.slopes.iter().all(|s| s.is_finite()));
    }

    #[test]
    fn separable_build_equals_the_window_of_every_cell() {
        // Odd sizes (remainder cells, some shorter than the widest apron),
        // NaN, infinities and unorm data.
        let dims = [19, 13, 27];
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
            let wide = WIDE_APRONS.iter().zip(&g.wide).map(|(a, (min, max))| (1 + a, min, max));
            for (apron, min, max) in [(1, &g.min, &g.max)].into_iter().chain(wide) {
                let window = |c: usize, n: usize| (c * BLOCK).saturating_sub(apron)..((c + 1) * BLOCK + apron).min(n);
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
                            assert_eq!((min[o], max[o]), (lo, hi), "apron {apron} cell {a} {b} {c}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn widening_takes_the_hull_of_the_neighbours() {
        let dims = [3, 4, 5];
        let n: usize = dims.iter().product();
        let min: Vec<f32> = (0..n).map(|i| ((i * 37) % 11) as f32).collect();
        let max: Vec<f32> = min.iter().map(|v| v + ((*v as usize * 7) % 5) as f32).collect();
        let g = MinMaxGrid { dims, min, max, wide: Vec::new(), has_nan: false, slopes: [0.0; 3] };
        for reach in [[0, 0, 0], [1, 1, 1], [0, 2, 1], [3, 0, 7]] {
            let w = g.clone().widened(reach);
            let near = |c: usize, k: usize, a: usize| c.abs_diff(k) <= reach[a];
            for a in 0..3 {
                for b in 0..4 {
                    for c in 0..5 {
                        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                        for i in (0..3).filter(|&i| near(a, i, 0)) {
                            for j in (0..4).filter(|&j| near(b, j, 1)) {
                                for k in (0..5).filter(|&k| near(c, k, 2)) {
                                    lo = lo.min(g.min[(i * 4 + j) * 5 + k]);
                                    hi = hi.max(g.max[(i * 4 + j) * 5 + k]);
                                }
                            }
                        }
                        let o = (a * 4 + b) * 5 + c;
                        assert_eq!((w.min[o], w.max[o]), (lo, hi), "reach {reach:?} cell {a} {b} {c}");
                    }
                }
            }
        }
    }

    #[test]
    fn segment_ranges_cover_half_a_step() {
        use SegmentRanges::*;
        // Voxels 0.01 apart: ends up to half a voxel out need nothing more,
        // up to 1.5 the one-voxel apron, up to 4.5 the half-cell one. Past
        // that, cells more: the one-voxel apron and a cell reach 9.5 voxels
        // (a window of 28 voxels along each axis, against 34 with the half
        // cell), the half cell and a cell 12.5, and so on.
        let wide = |apron, cells| Wide { apron, cells };
        assert_eq!(segment_ranges(0.0098, [0.01; 3]), Plain);
        assert_eq!(segment_ranges(0.029, [0.01; 3]), wide(0, [0; 3]));
        assert_eq!(segment_ranges(0.031, [0.01; 3]), wide(1, [0; 3]));
        assert_eq!(segment_ranges(0.089, [0.01; 3]), wide(1, [0; 3]));
        assert_eq!(segment_ranges(0.091, [0.01; 3]), wide(0, [1; 3]));
        assert_eq!(segment_ranges(0.18, [0.01; 3]), wide(0, [1; 3]));
        assert_eq!(segment_ranges(0.2, [0.01; 3]), wide(1, [1; 3]));
        assert_eq!(segment_ranges(0.25, [0.01; 3]), wide(0, [2; 3]));
        // One choice for all axes, the one of fewest voxels in all.
        assert_eq!(segment_ranges(0.0098, [0.01, 0.01, 0.001]), wide(0, [0, 0, 1]));
        assert_eq!(segment_ranges(0.16, [0.01, 0.02, 0.001]), wide(1, [1, 0, 10]));
        assert_eq!(segment_ranges(1.0, [0.0, 1.0, 1.0]), wide(0, [1_000_000, 0, 0]));
    }

    #[test]
    fn occupied_bounds_hold_every_cell_that_is_not_empty() {
        let dims = [5, 7, 9];
        let mut occ = vec![0u8; 5 * 7 * 9];
        assert_eq!(occupied_bounds(&occ, dims), None);
        for &(a, b, c) in &[(1, 6, 2), (3, 2, 8), (2, 4, 5)] {
            occ[(a * 7 + b) * 9 + c] = 3;
        }
        assert_eq!(occupied_bounds(&occ, dims), Some([[1, 3], [2, 6], [2, 8]]));
        let mut one = vec![0u8; 5 * 7 * 9];
        one[(4 * 7) * 9 + 3] = 1;
        assert_eq!(occupied_bounds(&one, dims), Some([[4, 4], [0, 0], [3, 3]]));
    }

    #[test]
    fn empty_radius_is_the_chebyshev_distance_to_an_occupied_cell() {
        // Brute force on a grid with a few occupied cells, and the cap.
        let dims = [5, 7, 9];
        let mut occ = vec![0u8; 5 * 7 * 9];
        for &(a, b, c) in &[(0, 0, 0), (4, 6, 2), (2, 3, 8)] {
            occ[(a * 7 + b) * 9 + c] = 3;
        }
        let r = empty_radius(&occ, dims);
        for a in 0..5i64 {
            for b in 0..7i64 {
                for c in 0..9i64 {
                    let want = [(0, 0, 0), (4, 6, 2), (2, 3, 8)]
                        .iter()
                        .map(|&(x, y, z)| (a - x).abs().max((b - y).abs()).max((c - z).abs()))
                        .min()
                        .unwrap();
                    assert_eq!(r[((a * 7 + b) * 9 + c) as usize] as i64, want, "cell {a} {b} {c}");
                }
            }
        }
        let wide = [1, 1, 40];
        let mut occ = vec![0u8; 40];
        occ[0] = 1;
        let r = empty_radius(&occ, wide);
        assert_eq!(r[1], 1);
        assert_eq!(r[39], MAX_EMPTY_RADIUS as u8);
        assert_eq!(empty_radius(&[0; 8], [2, 2, 2]), vec![MAX_EMPTY_RADIUS as u8; 8]);
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
    fn uniform_keys_mark_cells_whose_range_takes_one_entry() {
        let data = vec![0.0f32; 8];
        let v = VolumeView::new([1, 1, 8], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let mut g = MinMaxGrid::build(&v);
        g.dims = [1, 1, 6];
        // 0.3 exactly, a range inside the plateau 0.6..0.8, one across its
        // edge, one in the transparent start, one of NaN only, a point value.
        g.min = vec![0.3, 0.62, 0.55, 0.0, f32::INFINITY, 0.9];
        g.max = vec![0.3, 0.78, 0.65, 0.05, f32::NEG_INFINITY, 0.9];
        // Entries at 0.1 apart: opacity 0, 0, 0.1 .. 0.5, then 0.7 on 0.6..0.8.
        let a = [0.0, 0.0, 0.1, 0.2, 0.3, 0.5, 0.7, 0.7, 0.7, 0.2, 0.2];
        let lut: Vec<[f32; 4]> = (0..11).map(|i| [0.5, 0.5, 0.5, a[i]]).collect();
        let keys = g.uniform_keys(&lut, ValueMap::IDENTITY, &g.occupancy(&lut, ValueMap::IDENTITY));
        assert_eq!(keys, vec![12, 7, 0, 0, 0, 13]);
        // A colour change ends a run as an opacity change does.
        let mut lut2 = lut.clone();
        lut2[7][0] = 0.6;
        assert_eq!(g.uniform_keys(&lut2, ValueMap::IDENTITY, &g.occupancy(&lut2, ValueMap::IDENTITY))[1], 0);
        let data = [1.0f32, f32::NAN, 2.0];
        let v = VolumeView::new([1, 1, 3], Voxels::F32(&data), None, Bounds::default()).unwrap();
        assert!(MinMaxGrid::build(&v).has_nan);
        let v = VolumeView::new([1, 1, 3], Voxels::F32(&data[..1]), None, Bounds::default());
        assert!(v.is_err() || !MinMaxGrid::build(&v.unwrap()).has_nan);
    }

    #[test]
    fn uniform_radius_is_the_largest_cube_of_one_key() {
        // Brute force: keys 1 and 2 in blocks, keyless cells scattered.
        let dims = [6, 9, 11];
        let n: usize = dims.iter().product();
        let at = |i: usize| [i / (9 * 11), (i / 11) % 9, i % 11];
        let keys: Vec<u32> = (0..n)
            .map(|i| {
                let [a, b, c] = at(i);
                if (a * 7 + b * 3 + c) % 23 == 0 {
                    0
                } else if c < 6 {
                    1
                } else {
                    2
                }
            })
            .collect();
        let r = uniform_radius(&keys, dims);
        for i in 0..n {
            let c = at(i).map(|x| x as i64);
            let mut want = 0;
            if keys[i] != 0 {
                want = 1;
                while want < MAX_EMPTY_RADIUS {
                    let reach = want as i64;
                    let ok = (0..n).all(|j| {
                        let d = at(j).map(|x| x as i64);
                        let far = (0..3).any(|a| (d[a] - c[a]).abs() > reach);
                        far || keys[j] == keys[i]
                    });
                    if !ok {
                        break;
                    }
                    want += 1;
                }
            }
            assert_eq!(r[i] as usize, want, "cell {:?}", at(i));
        }
        // One key everywhere: the cap.
        assert_eq!(uniform_radius(&[3; 8], [2, 2, 2]), vec![MAX_EMPTY_RADIUS as u8; 8]);
    }

    /// The extinction per reference step a code stands for (255: unbounded),
    /// as shaders/tracking.wgsl decodes it.
    fn majorant_of(code: u8) -> f64 {
        if code == 255 {
            f64::INFINITY
        } else {
            ((code as f64 - 128.0) / 16.0).exp2()
        }
    }

    #[test]
    fn majorants_bound_the_extinction_and_empty_cells_stay_empty() {
        for e in [1e-9, 0.003, 0.01, 0.37, 1.0, 6.9, 200.0, 240.0, f64::INFINITY] {
            let q = majorant_code(e);
            assert!(q >= 1 && majorant_of(q) >= e, "{e}: code {q}");
            // Within one code step (4.4%) above it, where the codes reach.
            if (0.0042..234.0).contains(&e) {
                assert!(majorant_of(q) < e * 1.05, "{e}: {}", majorant_of(q));
            }
        }
        let data = vec![0.0f32; 8];
        let v = VolumeView::new([1, 1, 8], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let mut g = MinMaxGrid::build(&v);
        g.dims = [1, 1, 4];
        g.min = vec![0.0, 0.05, 0.45, 0.0];
        g.max = vec![0.04, 0.3, 0.55, 1.0];
        // Opacity 0 up to 0.1, 0.2 to 0.5, 0.999 at 0.5, 0.1 above.
        let lut: Vec<[f32; 4]> =
            (0..11).map(|i| [1.0, 1.0, 1.0, [0.0, 0.0, 0.2, 0.2, 0.2, 0.999, 0.1, 0.1, 0.1, 0.1, 0.1][i]]).collect();
        let q = g.majorants(&lut, ValueMap::IDENTITY, OpacityCorrection::Power);
        let occ = g.occupancy(&lut, ValueMap::IDENTITY);
        assert_eq!(q.iter().map(|&c| (c > 0) as u8).collect::<Vec<_>>(), occ);
        assert_eq!(q[0], 0);
        // Entries 0..=3 reach 0.2: -ln(0.8) = 0.223; the cells over 0.5 reach -ln(0.001) = 6.9.
        assert_eq!(q[1], majorant_code(-(0.8f64).ln()));
        assert_eq!(q[2], majorant_code(-(1.0 - 0.999f32 as f64).ln()));
        assert_eq!(q[3], q[2]);
        let exp = g.majorants(&lut, ValueMap::IDENTITY, OpacityCorrection::Exponential);
        assert_eq!(exp[2], majorant_code(0.999f32 as f64));
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

    #[test]
    fn value_bounds_hold_the_mapped_range_and_a_uniform_cell_exactly() {
        let data = vec![0.0f32; 8];
        let v = VolumeView::new([1, 1, 8], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let mut g = MinMaxGrid::build(&v);
        // Air (uniform), tissue, and a cell of NaN only.
        g.min = vec![-1000.0, 200.0, f32::INFINITY];
        g.max = vec![-1000.0, 560.0, f32::NEG_INFINITY];
        g.dims = [1, 1, 3];
        let map = ValueMap::new(1.0 / 2000.0, 0.5).unwrap();
        let (upper, lower) = (g.value_bounds(map, true, |x| x as f64), g.value_bounds(map, false, |x| x as f64));
        // A uniform cell's samples are its value: no margin.
        assert_eq!(upper[0], 0.0);
        assert_eq!(lower[0], 0.0);
        // Tissue maps to 0.6..0.78: moved out by 1e-5 of 0.18.
        let (hi, lo) = (0.78 + 1.8e-6, 0.6 - 1.8e-6);
        assert!((upper[1] as f64 - hi).abs() < 1e-7 && upper[1] as f64 > 0.78 + 1.5e-6, "{}", upper[1]);
        assert!((lower[1] as f64 - lo).abs() < 1e-7 && (lower[1] as f64) < 0.6 - 1.5e-6, "{}", lower[1]);
        // No value passes a NaN cell's bounds the wrong way: every ray leaps it.
        assert_eq!((upper[2], lower[2]), (f32::NEG_INFINITY, f32::INFINITY));
        // Bounds of the values as stored: air stored as -999 reads 0.0005.
        let stored = |x: f32| x as f64 + 1.0;
        assert_eq!((g.value_bounds(map, true, stored)[0], g.value_bounds(map, false, stored)[0]), (0.0005, 0.0005));
    }
}
