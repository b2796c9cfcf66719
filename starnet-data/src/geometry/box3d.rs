//! The box type and its conventions (see the crate docs for the layout diagram).

use crate::Point;
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;

/// Wraps an angle to [−π, π).
///
/// ```
/// # use starnet_data::wrap_angle;
/// assert!((wrap_angle(3.0 * std::f32::consts::PI / 2.0) + std::f32::consts::FRAC_PI_2).abs() < 1e-6);
/// assert_eq!(wrap_angle(std::f32::consts::PI), -std::f32::consts::PI);
/// ```
pub fn wrap_angle(a: f32) -> f32 {
    let two_pi = 2.0 * PI;
    let w = a - two_pi * ((a + PI) / two_pi).floor();
    // Rounding can land exactly on +π; the interval is half-open.
    if w >= PI { w - two_pi } else { w }
}

/// A 3D box in the LiDAR frame: centre `(x, y, z)`, extents `(dx, dy, dz)` = (length along
/// the heading, width, height), `heading` counter-clockwise about +z from +x in [−π, π).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Box3d {
    /// Centre x (forward), metres.
    pub x: f32,
    /// Centre y (left), metres.
    pub y: f32,
    /// Centre z (up), metres.
    pub z: f32,
    /// Length: extent along the heading.
    pub dx: f32,
    /// Width: extent across the heading.
    pub dy: f32,
    /// Height.
    pub dz: f32,
    /// Heading in radians, counter-clockwise about +z from +x.
    pub heading: f32,
}

impl Box3d {
    /// A box from its seven numbers; the heading is wrapped to [−π, π).
    pub fn new(x: f32, y: f32, z: f32, dx: f32, dy: f32, dz: f32, heading: f32) -> Self {
        Self {
            x,
            y,
            z,
            dx,
            dy,
            dz,
            heading: wrap_angle(heading),
        }
    }

    /// From `[x, y, z, dx, dy, dz, heading]`.
    pub fn from_array(a: [f32; 7]) -> Self {
        Self::new(a[0], a[1], a[2], a[3], a[4], a[5], a[6])
    }

    /// To `[x, y, z, dx, dy, dz, heading]`.
    pub fn to_array(&self) -> [f32; 7] {
        [self.x, self.y, self.z, self.dx, self.dy, self.dz, self.heading]
    }

    /// The box mirrored left to right, y → −y (heading → −heading): what the sensor would see
    /// of it in a mirrored world. Its own inverse.
    pub fn mirrored(&self) -> Self {
        Self::new(self.x, -self.y, self.z, self.dx, self.dy, self.dz, -self.heading)
    }

    /// Footprint area `dx · dy`.
    pub fn bev_area(&self) -> f32 {
        self.dx * self.dy
    }

    /// Volume `dx · dy · dz`.
    pub fn volume(&self) -> f32 {
        self.dx * self.dy * self.dz
    }

    /// Radius of the footprint's circumscribed circle: two boxes whose centres are farther
    /// apart than the sum of their radii cannot overlap.
    pub fn bev_radius(&self) -> f32 {
        0.5 * self.dx.hypot(self.dy)
    }

    /// Bottom and top z.
    pub fn z_range(&self) -> (f32, f32) {
        (self.z - 0.5 * self.dz, self.z + 0.5 * self.dz)
    }

    /// The four footprint corners `[x, y]`, counter-clockwise seen from above, starting at
    /// front-right: 0 = (+dx/2, −dy/2), 1 = (+dx/2, +dy/2), 2 = (−dx/2, +dy/2),
    /// 3 = (−dx/2, −dy/2) in the box's own frame.
    pub fn corners_bev(&self) -> [[f32; 2]; 4] {
        self.corners_bev_f64().map(|[x, y]| [x as f32, y as f32])
    }

    /// [`Self::corners_bev`] in f64, as the IoU code uses them.
    pub(crate) fn corners_bev_f64(&self) -> [[f64; 2]; 4] {
        let (s, c) = (self.heading as f64).sin_cos();
        let (hx, hy) = (0.5 * self.dx as f64, 0.5 * self.dy as f64);
        [[hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]]
            .map(|[u, v]| [self.x as f64 + c * u - s * v, self.y as f64 + s * u + c * v])
    }

    /// The eight corners `[x, y, z]`: the footprint corners at the bottom (0..4), then the
    /// same corners at the top (4..8).
    pub fn corners_3d(&self) -> [[f32; 3]; 8] {
        let bev = self.corners_bev();
        let (z0, z1) = self.z_range();
        std::array::from_fn(|i| {
            let [x, y] = bev[i % 4];
            [x, y, if i < 4 { z0 } else { z1 }]
        })
    }

    /// A point in the box's own frame (x along the heading), relative to its centre.
    pub fn to_local(&self, p: [f32; 3]) -> [f32; 3] {
        let (s, c) = self.heading.sin_cos();
        let (dx, dy) = (p[0] - self.x, p[1] - self.y);
        [c * dx + s * dy, -s * dx + c * dy, p[2] - self.z]
    }

    /// The inverse of [`Self::to_local`].
    pub fn from_local(&self, q: [f32; 3]) -> [f32; 3] {
        let (s, c) = self.heading.sin_cos();
        [
            self.x + c * q[0] - s * q[1],
            self.y + s * q[0] + c * q[1],
            self.z + q[2],
        ]
    }

    /// Whether `p` (x, y, z) lies inside the box or on its surface.
    pub fn contains(&self, p: [f32; 3]) -> bool {
        self.containment()(p)
    }

    /// [`Self::contains`] as a test with the rotation computed once, for testing many points
    /// (the same arithmetic as [`Self::to_local`], so the same answers).
    pub fn containment(&self) -> impl Fn([f32; 3]) -> bool + Copy + use<> {
        let (s, c) = self.heading.sin_cos();
        // A small tolerance keeps points sampled on a face inside despite rounding.
        const EPS: f32 = 1e-5;
        let (x, y, z) = (self.x, self.y, self.z);
        let half = [0.5 * self.dx + EPS, 0.5 * self.dy + EPS, 0.5 * self.dz + EPS];
        move |p: [f32; 3]| {
            let (dx, dy) = (p[0] - x, p[1] - y);
            let (u, v, w) = (c * dx + s * dy, -s * dx + c * dy, p[2] - z);
            u.abs() <= half[0] && v.abs() <= half[1] && w.abs() <= half[2]
        }
    }

    /// The box grown by `margin` metres on its four sides and its top, its bottom left where it
    /// is. Simulated and real returns of an object scatter a few centimetres about its surface
    /// (range noise), so the points *of* an object are those inside a slightly grown box; the
    /// bottom stays put so that the ground under it is not taken. `grown(−m)` undoes `grown(m)`.
    pub fn grown(&self, margin: f32) -> Self {
        Self {
            z: self.z + 0.5 * margin,
            dx: self.dx + 2.0 * margin,
            dy: self.dy + 2.0 * margin,
            dz: self.dz + margin,
            ..*self
        }
    }

    /// Indices of the points of `cloud` inside the box (in cloud order).
    pub fn points_inside(&self, cloud: &[Point]) -> Vec<usize> {
        let holds = self.point_test();
        let mut inside = Vec::new();
        for (i, p) in cloud.iter().enumerate() {
            if holds(p) {
                inside.push(i);
            }
        }
        inside
    }

    /// The test [`Self::points_inside`] applies to each point: within the box's bird's-eye
    /// circle (a cheap rejection of most of a sweep: one product on x first), then
    /// [`Self::containment`].
    pub fn point_test(&self) -> impl Fn(&Point) -> bool + Copy + use<> {
        let r = self.bev_radius() + 1e-3;
        let r2 = r * r;
        let inside = self.containment();
        let (x, y) = (self.x, self.y);
        move |p: &Point| {
            let dx = p[0] - x;
            // dx² > r² implies dx² + dy² > r² (adding a square never rounds below dx²), so this
            // only skips points the circle test rejects.
            if dx * dx > r2 {
                return false;
            }
            let dy = p[1] - y;
            dx * dx + dy * dy <= r2 && inside([p[0], p[1], p[2]])
        }
    }

    /// Number of points of `cloud` inside the box.
    pub fn count_points_inside(&self, cloud: &[Point]) -> usize {
        self.points_inside(cloud).len()
    }

    /// The azimuth angle the box subtends seen from the sensor in bird's-eye view, radians
    /// (2π when the sensor is inside it): how many streaming slices it can cross.
    pub fn subtended_angle(&self) -> f32 {
        let c = self.corners_bev();
        if self
            .to_local([0.0, 0.0, self.z])
            .iter()
            .take(2)
            .zip([self.dx, self.dy])
            .all(|(v, d)| v.abs() <= 0.5 * d)
        {
            return std::f32::consts::TAU;
        }
        let mid = self.y.atan2(self.x);
        let rel = c.map(|p| wrap_angle(p[1].atan2(p[0]) - mid));
        let max = rel.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let min = rel.iter().copied().fold(f32::INFINITY, f32::min);
        max - min
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn wrap_angle_hand_values() {
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-7);
        assert!((wrap_angle(-PI - 0.25) - (PI - 0.25)).abs() < 1e-6);
        assert!((wrap_angle(7.0 * PI) + PI).abs() < 1e-5);
        assert_eq!(wrap_angle(-PI), -PI);
    }

    #[test]
    fn mirroring_negates_y_and_heading_and_undoes_itself() {
        let b = Box3d::new(12.0, 3.5, -0.9, 4.2, 1.7, 1.5, 0.4);
        let m = b.mirrored();
        assert_eq!(m.to_array(), [12.0, -3.5, -0.9, 4.2, 1.7, 1.5, -0.4]);
        assert_eq!(m.mirrored(), b);
        // A box pointing along −x stays within [−π, π).
        assert_eq!(Box3d::new(1.0, 1.0, 0.0, 1.0, 1.0, 1.0, -PI).mirrored().heading, -PI);
        // The corners are the mirrored corners: front-right becomes front-left, and so on.
        let (cb, cm) = (b.corners_bev(), m.corners_bev());
        for k in 0..4 {
            let (c, d) = (cb[k ^ 1], cm[k]);
            assert!(
                (c[0] - d[0]).abs() < 1e-5 && (c[1] + d[1]).abs() < 1e-5,
                "{c:?} vs {d:?}"
            );
        }
    }

    #[test]
    fn subtended_angle_hand_values() {
        let close =
            |b: Box3d, v: f32| assert!((b.subtended_angle() - v).abs() < 1e-5, "{b:?}: {}", b.subtended_angle());
        // Nearest edge at 9 m, 1 m either side: 2·atan(1/9).
        close(
            Box3d::new(10.0, 0.0, -1.0, 2.0, 2.0, 1.5, 0.0),
            2.0 * (1.0f32 / 9.0).atan(),
        );
        // Turned 90°: 4 m across at 9 m.
        close(
            Box3d::new(10.0, 0.0, -1.0, 4.0, 2.0, 1.5, std::f32::consts::FRAC_PI_2),
            2.0 * (2.0f32 / 9.0).atan(),
        );
        // Straddling the ±180° seam behind the sensor.
        close(
            Box3d::new(-10.0, 0.0, -1.0, 2.0, 2.0, 1.5, 0.3),
            Box3d::new(10.0, 0.0, -1.0, 2.0, 2.0, 1.5, 0.3).subtended_angle(),
        );
        // Around the sensor.
        close(Box3d::new(0.5, 0.0, -1.0, 4.0, 2.0, 1.5, 0.0), std::f32::consts::TAU);
    }

    #[test]
    fn corners_of_an_axis_aligned_box() {
        let b = Box3d::new(1.0, 2.0, 3.0, 4.0, 2.0, 1.0, 0.0);
        assert_eq!(b.corners_bev(), [[3.0, 1.0], [3.0, 3.0], [-1.0, 3.0], [-1.0, 1.0]]);
        let c = b.corners_3d();
        assert_eq!(c[0], [3.0, 1.0, 2.5]);
        assert_eq!(c[6], [-1.0, 3.0, 3.5]);
    }

    #[test]
    fn corners_rotate_counter_clockwise() {
        // Heading +90°: the box's front (+x local) points along +y.
        let b = Box3d::new(0.0, 0.0, 0.0, 4.0, 2.0, 1.0, std::f32::consts::FRAC_PI_2);
        let [x, y] = b.corners_bev()[0]; // front-right = local (2, -1) -> world (1, 2)
        assert!((x - 1.0).abs() < 1e-6 && (y - 2.0).abs() < 1e-6, "{x} {y}");
    }

    #[test]
    fn growing_keeps_the_bottom_and_round_trips() {
        let b = Box3d::new(5.0, 1.0, -1.0, 4.0, 2.0, 1.5, 0.7);
        let g = b.grown(0.1);
        assert!((g.z_range().0 - b.z_range().0).abs() < 1e-6);
        assert!((g.z_range().1 - b.z_range().1 - 0.1).abs() < 1e-6);
        assert!((g.dx - 4.2).abs() < 1e-6 && (g.dy - 2.2).abs() < 1e-6);
        let back = g.grown(-0.1);
        assert!(
            b.to_array()
                .iter()
                .zip(back.to_array())
                .all(|(a, c)| (a - c).abs() < 1e-6)
        );
        // 5 cm beyond the front face, in the box's frame: outside the box, inside the grown one;
        // 2 cm below the bottom: outside both.
        let front = b.from_local([2.05, 0.0, 0.0]);
        let below = b.from_local([0.0, 0.0, -0.77]);
        assert!(!b.contains(front) && g.contains(front));
        assert!(!b.contains(below) && !g.contains(below));
    }

    #[test]
    fn contains_and_points_inside() {
        let b = Box3d::new(10.0, 0.0, -1.0, 4.0, 2.0, 1.5, 0.3);
        let inside = b.from_local([1.9, -0.9, 0.7]);
        let outside = b.from_local([2.1, 0.0, 0.0]);
        let above = b.from_local([0.0, 0.0, 0.8]);
        let cloud = [
            [inside[0], inside[1], inside[2], 0.1],
            [outside[0], outside[1], outside[2], 0.1],
            [above[0], above[1], above[2], 0.1],
        ];
        assert_eq!(b.points_inside(&cloud), vec![0]);
    }

    proptest! {
        #[test]
        fn containment_is_the_local_frame_test(x in -50f32..50., y in -50f32..50., h in -4f32..4., u in -3f32..3., v in -2f32..2., w in -1.5f32..1.5) {
            let b = Box3d::new(x, y, -1.0, 4.0, 2.0, 1.5, h);
            let p = b.from_local([u, v, w]);
            let [lu, lv, lw] = b.to_local(p);
            let want = lu.abs() <= 2.0 + 1e-5 && lv.abs() <= 1.0 + 1e-5 && lw.abs() <= 0.75 + 1e-5;
            prop_assert_eq!(b.contains(p), want);
        }

        #[test]
        fn local_round_trip(x in -50f32..50., y in -50f32..50., h in -4f32..4., px in -60f32..60., py in -60f32..60., pz in -3f32..3.) {
            let b = Box3d::new(x, y, 0.5, 4.0, 2.0, 1.5, h);
            let q = b.from_local(b.to_local([px, py, pz]));
            prop_assert!((q[0] - px).abs() < 1e-3 && (q[1] - py).abs() < 1e-3 && (q[2] - pz).abs() < 1e-5);
        }

        #[test]
        fn wrap_angle_range_and_equivalence(a in -100f32..100.) {
            let w = wrap_angle(a);
            prop_assert!((-PI..PI).contains(&w));
            prop_assert!((w.sin() - a.sin()).abs() < 1e-4 && (w.cos() - a.cos()).abs() < 1e-4);
        }

        #[test]
        fn array_round_trip(a in proptest::array::uniform7(-10f32..10.)) {
            let b = Box3d::from_array(a);
            prop_assert_eq!(Box3d::from_array(b.to_array()), b);
        }
    }
}
