//! Multi-rate stepping (docs/theory.md T1): each fibre section's terms fire at their own
//! step, a whole multiple of the run's, as impulses at the instants they share with it.
//!
//! The scheme is the impulse form of multiple time stepping (r-RESPA, Tuckerman, Berne and
//! Martyna 1992) applied by term, as the asynchronous variational integrators do (Lew,
//! Marsden, Ortiz and West 2003): every node drifts at every run step `h`; a term of rate `k`
//! (rods and bending springs of a section, a contact or tie between sections: the smallest
//! rate of its nodes) is evaluated only at the instants `n h` with `n` a multiple of `k`,
//! and there its forces are multiplied by `k`, so its kick `h k F` is the impulse it
//! delivers over its own step `k h`. Each term's forces on its nodes are equal and opposite
//! whatever its factor, so momentum is conserved exactly; a node whose every term has rate
//! `k` is integrated by velocity Verlet at step `k h`.

use std::ops::Range;

/// A run of consecutive local nodes of one section.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SectionRun {
    /// local node indices
    pub nodes: Range<usize>,
    /// their fibre section
    pub section: u16,
}

/// The runs of equal section over local nodes in `section` order.
pub fn section_runs(section: &[u16]) -> Vec<SectionRun> {
    let mut runs: Vec<SectionRun> = Vec::new();
    for (i, &s) in section.iter().enumerate() {
        match runs.last_mut() {
            Some(run) if run.section == s => run.nodes.end = i + 1,
            _ => runs.push(SectionRun { nodes: i..i + 1, section: s }),
        }
    }
    runs
}

/// The rate of each section: the largest power of two `k` for which `k` run steps of
/// `time_step` [s] stay within the section's stable step `limits[s]` [s] (taken at the same
/// safety as the run's step). Powers of two keep every two rates nested: the instants of
/// the larger are instants of the smaller.
pub fn rates_for(limits: &[f64], time_step: f64) -> Vec<u32> {
    limits
        .iter()
        .map(|&limit| {
            let mut rate = 1u32;
            while rate < (1 << 16) && 2.0 * rate as f64 * time_step <= limit {
                rate *= 2;
            }
            rate
        })
        .collect()
}

/// Which terms fire at one instant, and the factor of their forces.
#[derive(Clone, Debug, PartialEq)]
pub struct Firing {
    /// each section's chain terms: its rate when they fire now, else 0 [-]
    pub section_scale: Vec<f64>,
    /// each ordered pair of sections' contacts and ties (index `a * sections + b`): the
    /// smaller rate when they fire now, else 0 [-]
    pub pair_scale: Vec<f64>,
    /// the local nodes whose chain terms fire now: ascending, disjoint, maximal ranges
    pub active: Vec<Range<usize>>,
    /// every term fires with factor 1 (one rate, or a settle)
    pub single: bool,
}

impl Firing {
    /// Every term at factor 1 over `nodes` local nodes: single-rate stepping.
    pub fn every_term(sections: usize, nodes: usize) -> Self {
        Self {
            section_scale: vec![1.0; sections],
            pair_scale: vec![1.0; sections * sections],
            active: vec![0..nodes],
            single: true,
        }
    }

    /// The terms of `rates` (per section) that fire at `instant` (a count of run steps),
    /// over the local nodes of `runs`.
    pub fn at(rates: &[u32], instant: u64, runs: &[SectionRun], nodes: usize) -> Self {
        let mut firing = Self::every_term(rates.len(), nodes);
        firing.set_at(rates, instant, runs, nodes);
        firing
    }

    /// [`Self::at`] in place: the step sets its firing once per step, and reusing the
    /// buffers keeps that free of allocation.
    pub fn set_at(&mut self, rates: &[u32], instant: u64, runs: &[SectionRun], nodes: usize) {
        let single = rates.iter().all(|&r| r == 1);
        let scale = |rate: u32| {
            if single || instant.is_multiple_of(rate as u64) {
                rate as f64
            } else {
                0.0
            }
        };
        self.section_scale.clear();
        self.section_scale.extend(rates.iter().map(|&r| scale(r)));
        self.pair_scale.clear();
        self.pair_scale.extend(rates.iter().flat_map(|&a| rates.iter().map(move |&b| a.min(b))).map(scale));
        self.active.clear();
        self.single = single;
        if single {
            self.active.push(0..nodes);
            return;
        }
        for run in runs.iter().filter(|r| self.section_scale[r.section as usize] > 0.0) {
            match self.active.last_mut() {
                Some(last) if last.end == run.nodes.start => last.end = run.nodes.end,
                _ => self.active.push(run.nodes.clone()),
            }
        }
    }

    /// The factor of the terms between sections `a` and `b` now (0: they do not fire).
    #[inline(always)]
    pub fn pair(&self, a: u16, b: u16) -> f64 {
        self.pair_scale[a as usize * self.section_scale.len() + b as usize]
    }

    /// The active ranges cut to `0..end`.
    pub fn active_below(&self, end: usize) -> impl Iterator<Item = Range<usize>> + '_ {
        self.active.iter().map(move |r| r.start.min(end)..r.end.min(end)).filter(|r| !r.is_empty())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_are_the_largest_powers_of_two_within_each_sections_limit() {
        let h = 1.0;
        assert_eq!(rates_for(&[1.0, 2.07, 1.99, 4.0, 7.9, 8.0], h), vec![1, 2, 1, 4, 4, 8]);
    }

    #[test]
    fn a_section_fires_on_multiples_of_its_rate_and_a_pair_at_the_smaller_rate() {
        let section = [0u16, 0, 1, 1, 1, 0, 2, 2, 1];
        let runs = section_runs(&section);
        assert_eq!(runs.len(), 5);
        assert_eq!(runs[1], SectionRun { nodes: 2..5, section: 1 });
        let rates = [1, 2, 4];
        for instant in 0..16u64 {
            let firing = Firing::at(&rates, instant, &runs, section.len());
            for (s, &rate) in rates.iter().enumerate() {
                let expected = if instant % rate as u64 == 0 { rate as f64 } else { 0.0 };
                assert_eq!(firing.section_scale[s], expected, "instant {instant} section {s}");
                for (t, &other) in rates.iter().enumerate() {
                    let smaller = rate.min(other);
                    let expected = if instant % smaller as u64 == 0 { smaller as f64 } else { 0.0 };
                    assert_eq!(firing.pair(s as u16, t as u16), expected);
                }
            }
            // the active ranges are exactly the nodes of the firing sections
            let listed: Vec<usize> = firing.active.iter().flat_map(|r| r.clone()).collect();
            let expected: Vec<usize> =
                (0..section.len()).filter(|&i| firing.section_scale[section[i] as usize] > 0.0).collect();
            assert_eq!(listed, expected, "instant {instant}");
            assert!(firing.active.windows(2).all(|w| w[0].end < w[1].start), "maximal ranges");
        }
        let every = Firing::at(&[1, 1], 3, &section_runs(&[0, 1]), 2);
        assert!(every.single);
        assert_eq!(every.active, vec![0..2]);
    }
}
