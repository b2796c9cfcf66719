//! Rotated IoU of boxes: bird's-eye view (footprints) and 3D (footprint overlap × z overlap).

use super::{Box3d, convex_intersection_area, convex_separated};

/// Which IoU a matrix holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IouKind {
    /// Rotated footprint IoU in the x–y plane.
    Bev,
    /// Rotated 3D IoU: footprint intersection × z overlap over the union of volumes.
    ThreeD,
}

/// A box with its footprint's corners and bounding circle computed once, for the many IoUs of
/// an assignment or a matrix ([`iou_bev_prepared`], [`iou_3d_prepared`]; [`iou_bev`] and
/// [`iou_3d`] prepare their two boxes and call them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreparedBox {
    /// The box.
    pub b: Box3d,
    radius: f32,
    corners: [[f64; 2]; 4],
    /// The heading's `[cos, sin]`.
    axis: [f64; 2],
}

impl PreparedBox {
    /// Prepares `b`.
    pub fn new(b: &Box3d) -> Self {
        let (s, c) = (b.heading as f64).sin_cos();
        Self {
            b: *b,
            radius: b.bev_radius(),
            corners: b.corners_bev_f64(),
            axis: [c, s],
        }
    }

    /// The area of the footprint's overlap with the bounding rectangle, in this box's frame, of
    /// `other`'s footprint: at least their intersection's.
    fn overlap_in_own_frame(&self, other: &PreparedBox) -> f64 {
        let ([c, s], [oc, os]) = (self.axis, other.axis);
        let (dx, dy) = ((other.b.x - self.b.x) as f64, (other.b.y - self.b.y) as f64);
        // The other's centre and half-extents along this box's two axes.
        let (u, v) = (c * dx + s * dy, c * dy - s * dx);
        let (cos, sin) = ((c * oc + s * os).abs(), (c * os - s * oc).abs());
        let (hl, hw) = (0.5 * other.b.dx as f64, 0.5 * other.b.dy as f64);
        let (hu, hv) = (hl * cos + hw * sin, hl * sin + hw * cos);
        let overlap = |at: f64, half: f64, own: f64| ((at + half).min(own) - (at - half).max(-own)).max(0.0);
        overlap(u, hu, 0.5 * self.b.dx as f64) * overlap(v, hv, 0.5 * self.b.dy as f64)
    }

    /// Whether the footprints' bounding circles touch (the footprints can overlap only then).
    fn circle_touches(&self, other: &PreparedBox) -> bool {
        let (dx, dy) = ((self.b.x - other.b.x) as f64, (self.b.y - other.b.y) as f64);
        let r = (self.radius + other.radius) as f64;
        dx * dx + dy * dy <= r * r
    }
}

/// Footprint intersection area, 0 when the bounding circles do not touch or an edge separates
/// the footprints (two cheap tests before the clip: most pairs of an anchor assignment fail one).
fn bev_intersection(a: &PreparedBox, b: &PreparedBox) -> f64 {
    if !a.circle_touches(b) || convex_separated(&a.corners, &b.corners) {
        return 0.0;
    }
    convex_intersection_area(&a.corners, &b.corners)
}

/// [`iou_bev`] of prepared boxes.
pub fn iou_bev_prepared(a: &PreparedBox, b: &PreparedBox) -> f32 {
    let inter = bev_intersection(a, b);
    ratio(inter, a.b.bev_area() as f64, b.b.bev_area() as f64)
}

/// An upper bound of [`iou_bev_prepared`] that needs no clip: in each box's frame the other
/// footprint lies inside its bounding rectangle there, so the intersection is at most the
/// smaller of the two rectangles' overlaps with the box (exact for boxes of one heading, about
/// 0 when an edge separates them). Where a bound settles a comparison, the clip can be skipped.
pub fn iou_bev_upper_bound(a: &PreparedBox, b: &PreparedBox) -> f32 {
    let inter = a.overlap_in_own_frame(b).min(b.overlap_in_own_frame(a));
    // Enough to cover the rounding of both computations: the bound must never fall below the
    // clipped value.
    ratio(
        inter * (1.0 + 1e-9) + 1e-12,
        a.b.bev_area() as f64,
        b.b.bev_area() as f64,
    )
}

/// [`iou_3d`] of prepared boxes.
pub fn iou_3d_prepared(a: &PreparedBox, b: &PreparedBox) -> f32 {
    let ((a0, a1), (b0, b1)) = (a.b.z_range(), b.b.z_range());
    let dz = (a1.min(b1) - a0.max(b0)) as f64;
    if dz <= 0.0 {
        return 0.0;
    }
    let inter = bev_intersection(a, b) * dz;
    ratio(inter, a.b.volume() as f64, b.b.volume() as f64)
}

/// IoU of two areas (or volumes) given their intersection; 0 for a degenerate union.
fn ratio(inter: f64, a: f64, b: f64) -> f32 {
    let union = a + b - inter;
    if union <= 0.0 {
        0.0
    } else {
        (inter / union).clamp(0.0, 1.0) as f32
    }
}

/// Rotated bird's-eye-view IoU.
///
/// ```
/// # use starnet_data::{Box3d, geometry::iou_bev};
/// let a = Box3d::new(0.0, 0.0, 0.0, 2.0, 2.0, 1.0, 0.0);
/// let b = Box3d::new(1.0, 0.0, 0.0, 2.0, 2.0, 1.0, 0.0);
/// assert!((iou_bev(&a, &b) - 1.0 / 3.0).abs() < 1e-6);
/// ```
pub fn iou_bev(a: &Box3d, b: &Box3d) -> f32 {
    iou_bev_prepared(&PreparedBox::new(a), &PreparedBox::new(b))
}

/// Rotated 3D IoU: the footprint intersection times the overlap of the z ranges, over the
/// union of the volumes (the KITTI devkit's definition).
pub fn iou_3d(a: &Box3d, b: &Box3d) -> f32 {
    iou_3d_prepared(&PreparedBox::new(a), &PreparedBox::new(b))
}

/// Pairwise IoU, row-major `[a.len(), b.len()]`. Pairs whose bounding circles (and, for 3D,
/// z ranges) are apart are 0 without clipping, which makes sparse scenes cheap.
pub fn iou_matrix(a: &[Box3d], b: &[Box3d], kind: IouKind) -> Vec<f32> {
    let f = match kind {
        IouKind::Bev => iou_bev_prepared,
        IouKind::ThreeD => iou_3d_prepared,
    };
    let b: Vec<PreparedBox> = b.iter().map(PreparedBox::new).collect();
    let mut m = Vec::with_capacity(a.len() * b.len());
    for x in a.iter().map(PreparedBox::new) {
        m.extend(b.iter().map(|y| f(&x, y)));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use std::f32::consts::PI;

    fn arb_box() -> impl Strategy<Value = Box3d> {
        (
            -3f32..3.,
            -3f32..3.,
            -1f32..1.,
            0.3f32..5.,
            0.3f32..3.,
            0.3f32..2.,
            -PI..PI,
        )
            .prop_map(|(x, y, z, dx, dy, dz, h)| Box3d::new(x, y, z, dx, dy, dz, h))
    }

    /// Moves both boxes by the same rotation about the origin and translation.
    fn rigid(b: &Box3d, angle: f32, t: [f32; 2]) -> Box3d {
        let (s, c) = angle.sin_cos();
        Box3d::new(
            c * b.x - s * b.y + t[0],
            s * b.x + c * b.y + t[1],
            b.z,
            b.dx,
            b.dy,
            b.dz,
            b.heading + angle,
        )
    }

    #[test]
    fn hand_computed_values() {
        let a = Box3d::new(0.0, 0.0, 0.0, 2.0, 2.0, 2.0, 0.0);
        // Same footprint rotated 45°: intersection is a regular octagon of area 8(√2 − 1).
        let b = Box3d::new(0.0, 0.0, 0.0, 2.0, 2.0, 2.0, PI / 4.0);
        let oct = 8.0 * (2f32.sqrt() - 1.0);
        assert!((iou_bev(&a, &b) - oct / (8.0 - oct)).abs() < 1e-5);
        // Shifted up by half its height: BEV IoU 1, 3D IoU = 4 / (8 + 8 - 4) = 1/3.
        let c = Box3d::new(0.0, 0.0, 1.0, 2.0, 2.0, 2.0, 0.0);
        assert!((iou_bev(&a, &c) - 1.0).abs() < 1e-6);
        assert!((iou_3d(&a, &c) - 1.0 / 3.0).abs() < 1e-6);
        // The bound: exact for one heading (1/3 for two 2 × 2 squares 1 apart); for the 45°
        // square, the overlap of a with the 2√2 square around b, 4, in either frame.
        let bound = |a: &Box3d, b: &Box3d| iou_bev_upper_bound(&PreparedBox::new(a), &PreparedBox::new(b));
        let shifted = Box3d::new(1.0, 0.0, 0.0, 2.0, 2.0, 2.0, 0.0);
        assert!((bound(&a, &shifted) - 1.0 / 3.0).abs() < 1e-6);
        assert!((bound(&a, &b) - 1.0).abs() < 1e-6);
        // Apart: 0 but for the slack that covers rounding.
        assert!(bound(&a, &Box3d::new(3.5, 0.0, 0.0, 2.0, 2.0, 2.0, PI / 4.0)) < 1e-9);
        // Touching edges and far apart: 0.
        assert_eq!(iou_bev(&a, &Box3d::new(2.0, 0.0, 0.0, 2.0, 2.0, 2.0, 0.0)), 0.0);
        assert_eq!(iou_3d(&a, &Box3d::new(0.0, 0.0, 5.0, 2.0, 2.0, 2.0, 0.0)), 0.0);
    }

    #[test]
    fn matrix_layout_matches_pairwise_calls() {
        let a = [
            Box3d::new(0.0, 0.0, 0.0, 2.0, 2.0, 2.0, 0.0),
            Box3d::new(10.0, 0.0, 0.0, 2.0, 2.0, 2.0, 0.0),
        ];
        let b = [
            Box3d::new(1.0, 0.0, 0.0, 2.0, 2.0, 2.0, 0.3),
            Box3d::new(10.0, 0.5, 0.2, 2.0, 2.0, 2.0, 0.0),
            a[0],
        ];
        for kind in [IouKind::Bev, IouKind::ThreeD] {
            let m = iou_matrix(&a, &b, kind);
            assert_eq!(m.len(), 6);
            for (i, x) in a.iter().enumerate() {
                for (j, y) in b.iter().enumerate() {
                    let want = if kind == IouKind::Bev {
                        iou_bev(x, y)
                    } else {
                        iou_3d(x, y)
                    };
                    assert_eq!(m[i * 3 + j], want);
                }
            }
            assert_eq!(m[2], 1.0);
            assert_eq!(m[3], 0.0);
        }
    }

    /// Independent oracle: `geo`'s boolean polygon intersection on 1,000 random pairs.
    #[test]
    fn bev_iou_matches_geo_oracle() {
        use geo::{Area, BooleanOps, LineString, Polygon};
        let poly = |b: &Box3d| {
            let ring: Vec<(f64, f64)> = b.corners_bev_f64().iter().map(|p| (p[0], p[1])).collect();
            Polygon::new(LineString::from(ring), vec![])
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let rand_box = |rng: &mut rand_chacha::ChaCha8Rng| {
            Box3d::new(
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                0.0,
                rng.random_range(0.5..5.0),
                rng.random_range(0.5..3.0),
                1.0,
                rng.random_range(-PI..PI),
            )
        };
        let (mut max_err, mut overlapping) = (0f64, 0);
        for _ in 0..1000 {
            let (a, b) = (rand_box(&mut rng), rand_box(&mut rng));
            let (pa, pb) = (poly(&a), poly(&b));
            let inter = pa.intersection(&pb).unsigned_area();
            let want = inter / (pa.unsigned_area() + pb.unsigned_area() - inter);
            overlapping += (want > 0.0) as usize;
            max_err = max_err.max((iou_bev(&a, &b) as f64 - want).abs());
        }
        assert!(overlapping > 500, "the oracle test should mostly exercise overlaps");
        assert!(
            max_err <= 1e-4,
            "max |iou - geo| = {max_err:e} over 1000 pairs, {overlapping} overlapping"
        );
    }

    proptest! {
        #[test]
        fn symmetric_and_bounded(a in arb_box(), b in arb_box()) {
            let (ab, ba) = (iou_bev(&a, &b), iou_bev(&b, &a));
            prop_assert!((ab - ba).abs() < 1e-5);
            prop_assert!((0.0..=1.0).contains(&ab));
            let (ab3, ba3) = (iou_3d(&a, &b), iou_3d(&b, &a));
            prop_assert!((ab3 - ba3).abs() < 1e-5);
            prop_assert!((0.0..=1.0).contains(&ab3));
        }

        #[test]
        fn the_upper_bound_bounds_and_is_exact_for_one_heading(a in arb_box(), b in arb_box()) {
            let (pa, pb) = (PreparedBox::new(&a), PreparedBox::new(&b));
            prop_assert!(iou_bev_prepared(&pa, &pb) <= iou_bev_upper_bound(&pa, &pb));
            let c = PreparedBox::new(&Box3d { heading: a.heading, ..b });
            prop_assert!((iou_bev_upper_bound(&pa, &c) - iou_bev_prepared(&pa, &c)).abs() < 1e-5);
        }

        #[test]
        fn self_iou_is_one(a in arb_box()) {
            prop_assert!((iou_bev(&a, &a) - 1.0).abs() < 1e-5);
            prop_assert!((iou_3d(&a, &a) - 1.0).abs() < 1e-5);
        }

        #[test]
        fn invariant_under_common_rigid_motion(a in arb_box(), b in arb_box(), angle in -PI..PI, tx in -50f32..50., ty in -50f32..50.) {
            let (ra, rb) = (rigid(&a, angle, [tx, ty]), rigid(&b, angle, [tx, ty]));
            prop_assert!((iou_bev(&a, &b) - iou_bev(&ra, &rb)).abs() < 1e-3);
            prop_assert!((iou_3d(&a, &b) - iou_3d(&ra, &rb)).abs() < 1e-3);
        }

        #[test]
        fn heading_plus_pi_is_the_same_box(a in arb_box(), b in arb_box()) {
            let flipped = Box3d::new(a.x, a.y, a.z, a.dx, a.dy, a.dz, a.heading + PI);
            prop_assert!((iou_bev(&a, &b) - iou_bev(&flipped, &b)).abs() < 1e-5);
            prop_assert!((iou_3d(&a, &b) - iou_3d(&flipped, &b)).abs() < 1e-5);
        }

        #[test]
        fn three_d_at_most_bev_for_equal_heights(a in arb_box(), b in arb_box()) {
            let b = Box3d { dz: a.dz, ..b };
            prop_assert!(iou_3d(&a, &b) <= iou_bev(&a, &b) + 1e-6);
        }
    }
}
