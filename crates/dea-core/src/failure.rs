//! Combined tension–shear failure of rod elements, seed eq. (5-6):
//! `(sigma/sigma_u)^2 + (tau/tau_u)^2 > 1`, with `sigma = E eps` (4-16) and `tau = 4Q/(3A)` (5-5).

use crate::nodes::FailureMode;

/// Failure parameters shared by all elements (the tensile strength is per element).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FailureParameters {
    /// fibre shear strength tau_u [Pa] (seed §5.2.2: 0.7672 GPa)
    pub shear_strength: f64,
    /// false disables failure entirely (elastic verification runs)
    pub enabled: bool,
}

/// Classifies a state against (5-6); `None` while the element survives.
/// Compression does not break a fibre (sigma counts only when positive).
#[inline]
pub fn combined_criterion(sigma: f64, sigma_u: f64, tau: f64, tau_u: f64) -> Option<FailureMode> {
    let tension = (sigma.max(0.0) / sigma_u).powi(2);
    let shear = (tau / tau_u).powi(2);
    let total = tension + shear;
    if total <= 1.0 {
        return None;
    }
    Some(if shear < 0.1 * total {
        FailureMode::Tension
    } else if tension < 0.1 * total {
        FailureMode::Shear
    } else {
        FailureMode::Combined
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn criterion_on_its_boundary() {
        let (su, tu) = (3.8e9, 0.7672e9);
        // exactly on the ellipse: survives; just outside: fails
        for angle in [0.0f64, 0.3, std::f64::consts::FRAC_PI_4, 1.2, std::f64::consts::FRAC_PI_2] {
            let (sigma, tau) = (su * angle.cos(), tu * angle.sin());
            assert_eq!(combined_criterion(sigma * (1.0 - 1e-9), su, tau * (1.0 - 1e-9), tu), None, "inside at {angle}");
            assert!(combined_criterion(sigma * (1.0 + 1e-9) + 1.0, su, tau * (1.0 + 1e-9), tu).is_some(), "outside at {angle}");
        }
        assert_eq!(combined_criterion(su * 1.01, su, 0.0, tu), Some(FailureMode::Tension));
        assert_eq!(combined_criterion(0.0, su, tu * 1.01, tu), Some(FailureMode::Shear));
        assert_eq!(combined_criterion(su * 0.8, su, tu * 0.8, tu), Some(FailureMode::Combined));
        assert_eq!(combined_criterion(-10.0 * su, su, 0.0, tu), None, "compression does not break");
    }
}
