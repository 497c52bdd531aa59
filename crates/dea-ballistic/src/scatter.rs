//! Shot-to-shot scatter, as at a range: besides its strength seed, each shot of a campaign
//! draws where it strikes within one weave unit cell, and its yaw and obliquity, from stated
//! distributions (docs/theory.md V7).
//!
//! Every quantity has its own counter-based stream (ChaCha8 keyed by the campaign's seed,
//! the stream number made of the replicate, the shot's index and the quantity), so a draw
//! depends only on (seed, replicate, index) — not on which group fires the shot, nor on how
//! often the campaign was interrupted — and changing one distribution leaves the others'
//! draws as they were.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal, Uniform};
use serde::{Deserialize, Serialize};

/// Where a shot aims.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Aim {
    /// uniformly within one weave unit cell centred on the case's `offset_m` (the default):
    /// no range can aim at a chosen yarn crossing
    #[default]
    UnitCell,
    /// at the case's `offset_m`
    Fixed,
}

/// A spread about the case's value of an angle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Spread {
    /// the case's value
    Fixed {},
    /// uniform within ± `half_width` of the case's value [deg]
    Uniform {
        /// [deg]
        half_width: f64,
    },
    /// normal about the case's value, truncated at three standard deviations [deg]
    Normal {
        /// [deg]
        std_dev: f64,
    },
}

/// The largest spread of an angle a campaign may ask for [deg] (a range rejects a shot whose
/// yaw exceeds 5°, NIJ 0101.06 §7.5).
pub const MAX_SPREAD_DEG: f64 = 10.0;

impl Spread {
    fn validate(&self, field: &str) -> Result<(), String> {
        let width = match *self {
            Spread::Fixed {} => return Ok(()),
            Spread::Uniform { half_width } => half_width,
            Spread::Normal { std_dev } => 3.0 * std_dev,
        };
        if width.is_finite() && width >= 0.0 && width <= MAX_SPREAD_DEG {
            Ok(())
        } else {
            Err(format!(
                "{field}: must reach no further than {MAX_SPREAD_DEG} degrees from the case's value, got {width}"
            ))
        }
    }

    /// The deviation from the case's value drawn from `rng` [deg].
    fn draw(&self, rng: &mut ChaCha8Rng) -> f64 {
        match *self {
            Spread::Fixed {} => 0.0,
            Spread::Uniform { half_width } => {
                Uniform::new_inclusive(-half_width, half_width).expect("validated").sample(rng)
            }
            Spread::Normal { std_dev } => loop {
                let z: f64 = StandardNormal.sample(rng);
                if z.abs() <= 3.0 {
                    break std_dev * z;
                }
            },
        }
    }
}

/// What a campaign's shots draw besides their strength seeds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scatter {
    /// where each shot strikes (default: uniformly within a unit cell)
    #[serde(default)]
    pub aim: Aim,
    /// yaw about the case's `yaw_deg`, in the plane of obliquity (default: normal, 1°)
    #[serde(default = "default_yaw")]
    pub yaw_deg: Spread,
    /// obliquity about the case's `obliquity_deg` (default: fixed)
    #[serde(default = "fixed")]
    pub obliquity_deg: Spread,
}

fn default_yaw() -> Spread {
    Spread::Normal { std_dev: 1.0 }
}

fn fixed() -> Spread {
    Spread::Fixed {}
}

impl Default for Scatter {
    /// Aim uniform within a unit cell, yaw normal with a standard deviation of 1°, obliquity
    /// fixed (docs/theory.md V7 says why).
    fn default() -> Self {
        Self { aim: Aim::UnitCell, yaw_deg: default_yaw(), obliquity_deg: fixed() }
    }
}

/// What one shot drew: deviations from its case's aim, yaw and obliquity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Draws {
    /// shift of the aim point from the case's `offset_m` (x, y) [m]
    pub aim_shift_m: [f64; 2],
    /// [deg]
    pub yaw_deg: f64,
    /// [deg]
    pub obliquity_deg: f64,
}

/// Keys the scatter streams apart from the velocity and strength streams of the same seed.
const SCATTER_KEY: u64 = 0x5343_4154_5445_5231;

fn stream(seed: u64, replicate: usize, index: usize, quantity: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ SCATTER_KEY);
    rng.set_stream(((replicate as u64) << 40) | ((index as u64) << 3) | quantity);
    rng
}

impl Scatter {
    /// No scatter at all: every shot at the case's aim, yaw and obliquity.
    pub fn none() -> Self {
        Self { aim: Aim::Fixed, yaw_deg: fixed(), obliquity_deg: fixed() }
    }

    /// Whether every shot is fired exactly as its case says.
    pub fn is_none(&self) -> bool {
        *self == Self::none()
    }

    /// Checks the spreads; the error names the field (within `scatter`).
    pub fn validate(&self) -> Result<(), String> {
        self.yaw_deg.validate("scatter.yaw_deg")?;
        self.obliquity_deg.validate("scatter.obliquity_deg")
    }

    /// The draws of shot `index` of sequence `replicate`; `cell` is the unit cell's size
    /// along x and y [m] (required when the aim scatters).
    pub fn draw(&self, seed: u64, replicate: usize, index: usize, cell: Option<[f64; 2]>) -> Draws {
        let aim_shift_m = match (self.aim, cell) {
            (Aim::Fixed, _) => [0.0; 2],
            (Aim::UnitCell, Some(cell)) => {
                let mut rng = stream(seed, replicate, index, 0);
                let half = Uniform::new(-0.5, 0.5).expect("a range");
                [cell[0] * half.sample(&mut rng), cell[1] * half.sample(&mut rng)]
            }
            (Aim::UnitCell, None) => panic!("a unit-cell aim needs the cell's size"),
        };
        Draws {
            aim_shift_m,
            yaw_deg: self.yaw_deg.draw(&mut stream(seed, replicate, index, 1)),
            obliquity_deg: self.obliquity_deg.draw(&mut stream(seed, replicate, index, 2)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn moments(values: &[f64]) -> (f64, f64) {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        (mean, (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
    }

    #[test]
    fn draws_follow_their_stated_distributions() {
        let scatter = Scatter {
            aim: Aim::UnitCell,
            yaw_deg: Spread::Normal { std_dev: 1.5 },
            obliquity_deg: Spread::Uniform { half_width: 2.0 },
        };
        let cell = [1.5e-3, 1.2e-3];
        let draws: Vec<Draws> = (0..40_000).map(|k| scatter.draw(7, 0, k, Some(cell))).collect();
        let n = draws.len() as f64;
        for axis in 0..2 {
            let (mean, std) = moments(&draws.iter().map(|d| d.aim_shift_m[axis]).collect::<Vec<_>>());
            // uniform over a cell of side p: mean 0, standard deviation p / sqrt(12)
            let expected = cell[axis] / 12f64.sqrt();
            assert!(mean.abs() < 4.0 * expected / n.sqrt(), "axis {axis}: mean {mean}");
            assert!((std / expected - 1.0).abs() < 0.02, "axis {axis}: {std} against {expected}");
            assert!(draws.iter().all(|d| d.aim_shift_m[axis].abs() <= 0.5 * cell[axis]));
        }
        // a normal truncated at 3 sigma keeps a standard deviation of 0.98655 sigma
        let (mean, std) = moments(&draws.iter().map(|d| d.yaw_deg).collect::<Vec<_>>());
        assert!(mean.abs() < 4.0 * 1.5 / n.sqrt(), "{mean}");
        assert!((std / (1.5 * 0.986_55) - 1.0).abs() < 0.02, "{std}");
        assert!(draws.iter().all(|d| d.yaw_deg.abs() <= 4.5));
        let (mean, std) = moments(&draws.iter().map(|d| d.obliquity_deg).collect::<Vec<_>>());
        assert!(mean.abs() < 4.0 * 2.0 / (3f64.sqrt() * n.sqrt()), "{mean}");
        assert!((std / (2.0 / 3f64.sqrt()) - 1.0).abs() < 0.02, "{std}");
    }

    #[test]
    fn a_draw_depends_on_the_seed_and_the_shot_alone() {
        let scatter = Scatter::default();
        let cell = Some([1.5e-3, 1.5e-3]);
        let a = scatter.draw(3, 1, 17, cell);
        assert_eq!(a, scatter.draw(3, 1, 17, cell));
        for other in [scatter.draw(4, 1, 17, cell), scatter.draw(3, 0, 17, cell), scatter.draw(3, 1, 16, cell)] {
            assert_ne!(a.aim_shift_m, other.aim_shift_m);
            assert_ne!(a.yaw_deg, other.yaw_deg);
        }
        // fixing the aim leaves the yaw's draw alone
        let fixed_aim = Scatter { aim: Aim::Fixed, ..scatter }.draw(3, 1, 17, None);
        assert_eq!(fixed_aim.aim_shift_m, [0.0; 2]);
        assert_eq!(fixed_aim.yaw_deg, a.yaw_deg);
        assert_eq!(Scatter::none().draw(3, 1, 17, None), Draws::default());
    }

    #[test]
    fn spreads_are_parsed_and_bounded() {
        let scatter: Scatter =
            serde_json::from_str(r#"{ "aim": "fixed", "yaw_deg": { "kind": "uniform", "half_width": 2.0 } }"#).unwrap();
        assert_eq!(
            scatter,
            Scatter { aim: Aim::Fixed, yaw_deg: Spread::Uniform { half_width: 2.0 }, obliquity_deg: Spread::Fixed {} }
        );
        assert_eq!(serde_json::from_str::<Scatter>("{}").unwrap(), Scatter::default());
        let too_wide = Scatter { yaw_deg: Spread::Normal { std_dev: 4.0 }, ..Scatter::default() };
        assert!(too_wide.validate().unwrap_err().starts_with("scatter.yaw_deg"));
        let negative = Scatter { obliquity_deg: Spread::Uniform { half_width: -1.0 }, ..Scatter::default() };
        assert!(negative.validate().unwrap_err().starts_with("scatter.obliquity_deg"));
        assert!(serde_json::from_str::<Scatter>(r#"{ "yaw_deg": { "kind": "normal", "sigma": 1.0 } }"#).is_err());
    }
}
