//! The principal horizontal axis of a set of points (a 2D principal component analysis), shared
//! by the clusters' sizes and the tilt of a car's end.

/// The angle from the first coordinate axis to the principal direction of `points` (`[a, b]`
/// pairs), radians in [−π/2, π/2]: the major axis of their covariance,
/// `½ · atan2(2·s_ab, s_aa − s_bb)`.
pub fn principal_angle(points: impl Iterator<Item = [f32; 2]> + Clone) -> f32 {
    let n = points.clone().count() as f32;
    let (ma, mb) = points
        .clone()
        .fold((0.0, 0.0), |(a, b), p| (a + p[0] / n, b + p[1] / n));
    let (mut saa, mut sab, mut sbb) = (0.0f32, 0.0f32, 0.0f32);
    for p in points {
        let (da, db) = (p[0] - ma, p[1] - mb);
        (saa, sab, sbb) = (saa + da * da, sab + da * db, sbb + db * db);
    }
    0.5 * (2.0 * sab).atan2(saa - sbb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_along_a_line_give_its_angle() {
        for deg in [0.0f32, 30.0, -60.0, 89.0] {
            let (s, c) = deg.to_radians().sin_cos();
            // A line with a little spread across it, so the covariance is not degenerate.
            let pts: Vec<[f32; 2]> = (0..10)
                .flat_map(|i| [0.05f32, -0.05].map(|e| (i as f32 - 4.5, e)))
                .map(|(t, e)| [1.0 + t * c - e * s, -2.0 + t * s + e * c])
                .collect();
            let got = principal_angle(pts.iter().copied()).to_degrees();
            assert!((got - deg).abs() < 1e-2, "{got} for {deg}");
        }
    }
}
