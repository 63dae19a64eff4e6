//! The time step (paper §4.8, eq. 5–6).

/// `dt = safety · min(Δx / v_max, Δx² / (6β), 1 / relaxation)`: the CFL bound keeps the
/// skin from jumping a node in one step; the second keeps explicit tension stable in 3-D
/// (|∇φ| ≈ 1, κ the sum of principal curvatures). The paper stops there, but near rest
/// v_max → 0 while the attraction still relaxes the distance at rate α (and the
/// preservation terms the area and volume at their own rates): explicit Euler overshoots
/// unless dt < 1/rate, so `relaxation` is the largest of those rates.
pub(crate) fn stable_dt(dx: f32, v_max: f32, beta: f32, relaxation: f32, safety: f32) -> f32 {
    let bound = |rate: f32, limit: f32| if rate > 0.0 { limit } else { f32::INFINITY };
    let hyperbolic = bound(v_max, dx / v_max);
    let parabolic = bound(beta, dx * dx / (6.0 * beta));
    let relax = bound(relaxation, 1.0 / relaxation);
    safety * hyperbolic.min(parabolic).min(relax)
}

/// The next sub-step toward `remaining`: a stable step, or exactly what is left when that
/// is close, so sub-steps land on the requested time without a sliver at the end.
pub(crate) fn next_substep(remaining: f64, stable: f32) -> f64 {
    let stable = f64::from(stable);
    if stable >= remaining {
        remaining
    } else if stable * 1.5 > remaining {
        remaining * 0.5
    } else {
        stable
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substeps_land_exactly() {
        let mut left = 1.0 / 24.0;
        let mut n = 0;
        while left > 0.0 {
            let dt = next_substep(left, 0.004);
            assert!(dt > 0.0 && dt <= f64::from(0.004f32));
            left -= dt;
            n += 1;
        }
        assert_eq!(left, 0.0);
        assert!(n <= 12);
    }

    #[test]
    fn tension_bound_applies() {
        assert_eq!(stable_dt(0.1, 0.0, 0.0, 0.0, 0.5), f32::INFINITY);
        assert!((stable_dt(0.1, 0.0, 1.0, 0.0, 1.0) - 0.01 / 6.0).abs() < 1e-9);
        assert!((stable_dt(0.1, 2.0, 0.0, 0.0, 0.5) - 0.025).abs() < 1e-9);
        assert!((stable_dt(0.1, 0.0, 0.0, 4.0, 0.5) - 0.125).abs() < 1e-9);
    }
}
