//! Lambert–Jonas fit of residual against striking velocity:
//! `v_r = a (v^p - v_bl^p)^(1/p)` above the ballistic limit `v_bl`, 0 below.
//!
//! For given (v_bl, p) the best `a` is linear least squares in closed form; (v_bl, p) are
//! found by a grid search refined by a shrinking pattern search, so the fit is deterministic
//! and needs no starting guess. Every shot enters: partials with zero residual velocity.

use serde::Serialize;

use crate::{EstimateError, Shot};

/// A Lambert–Jonas fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LambertJonas {
    /// ballistic limit [m/s]
    pub v_bl: f64,
    /// the scale a of `v_r = a (v^p - v_bl^p)^(1/p)` [-]
    pub a: f64,
    /// the exponent p [-]
    pub p: f64,
    /// root-mean-square residual of the fit [m/s]
    pub rms_m_s: f64,
}

/// Range of the exponent searched.
const P_RANGE: (f64, f64) = (1.0, 6.0);

fn shape(v: f64, v_bl: f64, p: f64) -> f64 {
    if v <= v_bl {
        0.0
    } else {
        (v.powf(p) - v_bl.powf(p)).powf(1.0 / p)
    }
}

/// Best `a` and the sum of squared residuals for (v_bl, p).
fn best_a(shots: &[Shot], v_bl: f64, p: f64) -> (f64, f64) {
    let (mut gy, mut gg) = (0.0, 0.0);
    for s in shots {
        let g = shape(s.velocity, v_bl, p);
        gy += g * s.residual_velocity;
        gg += g * g;
    }
    let a = if gg > 0.0 { gy / gg } else { 0.0 };
    let sse = shots.iter().map(|s| (s.residual_velocity - a * shape(s.velocity, v_bl, p)).powi(2)).sum();
    (a, sse)
}

/// Fits the curve; needs at least three perforations.
pub fn lambert_jonas(shots: &[Shot]) -> Result<LambertJonas, EstimateError> {
    let completes: Vec<&Shot> = shots.iter().filter(|s| s.perforated).collect();
    if completes.len() < 3 {
        return Err(EstimateError::TooFewPerforations { needed: 3, completes: completes.len() });
    }
    let top = completes.iter().map(|s| s.velocity).fold(f64::INFINITY, f64::min);
    let sse = |v_bl: f64, p: f64| best_a(shots, v_bl, p).1;
    // grid over (0, lowest perforation) x P_RANGE
    let (mut v_bl, mut p, mut best) = (0.0, 2.0, f64::INFINITY);
    for i in 0..=200 {
        let v = top * i as f64 / 200.0 * 0.999_999;
        for j in 0..=50 {
            let q = P_RANGE.0 + (P_RANGE.1 - P_RANGE.0) * j as f64 / 50.0;
            let value = sse(v, q);
            if value < best {
                (v_bl, p, best) = (v, q, value);
            }
        }
    }
    // pattern search from there
    let (mut step_v, mut step_p) = (top / 200.0, (P_RANGE.1 - P_RANGE.0) / 50.0);
    for _ in 0..400 {
        let mut moved = false;
        for (dv, dp) in [(step_v, 0.0), (-step_v, 0.0), (0.0, step_p), (0.0, -step_p)] {
            let (v, q) = ((v_bl + dv).clamp(0.0, top * 0.999_999), (p + dp).clamp(P_RANGE.0, P_RANGE.1));
            let value = sse(v, q);
            if value < best {
                (v_bl, p, best, moved) = (v, q, value, true);
            }
        }
        if !moved {
            step_v *= 0.5;
            step_p *= 0.5;
            if step_v < 1e-9 * top.max(1.0) && step_p < 1e-12 {
                break;
            }
        }
    }
    let (a, sse) = best_a(shots, v_bl, p);
    Ok(LambertJonas { v_bl, a, p, rms_m_s: (sse / shots.len() as f64).sqrt() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_residual_velocities_give_back_their_curve() {
        let (a, p, v_bl) = (0.85, 2.3, 310.0);
        let shots: Vec<Shot> = (0..30)
            .map(|k| {
                let velocity = 250.0 + 12.0 * k as f64;
                let residual_velocity = a * shape(velocity, v_bl, p);
                Shot { velocity, perforated: residual_velocity > 0.0, residual_velocity }
            })
            .collect();
        let fit = lambert_jonas(&shots).unwrap();
        assert!((fit.v_bl - v_bl).abs() < 0.05, "{fit:?}");
        assert!((fit.p - p).abs() < 1e-3 && (fit.a - a).abs() < 1e-4, "{fit:?}");
        assert!(fit.rms_m_s < 1e-3);
        // with a little noise the limit moves little
        let noisy: Vec<Shot> = shots.iter().enumerate().map(|(k, s)| Shot { residual_velocity: if s.perforated { s.residual_velocity + if k % 2 == 0 { 3.0 } else { -3.0 } } else { 0.0 }, ..*s }).collect();
        let fit = lambert_jonas(&noisy).unwrap();
        assert!((fit.v_bl - v_bl).abs() < 10.0, "{fit:?}");
        assert!(matches!(lambert_jonas(&shots[..5]), Err(EstimateError::TooFewPerforations { .. })));
    }
}
