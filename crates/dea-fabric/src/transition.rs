//! How the fine fibres of a hybrid yarn share out among its coarse fibres where the yarn
//! changes kind (docs/theory.md F12).
//!
//! Each fine fibre's area is split among the coarse fibres by weights `w_fc` (each fine
//! fibre's weights sum to 1) so that every coarse fibre receives exactly its own area (the
//! weights of a coarse fibre sum to `n_fine / n_coarse`) and the area-weighted centre of
//! what it receives lies on its axis (no moment bends its end). Among the weights that do
//! this, these are the most spread that favour near pairs. The fine fibres' centre and the
//! coarse fibres' centre need not coincide (each kind is relaxed on its own); whatever
//! moment their difference makes is shared equally: each coarse fibre is centred on its
//! axis shifted by that difference, so a yarn ending at one coarse fibre keeps its own
//! small eccentricity and no more. Among these weights, these are the most spread that favour near pairs: the maximum-entropy weights
//! `w_fc ∝ exp(a_f + b_c + λ_c·d_fc − |d_fc|² / s²)`, `d_fc` the fine end's offset across
//! coarse fibre c's axis, `s` a length scale, found by alternating the row sums with a
//! Newton solve of each coarse fibre's centring (an iterative-scaling scheme).

use dea_core::tie::{Tie, TieEnd};
use dea_core::Vec3;

/// Sweeps of the alternating solve; each is cheap (fine x coarse terms).
const SWEEPS: usize = 200;

/// The weights `w[f][c]` for fine ends at offsets `offset(f, c)` across the axis of coarse
/// fibre `c`, coarse ends at offsets `coarse_offset(k, c)` across it, with length scale
/// `scale` [m]. With one coarse fibre every weight is 1 and
/// nothing can centre it. Where a coarse axis lies outside the fine ends' spread the
/// centring is approached as far as the sweeps allow; [`crate::panel::WovenPanel::transition_quality`]
/// reports what is left.
pub fn tie_weights(fine: usize, coarse: usize, offset: impl Fn(usize, usize) -> Vec3, coarse_offset: impl Fn(usize, usize) -> Vec3, scale: f64) -> Vec<Vec<f64>> {
    if coarse == 1 {
        return vec![vec![1.0]; fine];
    }
    let d: Vec<Vec<Vec3>> = (0..fine).map(|f| (0..coarse).map(|c| offset(f, c) / scale).collect()).collect();
    // each coarse fibre's target: its axis shifted by the fine centre's offset from the
    // coarse centre, both seen across that axis
    let target: Vec<Vec3> = (0..coarse)
        .map(|c| {
            let fine_centre: Vec3 = (0..fine).map(|f| d[f][c]).sum::<Vec3>() / fine as f64;
            let coarse_centre: Vec3 = (0..coarse).map(|k| coarse_offset(k, c) / scale).sum::<Vec3>() / coarse as f64;
            fine_centre - coarse_centre
        })
        .collect();
    let share = fine as f64 / coarse as f64;
    let (mut a, mut b, mut lambda) = (vec![0.0; fine], vec![0.0; coarse], vec![Vec3::zeros(); coarse]);
    let kernel = |f: usize, c: usize, lambda: &Vec3| lambda.dot(&d[f][c]) - d[f][c].norm_squared();
    for _ in 0..SWEEPS {
        for (f, a_f) in a.iter_mut().enumerate() {
            // log-sum-exp over the coarse fibres: row sums 1
            let terms: Vec<f64> = (0..coarse).map(|c| b[c] + kernel(f, c, &lambda[c])).collect();
            let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            *a_f = -(top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln());
        }
        for c in 0..coarse {
            // centring: a damped Newton step on sum_f u_f d_fc = 0 (b_c only scales u)
            for _ in 0..4 {
                let u: Vec<f64> = (0..fine).map(|f| (a[f] + kernel(f, c, &lambda[c])).exp()).collect();
                let total: f64 = u.iter().sum();
                let moment: Vec3 = (0..fine).map(|f| (d[f][c] - target[c]) * (u[f] / total)).sum();
                let mut jacobian = nalgebra::Matrix3::<f64>::identity() * 1e-9;
                for f in 0..fine {
                    let centred = d[f][c] - target[c] - moment;
                    jacobian += centred * centred.transpose() * (u[f] / total);
                }
                let Some(inverse) = jacobian.try_inverse() else {
                    break;
                };
                let mut step = inverse * moment;
                // no more than one length scale at a time: an axis outside the spread would
                // otherwise send the multiplier off in one leap
                if step.norm() > 1.0 {
                    step /= step.norm();
                }
                lambda[c] -= step;
            }
            let total: f64 = (0..fine).map(|f| (a[f] + kernel(f, c, &lambda[c])).exp()).sum();
            b[c] = share.ln() - total.ln();
        }
    }
    (0..fine).map(|f| (0..coarse).map(|c| (a[f] + b[c] + kernel(f, c, &lambda[c])).exp()).collect()).collect()
}

/// Shares below this are left out, and the rest of the fine fibre's rescaled to its whole.
const SMALLEST_SHARE: f64 = 1e-6;

/// A fibre's node at a transition: its name and position [m].
#[derive(Clone, Copy, Debug)]
pub struct EndNode {
    /// the node, named
    pub end: TieEnd,
    /// its position [m]
    pub at: Vec3,
}

/// The ties of one transition. `fine` holds every fine fibre's end node and the length of
/// fine fibre its ties stand for [m]; `coarse` every coarse fibre's end node and the node
/// inside it. Each fine fibre's area `fine_area` [m^2] is shared out by [`tie_weights`]
/// with length scale `scale` [m]; a tie takes its share of the area and of the mass, and its
/// place in the coarse end element's frame as built.
pub fn transition_ties(fine: &[(EndNode, f64)], coarse: &[(EndNode, EndNode)], fine_area: f64, scale: f64) -> Vec<Tie> {
    let across = |x: &Vec3, c: usize| Tie::offset_across(x, &coarse[c].0.at, &coarse[c].1.at);
    let weights = tie_weights(fine.len(), coarse.len(), |f, c| across(&fine[f].0.at, c), |k, c| across(&coarse[k].0.at, c), scale);
    let mut ties = Vec::new();
    for ((node, fibre_length), row) in fine.iter().zip(&weights) {
        let kept: f64 = row.iter().filter(|&&w| w >= SMALLEST_SHARE).sum();
        for ((end, next), &w) in coarse.iter().zip(row).filter(|(_, &w)| w >= SMALLEST_SHARE) {
            let (axial_length, radial_offset) = Tie::rest_geometry(&node.at, &end.at, &next.at);
            ties.push(Tie { fine: node.end, coarse: end.end, coarse_next: next.end, axial_length, radial_offset, area: w / kept * fine_area, fibre_length: *fibre_length });
        }
    }
    ties
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fine ends on a hexagonal patch of 19, coarse axes at `coarse` (all along z).
    fn weights(coarse: &[[f64; 2]]) -> (Vec<Vec<f64>>, Vec<[f64; 2]>) {
        let fine = crate::hexagonal_packing(19, 1.0);
        let offset = |f: usize, c: usize| Vec3::new(fine[f][0] - coarse[c][0], fine[f][1] - coarse[c][1], 0.0);
        let coarse_offset = |k: usize, c: usize| Vec3::new(coarse[k][0] - coarse[c][0], coarse[k][1] - coarse[c][1], 0.0);
        (tie_weights(19, coarse.len(), offset, coarse_offset, 2.0), fine)
    }

    #[test]
    fn every_coarse_fibre_gets_its_share_centred_on_its_axis() {
        // four coarse axes inside the patch, off its symmetry but centred as it is
        let coarse = [[-0.9, -0.4], [0.8, -0.6], [0.7, 0.9], [-0.6, 0.1]];
        let (w, fine) = weights(&coarse);
        for row in &w {
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{row:?}");
            assert!(row.iter().all(|&x| x >= 0.0));
        }
        for (c, axis) in coarse.iter().enumerate() {
            let received: f64 = w.iter().map(|row| row[c]).sum();
            assert!((received - 19.0 / 4.0).abs() < 1e-9, "coarse {c}: {received}");
            let centre = [0, 1].map(|k| (0..19).map(|f| w[f][c] * fine[f][k]).sum::<f64>() / received);
            assert!((centre[0] - axis[0]).hypot(centre[1] - axis[1]) < 1e-6, "coarse {c}: centre {centre:?}");
        }
        // the nearest ends weigh most
        assert!(w[0][0] > 0.0 && (0..4).all(|c| w[fine.len() - 1][c] >= 0.0));
    }

    #[test]
    fn a_coarse_centre_off_the_fine_one_shifts_every_target_alike() {
        let coarse = [[-0.9, -0.4], [0.8, -0.6], [0.7, 0.9], [-0.6, 0.8]];
        let shift = [0.0, -0.175];
        let (w, fine) = weights(&coarse);
        for (c, axis) in coarse.iter().enumerate() {
            let received: f64 = w.iter().map(|row| row[c]).sum();
            assert!((received - 19.0 / 4.0).abs() < 1e-9, "coarse {c}: {received}");
            let centre = [0, 1].map(|k| (0..19).map(|f| w[f][c] * fine[f][k]).sum::<f64>() / received);
            assert!((centre[0] - axis[0] - shift[0]).hypot(centre[1] - axis[1] - shift[1]) < 1e-6, "coarse {c}: centre {centre:?}");
        }
    }

    #[test]
    fn one_coarse_fibre_takes_everything() {
        let (w, _) = weights(&[[0.3, 0.0]]);
        assert!(w.iter().all(|row| row == &vec![1.0]));
    }
}
