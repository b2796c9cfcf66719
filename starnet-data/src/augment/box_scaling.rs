//! Per-object scaling (ST3D's random object scaling, Yang et al., CVPR 2021): each box and the
//! points inside it stretched by its own factors along its length, width and height, so that the
//! network reads an object's size from its points rather than learning the training data's mean
//! size: a detector trained on one source's cars meets other sizes elsewhere (the real street of
//! `kitti-real-dev` averages 1.63 m tall against KITTI's and the simulator's 1.52).

use super::transforms::{Scene, move_box_points};
use crate::{Box3d, Point};

/// Stretch factors along a box's length, width and height (1 leaves an axis alone).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxScale {
    /// Along the heading.
    pub length: f32,
    /// Across the heading.
    pub width: f32,
    /// Up, from the box's bottom.
    pub height: f32,
}

impl BoxScale {
    /// No stretch.
    pub const IDENTITY: Self = Self {
        length: 1.0,
        width: 1.0,
        height: 1.0,
    };

    /// The stretch that undoes this one.
    pub fn inverse(&self) -> Self {
        Self {
            length: 1.0 / self.length,
            width: 1.0 / self.width,
            height: 1.0 / self.height,
        }
    }
}

/// `b` stretched by `s`, its bottom and centre in bird's-eye view kept (an object stays on its
/// ground).
pub fn scaled_box(b: &Box3d, s: BoxScale) -> Box3d {
    let bottom = b.z - 0.5 * b.dz;
    let dz = b.dz * s.height;
    Box3d {
        z: bottom + 0.5 * dz,
        dx: b.dx * s.length,
        dy: b.dy * s.width,
        dz,
        ..*b
    }
}

/// One axis of the point map: inside the box (`|q| <= half`) stretched by `s` about the centre,
/// in the margin beyond it shifted with the box's face, so that the box grown by a margin maps
/// onto the stretched box grown by the same margin (and the map is inverted by `1 / s`).
fn stretch(q: f32, half: f32, s: f32) -> f32 {
    if q.abs() <= half {
        q * s
    } else {
        q.signum() * (half * s + q.abs() - half)
    }
}

/// Where point `p` inside `b` grown by a margin goes when `b` becomes [`scaled_box`]`(b, s)`.
pub fn scaled_point(b: &Box3d, s: BoxScale, p: &Point) -> Point {
    stretched_point(b, &scaled_box(b, s), s, p)
}

/// [`scaled_point`] with the stretched box `after` computed once per box, not per point.
fn stretched_point(before: &Box3d, after: &Box3d, s: BoxScale, p: &Point) -> Point {
    let q = before.to_local([p[0], p[1], p[2]]);
    // Heights are measured from the bottom, which stays (the grown box has no margin below it):
    // the box spans [0, dz] there.
    let up = stretch(q[2] + 0.5 * before.dz, before.dz, s.height);
    let moved = after.from_local([
        stretch(q[0], 0.5 * before.dx, s.length),
        stretch(q[1], 0.5 * before.dy, s.width),
        up - 0.5 * after.dz,
    ]);
    [moved[0], moved[1], moved[2], p[3]]
}

/// Stretches box `i` and the points inside it grown by `margin` ([`Box3d::grown`]) by `s`.
/// Inverse: `scale_box(i, s.inverse(), margin)`: the same points are inside the stretched box, as
/// long as a growing box took in no point that lay beyond it (a neighbour's).
pub fn scale_box(scene: &mut Scene, i: usize, s: BoxScale, margin: f32) {
    let (b, after) = (scene.boxes[i], scaled_box(&scene.boxes[i], s));
    for k in b.grown(margin).points_inside(&scene.points) {
        scene.points[k] = stretched_point(&b, &after, s, &scene.points[k]);
    }
    scene.boxes[i] = after;
}

/// [`scale_box`] for every box `i` by `scales[i]` in order (the identity leaves it alone), with the
/// same result, looking at each box's neighbourhood only.
pub fn scale_boxes(scene: &mut Scene, scales: &[BoxScale], margin: f32) {
    let stretched: Vec<usize> = (0..scales.len()).filter(|&i| scales[i] != BoxScale::IDENTITY).collect();
    let before = scene.boxes.clone();
    let after: Vec<Box3d> = stretched.iter().map(|&i| scaled_box(&before[i], scales[i])).collect();
    move_box_points(scene, stretched.iter().copied(), margin, |k, p| {
        let i = stretched[k];
        *p = stretched_point(&before[i], &after[k], scales[i], p);
    });
    for (k, i) in stretched.into_iter().enumerate() {
        scene.boxes[i] = after[k];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kitti::ObjectClass;

    fn car() -> Box3d {
        Box3d::new(10.0, 2.0, -0.9, 4.0, 1.6, 1.5, 0.5)
    }

    fn scene() -> Scene {
        let b = car();
        let mut points: Vec<Point> = Vec::new();
        // A lattice over the box grown by 0.1, and a far point.
        for i in 0..=20 {
            for j in 0..=10 {
                for k in 0..=10 {
                    let q = [
                        -2.05 + 4.1 * i as f32 / 20.0,
                        -0.85 + 1.7 * j as f32 / 10.0,
                        -0.7 + 1.5 * k as f32 / 10.0,
                    ];
                    let p = b.from_local(q);
                    points.push([p[0], p[1], p[2], 0.25]);
                }
            }
        }
        points.push([-20.0, 5.0, -1.7, 0.1]);
        Scene {
            points,
            boxes: vec![b, Box3d::new(30.0, -4.0, -0.8, 4.2, 1.7, 1.6, -1.0)],
            classes: vec![ObjectClass::Car, ObjectClass::Car],
        }
    }

    #[test]
    fn hand_values() {
        let b = Box3d::new(0.0, 0.0, 1.0, 4.0, 2.0, 2.0, 0.0); // bottom at z = 0
        let s = BoxScale {
            length: 1.1,
            width: 0.9,
            height: 1.2,
        };
        let after = scaled_box(&b, s);
        assert_eq!((after.dx, after.dy, after.dz), (4.4, 1.8, 2.4));
        assert!((after.z - 1.2).abs() < 1e-6, "the bottom stays at 0: {}", after.z);
        // Inside: stretched about the centre (x, y) and the bottom (z).
        let p = scaled_point(&b, s, &[1.0, 0.5, 1.5, 0.3]);
        let want = [1.1, 0.45, 1.8, 0.3];
        assert!((0..4).all(|k| (p[k] - want[k]).abs() < 1e-5), "{p:?}");
        // In the margin beyond the front face (x = 2) and above the top (z = 2): moved with the face.
        let p = scaled_point(&b, s, &[2.05, 0.0, 2.05, 0.3]);
        let want = [2.25, 0.0, 2.45, 0.3];
        assert!((0..4).all(|k| (p[k] - want[k]).abs() < 1e-5), "{p:?}");
    }

    #[test]
    fn the_inverse_undoes_it_and_the_counts_hold() {
        let s = scene();
        let margin = 0.1;
        let counts = |s: &Scene| -> Vec<usize> {
            s.boxes
                .iter()
                .map(|b| b.grown(margin).count_points_inside(&s.points))
                .collect()
        };
        for scale in [
            BoxScale {
                length: 1.1,
                width: 0.9,
                height: 1.15,
            },
            BoxScale {
                length: 0.8,
                width: 1.05,
                height: 0.9,
            },
        ] {
            let mut t = s.clone();
            scale_box(&mut t, 0, scale, margin);
            assert_ne!(t, s);
            assert_eq!(counts(&t), counts(&s));
            assert_eq!(t.points.last(), s.points.last(), "a point outside stays");
            scale_box(&mut t, 0, scale.inverse(), margin);
            let close = t
                .points
                .iter()
                .zip(&s.points)
                .all(|(p, q)| (0..4).all(|k| (p[k] - q[k]).abs() < 1e-4));
            assert!(close);
            let (a, b) = (t.boxes[0].to_array(), s.boxes[0].to_array());
            assert!(a.iter().zip(b).all(|(u, v)| (u - v).abs() < 1e-5), "{a:?} {b:?}");
        }
    }

    #[test]
    fn all_boxes_at_once_equals_one_by_one() {
        let s = scene();
        let scales = [
            BoxScale {
                length: 1.1,
                width: 0.95,
                height: 1.05,
            },
            BoxScale::IDENTITY,
        ];
        let mut one_by_one = s.clone();
        scale_box(&mut one_by_one, 0, scales[0], 0.1);
        let mut at_once = s.clone();
        scale_boxes(&mut at_once, &scales, 0.1);
        assert_eq!(at_once, one_by_one);
        let mut none = s.clone();
        scale_boxes(&mut none, &[BoxScale::IDENTITY; 2], 0.1);
        assert_eq!(none, s);
    }
}
