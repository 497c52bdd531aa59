//! Bending rigidity by torsional springs at interior nodes, seed eqs (5-1)…(5-5).

use crate::ids::NONE;
use crate::nodes::{Elements, Nodes};
use crate::{FibreSection, Vec3};

/// Per-node bending scratch: the spring at node i pushes on its previous node, itself and its
/// next node; the moment vector feeds the element shear (5-4).
#[derive(Clone, Debug, Default)]
pub struct BendingScratch {
    /// force of the spring at node i on node `prev[i]` [N]
    pub on_prev: Vec<Vec3>,
    /// force of the spring at node i on node `next[i]` [N]
    pub on_next: Vec<Vec3>,
    /// bending moment vector M_i = K_t theta_i n_i (5-1) [N m]
    pub moment: Vec<Vec3>,
    /// turning angle theta_i between the two elements at node i [rad]
    pub angle: Vec<f64>,
    /// not scratch: how the springs bent at rest store energy below their rest angle, set
    /// once from the case
    pub rest_law: RestAngleLaw,
}

/// The energy of a spring bent at rest (`theta_0 > 0`, a woven fabric's relaxed crimp) below
/// its rest angle (docs/theory.md F4b). Above it both are the seed's (5-1) with a rest angle,
/// `U = K_t (theta - theta_0)^2 / 2`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RestAngleLaw {
    /// `K_t (theta - theta_0)^2 / 2` down to the straight fibre: over the plane of a node's
    /// turns a cone whose tip, the straight fibre, is a maximum without a gradient. A node
    /// pulled near straight meets a force of nearly constant size `K_t theta_0` per element
    /// length whose direction turns about as the node passes, a stiffness that grows without
    /// bound there, and the central difference makes energy crossing it
    #[default]
    Cone,
    /// `K_t (theta^2 - theta_0^2)^2 / (8 theta_0^2)` below `theta_0`: a quartic in the turn
    /// vector, smooth through straight, that meets the cone's branch above `theta_0` with the
    /// same energy (zero), moment (zero) and stiffness (`K_t`); straightening a spring stores
    /// `K_t theta_0^2 / 8` instead of the cone's `K_t theta_0^2 / 2`
    Smooth,
}

impl RestAngleLaw {
    /// The name a case gives it (`target.weave.rest_angle_law`).
    pub fn name(self) -> &'static str {
        match self {
            RestAngleLaw::Cone => "cone",
            RestAngleLaw::Smooth => "smooth",
        }
    }

    /// The energy of a spring of rigidity `k_t` [N m / rad] turned by `theta` [rad] that
    /// rests at `rest` [rad] [J].
    #[inline]
    pub fn energy(self, k_t: f64, theta: f64, rest: f64) -> f64 {
        if self == RestAngleLaw::Smooth && theta < rest {
            let squares = theta * theta - rest * rest;
            return k_t * squares * squares / (8.0 * rest * rest);
        }
        let bent = theta - rest;
        0.5 * k_t * bent * bent
    }
}

impl BendingScratch {
    /// Sizes every array to `n` nodes (new entries zero).
    pub fn resize(&mut self, n: usize) {
        self.on_prev.resize(n, Vec3::zeros());
        self.on_next.resize(n, Vec3::zeros());
        self.moment.resize(n, Vec3::zeros());
        self.angle.resize(n, 0.0);
    }
}

/// fdlibm's `atan` polynomial for |x| < 0.4375, error below one ulp (musl `src/math/atan.c`,
/// as in the `libm` crate, which does not expose it).
const ATAN_COEFFICIENTS: [f64; 11] = [
    3.33333333333329318027e-01,
    -1.99999999998764832476e-01,
    1.42857142725034663711e-01,
    -1.11111104054623557880e-01,
    9.09088713343650656196e-02,
    -7.69187620504482999495e-02,
    6.66107313738753120669e-02,
    -5.83357013379057348645e-02,
    4.97687799461593236017e-02,
    -3.65315727442169155270e-02,
    1.62858201153657823623e-02,
];

/// Below this tangent the turning angle comes from the polynomial.
const ATAN_POLYNOMIAL_RANGE: f64 = 0.4375;

/// Below this sine a turn is straight to rounding: `sine^2 / 6` is below half an ulp of 1.
const STRAIGHT: f64 = 1e-8;

/// `atan(x) / x` for |x| < 0.4375.
#[inline]
fn atan_over_argument(x: f64) -> f64 {
    let a = &ATAN_COEFFICIENTS;
    let z = x * x;
    let w = z * z;
    let odd = z * (a[0] + w * (a[2] + w * (a[4] + w * (a[6] + w * (a[8] + w * a[10])))));
    let even = w * (a[1] + w * (a[3] + w * (a[5] + w * (a[7] + w * a[9]))));
    1.0 - (odd + even)
}

/// The angle `theta = atan2(sine, cosine)` in [0, pi] between two unit vectors, from
/// `sine = |a x b|` and `cosine = a . b`, and `theta / sine` (finite at theta -> 0).
///
/// Below 23.6 degrees, where a fibre's nodes almost always are, `tan theta = sine / cosine`
/// is within the polynomial's range and one division gives both: `theta / sine =
/// atan(t) / t / cosine`. The divider is this kernel's bottleneck, and a call to the system
/// `atan2` cost half of it. Sharper turns take `atan2`.
#[inline]
pub fn turning_angle(sine: f64, cosine: f64) -> (f64, f64) {
    if cosine > 0.0 && sine < STRAIGHT {
        // theta = sine (1 + sine^2 / 6 + ...) and theta / sine round to sine and 1 here
        (sine, 1.0)
    } else if cosine > 0.0 && sine < ATAN_POLYNOMIAL_RANGE * cosine {
        let inverse_cosine = 1.0 / cosine;
        let over_sine = atan_over_argument(sine * inverse_cosine) * inverse_cosine;
        (sine * over_sine, over_sine)
    } else {
        let theta = sine.atan2(cosine);
        // near pi (a fibre folded back) the direction is undefined and `cross` vanishes
        (theta, if sine > 0.0 { theta / sine } else { 1.0 })
    }
}

/// Forces of one torsional spring with rigidity `k_t` at a node joining the elements
/// `a = x_i - x_prev` and `b = x_next - x_i`, given as unit vectors and inverse lengths, from
/// the exact gradient of `U = K_t (theta - theta_0)^2 / 2` (seed 5-1; `rest` = theta_0, 0 for
/// a straight fibre), below `theta_0` as `law` says. Returns (force on prev, force on next,
/// theta, moment vector `dU/dtheta n`). The moment is `(a^ x b^) (dU/dtheta) / sin(theta)`,
/// so the plane's normal needs no normalisation. Under [`RestAngleLaw::Cone`] a spring bent
/// at rest has no defined direction when pulled exactly straight: it pushes nowhere there.
#[inline]
pub fn torsional_spring(
    ua: Vec3,
    inverse_la: f64,
    ub: Vec3,
    inverse_lb: f64,
    k_t: f64,
    rest: f64,
    law: RestAngleLaw,
) -> (Vec3, Vec3, f64, Vec3) {
    let cross = ua.cross(&ub);
    let sine = cross.norm();
    let cosine = ua.dot(&ub);
    let (theta, theta_over_sine) = turning_angle(sine, cosine);
    let factor = if rest == 0.0 {
        k_t * theta_over_sine
    } else if law == RestAngleLaw::Smooth && theta < rest {
        // dU/dtheta = K_t theta (theta^2 - theta_0^2) / (2 theta_0^2): over the sine it is
        // finite at straight, where the force vanishes
        k_t * theta_over_sine * (theta * theta - rest * rest) / (2.0 * rest * rest)
    } else if sine > 1e-12 {
        k_t * (theta - rest) / sine
    } else {
        0.0
    };
    let on_prev = (ua * cosine - ub) * (factor * inverse_la);
    let on_next = (ua - ub * cosine) * (factor * inverse_lb);
    (on_prev, on_next, theta, cross * factor)
}

/// Evaluates the torsional spring at every local node whose two elements are intact.
/// Reads the element directions of [`crate::rod::compute_element_tension`] (run it first).
pub fn compute_bending(nodes: &Nodes, elements: &Elements, sections: &[FibreSection], scratch: &mut BendingScratch) {
    compute_bending_over(nodes, elements, sections, scratch, 0..nodes.len());
}

/// [`compute_bending`] at the nodes in `range` (the nodes of the sections whose terms fire
/// at a multi-rate instant, [`crate::multi_rate`]).
pub fn compute_bending_over(
    nodes: &Nodes,
    elements: &Elements,
    sections: &[FibreSection],
    scratch: &mut BendingScratch,
    range: std::ops::Range<usize>,
) {
    if crate::in_avx2_lanes!(bending_in_lanes(nodes, elements, sections, scratch, range.clone())).is_some() {
        return;
    }
    for i in range {
        node_bending(nodes, elements, sections, scratch, i);
    }
}

/// [`compute_bending`] at node `i`.
#[inline]
fn node_bending(nodes: &Nodes, elements: &Elements, sections: &[FibreSection], scratch: &mut BendingScratch, i: usize) {
    let (p, n) = (nodes.prev[i], nodes.next[i]);
    let k_t = sections[nodes.section[i] as usize].torsional_stiffness;
    if p == NONE || n == NONE || k_t == 0.0 || !elements.is_intact(nodes, p as usize) || !elements.is_intact(nodes, i) {
        scratch.on_prev[i].fill(0.0);
        scratch.on_next[i].fill(0.0);
        scratch.moment[i].fill(0.0);
        // a spring that does not act holds no energy
        scratch.angle[i] = nodes.rest_angle[i];
        return;
    }
    let p = p as usize;
    let (on_prev, on_next, theta, moment) = torsional_spring(
        elements.direction[p],
        elements.inverse_length[p],
        elements.direction[i],
        elements.inverse_length[i],
        k_t,
        nodes.rest_angle[i],
        scratch.rest_law,
    );
    scratch.on_prev[i] = on_prev;
    scratch.on_next[i] = on_next;
    scratch.moment[i] = moment;
    scratch.angle[i] = theta;
}

/// [`compute_bending`] four nodes at a time where it can ([`springs_in_lanes`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn bending_in_lanes(
    nodes: &Nodes,
    elements: &Elements,
    sections: &[FibreSection],
    scratch: &mut BendingScratch,
    range: std::ops::Range<usize>,
) {
    let end = range.end;
    let mut i = range.start;
    while i + 4 <= end {
        if !springs_in_lanes(nodes, elements, sections, scratch, i) {
            for k in i..i + 4 {
                node_bending(nodes, elements, sections, scratch, k);
            }
        }
        i += 4;
    }
    for k in i..end {
        node_bending(nodes, elements, sections, scratch, k);
    }
}

/// The springs at nodes `i..i + 4` in four lanes, the operations of [`torsional_spring`]
/// lane by lane with the scalar code's bits, when four acting springs follow each other
/// along a fibre in memory (almost everywhere); false, and nothing written, otherwise. A
/// group with a spring bent beyond the polynomial's range takes its four angles from the
/// scalar [`turning_angle`] and the rest in the lanes: a coarse yarn's crimp kinks it by
/// 27 degrees at every crossing, so more than half the groups of a hybrid panel hold one.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn springs_in_lanes(
    nodes: &Nodes,
    elements: &Elements,
    sections: &[FibreSection],
    scratch: &mut BendingScratch,
    i: usize,
) -> bool {
    use crate::lanes::{F4, V4};
    use crate::nodes::FailureMode;
    let stiffness = |k: usize| sections[nodes.section[k] as usize].torsional_stiffness;
    let acting = |k: usize| {
        nodes.prev[k] == k as u32 - 1
            && nodes.next[k] == k as u32 + 1
            && elements.failure[k - 1] == FailureMode::Intact
            && elements.failure[k] == FailureMode::Intact
            && stiffness(k) != 0.0
    };
    // a group reads the element before its first node
    if i == 0 || !(i..i + 4).all(acting) {
        return false;
    }
    let zero = F4::splat(0.0);
    let (ua, ub) = (V4::load(&elements.direction, i - 1), V4::load(&elements.direction, i));
    let cross = ua.cross(ub);
    let sine = cross.dot(cross).sqrt();
    let cosine = ua.dot(ub);
    // turning_angle's two first paths
    let turning = zero.lt(cosine);
    let straight = turning.and(sine.lt(F4::splat(STRAIGHT)));
    let (theta, over_sine) = if straight.or(turning.and(sine.lt(F4::splat(ATAN_POLYNOMIAL_RANGE).mul(cosine)))).all() {
        let inverse_cosine = F4::splat(1.0).div(cosine);
        let over_sine = F4::select(
            straight,
            F4::splat(1.0),
            atan_over_argument_in_lanes(sine.mul(inverse_cosine)).mul(inverse_cosine),
        );
        (F4::select(straight, sine, sine.mul(over_sine)), over_sine)
    } else {
        // a sharp turn: atan2 one lane at a time, as the scalar code takes it
        let (sines, cosines) = (sine.to_array(), cosine.to_array());
        let turns: [(f64, f64); 4] = std::array::from_fn(|k| turning_angle(sines[k], cosines[k]));
        (F4::gather(0, |k| turns[k].0), F4::gather(0, |k| turns[k].1))
    };
    // torsional_spring's factor
    let k_t = F4::gather(i, stiffness);
    let rest = F4::load(&nodes.rest_angle, i);
    let straight_at_rest = rest.eq(zero);
    let factor = if straight_at_rest.all() {
        k_t.mul(over_sine)
    } else {
        let mut bent_at_rest = F4::select(F4::splat(1e-12).lt(sine), k_t.mul(theta.sub(rest)).div(sine), zero);
        if scratch.rest_law == RestAngleLaw::Smooth {
            // torsional_spring's smooth branch, operation for operation (a lane resting
            // straight divides by zero here, and is not selected)
            let below =
                k_t.mul(over_sine).mul(theta.mul(theta).sub(rest.mul(rest))).div(F4::splat(2.0).mul(rest.mul(rest)));
            bent_at_rest = F4::select(theta.lt(rest), below, bent_at_rest);
        }
        F4::select(straight_at_rest, k_t.mul(over_sine), bent_at_rest)
    };
    let (inverse_la, inverse_lb) = (F4::load(&elements.inverse_length, i - 1), F4::load(&elements.inverse_length, i));
    ua.scale(cosine).sub(ub).scale(factor.mul(inverse_la)).store(&mut scratch.on_prev, i);
    ua.sub(ub.scale(cosine)).scale(factor.mul(inverse_lb)).store(&mut scratch.on_next, i);
    cross.scale(factor).store(&mut scratch.moment, i);
    theta.store(&mut scratch.angle, i);
    true
}

/// [`atan_over_argument`] in four lanes, operation for operation.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn atan_over_argument_in_lanes(x: crate::lanes::F4) -> crate::lanes::F4 {
    use crate::lanes::F4;
    let a = ATAN_COEFFICIENTS.map(|c| F4::splat(c));
    let z = x.mul(x);
    let w = z.mul(z);
    let odd = z.mul(a[0].add(w.mul(a[2].add(w.mul(a[4].add(w.mul(a[6].add(w.mul(a[8].add(w.mul(a[10])))))))))));
    let even = w.mul(a[1].add(w.mul(a[3].add(w.mul(a[5].add(w.mul(a[7].add(w.mul(a[9])))))))));
    F4::splat(1.0).sub(odd.add(even))
}

/// Shear force in element `i -> next[i]`, seed (5-4): `Q = |M_i - M_j| / l0` [N], from the
/// springs' moments ([`BendingScratch::moment`]) or the failure stage's gauge moments.
#[inline]
pub fn element_shear_force(nodes: &Nodes, elements: &Elements, moment: &[Vec3], i: usize) -> f64 {
    let j = nodes.next[i] as usize;
    (moment[i] - moment[j]).norm() / elements.rest_length[i]
}

/// Maximum shear stress of a circular section, seed (5-5): `tau = 4 Q / (3 A)` [Pa].
#[inline]
pub fn max_shear_stress(shear_force: f64, area: f64) -> f64 {
    4.0 * shear_force / (3.0 * area)
}

/// Energy `K_t (theta - theta_0)^2 / 2` of the spring at node `i` as computed this step
/// (seed 5-1), below `theta_0` as [`BendingScratch::rest_law`] says [J].
#[inline]
pub fn spring_energy(nodes: &Nodes, scratch: &BendingScratch, sections: &[FibreSection], i: usize) -> f64 {
    let k_t = sections[nodes.section[i] as usize].torsional_stiffness;
    scratch.rest_law.energy(k_t, scratch.angle[i], nodes.rest_angle[i])
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn spring(a: Vec3, b: Vec3, k_t: f64) -> (Vec3, Vec3, f64, Vec3) {
        torsional_spring(a.normalize(), 1.0 / a.norm(), b.normalize(), 1.0 / b.norm(), k_t, 0.0, RestAngleLaw::Cone)
    }

    /// The closed forms of docs/theory.md F4b, written out apart from [`RestAngleLaw::energy`].
    fn energy(xp: Vec3, xi: Vec3, xn: Vec3, k_t: f64, rest: f64, law: RestAngleLaw) -> f64 {
        let (a, b) = (xi - xp, xn - xi);
        let theta = a.cross(&b).norm().atan2(a.dot(&b));
        match law {
            RestAngleLaw::Smooth if theta < rest => k_t * (theta.powi(2) - rest.powi(2)).powi(2) / (8.0 * rest.powi(2)),
            _ => 0.5 * k_t * (theta - rest) * (theta - rest),
        }
    }

    #[test]
    fn turning_angle_and_its_ratio_to_the_sine_match_atan2_on_both_paths() {
        let a = Vec3::x();
        let angles =
            (0..=3000).map(|k| std::f64::consts::PI * k as f64 / 3000.0).chain((1..60).map(|k| 0.3f64.powi(k)));
        let mut polynomial = 0;
        for angle in angles {
            let b = Vec3::new(angle.cos(), 0.6 * angle.sin(), 0.8 * angle.sin());
            let (sine, cosine) = (a.cross(&b).norm(), a.dot(&b));
            let expected = sine.atan2(cosine);
            let (theta, over_sine) = turning_angle(sine, cosine);
            polynomial += usize::from(cosine > 0.0 && sine < ATAN_POLYNOMIAL_RANGE * cosine);
            assert!((theta - expected).abs() <= 4.0 * f64::EPSILON * expected, "{angle}: {theta} vs {expected}");
            let expected_ratio = if sine > 0.0 { expected / sine } else { 1.0 };
            assert!(
                (over_sine - expected_ratio).abs() <= 4.0 * f64::EPSILON * expected_ratio,
                "{angle}: {over_sine} vs {expected_ratio}"
            );
        }
        // both paths were taken
        assert!(polynomial > 400 && polynomial < 3000, "{polynomial}");
    }

    #[test]
    fn spring_forces_are_the_exact_gradient_of_the_bending_energy() {
        // bent by 24.7 degrees (the atan2 path) and by 5.7 degrees (the polynomial)
        for (xp, xi, xn) in [
            (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.1, -0.05), Vec3::new(1.9, 0.5, 0.2)),
            (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 0.06, 0.08)),
        ] {
            spring_forces_are_the_gradient_at(xp, xi, xn);
        }
    }

    fn spring_forces_are_the_gradient_at(xp: Vec3, xi: Vec3, xn: Vec3) {
        let k_t = 2.5;
        // the test's angles lie below 0.9 and one of them below 0.2: both branches of each law
        for (rest, law) in
            [0.0, 0.2, 0.9].into_iter().flat_map(|r| [(r, RestAngleLaw::Cone), (r, RestAngleLaw::Smooth)])
        {
            let (a, b) = (xi - xp, xn - xi);
            let (on_prev, on_next, _, _) =
                torsional_spring(a.normalize(), 1.0 / a.norm(), b.normalize(), 1.0 / b.norm(), k_t, rest, law);
            let on_self = -(on_prev + on_next);
            let h = 1e-6;
            for (node, analytic) in [(0, on_prev), (1, on_self), (2, on_next)] {
                for axis in 0..3 {
                    let mut plus = [xp, xi, xn];
                    let mut minus = [xp, xi, xn];
                    plus[node][axis] += h;
                    minus[node][axis] -= h;
                    let numeric = -(energy(plus[0], plus[1], plus[2], k_t, rest, law)
                        - energy(minus[0], minus[1], minus[2], k_t, rest, law))
                        / (2.0 * h);
                    assert!(
                        (numeric - analytic[axis]).abs() < 1e-6,
                        "rest {rest}, {law:?}, node {node} axis {axis}: {numeric} vs {}",
                        analytic[axis]
                    );
                }
            }
        }
    }

    #[test]
    fn a_spring_at_its_rest_angle_pushes_nowhere_and_resists_both_ways() {
        let bend = |angle: f64| Vec3::new(angle.cos(), angle.sin(), 0.0);
        let rest = 0.3;
        for law in [RestAngleLaw::Cone, RestAngleLaw::Smooth] {
            let (on_prev, on_next, theta, moment) = torsional_spring(Vec3::x(), 1.0, bend(rest), 1.0, 2.0, rest, law);
            assert!((theta - rest).abs() < 1e-15);
            assert!(on_prev.norm() + on_next.norm() + moment.norm() < 1e-15);
            // straightened a little or bent further: the moment turns it back towards its rest
            let (_, _, _, less) = torsional_spring(Vec3::x(), 1.0, bend(0.8 * rest), 1.0, 2.0, rest, law);
            let (_, _, _, more) = torsional_spring(Vec3::x(), 1.0, bend(1.2 * rest), 1.0, 2.0, rest, law);
            assert!(less.z < 0.0 && more.z > 0.0, "{law:?}");
            // pulled exactly straight, its direction is undefined: no force
            let (on_prev, on_next, _, _) = torsional_spring(Vec3::x(), 1.0, Vec3::x(), 1.0, 2.0, rest, law);
            assert_eq!(on_prev.norm() + on_next.norm(), 0.0);
        }
        // the cone's moment is odd about the rest angle
        let (_, _, _, less) = torsional_spring(Vec3::x(), 1.0, bend(0.8 * rest), 1.0, 2.0, rest, RestAngleLaw::Cone);
        let (_, _, _, more) = torsional_spring(Vec3::x(), 1.0, bend(1.2 * rest), 1.0, 2.0, rest, RestAngleLaw::Cone);
        assert!((less.z + more.z).abs() < 1e-12);
    }

    #[test]
    fn the_smooth_law_meets_the_cone_at_the_rest_angle_and_lets_go_at_straight() {
        // closed forms (F4b): below theta_0, U = K (theta^2 - theta_0^2)^2 / (8 theta_0^2),
        // dU/dtheta = K theta (theta^2 - theta_0^2) / (2 theta_0^2), d2U/dtheta2 =
        // K (3 theta^2 - theta_0^2) / (2 theta_0^2)
        let bend = |angle: f64| Vec3::new(angle.cos(), angle.sin(), 0.0);
        let (k_t, rest) = (2.0, 0.3);
        let moment = |theta: f64, law| torsional_spring(Vec3::x(), 1.0, bend(theta), 1.0, k_t, rest, law).3.z;
        for theta in [0.05, 0.1, 0.2, 0.29] {
            let expected = k_t * theta * (theta * theta - rest * rest) / (2.0 * rest * rest);
            assert!((moment(theta, RestAngleLaw::Smooth) - expected).abs() < 1e-12 * k_t, "{theta}");
            // above straight the smooth law's moment is the smaller: it stores less
            assert!(moment(theta, RestAngleLaw::Smooth).abs() < moment(theta, RestAngleLaw::Cone).abs());
        }
        // at the rest angle: the same energy (zero), moment (zero) and stiffness K on both sides
        let h = 1e-6;
        for law in [RestAngleLaw::Cone, RestAngleLaw::Smooth] {
            assert_eq!(law.energy(k_t, rest, rest), 0.0);
            let below = (moment(rest, law) - moment(rest - h, law)) / h;
            let above = (moment(rest + h, law) - moment(rest, law)) / h;
            assert!((below - k_t).abs() < 1e-5 && (above - k_t).abs() < 1e-5, "{law:?}: {below}, {above}");
        }
        // straight: the cone stores K theta_0^2 / 2 behind a moment of K theta_0 that does not
        // fall as the turn vanishes; the smooth law K theta_0^2 / 8, its moment falling with theta
        assert!((RestAngleLaw::Cone.energy(k_t, 0.0, rest) - 0.5 * k_t * rest * rest).abs() < 1e-15);
        assert!((RestAngleLaw::Smooth.energy(k_t, 0.0, rest) - 0.125 * k_t * rest * rest).abs() < 1e-15);
        let tiny = 1e-7;
        assert!((moment(tiny, RestAngleLaw::Cone) + k_t * rest).abs() < 1e-6);
        assert!(moment(tiny, RestAngleLaw::Smooth).abs() < k_t * tiny);
        // a rest angle of zero is the straight spring under either law
        let straight = |law| torsional_spring(Vec3::x(), 1.0, bend(0.2), 1.0, k_t, 0.0, law);
        assert_eq!(straight(RestAngleLaw::Cone), straight(RestAngleLaw::Smooth));
    }

    #[test]
    fn straight_chain_carries_no_bending_force_and_moment_matches_5_1() {
        let (on_prev, on_next, theta, _) = spring(Vec3::x(), Vec3::x() * 2.0, 3.0);
        assert_eq!(theta, 0.0);
        assert_eq!(on_prev.norm() + on_next.norm(), 0.0);
        // 90 degree bend: M = K_t theta (5-1)
        let (_, _, theta, moment) = spring(Vec3::x(), Vec3::y(), 3.0);
        assert!((theta - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((moment - Vec3::z() * 3.0 * theta).norm() < 1e-14);
    }

    /// Fibres that take every path of the rod kernels: bent gently and sharply, exactly
    /// straight, bent at rest, stretched and compressed, broken elements, a section without
    /// bending rigidity, and a ghost-like stretch stored out of chain order.
    pub(crate) fn fibres_on_every_path() -> (Nodes, Elements, Vec<FibreSection>) {
        use crate::ids::{FibreId, GlobalNodeId};
        use crate::material::{FibreMaterial, InertiaModel};
        use crate::nodes::FailureMode;
        let material = FibreMaterial::kevlar_km2();
        let l0 = 25e-6;
        let sections = vec![
            FibreSection::new(&material, 2.4e-9, l0, InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3)),
            FibreSection::new(&material, 1.2e-9, l0, InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3)),
            FibreSection::new(&material, 2.4e-9, l0, InertiaModel::None {}.with_friction(0.3)),
        ];
        let mut state = 99u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut nodes, mut elements) = (Nodes::default(), Elements::default());
        let per_fibre = 41;
        for fibre in 0..6u32 {
            for along in 0..per_fibre {
                // fibre 1 exactly straight, fibre 3 kinked sharply every seventh node
                let jitter = match fibre {
                    1 => 0.0,
                    3 if along % 7 == 3 => 0.6,
                    _ => 0.05,
                } * l0;
                let x = Vec3::new(
                    along as f64 * l0 * (1.0 + 0.02 * next()),
                    fibre as f64 * 1e-4 + jitter * next(),
                    jitter * next(),
                );
                let gid = GlobalNodeId((fibre * per_fibre + along) as u64);
                nodes.push(
                    gid,
                    x,
                    Vec3::zeros(),
                    1e-12,
                    FibreId(fibre),
                    along,
                    (fibre % 3) as u16,
                    along == 0,
                    along + 1 == per_fibre,
                );
                // fibre 4 bent at rest
                *nodes.rest_angle.last_mut().unwrap() = if fibre == 4 { 0.05 + 0.05 * next() } else { 0.0 };
                let failure = if along % 11 == 5 { FailureMode::Tension } else { FailureMode::Intact };
                elements.push(l0, 3.9e9, failure);
            }
        }
        // the last fibre's nodes stored backwards, as ghosts may be
        let n = nodes.len();
        nodes.n_owned = n - per_fibre as usize;
        let reversed: Vec<usize> = (0..nodes.n_owned).chain((nodes.n_owned..n).rev()).collect();
        macro_rules! permute {
            ($($field:expr),*) => { $( $field = reversed.iter().map(|&k| $field[k].clone()).collect(); )* };
        }
        permute!(
            nodes.gid,
            nodes.position,
            nodes.velocity,
            nodes.force,
            nodes.mass,
            nodes.fibre,
            nodes.along,
            nodes.section,
            nodes.clamped,
            nodes.last,
            nodes.rest_angle
        );
        permute!(
            elements.rest_length,
            elements.tensile_strength,
            elements.failure,
            elements.strain,
            elements.axial_force,
            elements.direction,
            elements.inverse_length
        );
        nodes.link_chains();
        (nodes, elements, sections)
    }

    /// Every value of `got` has the bits of its value in `expected` (`Debug` prints the
    /// shortest decimal that reads back to the same bits, the sign of a zero included).
    pub(crate) fn assert_same_bits<T: std::fmt::Debug>(name: &str, got: &[T], expected: &[T]) {
        let bits = |v: &T| format!("{v:?}");
        if let Some(k) = (0..expected.len()).find(|&k| bits(&got[k]) != bits(&expected[k])) {
            panic!("{name} of node {k}: {:?} against the scalar {:?}", got[k], expected[k]);
        }
    }

    #[test]
    fn the_lanes_give_the_bits_of_the_scalar_kernels_on_every_path() {
        let (nodes, mut elements, sections) = fibres_on_every_path();
        let material = crate::material::FibreMaterial::kevlar_km2();
        let mut scalar = elements.clone();
        crate::rod::compute_element_tension(&nodes, &mut elements, &sections, &material);
        for i in 0..nodes.len() {
            crate::rod::element_tension(&nodes, &mut scalar, &sections, &material, i);
        }
        assert_same_bits("direction", &elements.direction, &scalar.direction);
        assert_same_bits("inverse length", &elements.inverse_length, &scalar.inverse_length);
        assert_same_bits("strain", &elements.strain, &scalar.strain);
        assert_same_bits("axial force", &elements.axial_force, &scalar.axial_force);
        // compressed and stretched elements both present
        assert!(elements.strain.iter().any(|&e| e < 0.0) && elements.strain.iter().any(|&e| e > 0.0));

        let (mut lanes, mut reference) = (BendingScratch::default(), BendingScratch::default());
        lanes.resize(nodes.len());
        reference.resize(nodes.len());
        for law in [RestAngleLaw::Smooth, RestAngleLaw::Cone] {
            (lanes.rest_law, reference.rest_law) = (law, law);
            compute_bending(&nodes, &elements, &sections, &mut lanes);
            for i in 0..nodes.len() {
                node_bending(&nodes, &elements, &sections, &mut reference, i);
            }
            assert_same_bits("force on the previous node", &lanes.on_prev, &reference.on_prev);
            assert_same_bits("force on the next node", &lanes.on_next, &reference.on_next);
            assert_same_bits("moment", &lanes.moment, &reference.moment);
            assert_same_bits("angle", &lanes.angle, &reference.angle);
        }
        // springs bent at rest both below and above their rest angles, on both laws' branches
        let bent_at_rest = |below: bool| {
            (0..nodes.len()).any(|k| {
                nodes.rest_angle[k] > 0.0
                    && reference.moment[k].norm() > 0.0
                    && (reference.angle[k] < nodes.rest_angle[k]) == below
            })
        };
        assert!(bent_at_rest(true) && bent_at_rest(false));
        // the paths were taken: exactly straight, the polynomial, atan2, bent at rest
        assert!(reference.angle.iter().any(|&t| t == 0.0));
        assert!(reference.angle.iter().any(|&t| t > 1e-3 && t < 0.4));
        assert!(reference.angle.iter().any(|&t| t > 0.5));
        // and a sharp turn inside a group of four acting springs, which the lanes take
        let acting = |k: usize| {
            k > 0
                && nodes.prev[k] == k as u32 - 1
                && nodes.next[k] == k as u32 + 1
                && elements.is_intact(&nodes, k - 1)
                && elements.is_intact(&nodes, k)
                && sections[nodes.section[k] as usize].torsional_stiffness != 0.0
        };
        assert!((0..nodes.len() / 4)
            .any(|g| (4 * g..4 * g + 4).all(acting) && (4 * g..4 * g + 4).any(|k| reference.angle[k] > 0.5)));
        assert!(reference.moment.iter().zip(&nodes.rest_angle).any(|(m, &rest)| rest > 0.0 && m.norm() > 0.0));
    }

    #[test]
    fn shear_stress_of_circular_section_is_four_thirds_mean() {
        assert!((max_shear_stress(3.0, 2.0) - 2.0).abs() < 1e-15);
    }
}
