//! The tension measure of the failure criterion (5-6): the seed's element strain (4-16) or
//! the strain averaged over a gauge of physical length (docs/theory.md, I9c).
//!
//! The seed tests each element's own strain. Where a fibre is pulled over an edge or the front
//! of a transverse wave passes, the strain peaks over a length set by the loading, and a
//! shorter element samples that peak more sharply: on the 1 in probe of validation.md the
//! ballistic outcome moved by +4.6 m/s from l0/d 0.5 to 0.25 with the element strain, by
//! −1.1 m/s with the strain taken over one fibre diameter. The gauge measure gives an
//! element the strain averaged along its fibre with a hat of half-width `L` (the gauge
//! length) centred on the element's middle,
//! `ε̄_i = Σ_j w_j ε_j / Σ_j w_j`, `w_j = l0_j (1 − |s_j − s_i| / L)`, over the elements `j`
//! of the same unbroken piece with `|s_j − s_i| < L` (`s` the rest arc length of an
//! element's middle). The weights are normalised, so a uniform strain is unchanged (also
//! where the window is cut by a broken element or a chain end), and a strain that varies
//! linearly along the window keeps its value at the middle; a one-element spike is spread
//! over `2L` of fibre at most `l0 / L` of its height (with the window whole).

use crate::ids::NONE;
use crate::measure::Measure;
use crate::nodes::{Elements, Nodes};
use crate::FibreSection;

/// How the failure criterion measures an element's tension: the seed's (4-16) of the
/// element's own strain ([`Measure::Element`], the default of a case; every result before
/// the choice was named), or the strain averaged over the gauge ([`Measure::Gauge`]).
pub type TensionMeasure = Measure;

/// What [`gauge_strains`] keeps between steps: each section's gauge length [m] and reach
/// (taken on the first call for the sections and measure it is given) and the gauge strains
/// [-] of the local elements.
#[derive(Clone, Debug, Default)]
pub struct StrainGaugeScratch {
    windows: Vec<(f64, u32)>,
    /// the measure `windows` were taken for
    measure: Option<TensionMeasure>,
    /// `ε̄` of each local element (indexed by its first node) [-]
    pub gauge_strain: Vec<f64>,
}

/// The gauge strains `ε̄` [-] of the local elements whose first node is in `ranges` (every
/// element, or at a multi-rate instant those of the sections whose terms fire,
/// [`crate::multi_rate`]; a gauge stays on its fibre, so on its section) into
/// `scratch.gauge_strain`, from the strains of [`crate::rod::compute_element_tension`]. An
/// element's window ends at a broken element, a chain end or a node not held here; only the
/// elements whose window the chain stencil holds are right, which are all the failure stage
/// reads. A broken element keeps its own strain (the criterion does not read it). Each sum
/// runs from the element outwards, the lower positions first, so an element's value has the
/// same bits on every rank that holds its window.
pub fn gauge_strains(
    nodes: &Nodes,
    elements: &Elements,
    sections: &[FibreSection],
    measure: TensionMeasure,
    scratch: &mut StrainGaugeScratch,
    ranges: &[std::ops::Range<usize>],
) {
    let StrainGaugeScratch { windows, measure: windows_of, gauge_strain } = scratch;
    gauge_strain.resize(nodes.len(), 0.0);
    // each section's gauge and reach: taken once for a domain's sections and measure (both
    // fixed for its life), not in the step loop
    if windows.len() != sections.len() || *windows_of != Some(measure) {
        windows.clear();
        windows.extend(sections.iter().map(|s| (measure.gauge_length(s), measure.reach(s))));
        *windows_of = Some(measure);
    }
    let windows: &[(f64, u32)] = windows;
    for range in ranges {
        let mut i = range.start;
        if let Some(done) =
            crate::in_avx2_lanes!(strain_gauge_in_lanes(nodes, elements, windows, gauge_strain, range.clone()))
        {
            i = done;
        }
        for i in i..range.end {
            gauge_strain[i] = element_gauge_strain(nodes, elements, windows, i);
        }
    }
}

/// [`gauge_strains`] four elements at a time over `range`, with the scalar walk's bits, where
/// the four share a section and their windows lie on one chain stored in order (almost
/// everywhere; the other groups take [`element_gauge_strain`]). Each lane walks its own
/// window as the scalar code does, in the same order of operations, a lane stopping at a
/// broken element or the gauge's end while the others go on; a broken element keeps its own
/// strain. Returns where the scalar code takes over (the last group's end).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn strain_gauge_in_lanes(
    nodes: &Nodes,
    elements: &Elements,
    windows: &[(f64, u32)],
    gauge_strain: &mut [f64],
    range: std::ops::Range<usize>,
) -> usize {
    use crate::lanes::F4;
    use crate::nodes::FailureMode;
    let n = nodes.len();
    let (rest, strain) = (&elements.rest_length, &elements.strain);
    let intact = |k: usize| if elements.failure[k] == FailureMode::Intact { 1.0 } else { 0.0 };
    let mut i = range.start;
    while i + 4 <= range.end {
        let section = nodes.section[i];
        let (gauge, reach) = windows[section as usize];
        let r = reach as usize;
        // elements i - r ..= i + 3 + r on one chain in memory order, each with its second
        // node (so an element there is intact exactly when its failure state says so)
        let in_order = gauge > 0.0
            && i >= r
            && i + 4 + r < n
            && (i..i + 4).all(|k| nodes.section[k] == section)
            && (i - r..=i + 3 + r).all(|k| nodes.next[k] == k as u32 + 1)
            && (i - r + 1..=i + 3 + r).all(|k| nodes.prev[k] == k as u32 - 1);
        if !in_order {
            for k in i..i + 4 {
                gauge_strain[k] = element_gauge_strain(nodes, elements, windows, k);
            }
            i += 4;
            continue;
        }
        let (one, zero, half) = (F4::splat(1.0), F4::splat(0.0), F4::splat(0.5));
        let gauge_lanes = F4::splat(gauge);
        let own = F4::load(strain, i);
        let mut weighted = F4::load(rest, i).mul(own);
        let mut total = F4::load(rest, i);
        // lower positions: element i + l - s after element i + l - s + 1; then higher ones:
        // element i + l + s after element i + l + s - 1
        for side in [-1isize, 1] {
            let mut distance = zero;
            let mut walking = one.eq(one);
            for step in 1..=r {
                let (element, before) = if side < 0 { (i - step, i - step + 1) } else { (i + step, i + step - 1) };
                walking = walking.and(F4::gather(element, intact).eq(one));
                let (rest_before, rest_here) = (F4::load(rest, before), F4::load(rest, element));
                distance = F4::select(walking, distance.add(half.mul(rest_before.add(rest_here))), distance);
                walking = walking.and(distance.lt(gauge_lanes));
                if walking.bits() == 0 {
                    break;
                }
                let weight = rest_here.mul(one.sub(distance.div(gauge_lanes)));
                weighted = F4::select(walking, weighted.add(weight.mul(F4::load(strain, element))), weighted);
                total = F4::select(walking, total.add(weight), total);
            }
        }
        let centre_intact = F4::gather(i, intact).eq(one);
        F4::select(centre_intact, weighted.div(total), own).store(gauge_strain, i);
        i += 4;
    }
    i
}

/// The gauge strain of local element `i` [-] ([`gauge_strains`]).
#[inline]
fn element_gauge_strain(nodes: &Nodes, elements: &Elements, windows: &[(f64, u32)], i: usize) -> f64 {
    let (gauge, reach) = windows[nodes.section[i] as usize];
    if gauge <= 0.0 || !elements.is_intact(nodes, i) {
        return elements.strain[i];
    }
    let rest = elements.rest_length[i];
    let mut sums = (rest * elements.strain[i], rest);
    let side = Side { nodes, elements, from: i, reach, gauge };
    // towards lower positions: the element before element j ends at j
    side.add(&mut sums, |j| nodes.prev[j]);
    // towards higher positions: element j is intact, so the element after it starts at its
    // second node
    side.add(&mut sums, |j| nodes.next[j]);
    sums.0 / sums.1
}

/// One element's window, walked one way at a time.
struct Side<'a> {
    nodes: &'a Nodes,
    elements: &'a Elements,
    /// the element the window is centred on
    from: usize,
    /// elements reached at most each way
    reach: u32,
    /// half-width L [m]
    gauge: f64,
}

impl Side<'_> {
    /// Adds to `(Σ w ε, Σ w)` the hat-weighted strains one way along the fibre, up to the
    /// reach, the gauge or a broken element; `neighbour` gives the next element that way (a
    /// generic, so the failure stage calls it without dynamic dispatch).
    #[inline]
    fn add(&self, (weighted, total): &mut (f64, f64), neighbour: impl Fn(usize) -> u32) {
        let (elements, rest) = (self.elements, &self.elements.rest_length);
        let (mut j, mut distance) = (self.from, 0.0);
        for _ in 0..self.reach {
            let k = neighbour(j);
            if k == NONE || !elements.is_intact(self.nodes, k as usize) {
                break;
            }
            let k = k as usize;
            // from middle to middle
            distance += 0.5 * (rest[j] + rest[k]);
            if distance >= self.gauge {
                break;
            }
            let weight = rest[k] * (1.0 - distance / self.gauge);
            *weighted += weight * elements.strain[k];
            *total += weight;
            j = k;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::fibre_along;
    use crate::nodes::FailureMode;
    use crate::Vec3;

    /// One straight fibre of `count` nodes, digital fibre diameter `diameter` [m] and
    /// elements `l0` [m], each element's strain set to `strain(k)` (positions are not read).
    fn fibre(
        count: u32,
        l0: f64,
        diameter: f64,
        strain: impl Fn(usize) -> f64,
    ) -> (Nodes, Elements, Vec<FibreSection>) {
        let half = 0.5 * (count - 1) as f64 * l0;
        let (nodes, mut elements, sections) = fibre_along(|s| Vec3::new(s, 0.0, 0.0), half, l0, diameter);
        for k in 0..count as usize {
            elements.strain[k] = strain(k);
        }
        (nodes, elements, sections)
    }

    fn measured(nodes: &Nodes, elements: &Elements, sections: &[FibreSection], diameters: f64) -> Vec<f64> {
        let mut scratch = StrainGaugeScratch::default();
        let measure = TensionMeasure::Gauge { diameters };
        gauge_strains(nodes, elements, sections, measure, &mut scratch, &[0..nodes.len()]);
        scratch.gauge_strain
    }

    #[test]
    fn a_uniform_or_linear_strain_is_kept_and_a_spike_is_spread_by_the_hat() {
        let diameter = 12e-6;
        for ratio in [0.5, 0.25, 0.125, 0.3] {
            let l0 = ratio * diameter;
            let count = 81;
            // uniform: unchanged everywhere, the windows cut by the chain's ends too
            let (nodes, elements, sections) = fibre(count, l0, diameter, |_| 0.02);
            let gauge = measured(&nodes, &elements, &sections, 1.0);
            for i in 0..count as usize - 1 {
                assert!((gauge[i] - 0.02).abs() <= 1e-15, "l0/d {ratio}, element {i}: {}", gauge[i]);
            }
            // linear along the fibre: kept where the window is whole (the hat is symmetric)
            let (nodes, elements, sections) = fibre(count, l0, diameter, |k| 0.01 + 1e-4 * k as f64);
            let gauge = measured(&nodes, &elements, &sections, 1.0);
            let whole = TensionMeasure::Gauge { diameters: 1.0 }.reach(&sections[0]) as usize;
            for i in whole..count as usize - 1 - whole {
                assert!((gauge[i] - elements.strain[i]).abs() <= 1e-15, "l0/d {ratio}, element {i}");
            }
            // one element at 0.03 amid zeros: its own gauge reads 0.03 l0 / Σ w, and every
            // element whose middle lies within L of its middle reads its share by the hat
            let spike = 40;
            let (nodes, elements, sections) = fibre(count, l0, diameter, |k| if k == spike { 0.03 } else { 0.0 });
            let gauge = measured(&nodes, &elements, &sections, 1.0);
            let weight = |k: usize| (1.0 - k as f64 * l0 / diameter).max(0.0);
            let sum: f64 = l0 * (weight(0) + 2.0 * (1..=whole).map(weight).sum::<f64>());
            for i in spike - whole - 2..=spike + whole + 2 {
                let expected = 0.03 * l0 * weight(i.abs_diff(spike)) / sum;
                assert!(
                    (gauge[i] - expected).abs() <= 1e-15,
                    "l0/d {ratio}, element {i}: {} against {expected}",
                    gauge[i]
                );
            }
            // the spike's peak falls as the elements shorten (l0/L of it with integer L/l0)
            if ratio == 0.5 || ratio == 0.25 {
                assert!((gauge[spike] - 0.03 * ratio).abs() <= 1e-15, "l0/d {ratio}: {}", gauge[spike]);
            }
        }
    }

    #[test]
    fn the_gauge_of_a_strain_peak_converges_as_the_elements_halve() {
        // a peak of fixed physical width (a Gaussian of 2 diameters' standard deviation at
        // s = 0, 2 % over a 1 % base): the element strain samples it ever closer to its top,
        // the gauge strain tends to its hat average, which is below the top
        let diameter = 12e-6;
        let peak = |s: f64| 0.01 + 0.02 * (-(s / (0.5 * diameter)).powi(2) / 2.0).exp();
        let mut element_peaks = Vec::new();
        let mut gauge_peaks = Vec::new();
        for ratio in [1.0, 0.5, 0.25, 0.125, 0.0625] {
            let l0 = ratio * diameter;
            let count = (16.0 / ratio) as u32 + 1;
            // an element's strain: the mean of the field over it, its middle at (k + 1/2) l0
            // from the fibre's middle shifted by a third of an element (no node on the top)
            let middle = |k: usize| (k as f64 + 0.5 - (count - 1) as f64 / 2.0 + 1.0 / 3.0) * l0;
            let mean = |k: usize| {
                let n = 64;
                (0..n).map(|q| peak(middle(k) + ((q as f64 + 0.5) / n as f64 - 0.5) * l0)).sum::<f64>() / n as f64
            };
            let (nodes, elements, sections) = fibre(count, l0, diameter, mean);
            let gauge = measured(&nodes, &elements, &sections, 1.0);
            element_peaks.push(elements.strain[..count as usize - 1].iter().copied().fold(0.0, f64::max));
            gauge_peaks.push(gauge[..count as usize - 1].iter().copied().fold(0.0, f64::max));
        }
        // the hat average of the field about its top, by the midpoint rule on 20,000 slices
        let n = 20_000;
        let hat_average = (0..n)
            .map(|q| {
                let s = ((q as f64 + 0.5) / n as f64 * 2.0 - 1.0) * diameter;
                (1.0 - s.abs() / diameter) * peak(s) * 2.0 * diameter / n as f64 / diameter
            })
            .sum::<f64>();
        // the element strain climbs toward the top (0.03) by more than 10 % of the peak from
        // l0/d 1 to 1/16; the gauge strain's changes shrink about fourfold a halving (0.9e-3,
        // 1.9e-4, 4.6e-5, 1.1e-5 when written), toward the hat average, below the top
        assert!(element_peaks[4] - element_peaks[0] > 0.002, "{element_peaks:?}");
        let steps: Vec<f64> = gauge_peaks.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        assert!(steps[3] < 0.1 * steps[1], "{gauge_peaks:?}");
        assert!((gauge_peaks[4] - hat_average).abs() < 2e-5, "{gauge_peaks:?} against {hat_average}");
        assert!(hat_average < 0.026, "{hat_average}");
    }

    #[test]
    fn the_lanes_give_the_gauge_strains_of_the_scalar_walk_with_its_bits() {
        use crate::bending::tests::{assert_same_bits, fibres_on_every_path};
        use crate::material::FibreMaterial;
        let (nodes, mut elements, sections) = fibres_on_every_path();
        crate::rod::compute_element_tension(&nodes, &mut elements, &sections, &FibreMaterial::kevlar_km2());
        // two reaches per section (the fixture's sections differ in diameter), and ranges that
        // split the elements where a group of four would not
        for diameters in [1.0, 2.5] {
            let measure = TensionMeasure::Gauge { diameters };
            let windows: Vec<(f64, u32)> =
                sections.iter().map(|s| (measure.gauge_length(s), measure.reach(s))).collect();
            let walked: Vec<f64> =
                (0..nodes.len()).map(|i| element_gauge_strain(&nodes, &elements, &windows, i)).collect();
            for ranges in [vec![0..nodes.len()], vec![0..7, 9..nodes.len() - 3]] {
                let mut scratch = StrainGaugeScratch { gauge_strain: vec![0.0; nodes.len()], ..Default::default() };
                gauge_strains(&nodes, &elements, &sections, measure, &mut scratch, &ranges);
                for range in &ranges {
                    assert_same_bits("gauge strain", &scratch.gauge_strain[range.clone()], &walked[range.clone()]);
                }
            }
            // the lanes' paths were taken: a group in order whose windows a broken element
            // cuts, one with a broken element of its own, and one across two sections or off
            // the chain's memory order; and the hat changed some strain (the test can fail)
            let reach = |i: usize| windows[nodes.section[i] as usize].1 as usize;
            let in_order = |i: usize| {
                i >= reach(i)
                    && i + 4 + reach(i) < nodes.len()
                    && (i..i + 4).all(|k| nodes.section[k] == nodes.section[i])
                    && (i - reach(i)..=i + 3 + reach(i)).all(|k| nodes.next[k] == k as u32 + 1)
            };
            let groups: Vec<usize> = (0..nodes.len() / 4).map(|g| 4 * g).collect();
            let broken_in =
                |range: std::ops::RangeInclusive<usize>| range.into_iter().any(|k| !elements.is_intact(&nodes, k));
            assert!(groups.iter().any(|&i| in_order(i) && broken_in(i - reach(i)..=i + 3 + reach(i))));
            assert!(groups.iter().any(|&i| in_order(i) && broken_in(i..=i + 3)));
            assert!(groups.iter().any(|&i| !in_order(i)));
            assert!((0..nodes.len()).any(|i| walked[i] != elements.strain[i]));
        }
    }

    #[test]
    fn a_window_ends_at_a_broken_element() {
        let diameter = 12e-6;
        let l0 = 0.25 * diameter;
        let (nodes, mut elements, sections) = fibre(41, l0, diameter, |k| if k < 20 { 0.05 } else { 0.01 });
        elements.failure[20] = FailureMode::Tension;
        let gauge = measured(&nodes, &elements, &sections, 1.0);
        // the two pieces do not read each other across the break
        for i in 15..20 {
            assert!((gauge[i] - 0.05).abs() <= 1e-15, "element {i}: {}", gauge[i]);
        }
        for i in 21..26 {
            assert!((gauge[i] - 0.01).abs() <= 1e-15, "element {i}: {}", gauge[i]);
        }
        // the broken element keeps its own strain
        assert_eq!(gauge[20], elements.strain[20]);
    }
}
