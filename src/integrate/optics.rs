//! Optical depth and opacity: the rules the shader shares (never its code).

use crate::config::OpacityCorrection;

/// Shadow rays stop once their optical depth passes this: the light left
/// (exp(-16) = 1.1e-7) is below what any output can show.
pub const SHADOW_TAU_MAX: f64 = 16.0;

/// `1 - exp(-x)` without cancellation for small `x`.
#[inline]
pub fn one_minus_exp_neg(x: f64) -> f64 {
    -(-x).exp_m1()
}

/// Extinction per reference step for transfer-function opacity `a`: `a`
/// itself (exponential form) or `-ln(1 - a)` (power form; infinite at 1).
#[inline]
pub fn extinction(a: f64, form: OpacityCorrection) -> f64 {
    if a <= 0.0 {
        return 0.0;
    }
    match form {
        OpacityCorrection::Exponential => a,
        OpacityCorrection::Power => {
            if a >= 1.0 {
                f64::INFINITY
            } else {
                -(-a).ln_1p()
            }
        }
    }
}

/// The largest extinction per reference step a transfer-function table
/// reaches (its entries are interpolated linearly, so the largest entry's):
/// the majorant of unbiased frames' Poisson process.
pub fn max_extinction(rows: &[[f32; 4]], form: OpacityCorrection) -> f64 {
    rows.iter().map(|r| extinction(r[3] as f64, form)).fold(0.0, f64::max)
}

/// Opacity of a segment of length `len` for transfer-function opacity `a`.
#[inline]
pub fn corrected_alpha(a: f64, len_over_ref: f64, form: OpacityCorrection) -> f64 {
    let sigma = extinction(a, form);
    if sigma == 0.0 || len_over_ref <= 0.0 {
        return 0.0;
    }
    one_minus_exp_neg(sigma * len_over_ref)
}
