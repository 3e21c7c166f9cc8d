//! A volume as the renderer sees it: voxels in one of the stored formats,
//! optional normals, and the world box. Sampling here is the f64 twin of the
//! shader's sampling (same clamp, same NaN and Inf rules).

use crate::error::Error;
use crate::scene::Bounds;
use glam::DVec3;

/// Voxel storage by input dtype; unsigned integers are read as fractions of
/// their type's range (GPU unorm), floats as given.
#[derive(Clone, Copy, Debug)]
pub enum Voxels<'a> {
    F32(&'a [f32]),
    U8(&'a [u8]),
    U16(&'a [u16]),
}

impl Voxels<'_> {
    pub fn len(&self) -> usize {
        match self {
            Voxels::F32(v) => v.len(),
            Voxels::U8(v) => v.len(),
            Voxels::U16(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    #[inline]
    pub fn value(&self, idx: usize) -> f64 {
        match self {
            Voxels::F32(v) => sanitize(v[idx]) as f64,
            Voxels::U8(v) => v[idx] as f64 / 255.0,
            Voxels::U16(v) => v[idx] as f64 / 65535.0,
        }
    }
}

/// How float data is stored on the device; integer data is always stored
/// exactly (u8 in 1 byte per voxel, u16 in 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Precision {
    /// Exact: 4 bytes per voxel, normals packed in a second texture.
    #[default]
    Float32,
    /// Values rounded to float16 (relative error 2^-11): 2 bytes per voxel,
    /// or 8 with normals, which then share the value's texel so that a lit
    /// sample fetches once instead of twice. Needs finite values within
    /// +-65504, the largest float16.
    Float16,
    /// Values as 16-bit fixed point over their own range
    /// (`crate::fixed16`): integer data exactly, float data to a 131068th
    /// of its range. With normals one Rgba16Snorm texel (value, normal) per
    /// voxel, 8 bytes, so that a lit sample fetches once; without, 2 bytes.
    /// Needs finite values and a device with 16-bit normalized textures.
    Fixed16,
}

/// The largest finite float16.
pub const F16_MAX: f32 = 65504.0;

impl Precision {
    pub fn parse(name: &str) -> Result<Precision, Error> {
        match name {
            "float32" => Ok(Precision::Float32),
            "float16" => Ok(Precision::Float16),
            "fixed16" => Ok(Precision::Fixed16),
            _ => Err(Error::InvalidInput(format!("precision must be 'float32', 'float16' or 'fixed16', got {name:?}"))),
        }
    }

    /// Checks that float data `values` can be stored at this precision.
    pub fn check(self, values: &[f32]) -> Result<(), Error> {
        if self != Precision::Float16 {
            return Ok(());
        }
        match values.iter().find(|v| v.abs() > F16_MAX) {
            None => Ok(()),
            Some(v) => Err(Error::InvalidInput(format!(
                "with precision='float16' values must be finite and within +-{F16_MAX} (the largest float16), \
                 and this volume holds {v}: use precision='float32'"
            ))),
        }
    }
}

/// Infinite values become a large finite one of the same sign, so that
/// interpolating next to them never makes `inf * 0 = NaN`; after the transfer
/// function's clamp they act as the domain's ends. NaN stays NaN (empty).
pub const INF_REPLACEMENT: f32 = f32::MAX / 16.0;

#[inline]
pub fn sanitize(v: f32) -> f32 {
    if v.is_infinite() {
        INF_REPLACEMENT.copysign(v)
    } else {
        v
    }
}

#[derive(Clone, Copy, Debug)]
pub struct VolumeView<'a> {
    /// numpy shape (s0, s1, s2); axis 0 runs along world x.
    pub dims: [usize; 3],
    pub voxels: Voxels<'a>,
    /// Three floats per voxel in numpy axis order, or none.
    pub normals: Option<&'a [f32]>,
    pub bounds: Bounds,
}

impl<'a> VolumeView<'a> {
    pub fn new(
        dims: [usize; 3],
        voxels: Voxels<'a>,
        normals: Option<&'a [f32]>,
        bounds: Bounds,
    ) -> Result<Self, Error> {
        let n = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
        let n = n.ok_or_else(|| Error::InvalidInput("volume shape overflows".into()))?;
        if dims.contains(&0) {
            return Err(Error::InvalidInput(format!("volume shape must have no zero axis, got {dims:?}")));
        }
        if voxels.len() != n {
            return Err(Error::InvalidInput(format!(
                "volume data has {} voxels but shape {dims:?} needs {n}",
                voxels.len()
            )));
        }
        if let Some(nr) = normals {
            if nr.len() != 3 * n {
                return Err(Error::InvalidInput(format!(
                    "normals must have shape {:?}, got {} values",
                    [dims[0], dims[1], dims[2], 3],
                    nr.len()
                )));
            }
        }
        Ok(VolumeView { dims, voxels, normals, bounds })
    }

    #[inline]
    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (i * self.dims[1] + j) * self.dims[2] + k
    }

    /// Cell-centred trilinear weights along one axis, clamped at the edges.
    #[inline]
    fn axis(u: f64, n: usize) -> (usize, usize, f64) {
        let x = u * n as f64 - 0.5;
        let f = x.floor();
        let w = x - f;
        let last = n as i64 - 1;
        let i0 = (f as i64).clamp(0, last) as usize;
        let i1 = (f as i64 + 1).clamp(0, last) as usize;
        (i0, i1, w)
    }

    /// Trilinear value at unit-box coordinates `q` (axis 0 = x). NaN when any
    /// of the eight neighbours is NaN.
    pub fn sample(&self, q: DVec3) -> f64 {
        let (i0, i1, wi) = Self::axis(q.x, self.dims[0]);
        let (j0, j1, wj) = Self::axis(q.y, self.dims[1]);
        let (k0, k1, wk) = Self::axis(q.z, self.dims[2]);
        let v = |i, j, k| self.voxels.value(self.index(i, j, k));
        let lerp = |a: f64, b: f64, w: f64| a + (b - a) * w;
        let c00 = lerp(v(i0, j0, k0), v(i0, j0, k1), wk);
        let c01 = lerp(v(i0, j1, k0), v(i0, j1, k1), wk);
        let c10 = lerp(v(i1, j0, k0), v(i1, j0, k1), wk);
        let c11 = lerp(v(i1, j1, k0), v(i1, j1, k1), wk);
        lerp(lerp(c00, c01, wj), lerp(c10, c11, wj), wi)
    }

    /// Interpolated direction of the supplied normals (each voxel's
    /// normalised first), re-normalised; `None` if zero or absent.
    pub fn normal(&self, q: DVec3) -> Option<DVec3> {
        let nr = self.normals?;
        let (i0, i1, wi) = Self::axis(q.x, self.dims[0]);
        let (j0, j1, wj) = Self::axis(q.y, self.dims[1]);
        let (k0, k1, wk) = Self::axis(q.z, self.dims[2]);
        let v = |i, j, k| {
            let b = 3 * self.index(i, j, k);
            let u = unit_direction([nr[b], nr[b + 1], nr[b + 2]]);
            DVec3::new(u[0] as f64, u[1] as f64, u[2] as f64)
        };
        let c00 = v(i0, j0, k0).lerp(v(i0, j0, k1), wk);
        let c01 = v(i0, j1, k0).lerp(v(i0, j1, k1), wk);
        let c10 = v(i1, j0, k0).lerp(v(i1, j0, k1), wk);
        let c11 = v(i1, j1, k0).lerp(v(i1, j1, k1), wk);
        unit_or_none(c00.lerp(c01, wj).lerp(c10.lerp(c11, wj), wi))
    }

    /// Direction of increasing value from central differences one voxel
    /// apart, divided by world spacing (so anisotropic boxes shade right).
    pub fn gradient_normal(&self, q: DVec3) -> Option<DVec3> {
        let ext = self.bounds.extent();
        let mut g = DVec3::ZERO;
        for a in 0..3 {
            let mut dq = DVec3::ZERO;
            dq[a] = 1.0 / self.dims[a] as f64;
            let spacing = ext[a] / self.dims[a] as f64;
            g[a] = (self.sample(q + dq) - self.sample(q - dq)) / (2.0 * spacing);
        }
        unit_or_none(g)
    }
}

/// A stored normal's direction: unit length, or zero for zero, NaN or
/// infinite input (such voxels get no diffuse term).
#[inline]
pub fn unit_direction(n: [f32; 3]) -> [f32; 3] {
    // An f32's square neither overflows nor underflows an f64, so no hypot
    // (a libm call); inlined, the packing loops overlap the voxels' square
    // roots and divisions.
    let l = n.iter().map(|&c| c as f64 * c as f64).sum::<f64>().sqrt();
    if !(l > 0.0 && l.is_finite()) {
        return [0.0; 3];
    }
    [(n[0] as f64 / l) as f32, (n[1] as f64 / l) as f32, (n[2] as f64 / l) as f32]
}

pub fn unit_or_none(v: DVec3) -> Option<DVec3> {
    let l = v.length();
    (l > 0.0 && l.is_finite()).then(|| v / l)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_directions_are_unit_at_every_scale() {
        let big = f32::MAX;
        let tiny = f32::from_bits(1); // the smallest subnormal
        for n in [[3.0, -4.0, 12.0], [big, big, -big], [tiny, 0.0, -tiny], [1e-30, 2e-30, 2e-30], [0.0, -5e37, 0.0]] {
            let u = unit_direction(n);
            let len = u.iter().map(|&c| (c as f64).powi(2)).sum::<f64>().sqrt();
            assert!((len - 1.0).abs() < 1e-6, "{n:?}: {u:?}");
            let same_way = (0..3).all(|k| if n[k] == 0.0 { u[k] == 0.0 } else { u[k].signum() == n[k].signum() });
            assert!(same_way, "{n:?}: {u:?}");
        }
        assert_eq!(unit_direction([3.0, -4.0, 12.0]), [3.0 / 13.0, -4.0 / 13.0, 12.0 / 13.0]);
        for n in [[0.0; 3], [f32::NAN, 1.0, 0.0], [f32::INFINITY, 0.0, 0.0]] {
            assert_eq!(unit_direction(n), [0.0; 3], "{n:?}");
        }
    }

    #[test]
    fn trilinear_is_cell_centred_and_clamped() {
        // 2 voxels along x: centres at q.x = 0.25 and 0.75.
        let data = [0.0f32, 1.0];
        let v = VolumeView::new([2, 1, 1], Voxels::F32(&data), None, Bounds::default()).unwrap();
        let s = |x| v.sample(DVec3::new(x, 0.5, 0.5));
        assert_eq!(s(0.25), 0.0);
        assert_eq!(s(0.75), 1.0);
        assert!((s(0.5) - 0.5).abs() < 1e-12);
        assert_eq!(s(0.0), 0.0);
        assert_eq!(s(1.0), 1.0);
    }

    #[test]
    fn nan_poisons_and_inf_is_finite() {
        let data = [0.0f32, f32::NAN, f32::INFINITY, 0.5];
        let v = VolumeView::new([4, 1, 1], Voxels::F32(&data), None, Bounds::default()).unwrap();
        assert!(v.sample(DVec3::new(0.25, 0.5, 0.5)).is_nan());
        let x = v.sample(DVec3::new(0.75, 0.5, 0.5));
        assert!(x.is_finite() && x > 1e30);
    }

    #[test]
    fn unorm_reads() {
        let data = [255u8, 0];
        let v = VolumeView::new([1, 1, 2], Voxels::U8(&data), None, Bounds::default()).unwrap();
        assert_eq!(v.sample(DVec3::new(0.5, 0.5, 0.25)), 1.0);
    }

    #[test]
    fn gradient_points_uphill_in_world_units() {
        // Linear ramp along axis 1 (world y), box twice as long in y.
        let n = 8;
        let data: Vec<f32> = (0..n * n * n).map(|idx| ((idx / n) % n) as f32).collect();
        let b = Bounds::new(DVec3::splat(-1.0), DVec3::new(1.0, 3.0, 1.0)).unwrap();
        let v = VolumeView::new([n, n, n], Voxels::F32(&data), None, b).unwrap();
        let g = v.gradient_normal(DVec3::splat(0.5)).unwrap();
        assert!((g - DVec3::Y).length() < 1e-12);
        let flat = vec![1.0f32; 8];
        let v = VolumeView::new([2, 2, 2], Voxels::F32(&flat), None, Bounds::default()).unwrap();
        assert!(v.gradient_normal(DVec3::splat(0.5)).is_none());
    }

    #[test]
    fn rejects_mismatched_sizes() {
        let data = [0.0f32; 7];
        assert!(VolumeView::new([2, 2, 2], Voxels::F32(&data), None, Bounds::default()).is_err());
    }
}
