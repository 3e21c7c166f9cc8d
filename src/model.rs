//! The optical models and projections a frame can compute (Max, "Optical
//! Models for Direct Volume Rendering"), and what each one's RGBA holds.
//!
//! With `T = exp(-∫ σ ds / ref)` the transmittance along the ray, `σ` the
//! extinction per reference step from the opacity TF, `c` the colour TF and
//! `I` the light intensity at a sample:
//!
//! | model | premultiplied RGB | alpha |
//! |---|---|---|
//! | emission_absorption | `∫ T(s) σ(s) I c(s) ds / ref` | `1 - T` |
//! | absorption | `0` (the medium emits nothing) | `1 - T` |
//! | emission | `∫ σ(s) I c(s) ds / ref` (no attenuation) | `0` (additive) |
//! | single_scattering | `∫ T σ c (ambient + diffuse · 4π p(θ) · T_light) ds / ref` | `1 - T` |
//! | mip / minip / average | `a · c(v*)` | `a(v*)` of the projected value `v*` |
//! | isosurface | `c(iso) · I(n)` at the first point with `v >= iso` | `1` on a hit |

use crate::error::Error;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Model {
    #[default]
    EmissionAbsorption,
    Absorption,
    Emission,
    SingleScattering,
    Mip,
    MinIp,
    Average,
    Isosurface,
}

impl Model {
    pub const ALL: [Model; 8] = [
        Model::EmissionAbsorption,
        Model::Absorption,
        Model::Emission,
        Model::SingleScattering,
        Model::Mip,
        Model::MinIp,
        Model::Average,
        Model::Isosurface,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Model::EmissionAbsorption => "emission_absorption",
            Model::Absorption => "absorption",
            Model::Emission => "emission",
            Model::SingleScattering => "single_scattering",
            Model::Mip => "mip",
            Model::MinIp => "minip",
            Model::Average => "average",
            Model::Isosurface => "isosurface",
        }
    }

    pub fn parse(s: &str) -> Result<Model, Error> {
        Model::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Model::ALL.iter().map(|m| m.name()).collect();
            Error::InvalidInput(format!("model must be one of {}, got '{s}'", names.join(", ")))
        })
    }

    /// The shader's `MODEL` override constant.
    pub fn code(self) -> u32 {
        Model::ALL.iter().position(|&m| m == self).unwrap_or(0) as u32
    }

    /// Accumulates optical depth along the ray (Beer–Lambert models).
    pub fn integrates(self) -> bool {
        matches!(self, Model::EmissionAbsorption | Model::Absorption | Model::Emission | Model::SingleScattering)
    }

    /// Projects the sampled values (MIP, MinIP, average).
    pub fn projects(self) -> bool {
        matches!(self, Model::Mip | Model::MinIp | Model::Average)
    }

    /// Opacity-0 samples contribute nothing, so empty cells may be skipped.
    pub fn skips_transparent(self) -> bool {
        self.integrates()
    }

    /// Some cells can be leapt over: transparent ones (integrating models)
    /// or, for the isosurface, ones whose values stay below `iso_value`.
    pub fn skips_cells(self) -> bool {
        self.integrates() || self == Model::Isosurface
    }

    /// Rays leap cells whose values cannot change the pixel (the cells'
    /// bounds against the ray's maximum or minimum so far).
    pub fn leaps_by_bounds(self) -> bool {
        matches!(self, Model::Mip | Model::MinIp)
    }

    /// Rays may stop once opaque (alpha is the accumulated opacity).
    pub fn terminates_early(self) -> bool {
        matches!(self, Model::EmissionAbsorption | Model::Absorption | Model::SingleScattering)
    }

    /// The light's intensity enters the colour.
    pub fn uses_light(self) -> bool {
        matches!(self, Model::EmissionAbsorption | Model::Emission | Model::SingleScattering | Model::Isosurface)
    }

    /// Has unbiased frames (ratio tracking at Poisson points; single
    /// scattering's shadow rays have none).
    pub fn tracks(self) -> bool {
        matches!(self, Model::EmissionAbsorption | Model::Absorption | Model::Emission)
    }

    /// Lit samples take their light from normals or the field's gradient
    /// (single scattering's take it from shadow rays).
    pub fn lit_by_normals(self) -> bool {
        self.uses_light() && self != Model::SingleScattering
    }

    /// How the partial images of a volume's parts combine into the frame:
    /// "max", "min", "average", "iso" (the nearest hit) or "integrate"
    /// (front-to-back compositing of colour and optical depth).
    pub fn reduction(self) -> &'static str {
        match self {
            Model::Mip => "max",
            Model::MinIp => "min",
            Model::Average => "average",
            Model::Isosurface => "iso",
            _ => "integrate",
        }
    }
}

/// Order in which segments are composited; the two are equal up to rounding
/// (back to front cannot stop early, so early termination is ignored).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Order {
    #[default]
    FrontToBack,
    BackToFront,
}

impl Order {
    pub fn name(self) -> &'static str {
        match self {
            Order::FrontToBack => "front_to_back",
            Order::BackToFront => "back_to_front",
        }
    }

    pub fn parse(s: &str) -> Result<Order, Error> {
        match s {
            "front_to_back" => Ok(Order::FrontToBack),
            "back_to_front" => Ok(Order::BackToFront),
            other => {
                Err(Error::InvalidInput(format!("order must be 'front_to_back' or 'back_to_front', got '{other}'")))
            }
        }
    }
}

/// `4π p(cos θ)` for the Henyey–Greenstein phase function with anisotropy
/// `g` (0: isotropic, giving 1). `cos_theta` is the cosine between the
/// light's travel direction and the direction scattered toward the eye.
pub fn phase_4pi(g: f64, cos_theta: f64) -> f64 {
    if g == 0.0 {
        return 1.0;
    }
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    (1.0 - g * g) / (denom * denom.sqrt())
}

/// Per-pixel jitter of the first segment boundary, in (-1, 0] steps:
/// deterministic in (column, row, seed) and computed bit-identically by the
/// shader (same integer hash, 24-bit fraction).
pub fn jitter_shift(col: u32, row: u32, seed: u32) -> f32 {
    let h = hash32(col ^ hash32(row ^ hash32(seed)));
    -((h >> 8) as f32) * (1.0 / 16_777_216.0)
}

/// A 32-bit integer mix with good avalanche (the "lowbias32" constants).
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for m in Model::ALL {
            assert_eq!(Model::parse(m.name()).unwrap(), m);
        }
        assert!(Model::parse("xray").unwrap_err().message().contains("emission_absorption"));
        assert_eq!(Order::parse("back_to_front").unwrap(), Order::BackToFront);
    }

    #[test]
    fn henyey_greenstein_is_normalised() {
        // ∫ p dω = 1  <=>  ∫_{-1}^{1} 4π p / 2 dμ = 1.
        for g in [0.0, 0.3, -0.6, 0.9] {
            let n = 20000;
            let s: f64 = (0..n).map(|i| phase_4pi(g, -1.0 + (i as f64 + 0.5) * 2.0 / n as f64)).sum::<f64>() / n as f64;
            assert!((s - 1.0).abs() < 1e-3, "g {g}: {s}");
        }
    }

    #[test]
    fn jitter_is_in_range_and_spread() {
        let v: Vec<f32> = (0..1000).map(|i| jitter_shift(i % 37, i / 37, 7)).collect();
        assert!(v.iter().all(|&s| s <= 0.0 && s > -1.0));
        let mean = v.iter().sum::<f32>() / v.len() as f32;
        assert!((mean + 0.5).abs() < 0.05, "{mean}");
        assert_ne!(jitter_shift(3, 4, 1), jitter_shift(3, 4, 2));
    }
}
