//! Maximum-likelihood fit of the probability of perforation, `P(v) = F(a + b v)`.
//!
//! Velocities are standardised (`u = (v - mean) / scale`) so that Newton's method works on
//! numbers of order one; the log-likelihood of both links is concave in (a, b), so Newton
//! with step halving converges from (0, 1). The covariance of (a, b) is the inverse of the
//! observed information at the optimum; `V_p = mean + scale (F^-1(p) - a) / b` and its
//! standard error follow by the delta method. The estimate exists only when the outcomes
//! overlap: a complete penetration below a partial one ([`crate::firth`] has one for
//! separated shots too).

use serde::Serialize;
use statrs::distribution::{Continuous, ContinuousCDF, Normal};

use crate::{EstimateError, Shot};

/// The link between velocity and probability.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Link {
    /// `F(z) = 1 / (1 + e^-z)`
    Logistic,
    /// `F(z) = Phi(z)`, the standard normal distribution
    Probit,
}

fn standard_normal() -> Normal {
    Normal::new(0.0, 1.0).expect("the standard normal exists")
}

impl Link {
    /// `F(z)`.
    pub fn cdf(self, z: f64) -> f64 {
        match self {
            Link::Logistic => 1.0 / (1.0 + (-z).exp()),
            Link::Probit => standard_normal().cdf(z),
        }
    }

    /// `F^-1(p)`.
    pub fn quantile(self, p: f64) -> f64 {
        match self {
            Link::Logistic => (p / (1.0 - p)).ln(),
            Link::Probit => standard_normal().inverse_cdf(p),
        }
    }

    /// First and second derivative of one shot's log-likelihood with respect to `z`.
    fn score(self, z: f64, perforated: bool) -> (f64, f64) {
        match self {
            Link::Logistic => {
                let f = self.cdf(z);
                (if perforated { 1.0 - f } else { -f }, -f * (1.0 - f))
            }
            Link::Probit => {
                let normal = standard_normal();
                let density = normal.pdf(z);
                if perforated {
                    // d/dz log Phi = phi / Phi = l; second: -l (z + l)
                    let l = density / normal.cdf(z).max(f64::MIN_POSITIVE);
                    (l, -l * (z + l))
                } else {
                    // d/dz log(1 - Phi) = -m with m = phi / (1 - Phi); second: -m (m - z)
                    let m = density / normal.sf(z).max(f64::MIN_POSITIVE);
                    (-m, -m * (m - z))
                }
            }
        }
    }
}

/// A velocity at a given probability of perforation, with its 95 % confidence interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Limit {
    /// probability of perforation [-]
    pub probability: f64,
    /// [m/s]
    pub velocity: f64,
    /// standard error [m/s]
    pub standard_error: f64,
    /// 95 % confidence interval (delta method, symmetric) [m/s]
    pub low: f64,
    /// (its upper end) [m/s]
    pub high: f64,
    /// 95 % profile-likelihood interval: the velocities whose best curve through them is
    /// within chi^2(1, 0.95) / 2 of the maximum log-likelihood; asymmetric, and better than
    /// the delta method for few shots [m/s] (infinite where the shots do not bound it)
    pub profile_low: f64,
    /// (its upper end) [m/s]
    pub profile_high: f64,
}

/// How the curve's parameters were estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Estimator {
    /// the maximum of the likelihood; exists only where the outcomes overlap
    MaximumLikelihood,
    /// the maximum of the likelihood times Jeffreys' prior (Firth 1993, [`crate::firth`]);
    /// finite for any shots with both outcomes
    FirthPenalised,
}

/// A fitted curve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fit {
    /// what was maximised
    pub estimator: Estimator,
    /// the distribution function F of the curve (logit or probit)
    pub link: Link,
    /// `P(v) = F(intercept + slope v)` [-], [s/m]
    pub intercept: f64,
    /// (the slope) [s/m]
    pub slope: f64,
    /// velocity at 10 % probability of perforation
    pub v10: Limit,
    /// velocity at 50 % probability of perforation: the V50
    pub v50: Limit,
    /// velocity at 90 % probability of perforation
    pub v90: Limit,
    /// the maximum log-likelihood reached (penalised, for Firth's estimator) [-]
    pub log_likelihood: f64,
    /// shots fitted
    pub shots: usize,
    /// Newton iterations taken
    pub iterations: u32,
}

/// Checks that the shots hold one of each outcome.
pub fn check_both_outcomes(shots: &[Shot]) -> Result<(), EstimateError> {
    let (partials, completes) =
        (shots.iter().filter(|s| !s.perforated).count(), shots.iter().filter(|s| s.perforated).count());
    if partials == 0 || completes == 0 {
        return Err(EstimateError::TooFewShots { needed: 1, partials, completes });
    }
    Ok(())
}

/// Checks that a maximum-likelihood estimate exists.
pub fn check_mixed_zone(shots: &[Shot]) -> Result<(), EstimateError> {
    check_both_outcomes(shots)?;
    let lowest_complete = shots.iter().filter(|s| s.perforated).map(|s| s.velocity).fold(f64::INFINITY, f64::min);
    let highest_partial = shots.iter().filter(|s| !s.perforated).map(|s| s.velocity).fold(f64::NEG_INFINITY, f64::max);
    if lowest_complete == highest_partial {
        return Err(EstimateError::MixedAtOneSpeed { velocity: lowest_complete });
    }
    if lowest_complete > highest_partial {
        return Err(EstimateError::NoMixedZone { lowest_complete, highest_partial });
    }
    Ok(())
}

/// The mean and the standard deviation of the shots' velocities [m/s]: the standardisation
/// `u = (v - mean) / scale` that keeps the fits' numbers of order one.
pub(crate) fn standardisation(shots: &[Shot]) -> (f64, f64) {
    let n = shots.len() as f64;
    let mean = shots.iter().map(|s| s.velocity).sum::<f64>() / n;
    let scale = (shots.iter().map(|s| (s.velocity - mean).powi(2)).sum::<f64>() / n).sqrt().max(1e-9);
    (mean, scale)
}

/// `V_p` with its delta-method and profile intervals, from the standardised fit (a, b), its
/// covariance, and `deviance(q, m)`: twice the fall of the (penalised) log-likelihood from its
/// maximum to the best curve through `F^-1(p) = q` at standardised velocity `m`.
pub(crate) fn limit(
    link: Link,
    p: f64,
    (a, b): (f64, f64),
    covariance: [[f64; 2]; 2],
    (mean, scale): (f64, f64),
    deviance: impl Fn(f64, f64) -> f64,
) -> Limit {
    let z = standard_normal().inverse_cdf(0.975);
    let q = link.quantile(p);
    let velocity = mean + scale * (q - a) / b;
    // d V / d(a, b)
    let gradient = [-scale / b, -scale * (q - a) / (b * b)];
    let variance = gradient[0] * gradient[0] * covariance[0][0]
        + 2.0 * gradient[0] * gradient[1] * covariance[0][1]
        + gradient[1] * gradient[1] * covariance[1][1];
    let standard_error = variance.max(0.0).sqrt();
    let (profile_low, profile_high) = profile_interval(|m| deviance(q, m), mean, scale, (velocity - mean) / scale);
    Limit {
        probability: p,
        velocity,
        standard_error,
        low: velocity - z * standard_error,
        high: velocity + z * standard_error,
        profile_low,
        profile_high,
    }
}

/// Fits `P(v) = F(a + b v)` by maximum likelihood.
pub fn fit(shots: &[Shot], link: Link) -> Result<Fit, EstimateError> {
    check_mixed_zone(shots)?;
    let (mean, scale) = standardisation(shots);
    let standard = |s: &Shot| (s.velocity - mean) / scale;
    let log_likelihood = |a: f64, b: f64| -> f64 {
        shots
            .iter()
            .map(|s| {
                let p = link.cdf(a + b * standard(s));
                if s.perforated {
                    p.max(f64::MIN_POSITIVE).ln()
                } else {
                    (1.0 - p).max(f64::MIN_POSITIVE).ln()
                }
            })
            .sum()
    };
    // the log-likelihood, its gradient and the observed information of (a, b)
    let evaluate = |a: f64, b: f64| {
        let (mut gradient, mut information) = ([0.0; 2], [[0.0; 2]; 2]);
        for s in shots {
            let u = standard(s);
            let (d1, d2) = link.score(a + b * u, s.perforated);
            gradient[0] += d1;
            gradient[1] += d1 * u;
            information[0][0] -= d2;
            information[0][1] -= d2 * u;
            information[1][1] -= d2 * u * u;
        }
        information[1][0] = information[0][1];
        Some(Objective { value: log_likelihood(a, b), gradient, information })
    };
    let Maximum { a, b, objective, iterations } = maximise(evaluate)?;
    let covariance = inverse(objective.information).ok_or(EstimateError::NotConverged)?;
    let current = objective.value;
    let limit = |p: f64| {
        limit(link, p, (a, b), covariance, (mean, scale), |q, m| {
            2.0 * (current - profile(shots, link, mean, scale, q, m, b))
        })
    };
    Ok(Fit {
        estimator: Estimator::MaximumLikelihood,
        link,
        intercept: a - b * mean / scale,
        slope: b / scale,
        v10: limit(0.1),
        v50: limit(0.5),
        v90: limit(0.9),
        log_likelihood: current,
        shots: shots.len(),
        iterations,
    })
}

/// A concave objective of the standardised (a, b) at one point: what Newton's method needs.
pub(crate) struct Objective {
    /// the (penalised) log-likelihood [-]
    pub value: f64,
    /// its gradient with respect to (a, b)
    pub gradient: [f64; 2],
    /// the information matrix of (a, b): observed (minus the Hessian) or expected
    pub information: [[f64; 2]; 2],
}

/// Where [`maximise`] stopped.
pub(crate) struct Maximum {
    pub a: f64,
    pub b: f64,
    /// the objective there
    pub objective: Objective,
    /// Newton steps taken
    pub iterations: u32,
}

/// The inverse of a 2 x 2 information matrix, or None unless it is positive definite.
pub(crate) fn inverse(m: [[f64; 2]; 2]) -> Option<[[f64; 2]; 2]> {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    (det > 0.0).then(|| [[m[1][1] / det, -m[0][1] / det], [-m[1][0] / det, m[0][0] / det]])
}

/// The maximum over (a, b), b > 0, of a concave objective, by Newton's (or Fisher's scoring)
/// step `I^-1 g` from (0, 1), halved until the objective does not fall; `evaluate` gives None
/// where the objective is minus infinity. Stops when no halving helps or the step is below
/// 1e-12; an information that is not positive definite, or more than 200 steps, is
/// [`EstimateError::NotConverged`]. Shared by the maximum-likelihood and Firth fits.
pub(crate) fn maximise(evaluate: impl Fn(f64, f64) -> Option<Objective>) -> Result<Maximum, EstimateError> {
    let (mut a, mut b) = (0.0, 1.0);
    let mut current = evaluate(a, b).ok_or(EstimateError::NotConverged)?;
    let mut iterations = 0;
    loop {
        let (g, i) = (current.gradient, current.information);
        // Cramer's rule rather than `inverse(i) * g`: the same step, rounded as the fits' records
        // were written
        let det = i[0][0] * i[1][1] - i[0][1] * i[1][0];
        if !(det > 0.0) || iterations > 200 {
            return Err(EstimateError::NotConverged);
        }
        let step = [(i[1][1] * g[0] - i[0][1] * g[1]) / det, (i[0][0] * g[1] - i[1][0] * g[0]) / det];
        let mut t = 1.0;
        let mut accepted = None;
        for _ in 0..60 {
            let (na, nb) = (a + t * step[0], b + t * step[1]);
            if nb > 0.0 {
                if let Some(next) = evaluate(na, nb).filter(|n| n.value >= current.value) {
                    accepted = Some((na, nb, next));
                    break;
                }
            }
            t *= 0.5;
        }
        iterations += 1;
        let Some((na, nb, next)) = accepted else { break };
        (a, b, current) = (na, nb, next);
        if (step[0] * t).abs() + (step[1] * t).abs() < 1e-12 {
            break;
        }
    }
    Ok(Maximum { a, b, objective: current, iterations })
}

/// chi^2 with one degree of freedom at 0.95.
pub(crate) const CHI2_95: f64 = 3.841_458_820_694_124;

/// Largest log-likelihood of the curves through `F^-1(p) = q` at standardised velocity `m`:
/// `z = q + b (u - m)`, maximised over the slope `b > 0` by Newton's method from `b0` (the
/// log-likelihood is concave in b). A slope that runs away means the shots separate there:
/// the supremum is then taken at the largest slope reached.
fn profile(shots: &[Shot], link: Link, mean: f64, scale: f64, q: f64, m: f64, b0: f64) -> f64 {
    let value = |b: f64| -> f64 {
        shots
            .iter()
            .map(|s| {
                let p = link.cdf(q + b * ((s.velocity - mean) / scale - m));
                if s.perforated {
                    p.max(f64::MIN_POSITIVE).ln()
                } else {
                    (1.0 - p).max(f64::MIN_POSITIVE).ln()
                }
            })
            .sum()
    };
    let mut b = b0;
    let mut best = value(b);
    for _ in 0..100 {
        let (mut g, mut h) = (0.0, 0.0);
        for s in shots {
            let u = (s.velocity - mean) / scale - m;
            let (d1, d2) = link.score(q + b * u, s.perforated);
            g += d1 * u;
            h += d2 * u * u;
        }
        let step = if h < 0.0 { -g / h } else { g.signum() * b };
        let mut t = 1.0;
        let mut moved = false;
        for _ in 0..60 {
            let candidate = b + t * step;
            if candidate > 0.0 {
                let v = value(candidate);
                if v >= best {
                    (b, best, moved) = (candidate, v, true);
                    break;
                }
            }
            t *= 0.5;
        }
        if !moved || (t * step).abs() < 1e-12 * b.max(1.0) || b > 1e6 {
            break;
        }
    }
    best
}

/// The profile-likelihood interval of `V_p` around its estimate `m_hat` (standardised), in
/// m/s, from `deviance(m)`: each bound found by stepping out until the deviance exceeds
/// chi^2(1, 0.95), then bisecting; infinite where it never does.
fn profile_interval(deviance: impl Fn(f64) -> f64, mean: f64, scale: f64, m_hat: f64) -> (f64, f64) {
    let bound = |direction: f64| -> f64 {
        let (mut inside, mut step) = (m_hat, 0.05);
        let mut outside = None;
        for _ in 0..40 {
            let trial = inside + direction * step;
            if deviance(trial) > CHI2_95 {
                outside = Some(trial);
                break;
            }
            inside = trial;
            step *= 1.6;
        }
        let Some(mut outside) = outside else { return direction * f64::INFINITY };
        for _ in 0..60 {
            let mid = 0.5 * (inside + outside);
            if deviance(mid) > CHI2_95 {
                outside = mid;
            } else {
                inside = mid;
            }
        }
        mean + scale * 0.5 * (inside + outside)
    };
    (bound(-1.0), bound(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn simulated(link: Link, v50: f64, width: f64, count: usize, seed: u64) -> Vec<Shot> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..count)
            .map(|_| {
                let velocity = rng.random_range(v50 - 3.0 * width..v50 + 3.0 * width);
                let perforated = rng.random::<f64>() < link.cdf((velocity - v50) / width);
                Shot { velocity, perforated, residual_velocity: 0.0 }
            })
            .collect()
    }

    #[test]
    fn the_fit_recovers_a_known_curve_within_its_confidence_interval() {
        for link in [Link::Logistic, Link::Probit] {
            let (v50, width) = (300.0, 15.0);
            // over many simulated campaigns, the 95 % interval holds the true V50 about 95 %
            // of the time, and each fit is close
            let (mut covered, mut profile_covered) = (0, 0);
            for seed in 0..200 {
                let shots = simulated(link, v50, width, 60, seed);
                let fit = fit(&shots, link).unwrap();
                assert!(
                    (fit.v50.velocity - v50).abs() < 5.0 * fit.v50.standard_error,
                    "{link:?} seed {seed}: {:?}",
                    fit.v50
                );
                covered += (fit.v50.low <= v50 && v50 <= fit.v50.high) as usize;
                profile_covered += (fit.v50.profile_low <= v50 && v50 <= fit.v50.profile_high) as usize;
                assert!(fit.v50.profile_low < fit.v50.velocity && fit.v50.velocity < fit.v50.profile_high);
                assert!(fit.v10.velocity < fit.v50.velocity && fit.v50.velocity < fit.v90.velocity);
            }
            assert!((180..=197).contains(&covered), "{link:?}: {covered} of 200 intervals hold the true V50");
            assert!(
                (180..=197).contains(&profile_covered),
                "{link:?}: {profile_covered} of 200 profile intervals hold the true V50"
            );
            // a large campaign pins the curve down
            let fit = fit(&simulated(link, v50, width, 4000, 7), link).unwrap();
            assert!((fit.v50.velocity - v50).abs() < 2.0, "{:?}", fit.v50);
            let v90 = v50 + width * link.quantile(0.9);
            assert!((fit.v90.velocity - v90).abs() < 3.0, "{:?} vs {v90}", fit.v90);
        }
    }

    #[test]
    fn the_profile_interval_ends_where_the_deviance_reaches_chi_squared() {
        // a small campaign: the interval is asymmetric, and its ends lie on the deviance level
        let shots = simulated(Link::Logistic, 300.0, 15.0, 14, 5);
        let fit = fit(&shots, Link::Logistic).unwrap();
        let n = shots.len() as f64;
        let mean = shots.iter().map(|s| s.velocity).sum::<f64>() / n;
        let scale = (shots.iter().map(|s| (s.velocity - mean).powi(2)).sum::<f64>() / n).sqrt();
        let b_hat = fit.slope * scale;
        for end in [fit.v50.profile_low, fit.v50.profile_high] {
            let deviance = 2.0
                * (fit.log_likelihood - profile(&shots, Link::Logistic, mean, scale, 0.0, (end - mean) / scale, b_hat));
            assert!((deviance - CHI2_95).abs() < 1e-6, "deviance {deviance} at {end}");
        }
        let (below, above) = (fit.v50.velocity - fit.v50.profile_low, fit.v50.profile_high - fit.v50.velocity);
        assert!((below - above).abs() > 1e-3 * (below + above), "asymmetric: {below} {above}");
    }

    #[test]
    fn the_gradient_vanishes_at_the_fit() {
        let shots = simulated(Link::Probit, 250.0, 20.0, 40, 3);
        let fit = fit(&shots, Link::Probit).unwrap();
        let ll = |a: f64, b: f64| -> f64 {
            shots
                .iter()
                .map(|s| {
                    let p = Link::Probit.cdf(a + b * s.velocity);
                    if s.perforated {
                        p.ln()
                    } else {
                        (1.0 - p).ln()
                    }
                })
                .sum()
        };
        let (a, b) = (fit.intercept, fit.slope);
        let best = ll(a, b);
        for (da, db) in [(1e-3, 0.0), (-1e-3, 0.0), (0.0, 1e-6), (0.0, -1e-6)] {
            assert!(ll(a + da, b + db) <= best + 1e-9);
        }
    }

    #[test]
    fn the_ascent_finds_a_quadratic_maximum_and_refuses_an_indefinite_information() {
        // l = -(a - 1)^2 - 2 (b - 3)^2: one Newton step from (0, 1) lands on (1, 3), and the
        // next, of length zero, ends the ascent
        let quadratic = |a: f64, b: f64| {
            Some(Objective {
                value: -(a - 1.0).powi(2) - 2.0 * (b - 3.0).powi(2),
                gradient: [-2.0 * (a - 1.0), -4.0 * (b - 3.0)],
                information: [[2.0, 0.0], [0.0, 4.0]],
            })
        };
        let Ok(Maximum { a, b, objective, iterations }) = maximise(quadratic) else { panic!("no maximum") };
        assert_eq!((a, b, objective.value, iterations), (1.0, 3.0, 0.0, 2));
        // a maximum at b < 0 is approached only while b stays positive
        let beyond = |a: f64, b: f64| {
            Some(Objective {
                value: -(a * a) - (b + 1.0).powi(2),
                gradient: [-2.0 * a, -2.0 * (b + 1.0)],
                information: [[2.0, 0.0], [0.0, 2.0]],
            })
        };
        let Ok(Maximum { b, .. }) = maximise(beyond) else { panic!("no stop") };
        assert!(b > 0.0 && b < 1e-12, "{b}");
        // a saddle's information is not positive definite
        let saddle = |a: f64, b: f64| {
            Some(Objective {
                value: b * b - a * a,
                gradient: [-2.0 * a, 2.0 * b],
                information: [[2.0, 0.0], [0.0, -2.0]],
            })
        };
        assert!(matches!(maximise(saddle), Err(EstimateError::NotConverged)));
        // an objective that is minus infinity at the start
        assert!(matches!(maximise(|_, _| None), Err(EstimateError::NotConverged)));
        assert_eq!(inverse([[2.0, 1.0], [1.0, 1.0]]), Some([[1.0, -1.0], [-1.0, 2.0]]));
        assert_eq!(inverse([[1.0, 2.0], [2.0, 1.0]]), None);
    }

    #[test]
    fn separated_outcomes_have_no_estimate() {
        let shots = [(200.0, false), (250.0, false), (260.0, true), (300.0, true)].map(|(velocity, perforated)| Shot {
            velocity,
            perforated,
            residual_velocity: 0.0,
        });
        assert!(matches!(fit(&shots, Link::Logistic), Err(EstimateError::NoMixedZone { .. })));
        assert!(matches!(fit(&shots[..2], Link::Logistic), Err(EstimateError::TooFewShots { .. })));
        // both outcomes at one speed and nowhere else: the likelihood still grows without bound
        // as the curve steepens there (quasi-complete separation), and the error says so
        let tied = [(200.0, false), (250.0, false), (250.0, true), (300.0, true)].map(|(velocity, perforated)| Shot {
            velocity,
            perforated,
            residual_velocity: 0.0,
        });
        let error = fit(&tied, Link::Logistic).unwrap_err();
        assert_eq!(error, EstimateError::MixedAtOneSpeed { velocity: 250.0 });
        assert!(error.to_string().contains("only at 250.0 m/s"), "{error}");
    }
}
