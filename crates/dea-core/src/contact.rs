//! Normal contact laws between a fibre node and a partner (another fibre node or the
//! projectile surface): the Hertz-like elastic law (seed 4-4…4-8) and the Kevlar KM2
//! elasto-plastic transverse law (seed 4-9, 4-10).
//!
//! Both laws share one construction (seed 4-4, 4-5): the contact stiffness is a modulus times
//! the penetrated area `A_c = 2 a l0` with `a = sqrt(r delta)` (4-6) over a reference length,
//! `dF = E_t(eps) A_c / L dδ`. With `E_t = E_T` constant this integrates to (4-8). With the
//! tangent of the KM2 loading curve (4-9) it integrates in closed form too, so the force is a
//! function of the overlap and the maximum overlap only — no incremental drift.
//! The reference length `L` is the sum of the two radii (the fibre diameter); the nominal
//! transverse strain is `eps = delta / L` (docs/theory.md, interpretation I3).

use serde::{Deserialize, Serialize};

/// Normal contact law, selectable per case.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum NormalLaw {
    /// Hertz-like elastic contact with transverse modulus E_T [Pa] (seed 4-8)
    Elastic {
        /// E_T [Pa]
        transverse_modulus: f64,
    },
    /// Kevlar KM2 transverse compression, loading on (4-9), unloading with slope (4-10)
    ElastoPlasticKm2,
}

/// Loading curve (4-9): `sigma = (6.9417 e^3 - 1.2208 e^2 + 0.5296 e + 0.0060) GPa`.
pub const KM2_LOADING_GPA: [f64; 4] = [0.0060, 0.5296, -1.2208, 6.9417];
/// Unloading slope (4-10): `K = (18.666 e_max^2 + 7.0632 e_max + 0.0646) GPa`.
pub const KM2_UNLOADING_GPA: [f64; 3] = [0.0646, 7.0632, 18.666];

/// Geometry of one contact: what scales the stress law into a force law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactGeometry {
    /// fibre radius r in (4-6) [m]
    pub radius: f64,
    /// element length l0 in A_c = 2 a l0 [m]
    pub element_length: f64,
    /// reference length L of the nominal strain delta / L [m]
    pub reference_length: f64,
    /// `2 sqrt(r) l0 / L` [m^0.5], cached: force = this x integral of E_t(eps) sqrt(delta) d delta
    area_factor: f64,
    /// `1 / L` [1/m], cached: the strain of every evaluation without a division
    inverse_reference_length: f64,
}

impl ContactGeometry {
    /// The geometry of a fibre of radius `radius` [m] with elements of length
    /// `element_length` [m], strains taken over `reference_length` [m].
    pub fn new(radius: f64, element_length: f64, reference_length: f64) -> Self {
        Self { radius, element_length, reference_length, area_factor: 2.0 * radius.sqrt() * element_length / reference_length, inverse_reference_length: 1.0 / reference_length }
    }
}

/// State of a normal contact after an evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct NormalResponse {
    /// normal force magnitude (compressive, >= 0) [N]
    pub force: f64,
    /// tangent stiffness dF/d delta [N/m]
    pub stiffness: f64,
}

impl NormalLaw {
    /// Tangent modulus E_t(eps) of the loading curve [Pa].
    #[inline]
    fn loading_tangent(&self, strain: f64) -> f64 {
        match *self {
            NormalLaw::Elastic { transverse_modulus } => transverse_modulus,
            NormalLaw::ElastoPlasticKm2 => {
                let [_, c1, c2, c3] = KM2_LOADING_GPA;
                (3.0 * c3 * strain * strain + 2.0 * c2 * strain + c1) * 1e9
            }
        }
    }

    /// Force and tangent stiffness on the loading curve: the force is the integral of
    /// `E_t(delta / L) 2 sqrt(r delta) l0 / L`; elastic: `4 E_T sqrt(r) l0 delta^(3/2) / (3 L)`
    /// (4-8). `s` is `sqrt(overlap)`: the callers share it.
    #[inline]
    fn loading(&self, geometry: &ContactGeometry, overlap: f64, s: f64) -> NormalResponse {
        let strain = overlap * geometry.inverse_reference_length;
        let integral = match *self {
            NormalLaw::Elastic { transverse_modulus } => transverse_modulus * (2.0 / 3.0) * overlap * s,
            NormalLaw::ElastoPlasticKm2 => {
                let [_, c1, c2, c3] = KM2_LOADING_GPA;
                1e9 * overlap * s * ((6.0 / 7.0) * c3 * strain * strain + (4.0 / 5.0) * c2 * strain + (2.0 / 3.0) * c1)
            }
        };
        NormalResponse { force: geometry.area_factor * integral, stiffness: geometry.area_factor * self.loading_tangent(strain) * s }
    }

    /// Force on the loading curve [N] (see [`Self::evaluate`] for the full law).
    pub fn loading_force(&self, geometry: &ContactGeometry, overlap: f64) -> f64 {
        self.loading(geometry, overlap, overlap.sqrt()).force
    }

    /// Work done along the loading curve from 0 to `overlap` [J].
    pub fn loading_work(&self, geometry: &ContactGeometry, overlap: f64) -> f64 {
        self.loading_work_at(geometry, overlap, overlap.sqrt())
    }

    /// [`Self::loading_work`] given `s = sqrt(overlap)`.
    #[inline]
    fn loading_work_at(&self, geometry: &ContactGeometry, overlap: f64, s: f64) -> f64 {
        let d52 = overlap * overlap * s;
        let integral = match *self {
            NormalLaw::Elastic { transverse_modulus } => transverse_modulus * (4.0 / 15.0) * d52,
            NormalLaw::ElastoPlasticKm2 => {
                let [_, c1, c2, c3] = KM2_LOADING_GPA;
                let strain = overlap * geometry.inverse_reference_length;
                1e9 * d52 * ((12.0 / 63.0) * c3 * strain * strain + (8.0 / 35.0) * c2 * strain + (4.0 / 15.0) * c1)
            }
        };
        geometry.area_factor * integral
    }

    /// Unloading stiffness from the largest overlap reached [N/m]: slope (4-10) on the contact
    /// area at `max_overlap`, never below the loading tangent there, so the unloading line
    /// stays under the (convex) loading curve and a cycle can only dissipate. `s` is
    /// `sqrt(max_overlap)`.
    #[inline]
    fn unloading_stiffness(&self, geometry: &ContactGeometry, max_overlap: f64, s: f64) -> f64 {
        let strain = max_overlap * geometry.inverse_reference_length;
        let [k0, k1, k2] = KM2_UNLOADING_GPA;
        let slope = (k2 * strain * strain + k1 * strain + k0) * 1e9;
        geometry.area_factor * slope.max(self.loading_tangent(strain)) * s
    }

    /// Evaluates the law at `overlap` (> 0) given the largest overlap reached so far;
    /// returns the response and the updated largest overlap (the pair's history).
    #[inline(always)]
    pub fn evaluate(&self, geometry: &ContactGeometry, overlap: f64, max_overlap: f64) -> (NormalResponse, f64) {
        match self {
            NormalLaw::Elastic { .. } => (self.loading(geometry, overlap, overlap.sqrt()), max_overlap.max(overlap)),
            NormalLaw::ElastoPlasticKm2 if overlap >= max_overlap => (self.loading(geometry, overlap, overlap.sqrt()), overlap),
            NormalLaw::ElastoPlasticKm2 => {
                let s = max_overlap.sqrt();
                let k_u = self.unloading_stiffness(geometry, max_overlap, s);
                let force = self.loading(geometry, max_overlap, s).force - k_u * (max_overlap - overlap);
                let response = if force > 0.0 { NormalResponse { force, stiffness: k_u } } else { NormalResponse::default() };
                (response, max_overlap)
            }
        }
    }

    /// Recoverable energy stored in the contact at `overlap` [J]: the area under the unloading
    /// line, `F^2 / (2 k_u)`, for the elasto-plastic law; the loading work for the elastic one.
    pub fn stored_energy(&self, geometry: &ContactGeometry, overlap: f64, max_overlap: f64) -> f64 {
        if overlap <= 0.0 {
            return 0.0;
        }
        match self {
            NormalLaw::Elastic { .. } => self.loading_work(geometry, overlap),
            NormalLaw::ElastoPlasticKm2 => {
                let (response, peak) = self.evaluate(geometry, overlap, max_overlap);
                response.force * response.force / (2.0 * self.unloading_stiffness(geometry, peak, peak.sqrt()))
            }
        }
    }

    /// Energy the unloading line does not return: `W(d_max) - F(d_max)^2 / (2 k_u)` [J].
    /// A state function of the history, so plastic dissipation is tracked by its increments.
    pub fn dissipated(&self, geometry: &ContactGeometry, max_overlap: f64) -> f64 {
        match self {
            NormalLaw::Elastic { .. } => 0.0,
            NormalLaw::ElastoPlasticKm2 => {
                if max_overlap <= 0.0 {
                    return 0.0;
                }
                // the three terms share one square root: this runs at every loading evaluation
                let s = max_overlap.sqrt();
                let peak = self.loading(geometry, max_overlap, s).force;
                self.loading_work_at(geometry, max_overlap, s) - peak * peak / (2.0 * self.unloading_stiffness(geometry, max_overlap, s))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> ContactGeometry {
        ContactGeometry::new(25e-6, 12.5e-6, 50e-6)
    }

    #[test]
    fn elastic_force_is_the_closed_form_4_8() {
        let g = geometry();
        let e_t = 1.34e9;
        let law = NormalLaw::Elastic { transverse_modulus: e_t };
        for overlap in [1e-8, 1e-7, 1e-6, 5e-6] {
            let (response, _) = law.evaluate(&g, overlap, 0.0);
            let closed = 4.0 * e_t * g.radius.sqrt() * g.element_length * overlap.powf(1.5) / (3.0 * g.reference_length);
            assert!((response.force - closed).abs() <= 1e-12 * closed, "{} vs {}", response.force, closed);
            // tangent stiffness is (4-7): 2 E_T sqrt(r delta) l0 / L
            let k = 2.0 * e_t * (g.radius * overlap).sqrt() * g.element_length / g.reference_length;
            assert!((response.stiffness - k).abs() <= 1e-12 * k);
        }
    }

    #[test]
    fn loading_work_is_the_integral_of_the_force() {
        let g = geometry();
        for law in [NormalLaw::Elastic { transverse_modulus: 1.34e9 }, NormalLaw::ElastoPlasticKm2] {
            let overlap = 8e-6;
            let n = 20000;
            let h = overlap / n as f64;
            let numeric: f64 = (0..n).map(|k| law.loading_force(&g, (k as f64 + 0.5) * h) * h).sum();
            let closed = law.loading_work(&g, overlap);
            assert!((numeric - closed).abs() < 1e-6 * closed, "{law:?}: {numeric} vs {closed}");
        }
    }

    #[test]
    fn km2_loading_tangent_is_the_derivative_of_4_9() {
        let law = NormalLaw::ElastoPlasticKm2;
        let sigma = |e: f64| (6.9417 * e * e * e - 1.2208 * e * e + 0.5296 * e + 0.0060) * 1e9;
        for e in [0.01, 0.1, 0.3] {
            let h = 1e-6;
            let numeric = (sigma(e + h) - sigma(e - h)) / (2.0 * h);
            assert!((law.loading_tangent(e) - numeric).abs() < 1e-3 * numeric);
        }
    }

    #[test]
    fn km2_unloads_on_4_10_and_leaves_residual_strain() {
        let g = geometry();
        let law = NormalLaw::ElastoPlasticKm2;
        let peak_overlap = 0.2 * g.reference_length;
        let (loaded, history) = law.evaluate(&g, peak_overlap, 0.0);
        assert_eq!(history, peak_overlap);
        // loading follows (4-9) integrated
        assert_eq!(loaded.force, law.loading_force(&g, peak_overlap));
        // unloading slope equals (4-10) on the contact area at the peak
        let back = peak_overlap * 0.99;
        let (unloaded, history_after) = law.evaluate(&g, back, history);
        assert_eq!(history_after, peak_overlap, "history keeps the maximum");
        let slope = (loaded.force - unloaded.force) / (peak_overlap - back);
        let e = 0.2;
        let k_410 = (18.666 * e * e + 7.0632 * e + 0.0646) * 1e9;
        let expected = 2.0 * g.radius.sqrt() * g.element_length / g.reference_length * k_410 * peak_overlap.sqrt();
        assert!((slope - expected).abs() < 1e-9 * expected, "{slope} vs {expected}");
        // the force vanishes before the overlap does: residual strain
        let residual = peak_overlap - loaded.force / expected;
        assert!(residual > 0.0);
        let (at_residual, _) = law.evaluate(&g, residual * 0.999, history);
        assert_eq!(at_residual.force, 0.0);
        let (above_residual, _) = law.evaluate(&g, residual * 1.01 + 1e-12, history);
        assert!(above_residual.force > 0.0);
        // reloading retraces the unloading line up to the peak, then the loading curve
        let (reloaded, _) = law.evaluate(&g, peak_overlap, history);
        assert!((reloaded.force - loaded.force).abs() < 1e-12 * loaded.force);
        // dissipation of the cycle is positive and equals W - F^2/(2k)
        let dissipated = law.dissipated(&g, peak_overlap);
        assert!(dissipated > 0.0 && dissipated < law.loading_work(&g, peak_overlap));
    }

    #[test]
    fn unloading_never_lies_above_loading_so_cycles_dissipate() {
        let g = geometry();
        let law = NormalLaw::ElastoPlasticKm2;
        for peak_strain in [0.001, 0.01, 0.05, 0.1, 0.3] {
            let peak = peak_strain * g.reference_length;
            for k in 1..100 {
                let overlap = peak * k as f64 / 100.0;
                let (unloading, _) = law.evaluate(&g, overlap, peak);
                assert!(unloading.force <= law.loading_force(&g, overlap) * (1.0 + 1e-12), "strain {peak_strain} at {k}%");
            }
            assert!(law.dissipated(&g, peak) >= 0.0);
        }
    }
}
