//! The bench's floor measurement: the fibre-contact law and friction alone, on the touching
//! pairs the sweep evaluates, packed in contiguous arrays (bench key
//! `ns_per_contact_pair_packed`). What the sweep would cost if its lists were free.

use std::cell::Cell;
use std::time::Instant;

use dea_core::contact::NormalLaw;
use dea_core::dispatch::{in_compilation, Compilation};
use dea_core::fibre_contact::{evaluate_pair, RunningSums};
use dea_core::friction::FibreFrictionSpring;
use dea_core::pair_data::PairData;
use dea_core::{Domain, Vec3};

/// The law and friction of the fibre-contact sweep on touching pairs packed in contiguous
/// arrays, `relative` their partners' positions relative to their nodes and `data_of(k)` the
/// data of pair `k`: each pair's terms added to one running sum and handed to the next slot
/// of `handed`, with no list, no pair apart and no partner gathered. What the sweep would
/// cost if its lists were free (`dea-mpi bench`). Returns the sum and the pairs' stiffnesses
/// summed [N/m].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sweep_packed_pairs(
    law: NormalLaw,
    mu: f64,
    relative: &[Vec3],
    touching: &[Cell<bool>],
    max_overlap: &mut [f64],
    anchor: &mut [Vec3],
    spring_stiffness: &mut [f64],
    handed: &mut [RunningSums],
    data_of: impl Fn(usize) -> PairData,
) -> RunningSums {
    let n = relative.len();
    let (touching, max_overlap, anchor, spring_stiffness, handed) =
        (&touching[..n], &mut max_overlap[..n], &mut anchor[..n], &mut spring_stiffness[..n], &mut handed[..n]);
    let mut sum = RunningSums::default();
    for k in 0..n {
        if let Some(terms) = evaluate_pair(
            law,
            mu,
            FibreFrictionSpring::Anchored,
            relative[k],
            data_of(k),
            &touching[k],
            &mut max_overlap[k],
            &mut anchor[k],
            &mut spring_stiffness[k],
        ) {
            sum.add(&terms);
            handed[k].add_mirrored(&terms);
        }
    }
    sum
}

/// Touching pairs packed in contiguous arrays, one slot a pair, for [`sweep_packed_pairs`].
pub struct PackedPairs {
    /// the partner's position relative to the node [m]
    relative: Vec<Vec3>,
    data: Vec<PairData>,
    touching: Vec<bool>,
    /// [m]
    max_overlap: Vec<f64>,
    /// [m]
    anchor: Vec<Vec3>,
    /// [N/m]
    spring_stiffness: Vec<f64>,
    /// the terms handed to each pair's partner, added up over the sweeps
    handed: Vec<RunningSums>,
}

impl PackedPairs {
    /// Times `sweeps` sweeps, with `one_section` the data of every pair when the domain has
    /// one section: the seconds and the pairs' stiffnesses summed at the last sweep [N/m].
    pub fn time(&mut self, law: NormalLaw, mu: f64, one_section: Option<PairData>, sweeps: usize) -> (f64, f64) {
        let compilation = Compilation::widest();
        let mut stiffness = 0.0;
        let clock = Instant::now();
        for _ in 0..sweeps {
            // every term is used, as the sweep's are
            stiffness = std::hint::black_box(self.sweep(compilation, law, mu, one_section)).stiffness;
        }
        (clock.elapsed().as_secs_f64(), stiffness)
    }

    /// One sweep in `compilation`, which the processor must run. Never inlined, so that
    /// `scripts/count-instructions.sh` counts it by this name.
    #[inline(never)]
    fn sweep(
        &mut self,
        compilation: Compilation,
        law: NormalLaw,
        mu: f64,
        one_section: Option<PairData>,
    ) -> RunningSums {
        let touching = Cell::from_mut(&mut self.touching[..]).as_slice_of_cells();
        let (relative, data, max_overlap, anchor, spring_stiffness, handed) = (
            &self.relative[..],
            &self.data[..],
            &mut self.max_overlap[..],
            &mut self.anchor[..],
            &mut self.spring_stiffness[..],
            &mut self.handed[..],
        );
        match one_section {
            Some(data) => in_compilation(
                compilation,
                #[inline(always)]
                move || {
                    sweep_packed_pairs(
                        law,
                        mu,
                        relative,
                        touching,
                        max_overlap,
                        anchor,
                        spring_stiffness,
                        handed,
                        |_| data,
                    )
                },
            ),
            None => in_compilation(
                compilation,
                #[inline(always)]
                move || {
                    sweep_packed_pairs(
                        law,
                        mu,
                        relative,
                        touching,
                        max_overlap,
                        anchor,
                        spring_stiffness,
                        handed,
                        |k| data[k],
                    )
                },
            ),
        }
    }
}

/// Times `sweeps` evaluations of the fibre-contact law and friction on `domain`'s touching
/// pairs, packed in contiguous arrays ([`PackedPairs`]): the floor the sweep stands on,
/// without its lists. The pairs are those the sweep evaluates there (a pair with a ghost on
/// both its ranks), with copies of their histories; the domain is not changed. Returns the
/// pairs, the seconds, and the pairs' stiffnesses summed at the last evaluation [N/m].
pub fn time_packed_contact_law(domain: &Domain, sweeps: usize) -> (usize, f64, f64) {
    let pairs = &domain.pairs;
    let evaluated: Vec<(usize, usize)> = pairs.evaluated_touching().collect();
    let partner = |k: usize| pairs.partner[k] as usize;
    let mut packed = PackedPairs {
        relative: evaluated
            .iter()
            .map(|&(i, k)| domain.nodes.position[partner(k)] - domain.nodes.position[i])
            .collect(),
        data: evaluated.iter().map(|&(i, k)| domain.pair_data_of(i, partner(k))).collect(),
        touching: vec![true; evaluated.len()],
        max_overlap: evaluated.iter().map(|&(_, k)| pairs.max_overlap[k]).collect(),
        anchor: evaluated.iter().map(|&(_, k)| pairs.anchor[k]).collect(),
        spring_stiffness: evaluated.iter().map(|&(_, k)| pairs.spring_stiffness[k]).collect(),
        handed: vec![RunningSums::default(); evaluated.len()],
    };
    let one_section = (domain.sections.len() == 1).then(|| domain.pair_data_of(0, 0));
    let (seconds, stiffness) =
        packed.time(domain.contact.law, domain.contact.friction_coefficient, one_section, sweeps);
    (evaluated.len(), seconds, stiffness)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::fixtures::{contact_overlap, squeezed_yarn};

    /// The bench's floor measurement evaluates the pairs the sweep evaluates, with their
    /// histories and data: its stiffnesses add up to the law's at every touching pair the
    /// sweep evaluates here (a pair with a ghost at its owned node), with one section or two.
    #[test]
    fn the_packed_law_evaluates_the_pairs_the_sweep_does() {
        for (sections, ghosts) in [(1, false), (2, true)] {
            let mut domain = squeezed_yarn(sections, ghosts);
            // the first sweep touches, the second sticks: friction is evaluated
            for _ in 0..2 {
                domain.add_fibre_contacts();
            }
            let (law, pairs) = (domain.contact.law, &domain.pairs);
            let evaluated: Vec<(usize, usize)> = (0..domain.nodes.n_owned)
                .flat_map(|i| pairs.row(i).map(move |k| (i, k)))
                .filter(|&(i, k)| pairs.evaluates(i, k) && pairs.touching[k])
                .collect();
            let expected: f64 = evaluated
                .iter()
                .map(|&(i, k)| {
                    law.evaluate(
                        &domain.pair_data_of(i, pairs.partner[k] as usize).geometry,
                        contact_overlap(&domain, i, k),
                        pairs.max_overlap[k],
                    )
                    .0
                    .stiffness
                })
                .sum();
            let (count, seconds, stiffness) = time_packed_contact_law(&domain, 3);
            assert_eq!(count, evaluated.len(), "sections {sections}, ghosts {ghosts}");
            assert!(count > 100 && seconds > 0.0);
            assert!(
                (stiffness - expected).abs() <= 1e-12 * expected,
                "sections {sections}, ghosts {ghosts}: {stiffness} against {expected}"
            );
            if !ghosts {
                assert_eq!(2 * count, pairs.touching_entries(), "each pair of owned nodes once");
            }
        }
    }
}
