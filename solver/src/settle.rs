//! The settle before the shot (docs/theory.md F9): dynamic relaxation of the built target
//! with the projectile set aside, friction and failure off and the nodes damped, then the shot
//! starts from the settled positions at rest.

use std::time::Instant;

use dea_core::domain::Phase;
use dea_core::DomainError;
use serde::Serialize;

use crate::comm::Comm;
use crate::distributed::Distributed;
use crate::step::compute_forces;

/// What a settle before the shot did (every value agreed over the ranks).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SettleReport {
    /// steps of the settle
    pub steps: u64,
    /// [s]
    pub time_s: f64,
    /// [1/s]
    pub damping_per_s: f64,
    /// largest force on a free fibre node as built, and after the settle [N]
    pub largest_force_before_n: f64,
    /// (after the settle) [N]
    pub largest_force_after_n: f64,
    /// deepest fibre contact over its contact distance, as built and after [-]
    pub largest_overlap_before: f64,
    /// (after the settle) [-]
    pub largest_overlap_after: f64,
    /// how far the target's top rose, and the projectile with it [m]
    pub top_rise_m: f64,
    /// [s]
    pub wall_s: f64,
}

/// The steps a settle of `duration` [s] takes at `time_step` [s] (what `check` prices too).
pub fn settle_steps(duration: f64, time_step: f64) -> u64 {
    (duration / time_step).ceil() as u64
}

impl<C: Comm> Distributed<C> {
    /// Lets the target settle for `duration` before the shot, on every rank together: the
    /// projectile is set aside, friction and failure are off, and the nodes are damped at
    /// `damping`; then the shot starts from the settled positions at rest with fresh
    /// contact histories ([`dea_core::Domain::start_afresh`]), the projectile raised by as much as the
    /// target's top rose. Deterministic like any step: the same bits on any number of ranks.
    pub fn settle(&mut self, duration: f64, damping: f64) -> Result<SettleReport, DomainError> {
        let clock = Instant::now();
        let agreed = |run: &Self, values: [f64; 2]| {
            let mut values = values;
            run.comm.max_f64(&mut values);
            values
        };
        let [force_before, overlap_before] =
            agreed(self, [self.domain.largest_free_force(), self.domain.largest_overlap_ratio()]);
        let (_, top_before) = self.z_range();
        let projectile = self.domain.projectile.take();
        let body = self.deformable.take();
        self.domain.phase = Phase::Settle { damping };
        let steps = settle_steps(duration, self.domain.time_step);
        let mut result = Ok(());
        for _ in 0..steps {
            result = self.step();
            if result.is_err() {
                break;
            }
        }
        self.domain.phase = Phase::Shot;
        self.domain.projectile = projectile;
        self.deformable = body;
        result?;
        let [force_after, overlap_after] =
            agreed(self, [self.domain.largest_free_force(), self.domain.largest_overlap_ratio()]);
        let (_, top_after) = self.z_range();
        let rise = (top_after - top_before).max(0.0);
        if let Some(p) = &mut self.domain.projectile {
            p.position.z += rise;
        }
        if let Some(body) = &mut self.deformable {
            body.body.position.iter_mut().for_each(|x| x.z += rise);
        }
        self.domain.start_afresh();
        let instant = self.domain.step;
        let forces = compute_forces(&mut self.domain, &mut self.timer, instant);
        self.agree_on_forces(forces)?;
        self.gather_projectile_load();
        let report = SettleReport {
            steps,
            time_s: steps as f64 * self.domain.time_step,
            damping_per_s: damping,
            largest_force_before_n: force_before,
            largest_force_after_n: force_after,
            largest_overlap_before: overlap_before,
            largest_overlap_after: overlap_after,
            top_rise_m: rise,
            wall_s: clock.elapsed().as_secs_f64(),
        };
        self.settled = Some(report);
        Ok(report)
    }
}
