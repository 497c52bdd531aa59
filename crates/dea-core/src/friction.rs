//! Stick–slip friction with a per-pair anchor, seed eqs (4-11)…(4-15).
//!
//! At first contact the pair's relative position `v0` is stored. Later the relative
//! displacement `u = v' - v0` (4-13) loses its component along `v'` (4-14, 4-15), leaving the
//! tangential displacement `U_s`. Stick: `F_s = k_s U_s` with `k_s = mu k_n` (4-11, 4-12).
//! Slip (`|F_s| > mu F_n`): `F_s = mu F_n U_s/|U_s|`, and — a documented deviation, the
//! Cundall–Strack truncation — the anchor is moved so that `|k_s U_s| = mu F_n`, so that a
//! reversal sticks again at once instead of sliding back through the whole past slip.
//!
//! A second deviation keeps the law from creating energy: `k_s` follows the normal
//! stiffness, so with a fixed anchor a stick spring whose overlap grows, then shrinks, would
//! return more work than it took. When `k_s` changes, the stored tangential displacement is
//! rescaled by `sqrt(k_old / k_new)`, so the spring's energy `k_s U_s^2 / 2` is unchanged by
//! the stiffness change itself (docs/theory.md, I6b).
//!
//! On a curved surface the seed's fixed `v0` creates energy: a displacement once along the
//! normal (the node pressing in) turns tangential as the normal turns, so a node drawn round
//! a tight edge finds its spring stretched by motion that did no work against it (I6c). The
//! fibre–projectile contact therefore keeps, by default, the spring's stretch itself: in the
//! tangent plane of each evaluation, turned with the normal at the next with its length kept
//! (Luding 2008, eq. 17; LAMMPS `pair granular`), plus the tangential part of the relative
//! motion since ([`stick_slip_rotating`]). The fibre–fibre lists keep one anchor per pair
//! and no stretch, so their opt-in form keeps the seed's anchor but takes from it, after
//! each evaluation, the stretch's part along the normal ([`stick_slip_projected`]): a
//! projection in place of the turn. [`FrictionSpring`] names the three.

use crate::Vec3;

/// How a friction spring keeps its stretch while a contact lasts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrictionSpring {
    /// the seed's (4-13): the partner's position at first touch is kept while the contact
    /// lasts, the stretch is the displacement since, less its part along today's normal;
    /// creates energy where the normal turns under a sliding node (docs/theory.md I6c)
    Anchored,
    /// the stretch of the last evaluation turned into today's tangent plane with its length
    /// kept, plus the tangential relative motion since (Luding 2008, eq. 17)
    #[default]
    Rotating,
    /// the seed's anchor, less the stretch's part along the normal after each evaluation
    /// ([`stick_slip_projected`]): a press along one normal never becomes stretch along a
    /// later one. The one-anchor form of `Rotating` (a projection in place of the turn), so
    /// the fibre–fibre lists can have it without more history per pair (I6d)
    Projected,
}

impl FrictionSpring {
    /// The name a case gives it (`contact.projectile_friction_spring`,
    /// `contact.fibre_friction_spring`).
    pub fn name(self) -> &'static str {
        match self {
            FrictionSpring::Anchored => "anchored",
            FrictionSpring::Rotating => "rotating",
            FrictionSpring::Projected => "projected",
        }
    }

    /// This spring's friction for a pair in contact: [`stick_slip`] with the fixed `anchor`
    /// or [`stick_slip_projected`] (`stretch` unused by both), or [`stick_slip_rotating`]
    /// with `anchor` the last relative position and `stretch` the spring's stretch then; the
    /// history is updated.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate(
        self,
        relative: Vec3,
        normal: Vec3,
        anchor: &mut Vec3,
        stretch: &mut Vec3,
        spring_stiffness: &mut f64,
        normal_force: f64,
        normal_stiffness: f64,
        coefficient: f64,
    ) -> FrictionResponse {
        match self {
            FrictionSpring::Anchored => {
                stick_slip(relative, normal, anchor, spring_stiffness, normal_force, normal_stiffness, coefficient)
            }
            FrictionSpring::Projected => stick_slip_projected(
                relative,
                normal,
                anchor,
                spring_stiffness,
                normal_force,
                normal_stiffness,
                coefficient,
            ),
            FrictionSpring::Rotating => stick_slip_rotating(
                relative,
                normal,
                anchor,
                stretch,
                spring_stiffness,
                normal_force,
                normal_stiffness,
                coefficient,
            ),
        }
    }
}

/// How the fibre–fibre friction spring keeps its stretch while a contact lasts: the lists
/// keep one anchor per pair, so the rotating spring, which needs a stretch as well, is not
/// among them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FibreFrictionSpring {
    /// the seed's (4-13), [`FrictionSpring::Anchored`]
    #[default]
    Anchored,
    /// the anchor kept in the tangent plane, [`FrictionSpring::Projected`]
    Projected,
}

impl FibreFrictionSpring {
    /// The name a case gives it (`contact.fibre_friction_spring`).
    pub fn name(self) -> &'static str {
        self.spring().name()
    }

    /// The spring it is.
    pub fn spring(self) -> FrictionSpring {
        match self {
            FibreFrictionSpring::Anchored => FrictionSpring::Anchored,
            FibreFrictionSpring::Projected => FrictionSpring::Projected,
        }
    }
}

/// `stretch` carried into the plane normal to the unit `normal` with its length kept: the
/// spring turns with the contact, neither gaining nor losing energy by the turn. A stretch
/// along the normal itself has no direction in the plane and is dropped.
#[inline(always)]
pub fn rotated_into_plane(stretch: Vec3, normal: Vec3) -> Vec3 {
    let projected = stretch - normal * stretch.dot(&normal);
    let length = projected.norm();
    if length > 0.0 {
        projected * (stretch.norm() / length)
    } else {
        Vec3::zeros()
    }
}

/// [`stick_slip`] with a spring that turns with the contact ([`FrictionSpring::Rotating`]):
/// `last_relative` is the partner's relative position at the last evaluation and `stretch`
/// the spring's tangential stretch then [m]; both are updated. The relative motion since
/// loses its part along `normal` (4-14, 4-15); the law, its slip truncation and its
/// stiffness rescaling are [`stick_slip`]'s.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn stick_slip_rotating(
    relative: Vec3,
    normal: Vec3,
    last_relative: &mut Vec3,
    stretch: &mut Vec3,
    spring_stiffness: &mut f64,
    normal_force: f64,
    normal_stiffness: f64,
    coefficient: f64,
) -> FrictionResponse {
    // the anchor that gives today's relative position the turned stretch plus the motion since
    let mut anchor = *last_relative - rotated_into_plane(*stretch, normal);
    let response =
        stick_slip(relative, normal, &mut anchor, spring_stiffness, normal_force, normal_stiffness, coefficient);
    let kept = relative - anchor;
    *stretch = kept - normal * kept.dot(&normal);
    *last_relative = relative;
    response
}

/// [`stick_slip`], then the `anchor` moved along `normal` until the spring's stretch lies in
/// today's tangent plane ([`FrictionSpring::Projected`]). The law sees only the stretch's
/// tangential part, so the move changes nothing now; it keeps a press along this normal from
/// turning into stretch when the normal turns later. Against the rotating spring the stretch
/// is projected into the next plane instead of turned: it loses about `θ²/2` of its length
/// to a turn of `θ` between evaluations, a loss the law does not book, which vanishes as the
/// step does (docs/theory.md I6d). Odd in `relative` with `anchor`, as (4-13) is.
#[inline(always)]
pub fn stick_slip_projected(
    relative: Vec3,
    normal: Vec3,
    anchor: &mut Vec3,
    spring_stiffness: &mut f64,
    normal_force: f64,
    normal_stiffness: f64,
    coefficient: f64,
) -> FrictionResponse {
    let response = stick_slip(relative, normal, anchor, spring_stiffness, normal_force, normal_stiffness, coefficient);
    let kept = relative - *anchor;
    *anchor += normal * kept.dot(&normal);
    response
}

/// Result of one friction evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionResponse {
    /// tangential force on the node whose partner moved by `relative - anchor` [N]
    pub force: Vec3,
    /// energy dissipated by slip in this evaluation [J]
    pub dissipated: f64,
    /// elastic energy in the tangential spring after the evaluation [J]
    pub stored: f64,
}

/// Evaluates friction for a pair in contact.
///
/// `relative` is the partner's position relative to the node (`v'`), `normal` its unit
/// direction, `anchor` the stored `v0` (updated on slip), `normal_force` F_n >= 0 and
/// `normal_stiffness` k_n the contact's tangent stiffness; `spring_stiffness` holds the
/// `k_s` of the previous evaluation (set it to `mu k_n` at first touch) and is updated.
#[inline(always)]
pub fn stick_slip(
    relative: Vec3,
    normal: Vec3,
    anchor: &mut Vec3,
    spring_stiffness: &mut f64,
    normal_force: f64,
    normal_stiffness: f64,
    coefficient: f64,
) -> FrictionResponse {
    let displacement = relative - *anchor; // (4-13)
    let mut tangential = displacement - normal * displacement.dot(&normal); // (4-14), (4-15)
    let stiffness = coefficient * normal_stiffness; // (4-12)
    if *spring_stiffness != stiffness {
        // keep k_s U_s^2 / 2 through the change of k_s (zero stiffness: the spring restarts)
        let scale = if stiffness > 0.0 { (*spring_stiffness / stiffness).sqrt() } else { 0.0 };
        *anchor += tangential * (1.0 - scale);
        tangential *= scale;
        *spring_stiffness = stiffness;
    }
    let limit = coefficient * normal_force;
    let trial = tangential * stiffness; // (4-11)
    let trial_squared = trial.norm_squared();
    if trial_squared <= limit * limit {
        let stored = if stiffness > 0.0 { trial_squared / (2.0 * stiffness) } else { 0.0 };
        return FrictionResponse { force: trial, dissipated: 0.0, stored };
    }
    let tangential_norm = tangential.norm();
    let direction = tangential / tangential_norm;
    let elastic_slip = if stiffness > 0.0 { limit / stiffness } else { 0.0 };
    // Cundall–Strack: keep only the elastic part of the tangential displacement
    *anchor = relative - direction * elastic_slip;
    FrictionResponse {
        force: direction * limit,
        dissipated: limit * (tangential_norm - elastic_slip),
        stored: limit * elastic_slip / 2.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MU: f64 = 0.3;
    const FN: f64 = 2.0;
    const KN: f64 = 1000.0;

    /// A pair at distance 1 along z; the partner is moved tangentially along x by `shift`.
    fn shifted(shift: f64) -> (Vec3, Vec3) {
        let relative = Vec3::new(shift, 0.0, 1.0);
        (relative, relative.normalize())
    }

    #[test]
    fn sticks_below_mu_fn_with_stiffness_mu_kn() {
        let mut anchor = Vec3::new(0.0, 0.0, 1.0);
        let slip_start = MU * FN / (MU * KN); // |k_s U_s| = mu F_n
        let (relative, normal) = shifted(0.5 * slip_start);
        let response = stick_slip(relative, normal, &mut anchor, &mut (MU * KN), FN, KN, MU);
        let tangential = relative - Vec3::z() - normal * (relative - Vec3::z()).dot(&normal);
        assert!((response.force - tangential * MU * KN).norm() < 1e-15);
        assert!(response.force.norm() < MU * FN);
        assert!(response.force.x > 0.0, "the node is dragged along with its partner");
        assert_eq!(response.dissipated, 0.0);
        assert_eq!(anchor, Vec3::z(), "sticking leaves the anchor in place");
    }

    #[test]
    fn slips_at_mu_fn_and_dissipates() {
        let mut anchor = Vec3::z();
        let (relative, normal) = shifted(0.05);
        let response = stick_slip(relative, normal, &mut anchor, &mut (MU * KN), FN, KN, MU);
        assert!((response.force.norm() - MU * FN).abs() < 1e-12);
        assert!(response.dissipated > 0.0);
        // after the truncation the spring holds exactly the limit force
        let again = stick_slip(relative, normal, &mut anchor, &mut (MU * KN), FN, KN, MU);
        assert!((again.force.norm() - MU * FN).abs() < 1e-12);
        assert!(again.dissipated.abs() < 1e-15, "no further slip without further motion");
    }

    #[test]
    fn recovers_after_a_reversal() {
        let mut anchor = Vec3::z();
        let (far, n_far) = shifted(0.05);
        let forward = stick_slip(far, n_far, &mut anchor, &mut (MU * KN), FN, KN, MU);
        assert!(forward.force.x > 0.0);
        // moving back by a little unloads the spring (stick), not slide
        let (back, n_back) = shifted(0.05 - 1e-4);
        let reversed = stick_slip(back, n_back, &mut anchor, &mut (MU * KN), FN, KN, MU);
        assert!(reversed.force.norm() < MU * FN, "sticks again after the reversal");
        assert_eq!(reversed.dissipated, 0.0);
        // moving back far enough slips the other way
        let (opposite, n_opposite) = shifted(-0.05);
        let slid = stick_slip(opposite, n_opposite, &mut anchor, &mut (MU * KN), FN, KN, MU);
        assert!(slid.force.x < 0.0 && (slid.force.norm() - MU * FN).abs() < 1e-12);
    }

    /// A node touches a rigid edge of radius `radius` (normal force FN, stiffness
    /// `normal_stiffness`), is pressed `depth` into it, then drawn round it by a quarter turn
    /// and back, in `steps` steps each way. Gives the work the friction force took from the
    /// motion and the energy the law books (dissipated plus stored at the end).
    fn drawn_round_an_edge(
        spring: FrictionSpring,
        radius: f64,
        depth: f64,
        normal_stiffness: f64,
        steps: usize,
    ) -> (f64, f64) {
        // the node's centre at an angle round the edge's axis and a distance from it
        let at = |(angle, distance): (f64, f64)| {
            let normal = Vec3::new(angle.sin(), 0.0, angle.cos());
            (normal * distance, normal)
        };
        // the partner (the edge) relative to the node, as the contact code gives it
        let relative = |point: (f64, f64)| -at(point).0;
        let start = (0.0, radius);
        let mut anchor = relative(start);
        let mut last = relative(start);
        let mut stretch = Vec3::zeros();
        let mut stiffness = MU * normal_stiffness;
        let mut evaluate = |point: (f64, f64)| {
            let (_, normal) = at(point);
            match spring {
                FrictionSpring::Anchored => {
                    stick_slip(relative(point), normal, &mut anchor, &mut stiffness, FN, normal_stiffness, MU)
                }
                FrictionSpring::Projected => {
                    stick_slip_projected(relative(point), normal, &mut anchor, &mut stiffness, FN, normal_stiffness, MU)
                }
                FrictionSpring::Rotating => stick_slip_rotating(
                    relative(point),
                    normal,
                    &mut last,
                    &mut stretch,
                    &mut stiffness,
                    FN,
                    normal_stiffness,
                    MU,
                ),
            }
        };
        let quarter = std::f64::consts::FRAC_PI_2;
        let pressed = radius - depth;
        let path: Vec<(f64, f64)> = (0..=steps)
            .map(|k| (0.0, radius - depth * k as f64 / steps as f64))
            .chain((1..=steps).map(|k| (quarter * k as f64 / steps as f64, pressed)))
            .chain((0..steps).rev().map(|k| (quarter * k as f64 / steps as f64, pressed)))
            .collect();
        let (mut work, mut dissipated) = (0.0, 0.0);
        let mut previous = evaluate(path[0]);
        for pair in path.windows(2) {
            let next = evaluate(pair[1]);
            dissipated += next.dissipated;
            // the force acts on the node; its work over the step by the trapezoid rule
            let moved = at(pair[1]).0 - at(pair[0]).0;
            work -= 0.5 * (previous.force + next.force).dot(&moved);
            previous = next;
        }
        (work, dissipated + previous.stored)
    }

    #[test]
    fn a_rotating_spring_books_the_work_a_node_drawn_round_an_edge_gives_it() {
        // as where a yarn is drawn over the cylinder of seed §5.3 (50 um edge): a node's centre
        // 150 um from the edge's axis pressed 60 um in, a spring that slips after 40 um
        // (mu F_n / k_s = F_n / k_n, about the overlap of a soft contact)
        let (radius, depth, normal_stiffness) = (150e-6, 60e-6, FN / 40e-6);
        let (work, booked) = drawn_round_an_edge(FrictionSpring::Rotating, radius, depth, normal_stiffness, 4000);
        assert!(work > 0.0);
        assert!((booked - work).abs() < 1e-3 * work, "work {work}, booked {booked}");
        // the seed's fixed anchor books energy no motion gave: the press along the first
        // normal turns into stretch as the normal turns
        let (work, booked) = drawn_round_an_edge(FrictionSpring::Anchored, radius, depth, normal_stiffness, 4000);
        // (4.0 % more here)
        assert!(booked > 1.03 * work, "work {work}, booked {booked}");
    }

    #[test]
    fn a_projected_spring_books_the_work_of_a_node_drawn_round_an_edge_as_the_step_shrinks() {
        // the edge of the rotating spring's test; the projection loses a little stretch to each
        // turn (unbooked, so it books less than the work), less as the steps get finer
        let (radius, depth, normal_stiffness) = (150e-6, 60e-6, FN / 40e-6);
        let shortfall = |steps| {
            let (work, booked) = drawn_round_an_edge(FrictionSpring::Projected, radius, depth, normal_stiffness, steps);
            assert!(work > 0.0 && booked <= work * (1.0 + 1e-9), "{steps} steps: work {work}, booked {booked}");
            (work - booked) / work
        };
        let (coarse, fine) = (shortfall(500), shortfall(4000));
        assert!(fine < 1e-3, "{fine}");
        assert!(fine < 0.5 * coarse, "the shortfall shrinks with the step: {coarse} then {fine}");
        // with no edge the forces are the seed's: the rotating test's flat surface
        let normal = Vec3::z();
        let (mut anchor, mut projected) = (Vec3::z(), Vec3::z());
        let (mut k_anchored, mut k_projected) = (MU * KN, MU * KN);
        for step in 1..200 {
            let t = step as f64 * 1e-5;
            let relative = Vec3::new(t * t, 0.3 * t, 1.0 - 0.1 * t);
            let a = stick_slip(relative, normal, &mut anchor, &mut k_anchored, FN, KN, MU);
            let p = stick_slip_projected(relative, normal, &mut projected, &mut k_projected, FN, KN, MU);
            assert!((a.force - p.force).norm() <= 1e-12 * a.force.norm().max(1e-30), "step {step}");
            assert!((a.dissipated - p.dissipated).abs() <= 1e-12 * a.dissipated.abs().max(1e-30));
        }
    }

    #[test]
    fn a_projected_spring_is_odd_in_the_relative_position() {
        // the fibre sweep evaluates a pair at one node and hands the other the force negated
        let (mut anchor, mut mirrored) = (Vec3::new(0.2e-6, 0.0, 1e-6), Vec3::new(-0.2e-6, 0.0, -1e-6));
        let (mut k, mut k_mirrored) = (MU * KN, MU * KN);
        for step in 1..100 {
            let angle = step as f64 * 0.01;
            let relative = Vec3::new(angle.sin(), 0.1 * angle, angle.cos()) * 1e-6;
            let normal = relative.normalize();
            let a = stick_slip_projected(relative, normal, &mut anchor, &mut k, FN, KN, MU);
            let b = stick_slip_projected(-relative, -normal, &mut mirrored, &mut k_mirrored, FN, KN, MU);
            assert_eq!(a.force, -b.force, "step {step}");
            assert_eq!(anchor, -mirrored, "step {step}");
        }
    }

    #[test]
    fn turning_a_stretch_into_a_plane_keeps_its_length() {
        let stretch = Vec3::new(3e-6, -1e-6, 2e-6);
        let normal = Vec3::new(1.0, 2.0, -0.5).normalize();
        let turned = rotated_into_plane(stretch, normal);
        assert!((turned.norm() - stretch.norm()).abs() < 1e-15 * stretch.norm());
        assert!(turned.dot(&normal).abs() < 1e-15 * stretch.norm());
        // already in the plane: unchanged; along the normal: dropped
        let in_plane = stretch - normal * stretch.dot(&normal);
        assert!((rotated_into_plane(in_plane, normal) - in_plane).norm() < 1e-20);
        assert_eq!(rotated_into_plane(normal * 2e-6, normal), Vec3::zeros());
    }

    #[test]
    fn a_rotating_spring_is_the_seeds_spring_on_a_flat_surface() {
        // one normal throughout: the turned stretch plus the motion since is the displacement
        // since first touch, less its normal part, as (4-13)…(4-15) have it
        let normal = Vec3::z();
        let mut anchor = Vec3::new(0.0, 0.0, 1.0);
        let (mut last, mut stretch) = (anchor, Vec3::zeros());
        let (mut k_anchored, mut k_rotating) = (MU * KN, MU * KN);
        for step in 1..200 {
            let t = step as f64 * 1e-5;
            let relative = Vec3::new(t * t, 0.3 * t, 1.0 - 0.1 * t);
            let a = stick_slip(relative, normal, &mut anchor, &mut k_anchored, FN, KN, MU);
            let r = stick_slip_rotating(relative, normal, &mut last, &mut stretch, &mut k_rotating, FN, KN, MU);
            assert!((a.force - r.force).norm() <= 1e-12 * a.force.norm().max(1e-30), "step {step}");
            assert!((a.dissipated - r.dissipated).abs() <= 1e-12 * a.dissipated.abs().max(1e-30));
        }
    }

    #[test]
    fn a_stick_spring_returns_the_work_it_took_when_its_stiffness_changes() {
        // load the spring at k1, stiffen the contact to k2 at rest, unload to zero force:
        // the returned work equals the work put in (a fixed anchor would return k2/k1 times it)
        let (k1, k2) = (KN, 4.0 * KN);
        let mut anchor = Vec3::z();
        let mut spring = MU * k1;
        let big = 1e3 * FN; // no slip in this test
        let steps = 20000;
        let (mut work_in, mut work_out) = (0.0, 0.0);
        let mut shift = 0.0;
        let mut force = stick_slip(shifted(0.0).0, shifted(0.0).1, &mut anchor, &mut spring, big, k1, MU).force;
        for _ in 0..steps {
            let next = shift + 1e-3 / steps as f64;
            let (relative, normal) = shifted(next);
            let new_force = stick_slip(relative, normal, &mut anchor, &mut spring, big, k1, MU).force;
            work_in += 0.5 * (force.x + new_force.x) * (next - shift);
            (shift, force) = (next, new_force);
        }
        let stored_before =
            stick_slip(shifted(shift).0, shifted(shift).1, &mut anchor.clone(), &mut spring.clone(), big, k1, MU)
                .stored;
        force = stick_slip(shifted(shift).0, shifted(shift).1, &mut anchor, &mut spring, big, k2, MU).force;
        let stored_after =
            stick_slip(shifted(shift).0, shifted(shift).1, &mut anchor.clone(), &mut spring.clone(), big, k2, MU)
                .stored;
        assert!(
            (stored_after - stored_before).abs() < 1e-12 * stored_before,
            "the change of stiffness keeps the energy"
        );
        while force.x > 0.0 {
            let next = shift - 1e-3 / steps as f64;
            let (relative, normal) = shifted(next);
            let new_force = stick_slip(relative, normal, &mut anchor, &mut spring, big, k2, MU).force;
            work_out += 0.5 * (force.x + new_force.x) * (shift - next);
            (shift, force) = (next, new_force);
        }
        assert!((work_out - work_in).abs() < 1e-3 * work_in, "in {work_in}, out {work_out}");
    }
}
