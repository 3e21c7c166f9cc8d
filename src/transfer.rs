//! Transfer functions as data: built-in colormaps, and evaluation of a
//! lookup table at a sample value (tables are built from control points in
//! Python, with numpy.interp).

#[path = "colormaps_data.rs"]
mod colormaps_data;

/// Evaluates an RGBA lookup table (entries at `m / (M - 1)`) at `v`, with
/// linear interpolation between entries and clamping outside [0, 1]. This is
/// the rule the shader applies; pyvr's GL lookup stretched it by M/(M-1).
#[inline]
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
            return Err(format!(
                "value map needs a finite scale > 0 and a finite offset, got scale {scale}, offset {offset}"
            ));
        }
        Ok(ValueMap { scale, offset })
    }

    #[inline]
    pub fn apply(self, v: f64) -> f64 {
        v * self.scale + self.offset
    }

    /// `inner` first, then this map.
    pub fn after(self, inner: ValueMap) -> ValueMap {
        ValueMap { scale: self.scale * inner.scale, offset: self.apply(inner.offset) }
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
    let bytes: Vec<u8> =
        (0..hex.len() / 2).map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap_or(0)).collect();
    Some(bytes.chunks_exact(3).map(|c| [c[0] as f64 / 255.0, c[1] as f64 / 255.0, c[2] as f64 / 255.0]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

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
