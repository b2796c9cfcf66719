//! Which points may become centers: a range box, a z band (ground removal) and, on KITTI, the
//! camera frustum. Only center selection uses the pool; every point stays available for
//! gathering (lingvo's `SparseCenterSelector` runs on a filtered copy of the points). With a
//! [`GroundModel`] the z band is measured on the levelled cloud: a point's z less the ground's
//! rise under it, so the band keeps its height above a road that is not flat.

use crate::Point;
use crate::geometry::GroundModel;
use crate::kitti::{Calib, ImageSize};
use crate::settings::{Checked, ordered_range};
use serde::{Deserialize, Serialize};

/// The center pool's filters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CenterPoolConfig {
    /// Allowed x `[min, max]`.
    pub x_range: [f32; 2],
    /// Allowed y `[min, max]`.
    pub y_range: [f32; 2],
    /// Allowed z `[min, max]`: KITTI keeps z ≥ −1.35 (above the road); the paper's Waymo band is
    /// the 10th–90th percentile of training-label centre z ([`z_band_from_labels`]).
    pub z_range: [f32; 2],
    /// Keep only points that project into camera image 2 (KITTI labels only that view).
    pub camera_frustum: bool,
}

impl CenterPoolConfig {
    /// Checks that each range is `[min, max]` (keys relative to the pool table).
    pub fn validate(&self) -> Checked {
        ordered_range("x_range", self.x_range)?;
        ordered_range("y_range", self.y_range)?;
        ordered_range("z_range", self.z_range)
    }

    /// The authors' KITTI pool: x ≥ 0, |y| ≤ 40, z ≥ −1.35, camera frustum.
    pub fn kitti() -> Self {
        Self {
            x_range: [0.0, f32::INFINITY],
            y_range: [-40.0, 40.0],
            z_range: [-1.35, f32::INFINITY],
            camera_frustum: true,
        }
    }

    /// All around the sensor (360° labels), z ≥ −1.35 and within `range` metres.
    pub fn all_around(range: f32) -> Self {
        Self {
            x_range: [-range, range],
            y_range: [-range, range],
            z_range: [-1.35, f32::INFINITY],
            camera_frustum: false,
        }
    }
}

/// Indices of the points that may become centers. `camera` is required when the config asks
/// for the frustum; without it the frustum test is skipped. `ground`, when given, levels each
/// point's z before the z band is tested.
pub fn center_pool(
    points: &[Point],
    cfg: &CenterPoolConfig,
    camera: Option<(&Calib, ImageSize)>,
    ground: Option<&GroundModel>,
) -> Vec<usize> {
    let levelled_z = |p: &Point| ground.map_or(p[2], |g| p[2] - g.rise_at(p[0], p[1]));
    let in_range = |p: &Point| {
        (cfg.x_range[0]..=cfg.x_range[1]).contains(&p[0])
            && (cfg.y_range[0]..=cfg.y_range[1]).contains(&p[1])
            && (cfg.z_range[0]..=cfg.z_range[1]).contains(&levelled_z(p))
    };
    let fov = match (cfg.camera_frustum, camera) {
        (true, Some((calib, size))) => Some(calib.fov_mask(points, size)),
        _ => None,
    };
    (0..points.len())
        .filter(|&i| in_range(&points[i]) && fov.as_ref().is_none_or(|m| m[i]))
        .collect()
}

/// The z band `[q_lo, q_hi]` quantiles of label centre heights (the paper's Waymo pool uses
/// the 10th and 90th percentiles). `None` without labels.
pub fn z_band_from_labels(centre_z: &[f32], q_lo: f32, q_hi: f32) -> Option<[f32; 2]> {
    if centre_z.is_empty() {
        return None;
    }
    let mut z = centre_z.to_vec();
    z.sort_by(f32::total_cmp);
    let at = |q: f32| z[((z.len() - 1) as f32 * q).round() as usize];
    Some([at(q_lo), at(q_hi)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filters_range_and_z() {
        let pts = [
            [5.0, 0.0, -1.7, 0.1],
            [5.0, 0.0, -1.0, 0.1],
            [-5.0, 0.0, -1.0, 0.1],
            [5.0, 50.0, -1.0, 0.1],
        ];
        let cfg = CenterPoolConfig {
            camera_frustum: false,
            ..CenterPoolConfig::kitti()
        };
        assert_eq!(center_pool(&pts, &cfg, None, None), vec![1]);
        assert_eq!(
            center_pool(&pts, &CenterPoolConfig::all_around(60.0), None, None),
            vec![1, 2, 3]
        );
    }

    #[test]
    fn the_z_band_follows_the_ground() {
        use crate::geometry::GroundConfig;
        // A road 0.4 m above the reference 30 m ahead, and a return 0.6 m above that road.
        let mut pts: Vec<Point> = (0..40)
            .flat_map(|i| (-4..4).map(move |j| [28.0 + 0.1 * i as f32, j as f32 * 0.5, -1.33, 0.1]))
            .collect();
        pts.push([30.0, 0.0, -0.73, 0.1]);
        let cfg = CenterPoolConfig {
            camera_frustum: false,
            ..CenterPoolConfig::kitti()
        };
        let road = center_pool(&pts, &cfg, None, None);
        assert_eq!(
            road.len(),
            pts.len(),
            "unlevelled, the raised road is all above z = -1.35"
        );
        let ground = GroundModel::fit(&pts, &GroundConfig::default());
        assert_eq!(center_pool(&pts, &cfg, None, Some(&ground)), vec![pts.len() - 1]);
    }

    #[test]
    fn frustum_uses_the_camera() {
        let calib = Calib::kitti_000000();
        let pts = [[10.0, 0.0, -1.0, 0.1], [10.0, 15.0, -1.0, 0.1]];
        assert_eq!(
            center_pool(&pts, &CenterPoolConfig::kitti(), Some((&calib, ImageSize::KITTI)), None),
            vec![0]
        );
    }

    #[test]
    fn z_band_quantiles() {
        let z: Vec<f32> = (0..=100).map(|i| i as f32 / 100.0).collect();
        assert_eq!(z_band_from_labels(&z, 0.1, 0.9), Some([0.1, 0.9]));
        assert_eq!(z_band_from_labels(&[], 0.1, 0.9), None);
    }
}
