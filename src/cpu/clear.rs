//! Where the transfer function is transparent, as lookups the march can
//! ask eight rays at once: a pass whose every sample (or pre-integrated
//! segment) has opacity 0 adds nothing, and skips the transfer function's
//! lookup, the light and the exponential (or the table's bilinear lookup).
//! In sparse scenes most passes in occupied cells are such: segments near,
//! not on, a narrow peak, or under a step's threshold.
//!
//! Each table holds, for every interval, the first interval at or after it
//! that is not transparent, so "intervals lo..=hi are all transparent" is
//! one lookup: `first[lo] > hi`.

/// The first non-transparent interval at or after each interval (`n` when
/// none), for intervals marked by `transparent`.
fn first_opaque(transparent: impl DoubleEndedIterator<Item = bool> + ExactSizeIterator) -> Vec<i32> {
    let n = transparent.len();
    let mut out = vec![0i32; n];
    let mut next = n as i32;
    for (i, clear) in transparent.enumerate().rev() {
        if !clear {
            next = i as i32;
        }
        out[i] = next;
    }
    out
}

/// The transfer function's transparent intervals, for the midpoint rule and
/// for the pre-integration table.
#[derive(Clone, Debug, Default)]
pub struct Clear {
    /// Interval k of the lookup table (entries k and k + 1): the first
    /// interval from k on with an entry of opacity other than 0.
    pub lut: Vec<i32>,
    /// Interval i of the pre-integration table (front or back values i to
    /// i + 1): the first from i on whose ramps have any colour or depth.
    /// Empty without a table.
    pub table: Vec<i32>,
    /// Whether any interval of each is transparent: where none is, the
    /// march asks neither (a gather a pass that could never skip anything).
    pub lut_has_clear: bool,
    pub table_has_clear: bool,
}

impl Clear {
    /// From the lookup table and, for pre-integrated frames, the
    /// pre-integration table (`side` entries a row, entry (front, back) at
    /// `back * side + front`). A table interval is transparent where both
    /// ramps across it alone are all zero: the integral of an opacity that is
    /// 0 throughout, which every longer ramp over such intervals only is as
    /// well (`preintegrate::table`: windows composed of empty pieces).
    pub fn new(lut: &[[f32; 4]], table: Option<(&[[f32; 4]], usize)>) -> Clear {
        let intervals = lut.len().saturating_sub(1);
        let lut_clear = (0..intervals).map(|k| lut[k][3] == 0.0 && lut[k + 1][3] == 0.0);
        let table = match table {
            Some((texels, side)) if side >= 2 && texels.len() >= side * side => {
                let zero = |f: usize, b: usize| texels[b * side + f] == [0.0; 4];
                first_opaque((0..side - 1).map(|i| zero(i, i + 1) && zero(i + 1, i)))
            }
            _ => Vec::new(),
        };
        let lut = first_opaque(lut_clear);
        let has_clear = |first: &[i32]| first.iter().enumerate().any(|(i, &f)| f > i as i32);
        Clear { lut_has_clear: has_clear(&lut), table_has_clear: has_clear(&table), lut, table }
    }

    /// Whether a midpoint sample in lookup-table interval `k` has opacity 0.
    #[cfg(test)]
    pub fn sample_clear(&self, k: usize) -> bool {
        self.lut[k] > k as i32
    }

    /// Whether the bilinear lookup at table entries (x0, y0) to
    /// (x0 + 1, y0 + 1) reads only transparent entries: table intervals from
    /// the smaller of x0, y0 to the larger (those past the last interval
    /// counted as it: entry side - 1 is weighed 0 beyond it).
    #[cfg(test)]
    pub fn segment_clear(&self, x0: usize, y0: usize) -> bool {
        let last = self.table.len() - 1;
        let (lo, hi) = (x0.min(y0).min(last), x0.max(y0).min(last));
        self.table[lo] > hi as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OpacityCorrection;
    use crate::preintegrate::{table, table_side};

    /// Three narrow opacity peaks over a colour ramp, as the benchmark's.
    fn peaks(n: usize) -> Vec<[f32; 4]> {
        (0..n)
            .map(|i| {
                let v = i as f32 / (n - 1) as f32;
                let a = [0.3f32, 0.5, 0.7].iter().map(|c| (0.6 - 30.0 * (v - c).abs()).max(0.0)).sum::<f32>();
                [v, 1.0 - v, 0.5, a]
            })
            .collect()
    }

    #[test]
    fn first_opaque_points_past_each_run_of_transparent_intervals() {
        let t = first_opaque([true, true, false, true, false, true].into_iter());
        assert_eq!(t, vec![2, 2, 2, 4, 4, 6]);
    }

    #[test]
    fn a_clear_sample_looks_up_opacity_zero() {
        let lut = peaks(256);
        let clear = Clear::new(&lut, None);
        let mut seen = [0usize; 2];
        for k in 0..255 {
            let zero = lut[k][3] == 0.0 && lut[k + 1][3] == 0.0;
            assert_eq!(clear.sample_clear(k), zero, "interval {k}");
            seen[zero as usize] += 1;
        }
        // Both kinds occur: the peaks are narrow, and not every interval is clear.
        assert!(seen[0] > 10 && seen[1] > 100, "{seen:?}");
        assert!(clear.lut_has_clear && !clear.table_has_clear);
        let opaque: Vec<[f32; 4]> = lut.iter().map(|e| [e[0], e[1], e[2], e[3] + 0.01]).collect();
        assert!(!Clear::new(&opaque, None).lut_has_clear);
    }

    /// Every bilinear lookup the check calls clear reads four entries of
    /// exactly zero, and lookups across a peak are not called clear, for
    /// lookup tables shorter than, as long as and longer than the table's
    /// side, at steps of one and of many table intervals of change.
    #[test]
    fn a_clear_segment_reads_only_zero_entries() {
        for n in [64, 256, 1024] {
            let lut = peaks(n);
            let side = table_side(n);
            for (len, reach) in [(0.5, 3), (2.0, 40), (8.0, side - 1)] {
                let t = table(&lut, len, OpacityCorrection::Power, reach);
                let clear = Clear::new(&lut, Some((&t, side)));
                let entry = |f: usize, b: usize| t[b * side + f];
                let (mut called, mut crossing) = (0usize, 0usize);
                for y0 in 0..side {
                    for x0 in y0.saturating_sub(reach - 1)..(y0 + reach).min(side) {
                        // Entries past the last front or back value are weighed 0 there.
                        let corners: Vec<[f32; 4]> = [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)]
                            .into_iter()
                            .filter(|&(f, b)| f < side && b < side)
                            .map(|(f, b)| entry(f, b))
                            .collect();
                        if clear.segment_clear(x0, y0) {
                            called += 1;
                            assert!(
                                corners.iter().all(|e| *e == [0.0; 4]),
                                "n {n} len {len}: ({x0}, {y0}) {corners:?}"
                            );
                        } else if corners[0][3] > 0.0 {
                            crossing += 1;
                        }
                    }
                }
                assert!(called > side && crossing > side / 4, "n {n} len {len}: {called} clear, {crossing} not");
                assert!(clear.table_has_clear);
            }
        }
    }
}
