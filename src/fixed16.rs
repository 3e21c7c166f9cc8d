//! Values as 16-bit fixed point over their own range: the codes of a snorm16
//! texture channel, which the device reads as `r = code / 32767` in [-1, 1],
//! and the map back to the values (`value = r * scale + offset`).
//!
//! Integer data is coded exactly: the n distinct steps between its least and
//! largest value are spread over the 65534 code steps by a whole factor.
//! Float data rounds to the nearest of 65535 levels spanning its finite
//! range, an error of at most a 131068th of that range.

use crate::error::{try_collect, Error};
use crate::transfer::ValueMap;
use crate::volume::Voxels;

/// The largest code: snorm16 reads -32768 as -1 too, so it is never written.
pub const CODE_MAX: i32 = 32767;

/// Codes for every voxel and the map from a code's reading to the value the
/// renderer samples (for integers, the fraction of their type's range).
pub struct Fixed16 {
    pub codes: Vec<i16>,
    pub map: ValueMap,
}

impl Fixed16 {
    /// The value a code reads as.
    #[inline]
    pub fn decode(map: ValueMap, code: i16) -> f64 {
        map.apply(code as f64 / CODE_MAX as f64)
    }

    /// Codes `voxels`. Float data must be finite: NaN marks missing data,
    /// which has no code.
    pub fn encode(voxels: Voxels) -> Result<Fixed16, Error> {
        match voxels {
            Voxels::U8(v) => Self::integers(v.iter().map(|&x| x as u32), v.len(), 255.0),
            Voxels::U16(v) => Self::integers(v.iter().map(|&x| x as u32), v.len(), 65535.0),
            Voxels::F32(v) => Self::floats(v),
        }
    }

    /// Value `x` (of a type whose largest is `unit`) codes as
    /// `(x - lo) * factor - 32767`, the largest factor that keeps the codes
    /// within 32767: exact, and a whole factor keeps it so.
    fn integers(values: impl Iterator<Item = u32> + Clone, n: usize, unit: f64) -> Result<Fixed16, Error> {
        let (lo, hi) = values.clone().fold((u32::MAX, 0), |(lo, hi), x| (lo.min(x), hi.max(x)));
        let (lo, hi) = if n == 0 { (0, 0) } else { (lo, hi) };
        let span = hi - lo;
        if span > 2 * CODE_MAX as u32 {
            return Err(Error::InvalidInput(format!(
                "16-bit fixed point codes at most {} steps exactly, and these values span {span}: \
                 store them as they are",
                2 * CODE_MAX
            )));
        }
        let factor = (2 * CODE_MAX as u32).checked_div(span).unwrap_or(1);
        let codes = try_collect(
            n,
            "coding the volume in 16 bits",
            values.map(|x| ((x - lo) * factor) as i32 - CODE_MAX).map(|c| c as i16),
        )?;
        // value = (lo + (r * 32767 + 32767) / factor) / unit
        let f = factor as f64;
        let map = ValueMap { scale: CODE_MAX as f64 / (f * unit), offset: (lo as f64 + CODE_MAX as f64 / f) / unit };
        Ok(Fixed16 { codes, map })
    }

    fn floats(values: &[f32]) -> Result<Fixed16, Error> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &x in values {
            if !x.is_finite() {
                return Err(Error::InvalidInput(format!(
                    "16-bit fixed point needs finite values, and this volume holds {x}: store it as float32"
                )));
            }
            lo = lo.min(x as f64);
            hi = hi.max(x as f64);
        }
        if values.is_empty() {
            (lo, hi) = (0.0, 0.0);
        }
        let mid = 0.5 * (lo + hi);
        // A constant volume codes as 0 everywhere, read as `mid`.
        let half = if hi > lo { 0.5 * (hi - lo) } else { 1.0 };
        let map = ValueMap { scale: half, offset: mid };
        let code =
            |x: f32| round_code(((x as f64 - mid) / half * CODE_MAX as f64).clamp(-CODE_MAX as f64, CODE_MAX as f64));
        let codes = try_collect(values.len(), "coding the volume in 16 bits", values.iter().map(|&x| code(x)))?;
        Ok(Fixed16 { codes, map })
    }
}

/// A unit normal's component as a snorm16 code (zero stays exactly zero).
#[inline]
pub fn normal_code(c: f32) -> i16 {
    round_code((c.clamp(-1.0, 1.0) * CODE_MAX as f32) as f64)
}

/// `x.round() as i16` for |x| <= CODE_MAX (halves away from zero), by the
/// truncating conversion: `round` is a libm call on x86-64 without SSE4.1,
/// a few per voxel while a volume is coded. x - trunc(x) is exact.
#[inline]
fn round_code(x: f64) -> i16 {
    let t = x.abs();
    let whole = t as i32;
    let r = whole + (t - whole as f64 >= 0.5) as i32;
    (if x < 0.0 { -r } else { r }) as i16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_as_round_does() {
        // Halves, the floats either side of them, and values all over the range.
        let mut xs: Vec<f64> = (-2 * CODE_MAX..=2 * CODE_MAX).map(|k| k as f64 / 2.0).collect();
        xs.extend(xs.clone().iter().flat_map(|&x| [x.next_down(), x.next_up()]));
        xs.extend((0..100_000).map(|k| -(CODE_MAX as f64) + k as f64 * 0.6553));
        for x in xs.into_iter().filter(|x| x.abs() <= CODE_MAX as f64) {
            assert_eq!(round_code(x), x.round() as i16, "{x}");
        }
        for c in [0.0f32, 1.0, -1.0, 0.5, -0.5, 1.0 / 3.0, -0.999_99, 2.0, -7.0] {
            assert_eq!(normal_code(c), (c.clamp(-1.0, 1.0) * CODE_MAX as f32).round() as i16, "{c}");
        }
    }

    #[test]
    fn integers_code_exactly_and_fill_the_codes() {
        let v: Vec<u8> = vec![3, 200, 17, 3, 255];
        let f = Fixed16::encode(Voxels::U8(&v)).unwrap();
        for (&x, &c) in v.iter().zip(&f.codes) {
            assert!((Fixed16::decode(f.map, c) - x as f64 / 255.0).abs() < 1e-12, "{x} -> {c}");
        }
        assert_eq!(*f.codes.iter().min().unwrap(), -CODE_MAX as i16);
        // 252 steps spread by a factor of 260: the largest code is 252 * 260 - 32767.
        assert_eq!(*f.codes.iter().max().unwrap(), (252 * 260 - CODE_MAX) as i16);
        let w: Vec<u16> = vec![0, 65534, 40000, 1];
        let g = Fixed16::encode(Voxels::U16(&w)).unwrap();
        for (&x, &c) in w.iter().zip(&g.codes) {
            assert!((Fixed16::decode(g.map, c) - x as f64 / 65535.0).abs() < 1e-12);
        }
        assert!(Fixed16::encode(Voxels::U16(&[0, 65535])).is_err());
        let k = Fixed16::encode(Voxels::U16(&[7, 7])).unwrap();
        assert!((Fixed16::decode(k.map, k.codes[0]) - 7.0 / 65535.0).abs() < 1e-15);
    }

    #[test]
    fn floats_round_within_a_131068th_of_their_range() {
        let v: Vec<f32> = (0..10_000).map(|i| ((i as f32) * 0.7137).sin() * 3.0 - 1000.0).collect();
        let f = Fixed16::encode(Voxels::F32(&v)).unwrap();
        let range = 6.0;
        let err =
            v.iter().zip(&f.codes).map(|(&x, &c)| (Fixed16::decode(f.map, c) - x as f64).abs()).fold(0.0, f64::max);
        assert!(err <= range / 131068.0 * 1.0001, "{err}");
        assert!(err > range / 131068.0 * 0.5);
        assert_eq!(*f.codes.iter().max().unwrap(), CODE_MAX as i16);
        assert_eq!(*f.codes.iter().min().unwrap(), -CODE_MAX as i16);
        let c = Fixed16::encode(Voxels::F32(&[2.5, 2.5])).unwrap();
        assert_eq!(c.codes, [0, 0]);
        assert_eq!(Fixed16::decode(c.map, 0), 2.5);
        assert!(Fixed16::encode(Voxels::F32(&[0.0, f32::NAN])).is_err());
        assert!(Fixed16::encode(Voxels::F32(&[0.0, f32::INFINITY])).is_err());
    }

    #[test]
    fn normal_components_keep_zero_and_sign() {
        assert_eq!(normal_code(0.0), 0);
        assert_eq!(normal_code(1.0), 32767);
        assert_eq!(normal_code(-1.0), -32767);
        assert_eq!(normal_code(-0.5), -16384);
    }
}
