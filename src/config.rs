//! Render configuration: pyvr 0.4.1's presets, validation rules and cost
//! estimates, plus the opacity-correction form (an extension).

use crate::error::Error;
use crate::model::{Model, Order};
use std::fmt;

/// How a transfer-function opacity is turned into the opacity of one step.
///
/// Both are Beer–Lambert with `sigma * ref = alpha` (exponential, pyvr 0.3.3)
/// or `sigma * ref = -ln(1 - alpha)` (power, the VTK/OpenGL convention).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OpacityCorrection {
    /// `a' = 1 - exp(-a * len / ref)`
    Exponential,
    /// `a' = 1 - (1 - a)^(len / ref)`
    Power,
}

impl OpacityCorrection {
    pub fn name(self) -> &'static str {
        match self {
            OpacityCorrection::Exponential => "exponential",
            OpacityCorrection::Power => "power",
        }
    }

    pub fn parse(s: &str) -> Result<Self, Error> {
        match s {
            "exponential" => Ok(OpacityCorrection::Exponential),
            "power" => Ok(OpacityCorrection::Power),
            other => {
                Err(Error::InvalidInput(format!("opacity_correction must be 'exponential' or 'power', got '{other}'")))
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderConfig {
    /// World units along the unit-length ray.
    pub step_size: f64,
    pub max_steps: i64,
    pub early_ray_termination: bool,
    /// Rays stop once accumulated opacity reaches this (when termination is on).
    pub opacity_threshold: f64,
    /// The step length at which a transfer function's opacity is defined.
    pub reference_step_size: f64,
    pub opacity_correction: OpacityCorrection,
    /// What the ray computes (see `model.rs` for each model's RGBA).
    pub model: Model,
    /// The isosurface model's threshold: the surface is where `v = iso_value`.
    pub iso_value: f64,
    /// Henyey–Greenstein anisotropy `g` in (-1, 1) for single scattering
    /// (0: isotropic).
    pub anisotropy: f64,
    /// Step of the shadow rays of single scattering; 0 means `step_size`.
    pub shadow_step_size: f64,
    /// Start each ray's segment grid at a per-pixel random fraction of a step.
    pub jitter: bool,
    pub jitter_seed: u32,
    /// Emission–absorption with a pre-integrated table over (front, back)
    /// values per segment instead of one midpoint sample.
    pub pre_integrated: bool,
    /// With `pre_integrated` (ignored without it): a full segment whose
    /// values may reach a change of the transfer function's opacity its
    /// (front, back) ramp does not see is taken as this many midpoint
    /// samples instead (0: never). See `needs_refining` in the shader and
    /// `reaches_unseen_opacity` in the f64 integrator for the rule.
    pub refine: i64,
    /// Each frame an unbiased estimate of the exact integral: points of a
    /// Poisson process composited with opacity sigma / rate (ratio tracking)
    /// instead of one midpoint sample per segment.
    pub unbiased: bool,
    /// Interpolate the volume and the tables in the shader with f32 weights
    /// instead of by the texture units, whose weights GPUs keep in 8-bit
    /// fixed point (1/256 of a texel): that rounding puts a floor under the
    /// error of steep transfer functions at small steps. CPU engines always
    /// interpolate in f32.
    pub exact_filtering: bool,
    pub order: Order,
}

/// Most midpoint samples a refined pre-integrated segment takes.
pub const MAX_REFINE: i64 = 16;

/// The five quality presets, in order from fastest to slowest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    Preview,
    Fast,
    Balanced,
    HighQuality,
    UltraQuality,
}

impl Preset {
    pub const ALL: [Preset; 5] =
        [Preset::Preview, Preset::Fast, Preset::Balanced, Preset::HighQuality, Preset::UltraQuality];

    pub fn name(self) -> &'static str {
        match self {
            Preset::Preview => "preview",
            Preset::Fast => "fast",
            Preset::Balanced => "balanced",
            Preset::HighQuality => "high_quality",
            Preset::UltraQuality => "ultra_quality",
        }
    }

    pub fn from_name(name: &str) -> Option<Preset> {
        Preset::ALL.into_iter().find(|p| p.name() == name)
    }
}

pub const DEFAULT_REFERENCE_STEP: f64 = 0.01;
/// The densest Poisson process an unbiased frame uses, in points per step:
/// it bounds the work per step (and so per pass). Only media whose optical
/// depth over a step exceeds it (transmitting e^-16 = 1e-7) are biased:
/// they turn opaque at their first point, a sixteenth of a step in on
/// average, instead of at their boundary.
pub const MAX_POINTS_PER_STEP: f64 = 16.0;
/// pyvr's estimate divides the unit cube's diagonal (sqrt 3, written 1.732) by the step.
const UNIT_CUBE_DIAGONAL: f64 = 1.732;

impl Default for RenderConfig {
    fn default() -> Self {
        RenderConfig::preset(Preset::Balanced)
    }
}

impl RenderConfig {
    pub fn preset(p: Preset) -> Self {
        let (step_size, max_steps, early, threshold) = match p {
            Preset::Preview => (0.05, 50, true, 0.80),
            Preset::Fast => (0.02, 100, true, 0.90),
            Preset::Balanced => (0.01, 500, true, 0.95),
            Preset::HighQuality => (0.005, 1000, true, 0.98),
            Preset::UltraQuality => (0.001, 2000, false, 1.0),
        };
        RenderConfig {
            step_size,
            max_steps,
            early_ray_termination: early,
            opacity_threshold: threshold,
            reference_step_size: DEFAULT_REFERENCE_STEP,
            opacity_correction: OpacityCorrection::Exponential,
            model: Model::EmissionAbsorption,
            iso_value: 0.5,
            anisotropy: 0.0,
            shadow_step_size: 0.0,
            jitter: false,
            jitter_seed: 0,
            pre_integrated: false,
            refine: 0,
            unbiased: false,
            exact_filtering: false,
            order: Order::FrontToBack,
        }
    }

    /// The shadow rays' step: `shadow_step_size`, or `step_size` when 0.
    pub fn shadow_step(&self) -> f64 {
        if self.shadow_step_size > 0.0 {
            self.shadow_step_size
        } else {
            self.step_size
        }
    }

    /// Whether frames take pre-integrated segments (only emission–absorption
    /// has them; other models ignore the flag).
    pub fn pre_integrates(&self) -> bool {
        self.pre_integrated && self.model == Model::EmissionAbsorption
    }

    /// Checks pyvr's rules in pyvr's order, then the ones pyvr lacked
    /// (finite values, positive reference step). Returns the warnings to emit.
    pub fn validate(&self) -> Result<Vec<String>, Error> {
        let mut warnings = Vec::new();
        if !self.step_size.is_finite() {
            return Err(Error::InvalidInput(format!("step_size must be a finite number, got {}", self.step_size)));
        }
        if self.step_size <= 0.0 {
            return Err(Error::InvalidInput("step_size must be positive".into()));
        }
        if self.step_size > 1.0 {
            warnings.push(format!("step_size {} is very large and may produce poor quality", py_float(self.step_size)));
        }
        if self.max_steps < 1 {
            return Err(Error::InvalidInput("max_steps must be at least 1".into()));
        }
        if self.max_steps > 10000 {
            warnings.push(format!("max_steps {} is very large and may be slow", self.max_steps));
        }
        if !(0.0..=1.0).contains(&self.opacity_threshold) {
            return Err(Error::InvalidInput("opacity_threshold must be between 0.0 and 1.0".into()));
        }
        if !self.reference_step_size.is_finite() || self.reference_step_size <= 0.0 {
            return Err(Error::InvalidInput(format!(
                "reference_step_size must be a positive finite number, got {}",
                py_float(self.reference_step_size)
            )));
        }
        if !self.iso_value.is_finite() {
            return Err(Error::InvalidInput(format!("iso_value must be finite, got {}", py_float(self.iso_value))));
        }
        if !(self.anisotropy > -1.0 && self.anisotropy < 1.0) {
            return Err(Error::InvalidInput(format!(
                "anisotropy must be in (-1, 1) (0 is isotropic), got {}",
                py_float(self.anisotropy)
            )));
        }
        if !self.shadow_step_size.is_finite() || self.shadow_step_size < 0.0 {
            return Err(Error::InvalidInput(format!(
                "shadow_step_size must be a finite number >= 0 (0: use step_size), got {}",
                py_float(self.shadow_step_size)
            )));
        }
        if self.pre_integrated && self.model != Model::EmissionAbsorption {
            return Err(Error::InvalidInput(format!(
                "pre_integrated applies to the 'emission_absorption' model only, not '{}'",
                self.model.name()
            )));
        }
        if self.refine != 0 && !(2..=MAX_REFINE).contains(&self.refine) {
            return Err(Error::InvalidInput(format!(
                "refine must be 0 (off) or 2..={MAX_REFINE} samples per refined pre-integrated segment, got {}",
                self.refine
            )));
        }
        if self.unbiased {
            if !matches!(self.model, Model::EmissionAbsorption | Model::Absorption | Model::Emission) {
                return Err(Error::InvalidInput(format!(
                    "unbiased applies to the 'emission_absorption', 'absorption' and 'emission' models, not '{}'",
                    self.model.name()
                )));
            }
            if self.pre_integrated {
                return Err(Error::InvalidInput(
                    "unbiased and pre_integrated exclude each other: unbiased frames sample points, \
                     not (front, back) segments"
                        .into(),
                ));
            }
        }
        Ok(warnings)
    }

    /// Points per unit length of an unbiased frame's Poisson process, given
    /// the largest extinction per unit length its transfer function reaches:
    /// that majorant (so no point's opacity sigma / rate exceeds 1), but at
    /// least one point per step on average, and at most
    /// `MAX_POINTS_PER_STEP` (extinction above that is taken as opaque).
    pub fn tracking_rate(&self, max_extinction: f64) -> f64 {
        let floor = 1.0 / self.step_size;
        let m = if max_extinction.is_nan() { f64::INFINITY } else { max_extinction };
        m.max(floor).min(MAX_POINTS_PER_STEP * floor)
    }

    /// pyvr: `min(int(1.732 / step_size), max_steps)`.
    pub fn estimate_samples_per_ray(&self) -> i64 {
        let n = (UNIT_CUBE_DIAGONAL / self.step_size).trunc();
        let n = if n.is_finite() && n < i64::MAX as f64 { n as i64 } else { i64::MAX };
        n.min(self.max_steps)
    }

    /// Own estimate over the balanced preset's (173).
    pub fn estimate_render_time_relative(&self) -> f64 {
        let base = RenderConfig::preset(Preset::Balanced).estimate_samples_per_ray();
        self.estimate_samples_per_ray() as f64 / base as f64
    }

    /// Steps needed to cross a chord of `length` world units.
    pub fn steps_for_length(&self, length: f64) -> u64 {
        if length <= 0.0 {
            return 0;
        }
        let n = (length / self.step_size).ceil();
        if n >= u64::MAX as f64 {
            u64::MAX
        } else {
            n as u64
        }
    }
}

/// Python's `repr(float)` for the values configs hold: shortest round-trip
/// digits with a trailing `.0` for integral values.
pub fn py_float(v: f64) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let s = format!("{v}");
    if v.abs() >= 1e16 || (v != 0.0 && v.abs() < 1e-4) {
        // Python switches to exponent notation here; Rust's {:e} is close enough
        // but spells the exponent without sign padding, so build it by hand.
        let e = format!("{v:e}");
        let (mant, exp) = e.split_once('e').unwrap_or((&e, "0"));
        let exp: i32 = exp.parse().unwrap_or(0);
        let sign = if exp < 0 { '-' } else { '+' };
        return format!("{mant}e{sign}{:02}", exp.abs());
    }
    if s.contains('.') {
        s
    } else {
        format!("{s}.0")
    }
}

impl fmt::Display for RenderConfig {
    /// pyvr's repr, byte for byte.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "RenderConfig(step_size={}, max_steps={}, early_termination={}, ~{} samples/ray)",
            py_float(self.step_size),
            self.max_steps,
            if self.early_ray_termination { "True" } else { "False" },
            self.estimate_samples_per_ray()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preset_estimates_match_pyvr() {
        let expected = [34, 86, 173, 346, 1732];
        for (p, e) in Preset::ALL.iter().zip(expected) {
            assert_eq!(RenderConfig::preset(*p).estimate_samples_per_ray(), e, "{p:?}");
        }
        let ultra = RenderConfig::preset(Preset::UltraQuality);
        assert!((ultra.estimate_render_time_relative() - 1732.0 / 173.0).abs() < 1e-12);
        assert_eq!(RenderConfig::default().estimate_render_time_relative(), 1.0);
    }

    #[test]
    fn repr_matches_pyvr() {
        let c = RenderConfig::preset(Preset::Fast);
        assert_eq!(
            c.to_string(),
            "RenderConfig(step_size=0.02, max_steps=100, early_termination=True, ~86 samples/ray)"
        );
        let mut d = c;
        d.step_size = 2.0;
        assert!(d.to_string().starts_with("RenderConfig(step_size=2.0,"));
        assert_eq!(py_float(1e-6), "1e-06");
        assert_eq!(py_float(0.001), "0.001");
    }

    #[test]
    fn validation_order_and_messages() {
        let mut c = RenderConfig { step_size: 0.0, max_steps: 0, ..RenderConfig::default() };
        assert_eq!(c.validate().unwrap_err().message(), "step_size must be positive");
        c.step_size = 0.01;
        assert_eq!(c.validate().unwrap_err().message(), "max_steps must be at least 1");
        c.max_steps = 20000;
        c.step_size = 2.0;
        let w = c.validate().unwrap();
        assert_eq!(w.len(), 2);
        assert!(w[0].contains("step_size 2.0 is very large"));
        c.opacity_threshold = 1.5;
        assert!(c.validate().unwrap_err().message().contains("opacity_threshold"));
        c.opacity_threshold = 0.5;
        c.reference_step_size = 0.0;
        assert!(c.validate().unwrap_err().message().contains("reference_step_size"));
        c.reference_step_size = 0.01;
        c.step_size = f64::NAN;
        assert!(c.validate().unwrap_err().message().contains("finite"));
    }

    #[test]
    fn steps_for_length_rounds_up() {
        let c = RenderConfig::preset(Preset::Preview);
        assert_eq!(c.steps_for_length(3.4641), 70);
        assert_eq!(c.steps_for_length(0.0), 0);
        assert_eq!(c.steps_for_length(0.05), 1);
    }
}
