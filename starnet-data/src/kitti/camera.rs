//! Crossing frames with a [`Calib`]: LiDAR ↔ camera-rect for points and boxes, projection
//! into image 2, the clipped 2D box, the observation angle alpha and the camera-FOV crop.

use super::{Calib, CameraBox};
use crate::{Box3d, Point, wrap_angle};
use nalgebra::{Matrix4, Vector4};
use serde::{Deserialize, Serialize};
use std::f32::consts::FRAC_PI_2;

/// Size of image 2 in pixels. KITTI images are mostly 1242 × 375 (a few days' are cropped to
/// 1224–1241 × 370–376); only the image header says which.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ImageSize {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl ImageSize {
    /// The common KITTI size, 1242 × 375.
    pub const KITTI: ImageSize = ImageSize {
        width: 1242,
        height: 375,
    };
}

impl Default for ImageSize {
    fn default() -> Self {
        Self::KITTI
    }
}

fn apply(m: &Matrix4<f64>, p: [f64; 3]) -> [f64; 3] {
    let v = m * Vector4::new(p[0], p[1], p[2], 1.0);
    [v.x, v.y, v.z]
}

impl Calib {
    /// A LiDAR point in the camera-rect frame: `R0_rect · (Tr_velo_to_cam · [p; 1])`.
    pub fn lidar_to_rect(&self, p: [f64; 3]) -> [f64; 3] {
        apply(self.lidar_to_rect_matrix(), p)
    }

    /// The inverse of [`Self::lidar_to_rect`].
    pub fn rect_to_lidar(&self, p: [f64; 3]) -> [f64; 3] {
        apply(self.rect_to_lidar_matrix(), p)
    }

    /// Projects a camera-rect point into image 2: `[u, v, depth]`, where depth is the third
    /// homogeneous coordinate (≈ z_rect). Pixels are meaningful only for depth > 0.
    pub fn rect_to_image(&self, p: [f64; 3]) -> [f64; 3] {
        let v = self.p2() * Vector4::new(p[0], p[1], p[2], 1.0);
        [v.x / v.z, v.y / v.z, v.z]
    }

    /// The LiDAR box of a label: centre = rect→LiDAR(x, y − h/2, z) (the label stores the
    /// bottom centre and camera y points down), (dx, dy, dz) = (l, w, h), heading = −(ry + π/2).
    pub fn label_to_box(&self, c: &CameraBox) -> Box3d {
        let [x, y, z] = self.rect_to_lidar([c.x as f64, (c.y - 0.5 * c.h) as f64, c.z as f64]);
        Box3d::new(x as f32, y as f32, z as f32, c.l, c.w, c.h, -(c.ry + FRAC_PI_2))
    }

    /// The inverse of [`Self::label_to_box`]; `ry` wrapped to [−π, π).
    pub fn box_to_label(&self, b: &Box3d) -> CameraBox {
        let [x, y, z] = self.lidar_to_rect([b.x as f64, b.y as f64, b.z as f64]);
        CameraBox {
            h: b.dz,
            w: b.dy,
            l: b.dx,
            x: x as f32,
            y: (y + 0.5 * b.dz as f64) as f32,
            z: z as f32,
            ry: wrap_angle(-b.heading - FRAC_PI_2),
        }
    }

    /// The unclipped 2D box `[left, top, right, bottom]` of a camera box in image 2: the
    /// bounds of its eight corners projected with P2. `None` if a corner lies behind the
    /// camera, where the pinhole projection is meaningless.
    pub fn projected_bbox(&self, c: &CameraBox) -> Option<[f64; 4]> {
        let (s, co) = (c.ry as f64).sin_cos();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for i in 0..8 {
            let u = if i & 1 == 0 { 0.5 } else { -0.5 } * c.l as f64;
            let w = if i & 2 == 0 { 0.5 } else { -0.5 } * c.w as f64;
            let v = if i & 4 == 0 { 0.0 } else { -(c.h as f64) };
            // R_y = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
            let p = [
                co * u + s * w + c.x as f64,
                v + c.y as f64,
                -s * u + co * w + c.z as f64,
            ];
            let [px, py, depth] = self.rect_to_image(p);
            if depth <= 0.0 {
                return None;
            }
            lo = [lo[0].min(px), lo[1].min(py)];
            hi = [hi[0].max(px), hi[1].max(py)];
        }
        Some([lo[0], lo[1], hi[0], hi[1]])
    }

    /// The 2D box `[left, top, right, bottom]` of a camera box in image 2: its eight corners
    /// projected with P2, then clipped to `[0, W−1] × [0, H−1]` (OpenPCDet's
    /// `boxes3d_kitti_camera_to_imageboxes`). `None` if a corner lies behind the camera or
    /// the box misses the image.
    pub fn image_bbox(&self, c: &CameraBox, size: ImageSize) -> Option<[f32; 4]> {
        let [l, t, r, b] = self.projected_bbox(c)?;
        let (w1, h1) = ((size.width - 1) as f64, (size.height - 1) as f64);
        if r < 0.0 || b < 0.0 || l > w1 || t > h1 {
            return None;
        }
        Some([l.clamp(0.0, w1), t.clamp(0.0, h1), r.clamp(0.0, w1), b.clamp(0.0, h1)].map(|v| v as f32))
    }

    /// Mask of the points that project into image 2 with non-negative depth (OpenPCDet's
    /// `get_fov_flag`, lingvo's `KITTIDropPointsOutOfFrustum`).
    pub fn fov_mask(&self, points: &[Point], size: ImageSize) -> Vec<bool> {
        let (w, h) = (size.width as f64, size.height as f64);
        points
            .iter()
            .map(|p| {
                let rect = self.lidar_to_rect([p[0] as f64, p[1] as f64, p[2] as f64]);
                let [u, v, _] = self.rect_to_image(rect);
                rect[2] >= 0.0 && (0.0..w).contains(&u) && (0.0..h).contains(&v)
            })
            .collect()
    }

    /// The points inside the camera field of view.
    pub fn crop_to_fov(&self, points: &[Point], size: ImageSize) -> Vec<Point> {
        let mask = self.fov_mask(points, size);
        points
            .iter()
            .zip(mask)
            .filter(|(_, keep)| *keep)
            .map(|(p, _)| *p)
            .collect()
    }
}

/// The observation angle of a camera box: `alpha = ry − atan2(x, z)`, wrapped to [−π, π).
pub fn observation_angle(c: &CameraBox) -> f32 {
    wrap_angle(c.ry - c.x.atan2(c.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kitti::calib::tests::SAMPLE;
    use proptest::prelude::*;
    use std::path::Path;

    fn calib() -> Calib {
        Calib::parse(SAMPLE, Path::new("c.txt")).unwrap()
    }

    #[test]
    fn approximate_axes() {
        // x_cam ≈ −y_velo, y_cam ≈ −z_velo − 0.08, z_cam ≈ x_velo + Tr[2, 3] (kitti-format.md §1);
        // by hand from the sample's Tr and R0_rect: (−0.038, −0.112, 9.667).
        let [x, y, z] = calib().lidar_to_rect([10.0, 0.0, 0.0]);
        assert!(
            (z - 9.667).abs() < 0.005 && (x + 0.038).abs() < 0.005 && (y + 0.112).abs() < 0.005,
            "{x} {y} {z}"
        );
    }

    #[test]
    fn box_round_trip_and_heading_convention() {
        let c = calib();
        let cam = CameraBox {
            h: 1.52,
            w: 1.63,
            l: 3.88,
            x: 2.0,
            y: 1.6,
            z: 20.0,
            ry: 0.0,
        };
        let b = c.label_to_box(&cam);
        // ry = 0 puts the length along camera +x = LiDAR −y: heading −π/2.
        assert!((b.heading + FRAC_PI_2).abs() < 1e-6);
        assert!((b.dx, b.dy, b.dz) == (3.88, 1.63, 1.52));
        let back = c.box_to_label(&b);
        for (u, v) in [(back.x, cam.x), (back.y, cam.y), (back.z, cam.z), (back.ry, cam.ry)] {
            assert!((u - v).abs() < 1e-5, "{back:?}");
        }
    }

    #[test]
    fn image_bbox_of_a_centred_car() {
        let c = calib();
        // A car 20 m ahead on the optical axis spans f·l/z = 707·1.63/20 ≈ 58 px across.
        let cam = CameraBox {
            h: 1.5,
            w: 3.9,
            l: 1.63,
            x: -0.06,
            y: 1.65,
            z: 20.0,
            ry: 0.0,
        };
        let [l, t, r, b] = c.image_bbox(&cam, ImageSize::KITTI).unwrap();
        assert!(l < 604.0 && r > 604.0 && (r - l - 60.0).abs() < 10.0, "{l} {r}");
        assert!(b > t && b < 375.0 && t > 0.0);
        let behind = CameraBox { z: -5.0, ..cam };
        assert_eq!(c.image_bbox(&behind, ImageSize::KITTI), None);
        let clipped = CameraBox { x: 3.5, z: 5.0, ..cam };
        assert_eq!(c.image_bbox(&clipped, ImageSize::KITTI).unwrap()[2], 1241.0);
    }

    #[test]
    fn fov_keeps_front_drops_back() {
        let c = calib();
        let pts = [[10.0, 0.0, -1.0, 0.1], [-10.0, 0.0, -1.0, 0.1], [5.0, 20.0, 0.0, 0.1]];
        assert_eq!(c.fov_mask(&pts, ImageSize::KITTI), vec![true, false, false]);
    }

    #[test]
    fn alpha_matches_definition() {
        let cam = CameraBox {
            h: 1.0,
            w: 1.0,
            l: 1.0,
            x: 5.0,
            y: 1.0,
            z: 5.0,
            ry: 1.0,
        };
        assert!((observation_angle(&cam) - (1.0 - std::f32::consts::FRAC_PI_4)).abs() < 1e-6);
    }

    proptest! {
        #[test]
        fn point_round_trip(x in -80f64..80., y in -40f64..40., z in -3f64..3.) {
            let c = calib();
            let [a, b, d] = c.rect_to_lidar(c.lidar_to_rect([x, y, z]));
            prop_assert!((a - x).abs() < 1e-9 && (b - y).abs() < 1e-9 && (d - z).abs() < 1e-9);
        }
    }
}
