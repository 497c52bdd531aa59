//! Velocity designs: which striking velocity the next shot takes, from the shots so far.
//!
//! - Bisection: the bracket [highest partial, lowest complete], starting from
//!   [`low`, `high`], halved until it is no wider than the resolution (one strength
//!   realisation: the outcome is a deterministic function of velocity). A bracket end that
//!   no shot stands on (the design's own bound) is then fired; a low bound that perforates
//!   halves, a high bound that is stopped doubles, and the halving goes on below it
//!   ([`bisection_bounds`]), so the final bracket rests on a partial and a complete.
//! - Up-and-down (Bruceton): one step down after a complete, one up after a partial.
//! - Langlie: the mean of the last velocity and that of the latest earlier shot from which on
//!   partials and completes are equal in number; `low` after a complete, `high` after a
//!   partial, when there is none.
//! - Monte Carlo: velocities drawn uniformly within `centre ± spread`, independent of the
//!   outcomes, each shot with its own strength realisation.
//! - Velocities: the listed velocities, one shot each (a residual-velocity curve, a mesh
//!   study at one striking speed), each shot with its own strength realisation.

use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::Shot;

/// A velocity design, as a campaign file names it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Design {
    /// bisect a bracket: the next shot halfway between the fastest stop and the slowest perforation
    Bisection {
        /// [m/s]
        low_m_s: f64,
        /// [m/s]
        high_m_s: f64,
        /// stop when the bracket is no wider [m/s]
        resolution_m_s: f64,
    },
    /// up-and-down: a step down after each perforation, up after each stop
    UpAndDown {
        /// [m/s]
        start_m_s: f64,
        /// [m/s]
        step_m_s: f64,
        /// shots to fire
        shots: usize,
    },
    /// Langlie: each next shot from the outcomes so far, within the bounds
    Langlie {
        /// [m/s]
        low_m_s: f64,
        /// [m/s]
        high_m_s: f64,
        /// shots to fire
        shots: usize,
    },
    /// velocities drawn uniformly around a centre, independent of the outcomes
    MonteCarlo {
        /// [m/s]
        centre_m_s: f64,
        /// half-width of the uniform spread [m/s]
        spread_m_s: f64,
        /// shots to fire
        shots: usize,
    },
    /// the listed velocities, one shot each, independent of the outcomes
    Velocities {
        /// the striking velocities, one shot each, in this order [m/s]
        velocities_m_s: Vec<f64>,
    },
}

/// A bisection's bounds once its shots have been seen: a low bound that some shot at or
/// below it perforated is halved, a high bound that some shot at or above it did not
/// perforate is doubled, each until the shots agree or the bound reaches its limit (the
/// resolution below, eight times the design's high bound above: a target that stops nothing,
/// or everything, ends the design there).
pub fn bisection_bounds(low: f64, high: f64, resolution: f64, shots: &[Shot]) -> (f64, f64) {
    let (mut low, mut high) = (low, high);
    let ceiling = 8.0 * high;
    while low > resolution && shots.iter().any(|s| s.perforated && s.velocity <= low) {
        low = (0.5 * low).max(resolution);
    }
    while high < ceiling && shots.iter().any(|s| !s.perforated && s.velocity >= high) {
        high = (2.0 * high).min(ceiling);
    }
    (low, high)
}

/// The bracket [highest partial, lowest complete] within [`low`, `high`].
pub fn bracket(low: f64, high: f64, shots: &[Shot]) -> (f64, f64) {
    shots
        .iter()
        .fold((low, high), |(lo, hi), s| if s.perforated { (lo, hi.min(s.velocity)) } else { (lo.max(s.velocity), hi) })
}

impl Design {
    /// Checks the numbers; the error names the field (within `design`).
    pub fn validate(&self) -> Result<(), String> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("design.{name}: must be > 0, got {v}"))
            }
        };
        let shots = |n: usize| {
            if (1..=10_000).contains(&n) {
                Ok(())
            } else {
                Err(format!("design.shots: must be in 1..=10000, got {n}"))
            }
        };
        let bracket = |low: f64, high: f64| {
            if low > 0.0 && high > low && high.is_finite() {
                Ok(())
            } else {
                Err(format!("design.low_m_s: must be > 0 and below high_m_s ({high}), got {low}"))
            }
        };
        match *self {
            Design::Velocities { ref velocities_m_s } => {
                shots(velocities_m_s.len()).map_err(|_| {
                    format!("design.velocities_m_s: must list 1..=10000 velocities, got {}", velocities_m_s.len())
                })?;
                match velocities_m_s.iter().position(|&v| !(v.is_finite() && v > 0.0)) {
                    Some(k) => Err(format!("design.velocities_m_s[{k}]: must be > 0, got {}", velocities_m_s[k])),
                    None => Ok(()),
                }
            }
            Design::Bisection { low_m_s, high_m_s, resolution_m_s } => {
                bracket(low_m_s, high_m_s).and(positive("resolution_m_s", resolution_m_s))
            }
            Design::Langlie { low_m_s, high_m_s, shots: n } => bracket(low_m_s, high_m_s).and(shots(n)),
            Design::UpAndDown { start_m_s, step_m_s, shots: n } => {
                positive("start_m_s", start_m_s).and(positive("step_m_s", step_m_s)).and(shots(n))
            }
            Design::MonteCarlo { centre_m_s, spread_m_s, shots: n } => {
                positive("centre_m_s", centre_m_s)?;
                if !(spread_m_s >= 0.0 && spread_m_s < centre_m_s) {
                    return Err(format!("design.spread_m_s: must be in [0, centre_m_s), got {spread_m_s}"));
                }
                shots(n)
            }
        }
    }

    /// The shots the design fires, for pricing it before it runs: a count design's count, a
    /// bisection's halvings of its bounds to the resolution plus the one bound it may fire
    /// when its limit lies within its bounds (beyond them it fires more: [`bisection_bounds`]).
    pub fn expected_shots(&self) -> usize {
        match *self {
            Design::Bisection { low_m_s, high_m_s, resolution_m_s } => {
                ((high_m_s - low_m_s) / resolution_m_s).log2().ceil().max(0.0) as usize + 1
            }
            Design::UpAndDown { shots, .. } | Design::Langlie { shots, .. } | Design::MonteCarlo { shots, .. } => shots,
            Design::Velocities { ref velocities_m_s } => velocities_m_s.len(),
        }
    }

    /// Whether every velocity is known before any shot (the shots can run at once).
    pub fn independent(&self) -> bool {
        matches!(self, Design::MonteCarlo { .. } | Design::Velocities { .. })
    }

    /// Velocity of shot `index` of an independent design (`None` past its last shot).
    pub fn planned(&self, index: usize, seed: u64) -> Option<f64> {
        match *self {
            Design::Velocities { ref velocities_m_s } => velocities_m_s.get(index).copied(),
            Design::MonteCarlo { centre_m_s, spread_m_s, shots } if index < shots => {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(index as u64);
                Some(centre_m_s + spread_m_s * (2.0 * rng.random::<f64>() - 1.0))
            }
            _ => None,
        }
    }

    /// The next velocity after `shots` (in the order they were fired), or `None` when the
    /// design is complete.
    pub fn next(&self, shots: &[Shot], seed: u64) -> Option<f64> {
        match *self {
            Design::Bisection { low_m_s, high_m_s, resolution_m_s } => {
                let (low, high) = bisection_bounds(low_m_s, high_m_s, resolution_m_s, shots);
                let (lo, hi) = bracket(low, high, shots);
                if hi - lo > resolution_m_s {
                    return Some(0.5 * (lo + hi));
                }
                // narrow enough: an end no shot stands on (a bound never fired) is fired once
                let fired = |v: f64| shots.iter().any(|s| s.velocity == v);
                [lo, hi].into_iter().find(|&end| !fired(end) && end > 0.0)
            }
            Design::UpAndDown { start_m_s, step_m_s, shots: count } => {
                if shots.len() >= count {
                    return None;
                }
                Some(match shots.last() {
                    None => start_m_s,
                    Some(last) if last.perforated => (last.velocity - step_m_s).max(step_m_s),
                    Some(last) => last.velocity + step_m_s,
                })
            }
            Design::Langlie { low_m_s, high_m_s, shots: count } => {
                if shots.len() >= count {
                    return None;
                }
                let Some(last) = shots.last() else { return Some(0.5 * (low_m_s + high_m_s)) };
                let n = shots.len();
                let back = (0..n - 1).rev().find(|&p| {
                    let completes = shots[p..].iter().filter(|s| s.perforated).count();
                    2 * completes == n - p
                });
                let partner = match back {
                    Some(p) => shots[p].velocity,
                    None if last.perforated => low_m_s,
                    None => high_m_s,
                };
                Some(0.5 * (last.velocity + partner))
            }
            Design::MonteCarlo { .. } | Design::Velocities { .. } => self.planned(shots.len(), seed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fires a design at a target that stops everything below `limit`.
    fn fire(design: &Design, limit: f64) -> Vec<Shot> {
        let mut shots = Vec::new();
        while let Some(velocity) = design.next(&shots, 1) {
            shots.push(Shot { velocity, perforated: velocity > limit, residual_velocity: 0.0 });
            assert!(shots.len() < 1000);
        }
        shots
    }

    #[test]
    fn a_bisection_fires_no_more_than_it_is_priced_at_when_its_limit_lies_within_its_bounds() {
        for (low, high, resolution) in [(100.0, 500.0, 25.0), (100.0, 700.0, 5.0), (75.0, 400.0, 10.0)] {
            let design = Design::Bisection { low_m_s: low, high_m_s: high, resolution_m_s: resolution };
            let priced = design.expected_shots();
            let mut most = 0;
            let mut limit = low + 0.37;
            while limit < high {
                most = most.max(fire(&design, limit).len());
                limit += 0.73;
            }
            // the price is what the worst limit inside the bounds fires, not more
            assert_eq!(most, priced, "[{low}, {high}] by {resolution}");
        }
        let counted = Design::UpAndDown { start_m_s: 250.0, step_m_s: 25.0, shots: 12 };
        assert_eq!(counted.expected_shots(), 12);
        assert_eq!(Design::Velocities { velocities_m_s: vec![300.0, 400.0] }.expected_shots(), 2);
    }

    #[test]
    fn bisection_brackets_the_limit_to_its_resolution() {
        let design = Design::Bisection { low_m_s: 100.0, high_m_s: 700.0, resolution_m_s: 5.0 };
        let shots = fire(&design, 333.3);
        let (lo, hi) = bracket(100.0, 700.0, &shots);
        assert!(lo < 333.3 && 333.3 < hi && hi - lo <= 5.0, "{lo} {hi}");
        assert_eq!(shots.len(), 7, "600 m/s halved seven times is 4.7 m/s");
        assert_eq!(shots[0].velocity, 400.0);
    }

    #[test]
    fn a_bisection_fires_the_bounds_it_rests_on_and_goes_past_them() {
        // every shot down to the low bound perforates: the bound is fired, perforates too,
        // and the bisection goes on below it until a partial stands under the bracket
        let design = Design::Bisection { low_m_s: 100.0, high_m_s: 500.0, resolution_m_s: 25.0 };
        let shots = fire(&design, 60.0);
        let velocities: Vec<f64> = shots.iter().map(|s| s.velocity).collect();
        assert_eq!(velocities, vec![300.0, 200.0, 150.0, 125.0, 100.0, 75.0, 50.0]);
        let (low, high) = bisection_bounds(100.0, 500.0, 25.0, &shots);
        assert_eq!(bracket(low, high, &shots), (50.0, 75.0));
        // the low bound stops the projectile: the bracket [100, 125] is confirmed by a shot
        let shots = fire(&design, 110.0);
        assert_eq!(shots.iter().map(|s| s.velocity).collect::<Vec<_>>(), vec![300.0, 200.0, 150.0, 125.0, 100.0]);
        // above the high bound: it is fired, stopped, doubled
        let shots = fire(&design, 620.0);
        let (low, high) = bisection_bounds(100.0, 500.0, 25.0, &shots);
        let (lo, hi) = bracket(low, high, &shots);
        assert!(lo < 620.0 && 620.0 < hi && hi - lo <= 25.0, "{lo} {hi}");
        assert!(
            shots.iter().any(|s| s.velocity == lo && !s.perforated)
                && shots.iter().any(|s| s.velocity == hi && s.perforated)
        );
        // a target that stops nothing, or everything, ends the design at a limit
        let (none, all) = (fire(&design, 0.0), fire(&design, 1e9));
        assert!(none.len() < 20 && none.iter().all(|s| s.perforated && s.velocity >= 25.0), "{none:?}");
        assert!(all.len() < 60 && all.iter().all(|s| !s.perforated && s.velocity <= 4000.0), "{}", all.len());
    }

    #[test]
    fn up_and_down_steps_about_the_limit() {
        let design = Design::UpAndDown { start_m_s: 250.0, step_m_s: 20.0, shots: 12 };
        let shots = fire(&design, 300.0);
        assert_eq!(shots.len(), 12);
        let velocities: Vec<f64> = shots.iter().map(|s| s.velocity).collect();
        assert_eq!(&velocities[..5], &[250.0, 270.0, 290.0, 310.0, 290.0]);
        assert!(velocities[3..].iter().all(|v| (290.0..=310.0).contains(v)));
    }

    #[test]
    fn langlie_follows_its_rule() {
        let design = Design::Langlie { low_m_s: 200.0, high_m_s: 400.0, shots: 6 };
        let shots = fire(&design, 330.0);
        let v: Vec<f64> = shots.iter().map(|s| s.velocity).collect();
        // 300 partial -> (300 + high) / 2 = 350 complete -> shots 300,350 balance: (350 + 300) / 2
        assert_eq!(&v[..3], &[300.0, 350.0, 325.0]);
        // 325 partial: [350, 325] balance -> (325 + 350) / 2
        assert_eq!(v[3], 337.5);
        // 337.5 complete: [325, 337.5] balance -> (337.5 + 325) / 2
        assert_eq!(v[4], 331.25);
        assert_eq!(shots.len(), 6);
    }

    #[test]
    fn monte_carlo_velocities_are_fixed_by_the_seed_alone() {
        let design = Design::MonteCarlo { centre_m_s: 300.0, spread_m_s: 50.0, shots: 20 };
        let planned: Vec<f64> = (0..20).map(|k| design.planned(k, 9).unwrap()).collect();
        assert!(planned.iter().all(|v| (250.0..350.0).contains(v)));
        assert!(design.planned(20, 9).is_none());
        // the same whatever the outcomes
        assert_eq!(
            fire(&design, 300.0).iter().map(|s| s.velocity).collect::<Vec<_>>(),
            (0..20).map(|k| design.planned(k, 1).unwrap()).collect::<Vec<_>>()
        );
        assert_ne!(planned[0], design.planned(0, 10).unwrap());
    }

    #[test]
    fn a_list_of_velocities_fires_each_once_in_order() {
        let design = Design::Velocities { velocities_m_s: vec![400.0, 250.0, 325.0] };
        assert!(design.independent());
        assert_eq!(fire(&design, 300.0).iter().map(|s| s.velocity).collect::<Vec<_>>(), [400.0, 250.0, 325.0]);
        assert_eq!(design.planned(2, 7), Some(325.0));
        assert_eq!(design.planned(3, 7), None);
        let design: Design = serde_json::from_str(r#"{ "kind": "velocities", "velocities_m_s": [400.0] }"#).unwrap();
        assert_eq!(design, Design::Velocities { velocities_m_s: vec![400.0] });
    }

    #[test]
    fn bad_designs_name_their_field() {
        assert!(Design::Velocities { velocities_m_s: vec![] }
            .validate()
            .unwrap_err()
            .contains("design.velocities_m_s"));
        assert!(Design::Velocities { velocities_m_s: vec![300.0, -1.0] }
            .validate()
            .unwrap_err()
            .contains("design.velocities_m_s[1]"));
        assert!(Design::Velocities { velocities_m_s: vec![f64::NAN] }
            .validate()
            .unwrap_err()
            .contains("design.velocities_m_s[0]"));
        assert!(Design::Bisection { low_m_s: 300.0, high_m_s: 200.0, resolution_m_s: 5.0 }
            .validate()
            .unwrap_err()
            .contains("low_m_s"));
        assert!(Design::UpAndDown { start_m_s: 300.0, step_m_s: 0.0, shots: 5 }
            .validate()
            .unwrap_err()
            .contains("design.step_m_s"));
        assert!(Design::MonteCarlo { centre_m_s: 300.0, spread_m_s: 400.0, shots: 5 }
            .validate()
            .unwrap_err()
            .contains("design.spread_m_s"));
        assert!(Design::Langlie { low_m_s: 100.0, high_m_s: 200.0, shots: 0 }
            .validate()
            .unwrap_err()
            .contains("design.shots"));
    }
}
