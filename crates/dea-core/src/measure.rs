//! How the failure criterion (5-6) measures an element's tension and its shear: over the
//! element itself, as the seed writes (4-16) and (5-4), or over a gauge of physical length
//! (docs/theory.md, I9b and I9c). Both terms take the same choice; what each averages is
//! in [`crate::tension_gauge`] (the strain) and [`crate::shear_gauge`] (the moment).

use crate::FibreSection;

/// How one term of the failure criterion is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Measure {
    /// the seed's form as written: the element's own strain (4-16), or `Q = |M_i - M_j| / l0`
    /// from the bending springs at its two ends (5-4); neither converges where the loading
    /// peaks over less than an element (kept to reproduce the seed and earlier results)
    #[default]
    Element,
    /// the strain or moment averaged along the fibre with a hat of half-width `diameters`
    /// digital fibre diameters (converges as `l0` shrinks)
    Gauge {
        /// the gauge length in digital fibre diameters of the element's section [-]
        diameters: f64,
    },
}

impl Measure {
    /// The name a case gives it (`failure.shear_measure`, `failure.tension_measure`).
    pub fn name(self) -> &'static str {
        match self {
            Measure::Element => "element",
            Measure::Gauge { .. } => "gauge",
        }
    }

    /// The gauge's half-width in digital fibre diameters [-], none for the element measure.
    pub fn gauge_diameters(self) -> Option<f64> {
        match self {
            Measure::Element => None,
            Measure::Gauge { diameters } => Some(diameters),
        }
    }

    /// How many positions beyond its own (nodes for the shear gauge, elements for the
    /// tension gauge) a gauge reaches along its fibre in `section`: `ceil(L / l0)` (0 for the
    /// element measure). The walk stops there even when rest lengths shorter than the
    /// nominal one would let it go on, so the reach is a count and every rank that holds the
    /// chain stencil sees the same window.
    pub fn reach(self, section: &FibreSection) -> u32 {
        match self {
            Measure::Element => 0,
            Measure::Gauge { diameters } => (diameters * section.diameter / section.element_length).ceil() as u32,
        }
    }

    /// The gauge length `L` of `section` [m] (0 for the element measure).
    pub fn gauge_length(self, section: &FibreSection) -> f64 {
        match self {
            Measure::Element => 0.0,
            Measure::Gauge { diameters } => diameters * section.diameter,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_element_measure_reaches_nothing_and_the_gauge_its_length_over_l0() {
        // lengths whose ratios are exact in binary
        let section = FibreSection {
            diameter: 1.0,
            area: 0.25 * std::f64::consts::PI,
            element_length: 0.25,
            contact_diameter: 1.0,
            moment_of_inertia: 0.05,
            torsional_stiffness: 1.0,
            filaments_per_fibre: 1.0,
        };
        assert_eq!(Measure::Element.reach(&section), 0);
        assert_eq!(Measure::Element.gauge_length(&section), 0.0);
        assert_eq!(Measure::Element.gauge_diameters(), None);
        assert_eq!(Measure::Gauge { diameters: 1.0 }.reach(&section), 4);
        assert_eq!(Measure::Gauge { diameters: 1.1 }.reach(&section), 5);
        assert_eq!(Measure::Gauge { diameters: 2.0 }.gauge_length(&section), 2.0);
        assert_eq!(Measure::Gauge { diameters: 2.0 }.gauge_diameters(), Some(2.0));
        assert_eq!((Measure::Element.name(), Measure::Gauge { diameters: 1.0 }.name()), ("element", "gauge"));
    }
}
