//! Transfer functions as data: control points to lookup tables, built-in
//! colormaps, and evaluation of a table at a sample value.

#[path = "colormaps_data.rs"]
mod colormaps_data;

/// numpy's `np.interp(x, xp, fp)` for increasing (possibly repeated) `xp`:
/// clamped to the end values outside, and at a repeated abscissa the later
/// point wins (pyvr's `peaks` relies on that).
pub fn interp(x: f64, xp: &[f64], fp: &[f64]) -> f64 {
    debug_assert_eq!(xp.len(), fp.len());
    let n = xp.len();
    if n == 0 {
        return f64::NAN;
    }
    if x.is_nan() {
        return f64::NAN;
    }
    if x < xp[0] {
        return fp[0];
    }
    if x >= xp[n - 1] {
        return fp[n - 1];
    }
    // Last j with xp[j] <= x; x < xp[n-1] guarantees j + 1 < n and xp[j+1] > x.
    let j = xp.partition_point(|&v| v <= x) - 1;
    let (x0, x1) = (xp[j], xp[j + 1]);
    if x == x0 {
        return fp[j];
    }
    let w = (x - x0) / (x1 - x0);
    fp[j] + w * (fp[j + 1] - fp[j])
}

/// `np.linspace(0, 1, n)[i]`, with the end exactly 1 as numpy makes it.
pub fn linspace01(i: usize, n: usize) -> f64 {
    if n <= 1 {
        return 0.0;
    }
    if i == n - 1 {
        return 1.0;
    }
    i as f64 * (1.0 / (n - 1) as f64)
}

/// Samples piecewise-linear channels at `linspace(0, 1, size)`.
/// `values` holds `channels` numbers per control point, point-major.
/// Returns `size * channels` f32 values, entry-major (pyvr's `to_lut`).
pub fn lut_from_points(scalars: &[f64], values: &[f64], channels: usize, size: usize) -> Vec<f32> {
    let n = scalars.len();
    assert_eq!(values.len(), n * channels, "values must hold channels per point");
    let columns: Vec<Vec<f64>> = (0..channels)
        .map(|c| (0..n).map(|i| values[i * channels + c]).collect())
        .collect();
    let mut out = Vec::with_capacity(size * channels);
    for i in 0..size {
        let x = linspace01(i, size);
        for col in &columns {
            out.push(interp(x, scalars, col) as f32);
        }
    }
    out
}

/// Evaluates an RGBA lookup table (entries at `m / (M - 1)`) at `v`, with
/// linear interpolation between entries and clamping outside [0, 1]. This is
/// the rule the shader applies; pyvr's GL lookup stretched it by M/(M-1).
pub fn eval_lut(lut: &[[f32; 4]], v: f64) -> [f64; 4] {
    let m = lut.len();
    if m == 0 {
        return [0.0; 4];
    }
    if m == 1 {
        return lut[0].map(f64::from);
    }
    let x = v.clamp(0.0, 1.0) * (m - 1) as f64;
    let i0 = (x.floor() as usize).min(m - 1);
    let i1 = (i0 + 1).min(m - 1);
    let f = x - i0 as f64;
    let mut out = [0.0; 4];
    for c in 0..4 {
        let a = lut[i0][c] as f64;
        let b = lut[i1][c] as f64;
        out[c] = a + (b - a) * f;
    }
    out
}

/// Affine map from a sampled value to the transfer function's [0, 1]
/// domain, `tf = sample * scale + offset`: a value range in data units
/// (Hounsfield units, densities) without rescaling the volume. The scale is
/// positive, so the map keeps order: maxima, minima and iso crossings of the
/// mapped field are those of the sampled one. NaN stays NaN.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueMap {
    pub scale: f64,
    pub offset: f64,
}

impl ValueMap {
    pub const IDENTITY: ValueMap = ValueMap { scale: 1.0, offset: 0.0 };

    pub fn new(scale: f64, offset: f64) -> Result<ValueMap, String> {
        if !(scale.is_finite() && scale > 0.0 && offset.is_finite()) {
            return Err(format!("value map needs a finite scale > 0 and a finite offset, got scale {scale}, offset {offset}"));
        }
        Ok(ValueMap { scale, offset })
    }

    #[inline]
    pub fn apply(self, v: f64) -> f64 {
        v * self.scale + self.offset
    }
}

impl Default for ValueMap {
    fn default() -> Self {
        ValueMap::IDENTITY
    }
}

/// Names of the colormaps pyvr carries itself.
pub fn colormap_names() -> Vec<&'static str> {
    colormaps_data::TABLES.iter().map(|(n, _)| *n).collect()
}

/// A built-in colormap as 256 RGB triples in [0, 1].
pub fn colormap(name: &str) -> Option<Vec<[f64; 3]>> {
    let (_, hex) = colormaps_data::TABLES.iter().find(|(n, _)| *n == name)?;
    let bytes: Vec<u8> = (0..hex.len() / 2)
        .map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap_or(0))
        .collect();
    Some(
        bytes
            .chunks_exact(3)
            .map(|c| [c[0] as f64 / 255.0, c[1] as f64 / 255.0, c[2] as f64 / 255.0])
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interp_matches_numpy_rules() {
        let xp = [0.0, 0.5, 1.0];
        let fp = [0.0, 1.0, 0.0];
        assert_eq!(interp(-1.0, &xp, &fp), 0.0);
        assert_eq!(interp(0.25, &xp, &fp), 0.5);
        assert_eq!(interp(0.5, &xp, &fp), 1.0);
        assert_eq!(interp(2.0, &xp, &fp), 0.0);
        // Repeated abscissa: the later value wins at the repeat.
        let xp = [0.0, 0.0, 0.02, 1.0];
        let fp = [0.0, 1.0, 0.0, 0.0];
        assert_eq!(interp(0.0, &xp, &fp), 1.0);
        assert!((interp(0.01, &xp, &fp) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn lut_endpoints_and_midpoint() {
        let lut = lut_from_points(&[0.0, 1.0], &[0.0, 1.0], 1, 5);
        assert_eq!(lut, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        let rgb = lut_from_points(&[0.0, 1.0], &[0.0, 0.0, 0.0, 1.0, 0.5, 0.25], 3, 3);
        assert_eq!(&rgb[3..6], &[0.5, 0.25, 0.125]);
    }

    #[test]
    fn eval_lut_is_exact_at_nodes_and_linear_between() {
        let lut: Vec<[f32; 4]> = (0..5).map(|i| [i as f32 / 4.0, 0.0, 0.0, 1.0]).collect();
        for k in 0..=20 {
            let v = k as f64 / 20.0;
            assert!((eval_lut(&lut, v)[0] - v).abs() < 1e-7);
        }
        assert_eq!(eval_lut(&lut, -3.0)[0], 0.0);
        assert_eq!(eval_lut(&lut, 7.0)[0], 1.0);
    }

    #[test]
    fn builtin_colormaps_exist_and_are_256_long() {
        for name in ["viridis", "plasma", "inferno", "magma", "cividis", "gray"] {
            let t = colormap(name).expect(name);
            assert_eq!(t.len(), 256);
        }
        let g = colormap("gray").unwrap();
        assert_eq!(g[0], [0.0, 0.0, 0.0]);
        assert_eq!(g[255], [1.0, 1.0, 1.0]);
        // viridis starts dark purple and ends yellow.
        let v = colormap("viridis").unwrap();
        assert!(v[0][2] > v[0][1] && v[255][0] > 0.9 && v[255][2] < 0.2);
        assert!(colormap("nope").is_none());
    }
}
