//! What the grid's cells tell a ray: the code of a cell's largest
//! extinction, the ranges unbiased segments read, and the radius of the
//! cube of empty (or uniform) cells around each cell that one leap crosses.

use super::*;

/// Code 1..=254 of an extinction per reference step `e` > 0: the smallest q
/// with 2^((q - 128) / 16) >= e (a step of 4.4%, from 0.0041 to 235), with a
/// margin for the shader's f32 exp2; 255 for larger or infinite ones (the
/// frame's own rate, the transfer function's largest).
pub fn majorant_code(e: f64) -> u8 {
    let q = (16.0 * (e * (1.0 + 1e-4)).log2() + 128.0).ceil();
    if !(q <= 254.0) {
        255
    } else {
        q.max(1.0) as u8
    }
}

/// The ranges holding every segment of length `step` (world units) centred
/// in a cell, for voxels `spacing` apart along the numpy axes: its ends lie
/// up to half a step from the midpoint (with a margin for the shader's f32
/// positions). The plain ranges cover half a voxel past the cell, the wide
/// ones `WIDE_APRONS[i]` more, and whole cells more reach further: of the
/// wide ranges, those whose windows (apron and cells) hold the fewest voxels.
pub fn segment_ranges(step: f64, spacing: [f64; 3]) -> SegmentRanges {
    let beyond = spacing.map(|s| 0.5 * step / s + 0.01 - 0.5);
    if beyond.iter().all(|&b| b <= 0.0) {
        return SegmentRanges::Plain;
    }
    let cells_past = |apron: usize| {
        beyond.map(|b| {
            let cells = (b - apron as f64).max(0.0) / BLOCK as f64;
            if cells.is_nan() || cells > 1e6 {
                1_000_000
            } else {
                cells.ceil() as usize
            }
        })
    };
    let voxels = |apron: usize, cells: [usize; 3]| {
        cells.iter().map(|&c| (BLOCK + 2 * (1 + apron + BLOCK * c)) as f64).product::<f64>()
    };
    let (apron, cells) = (0..WIDE_APRONS.len())
        .map(|i| (i, cells_past(WIDE_APRONS[i])))
        .min_by(|a, b| voxels(WIDE_APRONS[a.0], a.1).total_cmp(&voxels(WIDE_APRONS[b.0], b.1)))
        .expect("WIDE_APRONS is not empty");
    SegmentRanges::Wide { apron, cells }
}

/// Largest empty radius kept, in cells: a leap ends at most R cells past
/// the cell it starts in (16 cells = 128 voxels), and the field costs
/// O(cells * R) to build. 64 measured no faster on the accuracy scenes.
pub const MAX_EMPTY_RADIUS: usize = 16;

/// Per cell of an occupancy grid (0 = occupied), its empty radius: the
/// Chebyshev distance in cells to the nearest occupied cell (0 for an
/// occupied cell, at most MAX_EMPTY_RADIUS). A cell of radius r sits at the
/// centre of an empty cube of 2r - 1 cells a side, which a ray leaves in one
/// leap. Cells outside the grid count as empty: rays never sample there.
/// The distance is separable: min over occupied o of max(|da|, |db|, |dc|)
/// is taken one axis at a time, each pass the max of the offset along its
/// axis and the previous pass's distance, within the radius cap.
pub fn empty_radius(occ: &[u8], dims: [usize; 3]) -> Vec<u8> {
    let cap = MAX_EMPTY_RADIUS;
    let [d0, d1, d2] = dims;
    let index = |a: usize, b: usize, c: usize| (a * d1 + b) * d2 + c;
    // Along axis 2: the distance to the nearest occupied cell of the row.
    let mut dist: Vec<usize> = occ.iter().map(|&o| if o != 0 { 0 } else { cap }).collect();
    for a in 0..d0 {
        for b in 0..d1 {
            for c in 1..d2 {
                dist[index(a, b, c)] = dist[index(a, b, c)].min(dist[index(a, b, c - 1)] + 1);
            }
            for c in (0..d2.saturating_sub(1)).rev() {
                dist[index(a, b, c)] = dist[index(a, b, c)].min(dist[index(a, b, c + 1)] + 1);
            }
        }
    }
    // Along axes 1 and 0: min over offsets k of max(|k|, distance there).
    for axis in [1, 0] {
        let len = dims[axis];
        let step = if axis == 1 { d2 } else { d1 * d2 };
        let prev = dist.clone();
        for (i, out) in dist.iter_mut().enumerate() {
            let at = (i / step) % len;
            // Offsets k >= best cannot lower it.
            let mut best = prev[i];
            let mut k = 1;
            while k < best && k < len {
                if at >= k {
                    best = best.min(k.max(prev[i - k * step]));
                }
                if at + k < len {
                    best = best.min(k.max(prev[i + k * step]));
                }
                k += 1;
            }
            *out = best;
        }
    }
    dist.into_iter().map(|r| r.min(cap) as u8).collect()
}

/// The box of cells of `occ` (0 = empty) that are not empty: per axis the
/// first and last such cell's index, or None where every cell is empty. A
/// ray's segments centred outside it add nothing, so the march can start
/// where the ray enters it and end where it leaves.
pub fn occupied_bounds(occ: &[u8], dims: [usize; 3]) -> Option<[[usize; 2]; 3]> {
    let [_, d1, d2] = dims;
    let mut bounds: Option<[[usize; 2]; 3]> = None;
    for (i, _) in occ.iter().enumerate().filter(|(_, &o)| o != 0) {
        let at = [i / (d1 * d2), (i / d2) % d1, i % d2];
        let b = bounds.get_or_insert([[at[0]; 2], [at[1]; 2], [at[2]; 2]]);
        for a in 0..3 {
            b[a] = [b[a][0].min(at[a]), b[a][1].max(at[a])];
        }
    }
    bounds
}

/// Added to the radius byte of a uniform cell (`uniform_radius`); empty
/// radii stay below it.
pub const UNIFORM_FLAG: u8 = 128;

/// Per cell of `keys` (`MinMaxGrid::uniform_keys`), 0 where the key is 0,
/// else its uniform radius: the largest r (at least 1, at most
/// MAX_EMPTY_RADIUS) such that the cube of 2r - 1 cells around it holds only
/// cells of its key, which a ray crosses as one segment. Cells outside the
/// grid count as its key: rays never sample there.
pub fn uniform_radius(keys: &[u32], dims: [usize; 3]) -> Vec<u8> {
    // The smallest and largest key among each cell's 27 neighbours (itself
    // included), keyless cells left out, one axis at a time.
    let mut lo: Vec<u32> = keys.iter().map(|&k| if k == 0 { u32::MAX } else { k }).collect();
    let mut hi = keys.to_vec();
    for axis in 0..3 {
        let stride: usize = dims[axis + 1..].iter().product();
        let len = dims[axis];
        let (plo, phi) = (lo.clone(), hi.clone());
        for i in 0..keys.len() {
            let at = (i / stride) % len;
            for j in [at.checked_sub(1), (at + 1 < len).then_some(at + 1)].into_iter().flatten() {
                let n = i - at * stride + j * stride;
                lo[i] = lo[i].min(plo[n]);
                hi[i] = hi[i].max(phi[n]);
            }
        }
    }
    // The radius is the distance to the nearest keyless cell or cell of
    // another key. The nearest of the latter is one cell past the nearest
    // keyed cell beside another key, unless a keyless cell comes first.
    let keyless: Vec<u8> = keys.iter().map(|&k| (k == 0) as u8).collect();
    let beside: Vec<u8> = keys.iter().enumerate().map(|(i, &k)| (k != 0 && (lo[i] != k || hi[i] != k)) as u8).collect();
    let (to_keyless, to_beside) = (empty_radius(&keyless, dims), empty_radius(&beside, dims));
    let cap = MAX_EMPTY_RADIUS as u8;
    (0..keys.len()).map(|i| if keys[i] == 0 { 0 } else { to_keyless[i].min(to_beside[i] + 1).clamp(1, cap) }).collect()
}
