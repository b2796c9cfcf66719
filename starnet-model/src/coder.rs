//! The box coder (lingvo `detection_3d_lib.py`, ARCHITECTURE.md §6): residuals of a box against an
//! anchor, and back. With `d = √(dx_a² + dy_a²)`:
//!
//! ```text
//! r = [(x − x_a)/d, (y − y_a)/d, (z − z_a)/dz_a, ln(dx/dx_a), ln(dy/dy_a), ln(dz/dz_a), φ − φ_a]
//! ```
//! The heading residual is not wrapped (the losses decide how to compare angles); decoding
//! wraps the heading back to [−π, π).
//!
//! Direction bins (SECOND, OpenPCDet's `dir_offset`): the heading loss on sin Δ cannot tell a
//! box from its 180° turn, so a two-bin classifier says which half-turn the heading lies in:
//! bin `⌊((φ − offset) mod 2π) / π⌋` ([`direction_bin`]); decoding folds the regressed heading
//! into that half-turn ([`with_direction`]).

use starnet_data::{Box3d, wrap_angle};
use std::f32::consts::{PI, TAU};

/// Where the two direction bins meet (and π later): OpenPCDet's KITTI `dir_offset`, π/4, away
/// from the headings roads make common (0, ±π/2, π).
pub const DIRECTION_OFFSET: f32 = std::f32::consts::FRAC_PI_4;

/// The direction bin (0 or 1) of heading `phi`: which half-turn from [`DIRECTION_OFFSET`].
pub fn direction_bin(phi: f32) -> usize {
    let a = (phi - DIRECTION_OFFSET).rem_euclid(TAU);
    usize::from(a >= PI)
}

/// Heading `phi` turned by π if needed so that it lies in direction bin `bin`, wrapped to
/// [−π, π): the inverse of [`direction_bin`] up to a half-turn
/// (`with_direction(φ + kπ, direction_bin(φ)) = φ`).
pub fn with_direction(phi: f32, bin: usize) -> f32 {
    let folded = (phi - DIRECTION_OFFSET).rem_euclid(PI);
    wrap_angle(DIRECTION_OFFSET + folded + PI * bin as f32)
}

/// Residuals of `gt` against `anchor`.
pub fn encode(gt: &Box3d, anchor: &Box3d) -> [f32; 7] {
    let d = anchor.dx.hypot(anchor.dy);
    [
        (gt.x - anchor.x) / d,
        (gt.y - anchor.y) / d,
        (gt.z - anchor.z) / anchor.dz,
        (gt.dx / anchor.dx).ln(),
        (gt.dy / anchor.dy).ln(),
        (gt.dz / anchor.dz).ln(),
        gt.heading - anchor.heading,
    ]
}

/// The box that residuals `r` describe around `anchor` (the inverse of [`encode`]).
pub fn decode(r: &[f32; 7], anchor: &Box3d) -> Box3d {
    let d = anchor.dx.hypot(anchor.dy);
    Box3d::new(
        anchor.x + r[0] * d,
        anchor.y + r[1] * d,
        anchor.z + r[2] * anchor.dz,
        anchor.dx * r[3].exp(),
        anchor.dy * r[4].exp(),
        anchor.dz * r[5].exp(),
        anchor.heading + r[6],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn hand_values() {
        let a = Box3d::new(10.0, 0.0, -1.0, 4.0, 3.0, 2.0, 0.0);
        let g = Box3d::new(15.0, -5.0, 0.0, 8.0, 3.0, 1.0, 0.5);
        let r = encode(&g, &a);
        // d = 5: (5/5, −5/5, 1/2, ln 2, 0, ln ½, 0.5).
        let want = [1.0, -1.0, 0.5, 2f32.ln(), 0.0, 0.5f32.ln(), 0.5];
        assert!(r.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6), "{r:?}");
    }

    #[test]
    fn direction_bins_round_trip_and_hand_values() {
        // Heading 0 is 7π/4 past the offset: bin 1; heading π is 3π/4 past it: bin 0.
        assert_eq!(direction_bin(0.0), 1);
        assert_eq!(direction_bin(PI - 1e-3), 0);
        assert_eq!(direction_bin(DIRECTION_OFFSET + 0.01), 0);
        assert_eq!(direction_bin(DIRECTION_OFFSET - 0.01), 1);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..10_000 {
            let phi = wrap_angle(rng.random_range(-PI..PI));
            let bin = direction_bin(phi);
            for turn in [0.0, PI, -PI, TAU] {
                let back = with_direction(phi + turn, bin);
                let d = wrap_angle(back - phi).abs();
                assert!(d < 1e-4, "{phi} + {turn} -> {back}");
            }
            // The other bin is the opposite direction.
            assert!((wrap_angle(with_direction(phi, 1 - bin) - phi).abs() - PI).abs() < 1e-4);
        }
    }

    #[test]
    fn round_trips() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let pi = std::f32::consts::PI;
        for _ in 0..10_000 {
            let mut b = || {
                Box3d::new(
                    rng.random_range(-70.0..70.0),
                    rng.random_range(-40.0..40.0),
                    rng.random_range(-3.0..1.0),
                    rng.random_range(0.3..12.0),
                    rng.random_range(0.3..3.0),
                    rng.random_range(0.5..4.0),
                    rng.random_range(-pi..pi),
                )
            };
            let (g, a) = (b(), b());
            // Box → residuals → box: within a few f32 ulps of the larger of the box's and the
            // anchor's component (x − x_a cancels).
            let back = decode(&encode(&g, &a), &a);
            for ((u, v), w) in g.to_array().iter().zip(back.to_array()).zip(a.to_array()) {
                assert!(
                    (u - v).abs() <= 8.0 * f32::EPSILON * u.abs().max(w.abs()).max(1.0),
                    "{g:?} -> {back:?}"
                );
            }
            // Residuals → box → residuals: exact to 1e-5 (the heading up to a turn).
            let r: [f32; 7] = std::array::from_fn(|i| {
                if i == 6 {
                    rng.random_range(-pi..pi)
                } else {
                    rng.random_range(-1.0..1.0)
                }
            });
            let r2 = encode(&decode(&r, &a), &a);
            for i in 0..7 {
                let d = (r[i] - r2[i]).abs();
                assert!(
                    d < 1e-5 || (i == 6 && (d - std::f32::consts::TAU).abs() < 1e-5),
                    "{i}: {r:?} vs {r2:?}"
                );
            }
        }
    }
}
