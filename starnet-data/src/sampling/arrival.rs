//! When a point's neighbourhood has arrived: the geometry behind [`super::SliceContext::Arrived`].
//!
//! After the first `k` of a sweep's `n` slices, the sensor has delivered the azimuths
//! `[0°, k·w)` counted from the sweep's start in the rotation sense (w = 360°/n); the rest of
//! the plane, a cone from the sensor bounded by the leading ray (at `k·w`) and the seam (the
//! start ray, which the sweep reaches again at its end), is still to come. A center's ball of
//! radius R is whole once the center lies at least R (in bird's-eye view) from that cone.

/// How far, in bird's-eye view, a point lies from the part of the plane not yet delivered
/// when the first `delivered` degrees of a sweep have been: 0 inside it (or before anything
/// has been delivered), infinite once the whole turn has.
///
/// `along` is the point's azimuth in degrees from the sweep's start in the rotation sense, in
/// `[0, 360)`; `rho` its distance from the sensor. The nearest point of a cone (convex or not)
/// from a point outside it lies on one of its two boundary rays: at `rho · sin δ` when the
/// ray is `δ < 90°` away in angle, else at the apex (`rho`).
pub fn distance_to_undelivered(along: f32, rho: f32, delivered: f32) -> f32 {
    if delivered >= 360.0 {
        return f32::INFINITY;
    }
    if delivered <= 0.0 || along >= delivered {
        return 0.0;
    }
    // Angular gaps to the leading ray and to the seam (0° = 360°).
    let to_leading = delivered - along;
    let to_seam = along.min(360.0 - along);
    ray_distance(to_leading, rho).min(ray_distance(to_seam, rho))
}

/// The distance from a point at range `rho` to a ray from the sensor `gap` degrees away
/// (`0 ≤ gap ≤ 180`).
fn ray_distance(gap: f32, rho: f32) -> f32 {
    if gap >= 90.0 { rho } else { rho * gap.to_radians().sin() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: the nearest of many points sampled over the undelivered cone.
    fn oracle(along: f32, rho: f32, delivered: f32) -> f32 {
        let (px, py) = (rho * along.to_radians().cos(), rho * along.to_radians().sin());
        let mut best = f32::INFINITY;
        let steps = 2000;
        for i in 0..=steps {
            let a = delivered + (360.0 - delivered) * i as f32 / steps as f32;
            for j in 0..=400 {
                let r = j as f32 * 0.25; // 0–100 m
                let (x, y) = (r * a.to_radians().cos(), r * a.to_radians().sin());
                best = best.min((x - px).hypot(y - py));
            }
        }
        best
    }

    #[test]
    fn matches_a_brute_force_search_over_the_cone() {
        let cases = [
            (10.0, 20.0, 11.25),  // just behind the leading ray
            (5.0, 30.0, 11.25),   // between the seam and the leading ray
            (1.0, 40.0, 180.0),   // beside the seam
            (100.0, 15.0, 270.0), // a reflex delivered cone, far from both rays
            (200.0, 3.0, 350.0),  // near the sensor: the apex is nearest
            (340.0, 25.0, 348.75),
        ];
        for (along, rho, delivered) in cases {
            let d = distance_to_undelivered(along, rho, delivered);
            let o = oracle(along, rho, delivered);
            assert!(
                (d - o).abs() < 0.05,
                "along {along} rho {rho} delivered {delivered}: {d} vs {o}"
            );
        }
    }

    #[test]
    fn nothing_delivered_is_everywhere_near_and_a_whole_turn_nowhere() {
        assert_eq!(distance_to_undelivered(10.0, 20.0, 0.0), 0.0);
        assert_eq!(distance_to_undelivered(30.0, 20.0, 22.5), 0.0, "not delivered yet");
        assert_eq!(distance_to_undelivered(359.0, 20.0, 360.0), f32::INFINITY);
    }

    #[test]
    fn the_distance_only_grows_as_slices_arrive() {
        for along in [0.5f32, 7.0, 45.0, 181.0, 300.0] {
            let mut last = 0.0;
            for k in 0..=32 {
                let d = distance_to_undelivered(along, 18.0, k as f32 * 11.25);
                assert!(d >= last, "along {along}, {k} slices: {d} < {last}");
                last = d;
            }
        }
    }
}
