//! Contact data of each pair of fibre sections, computed once at assembly: the contact
//! distance and the geometry of the normal law (seed 4-4…4-15) for two fibres of sections
//! `a` and `b`.

use crate::contact::ContactGeometry;
use crate::FibreSection;

/// Precomputed contact data for a pair of sections.
#[derive(Clone, Copy, Debug)]
pub struct PairData {
    /// contact distance: the mean of the two contact diameters [m]
    pub reach: f64,
    /// the normal law's geometry of the pair (effective radius, length, radii sum)
    pub geometry: ContactGeometry,
    /// the factor of the pair's forces at this instant: 1, or under multi-rate stepping the
    /// pair's rate when it fires now and 0 when it does not ([`crate::multi_rate`]) [-]
    pub scale: f64,
}

impl PairData {
    /// The data of a fibre of section `a` against one of section `b`: the law sees the
    /// harmonic mean radius `2 r_a r_b / (r_a + r_b)`, the mean element length and the sum of
    /// the radii.
    pub fn new(a: &FibreSection, b: &FibreSection) -> Self {
        let (ra, rb) = (0.5 * a.diameter, 0.5 * b.diameter);
        Self {
            reach: 0.5 * (a.contact_diameter + b.contact_diameter),
            geometry: ContactGeometry::new(
                2.0 * ra * rb / (ra + rb),
                0.5 * (a.element_length + b.element_length),
                ra + rb,
            ),
            scale: 1.0,
        }
    }
}

/// The contact data of every ordered pair of sections.
#[derive(Clone, Debug)]
pub struct PairDataTable {
    sections: usize,
    data: Vec<PairData>,
}

impl PairDataTable {
    /// The data of every ordered pair of `sections`.
    pub fn new(sections: &[FibreSection]) -> Self {
        let data = sections.iter().flat_map(|a| sections.iter().map(move |b| PairData::new(a, b))).collect();
        Self { sections: sections.len(), data }
    }

    /// The data of a fibre of section `a` against one of section `b`.
    #[inline(always)]
    pub fn of(&self, a: u16, b: u16) -> PairData {
        self.data[a as usize * self.sections + b as usize]
    }

    /// The data with each ordered pair's force factor `scale[a * sections + b]`
    /// ([`crate::multi_rate::Firing::pair_scale`]).
    pub fn set_scales(&mut self, scale: &[f64]) {
        for (data, &scale) in self.data.iter_mut().zip(scale) {
            data.scale = scale;
        }
    }

    /// The one pair's data when there is one section (most cases).
    pub fn single(&self) -> Option<PairData> {
        (self.sections == 1).then(|| self.data[0])
    }
}
