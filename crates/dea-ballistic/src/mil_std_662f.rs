//! The ballistic limit of MIL-STD-662F: the arithmetic mean of the `count` highest partial
//! penetrations and the `count` lowest complete penetrations, all `2 count` within a given
//! velocity spread (the standard's usual choices: 3 + 3 within 38 m/s (125 ft/s), or 5 + 5
//! or 7 + 7 within wider spreads when the results scatter).

use serde::Serialize;

use crate::{EstimateError, Shot};

/// A MIL-STD-662F estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MilStdEstimate {
    /// [m/s]
    pub v50: f64,
    /// shots of each outcome in the mean
    pub count: usize,
    /// highest minus lowest velocity of the shots used [m/s]
    pub spread: f64,
    /// the velocities used, partials then completes [m/s]
    pub partials: Vec<f64>,
    /// (the completes) [m/s]
    pub completes: Vec<f64>,
}

/// The V50 of MIL-STD-662F from `count` partials and `count` completes within `spread` [m/s].
pub fn mil_std_662f(shots: &[Shot], count: usize, allowed_spread: f64) -> Result<MilStdEstimate, EstimateError> {
    let mut partials: Vec<f64> = shots.iter().filter(|s| !s.perforated).map(|s| s.velocity).collect();
    let mut completes: Vec<f64> = shots.iter().filter(|s| s.perforated).map(|s| s.velocity).collect();
    if partials.len() < count || completes.len() < count || count == 0 {
        return Err(EstimateError::TooFewShots { needed: count.max(1), partials: partials.len(), completes: completes.len() });
    }
    partials.sort_by(|a, b| b.total_cmp(a));
    completes.sort_by(f64::total_cmp);
    partials.truncate(count);
    completes.truncate(count);
    let used = partials.iter().chain(&completes);
    let (low, high) = used.clone().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
    let spread = high - low;
    if spread > allowed_spread {
        return Err(EstimateError::SpreadTooWide { count, spread, allowed: allowed_spread });
    }
    let v50 = used.sum::<f64>() / (2 * count) as f64;
    Ok(MilStdEstimate { v50, count, spread, partials, completes })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shots(list: &[(f64, bool)]) -> Vec<Shot> {
        list.iter().map(|&(velocity, perforated)| Shot { velocity, perforated, residual_velocity: 0.0 }).collect()
    }

    #[test]
    fn a_hand_made_table() {
        // partials 290 300 305 312, completes 298 310 320 340: the three highest partials
        // (312, 305, 300) and the three lowest completes (298, 310, 320) span 22 m/s
        let table = shots(&[(290.0, false), (298.0, true), (300.0, false), (305.0, false), (310.0, true), (312.0, false), (320.0, true), (340.0, true)]);
        let estimate = mil_std_662f(&table, 3, 38.0).unwrap();
        assert_eq!(estimate.partials, vec![312.0, 305.0, 300.0]);
        assert_eq!(estimate.completes, vec![298.0, 310.0, 320.0]);
        assert!((estimate.v50 - (312.0 + 305.0 + 300.0 + 298.0 + 310.0 + 320.0) / 6.0).abs() < 1e-12);
        assert!((estimate.spread - 22.0).abs() < 1e-12);
        // too narrow a spread, too many shots asked
        assert!(matches!(mil_std_662f(&table, 3, 20.0), Err(EstimateError::SpreadTooWide { .. })));
        assert!(matches!(mil_std_662f(&table, 5, 100.0), Err(EstimateError::TooFewShots { .. })));
    }
}
