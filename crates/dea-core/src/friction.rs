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

use crate::Vec3;

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
pub fn stick_slip(relative: Vec3, normal: Vec3, anchor: &mut Vec3, spring_stiffness: &mut f64, normal_force: f64, normal_stiffness: f64, coefficient: f64) -> FrictionResponse {
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
        let stored_before = stick_slip(shifted(shift).0, shifted(shift).1, &mut anchor.clone(), &mut spring.clone(), big, k1, MU).stored;
        force = stick_slip(shifted(shift).0, shifted(shift).1, &mut anchor, &mut spring, big, k2, MU).force;
        let stored_after = stick_slip(shifted(shift).0, shifted(shift).1, &mut anchor.clone(), &mut spring.clone(), big, k2, MU).stored;
        assert!((stored_after - stored_before).abs() < 1e-12 * stored_before, "the change of stiffness keeps the energy");
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
