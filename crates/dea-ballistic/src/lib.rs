//! Ballistic-limit statistics and velocity designs, MPI-free.
//!
//! - [`fit`]: the probability of perforation against striking velocity, `P(v) = F(a + b v)`,
//!   with `F` logistic or normal (probit), fitted by maximum likelihood; V50, V10, V90 and
//!   their 95 % confidence intervals by the delta method and the profile likelihood.
//! - [`firth`]: the logistic curve by Firth's penalised likelihood, finite where the outcomes
//!   separate by velocity and maximum likelihood has no estimate.
//! - [`mil_std_662f`]: the V50 of MIL-STD-662F, the mean of equal numbers of the highest
//!   partial and the lowest complete penetrations within a velocity spread.
//! - [`lambert_jonas`]: the residual-velocity fit `v_r = a (v^p - v_bl^p)^(1/p)`.
//! - [`design`]: which velocity to shoot next (bisection, up-and-down, Langlie, Monte Carlo,
//!   a list).
//! - [`scatter`]: what else each shot draws: its aim within a unit cell, its yaw, obliquity.

pub mod design;
pub mod firth;
pub mod fit;
pub mod lambert_jonas;
pub mod mil_std_662f;
pub mod scatter;

use serde::{Deserialize, Serialize};

/// One shot's outcome.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Shot {
    /// striking velocity [m/s]
    pub velocity: f64,
    /// a complete penetration
    pub perforated: bool,
    /// residual velocity of a perforation, 0 for a partial [m/s]
    pub residual_velocity: f64,
}

/// Why an estimate cannot be made from the shots at hand.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EstimateError {
    /// The outcomes do not overlap in velocity.
    #[error("no zone of mixed results: the lowest complete penetration ({lowest_complete:.1} m/s) is not below the highest partial ({highest_partial:.1} m/s), so the likelihood has no maximum")]
    NoMixedZone {
        /// [m/s]
        lowest_complete: f64,
        /// [m/s]
        highest_partial: f64,
    },
    /// Both outcomes at one speed, and each alone everywhere else (quasi-complete separation).
    #[error("outcomes mix only at {velocity:.1} m/s (the highest partial and the lowest complete penetration are both there), so the likelihood still grows without bound as the curve steepens there and has no maximum")]
    MixedAtOneSpeed {
        /// [m/s]
        velocity: f64,
    },
    /// Too few shots of one outcome.
    #[error(
        "{} of each outcome {} needed, there are {partials} partial and {completes} complete penetrations",
        count_of(*.needed, "shot", "shots"), is_or_are(*.needed)
    )]
    TooFewShots {
        /// of each outcome
        needed: usize,
        /// partial penetrations at hand
        partials: usize,
        /// complete penetrations at hand
        completes: usize,
    },
    /// The shots nearest the limit spread wider than the estimate allows.
    #[error("the {count} highest partials and {count} lowest completes span {spread:.1} m/s, more than the {allowed:.1} m/s allowed")]
    SpreadTooWide {
        /// shots of each outcome taken
        count: usize,
        /// their spread [m/s]
        spread: f64,
        /// the largest spread allowed [m/s]
        allowed: f64,
    },
    /// Too few perforations for the estimate.
    #[error(
        "{} {} needed, there {} {completes}",
        count_of(*.needed, "complete penetration", "complete penetrations"),
        is_or_are(*.needed),
        is_or_are(*.completes)
    )]
    TooFewPerforations {
        /// complete penetrations needed
        needed: usize,
        /// complete penetrations at hand
        completes: usize,
    },
    /// The fit's iterations did not converge.
    #[error("the fit did not converge")]
    NotConverged,
}

/// `count` with the noun in the number it takes ("1 shot", "3 shots"), so that a message about
/// a one-shot requirement reads as English.
fn count_of(count: usize, singular: &str, plural: &str) -> String {
    format!("{count} {}", if count == 1 { singular } else { plural })
}

/// The verb that agrees with `count`.
fn is_or_are(count: usize) -> &'static str {
    if count == 1 {
        "is"
    } else {
        "are"
    }
}

#[cfg(test)]
mod tests {
    use super::EstimateError;

    #[test]
    fn too_few_shots_reads_in_the_right_number() {
        let one = EstimateError::TooFewShots { needed: 1, partials: 0, completes: 1 };
        assert_eq!(
            one.to_string(),
            "1 shot of each outcome is needed, there are 0 partial and 1 complete penetrations"
        );
        let three = EstimateError::TooFewShots { needed: 3, partials: 1, completes: 2 };
        assert_eq!(
            three.to_string(),
            "3 shots of each outcome are needed, there are 1 partial and 2 complete penetrations"
        );
        let perforations = EstimateError::TooFewPerforations { needed: 3, completes: 1 };
        assert_eq!(perforations.to_string(), "3 complete penetrations are needed, there is 1");
    }
}
