//! What a run measures of the whole problem: energies, broken elements, extents. Every value
//! is a collective with the same bits on every rank and any partition (exact sums,
//! maxima, bitwise or).

use dea_core::energy::EnergySums;
use dea_core::failure::BrokenCount;
use dea_core::nodes::FailureMode;

use crate::comm::Comm;
use crate::distributed::Distributed;

impl<C: Comm> Distributed<C> {
    /// Every energy of the whole problem, the same bits on every rank and any partition.
    pub fn energies(&self) -> dea_core::energy::EnergyReport {
        let mut sums = self.domain.energy_sums();
        if let Some(body) = &self.deformable {
            sums.projectile_kinetic.add(body.body.kinetic_energy());
            sums.projectile_strain.add(body.strain_energy);
        }
        let mut words = sums.to_words();
        self.comm.sum_i64(&mut words);
        EnergySums::from_words(&words).report()
    }

    /// Broken elements of the whole problem.
    pub fn broken(&self) -> BrokenCount {
        let b = self.domain.broken;
        let mut counts = [b.tension as i64, b.shear as i64, b.combined as i64];
        self.comm.sum_i64(&mut counts);
        BrokenCount { tension: counts[0] as u64, shear: counts[1] as u64, combined: counts[2] as u64 }
    }

    /// Broken elements of each layer, whole problem.
    pub fn broken_by_layer(&self, layers: usize) -> Vec<u64> {
        let nodes = &self.domain.nodes;
        let mut counts = vec![0i64; layers];
        for i in 0..nodes.n_owned {
            if self.domain.elements.failure[i] != FailureMode::Intact {
                counts[self.layer_of(nodes.fibre[i]) as usize] += 1;
            }
        }
        self.comm.sum_i64(&mut counts);
        counts.into_iter().map(|c| c as u64).collect()
    }

    /// Energy each layer holds or has dissipated (kinetic, strain, bending, contact,
    /// friction, plasticity, fracture), whole problem, exact sums [J].
    pub fn energy_by_layer(&self, layers: usize) -> Vec<f64> {
        let nodes = &self.domain.nodes;
        let sums = self.domain.energy_sums_by(|i| self.layer_of(nodes.fibre[i]) as usize, layers);
        let mut words: Vec<i64> = sums.iter().flat_map(EnergySums::to_words).collect();
        self.comm.sum_i64(&mut words);
        words.chunks_exact(dea_core::energy::ENERGY_WORDS).map(|w| EnergySums::from_words(w).report().total()).collect()
    }

    /// Lowest and highest owned node along z over every rank [m].
    pub fn z_range(&self) -> (f64, f64) {
        let owned = &self.domain.nodes.position[..self.domain.nodes.n_owned];
        let mut extremes = [
            owned.iter().map(|p| -p.z).fold(f64::NEG_INFINITY, f64::max),
            owned.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max),
        ];
        self.comm.max_f64(&mut extremes);
        (-extremes[0], extremes[1])
    }

    /// Bit set over global fibre ids: fibres with a broken element anywhere.
    pub fn fibres_with_broken_elements(&self, fibres: usize) -> Vec<u64> {
        let mut bits = vec![0u64; fibres.div_ceil(64)];
        let nodes = &self.domain.nodes;
        for i in 0..nodes.n_owned {
            if self.domain.elements.failure[i] != FailureMode::Intact {
                let f = nodes.fibre[i].0 as usize;
                bits[f / 64] |= 1 << (f % 64);
            }
        }
        self.comm.or_u64(&mut bits);
        bits
    }
}
