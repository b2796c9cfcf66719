//! The geometric transforms of augmentation as pure functions on a [`Scene`], each with its
//! inverse. Points and boxes always move together.

use super::near::{near_grid, points_near};
use crate::kitti::ObjectClass;
use crate::{Box3d, Point, wrap_angle};

/// A labelled point cloud as augmentation sees it (LiDAR frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Points `[N, 4]`.
    pub points: Vec<Point>,
    /// Object boxes.
    pub boxes: Vec<Box3d>,
    /// Their classes.
    pub classes: Vec<ObjectClass>,
}

fn rot(x: f32, y: f32, a: f32) -> (f32, f32) {
    let (s, c) = a.sin_cos();
    (c * x - s * y, s * x + c * y)
}

/// Rotates everything by `angle` about the sensor's z axis. Inverse: `rotate_z(−angle)`.
pub fn rotate_z(scene: &mut Scene, angle: f32) {
    for p in &mut scene.points {
        (p[0], p[1]) = rot(p[0], p[1], angle);
    }
    for b in &mut scene.boxes {
        (b.x, b.y) = rot(b.x, b.y, angle);
        b.heading = wrap_angle(b.heading + angle);
    }
}

/// Mirrors y → −y (heading → −heading). Its own inverse.
pub fn flip_y(scene: &mut Scene) {
    for p in &mut scene.points {
        p[1] = -p[1];
    }
    for b in &mut scene.boxes {
        *b = b.mirrored();
    }
}

/// Scales positions and box sizes by `s` about the sensor. Inverse: `scale(1 / s)`.
pub fn scale(scene: &mut Scene, s: f32) {
    for p in &mut scene.points {
        p[0] *= s;
        p[1] *= s;
        p[2] *= s;
    }
    for b in &mut scene.boxes {
        (b.x, b.y, b.z, b.dx, b.dy, b.dz) = (b.x * s, b.y * s, b.z * s, b.dx * s, b.dy * s, b.dz * s);
    }
}

/// Shifts everything by `dz` along z. Inverse: `shift_z(−dz)`.
pub fn shift_z(scene: &mut Scene, dz: f32) {
    scene.points.iter_mut().for_each(|p| p[2] += dz);
    scene.boxes.iter_mut().for_each(|b| b.z += dz);
}

/// Rotates box `i` and the points inside it grown by `margin` ([`Box3d::grown`]: the object's
/// returns scatter about its surface) by `angle` about the box's centre. Inverse:
/// `rotate_box(i, −angle, margin)` (the same points are inside the rotated box).
pub fn rotate_box(scene: &mut Scene, i: usize, angle: f32, margin: f32) {
    let b = scene.boxes[i];
    for k in b.grown(margin).points_inside(&scene.points) {
        let p = &mut scene.points[k];
        let (x, y) = rot(p[0] - b.x, p[1] - b.y, angle);
        (p[0], p[1]) = (x + b.x, y + b.y);
    }
    scene.boxes[i].heading = wrap_angle(b.heading + angle);
}

/// [`rotate_box`] for every box `i` by `angles[i]` in order (0 leaves it alone), with the same
/// result, looking at each box's neighbourhood only (the points are put in a grid once).
pub fn rotate_boxes(scene: &mut Scene, angles: &[f32], margin: f32) {
    let turned: Vec<(usize, f32)> = angles.iter().copied().enumerate().filter(|(_, a)| *a != 0.0).collect();
    let boxes = scene.boxes.clone();
    move_box_points(scene, turned.iter().map(|(i, _)| *i), margin, |k, p| {
        let (b, angle) = (boxes[turned[k].0], turned[k].1);
        let (x, y) = rot(p[0] - b.x, p[1] - b.y, angle);
        (p[0], p[1]) = (x + b.x, y + b.y);
    });
    for (i, angle) in turned {
        scene.boxes[i].heading = wrap_angle(boxes[i].heading + angle);
    }
}

/// Moves the points inside each of `boxes` (indices, in order) grown by `margin` with
/// `move_point(k, point)`, `k` the box's position in `boxes`, as if each box took its points from
/// the whole cloud in turn, but looking at each box's neighbourhood only: the points are put in a
/// grid once, and a point is inside a box now either near where it was put in the grid or because
/// an earlier box moved it, so those are looked at too. The boxes themselves are left as they
/// were (the caller updates them).
pub(crate) fn move_box_points(
    scene: &mut Scene,
    boxes: impl Iterator<Item = usize>,
    margin: f32,
    mut move_point: impl FnMut(usize, &mut Point),
) {
    let grid = near_grid(&scene.points);
    let mut moved: Vec<u32> = Vec::new();
    let mut near = Vec::new();
    for (k, i) in boxes.enumerate() {
        let grown = scene.boxes[i].grown(margin);
        let holds = grown.point_test();
        points_near(&grid, &grown, &mut near);
        near.extend_from_slice(&moved);
        near.sort_unstable();
        near.dedup();
        near.retain(|&n| holds(&scene.points[n as usize]));
        for &n in &near {
            move_point(k, &mut scene.points[n as usize]);
        }
        moved.extend_from_slice(&near);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn scene() -> Scene {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let boxes = vec![
            Box3d::new(10.0, 3.0, -0.9, 4.0, 1.7, 1.5, 0.4),
            Box3d::new(-6.0, -8.0, -0.8, 0.8, 0.7, 1.7, -2.0),
        ];
        // Background points stay 3 m clear of the boxes: a per-box rotation sweeps its box over
        // new ground and would otherwise pick up neighbours (lingvo's op does the same).
        let mut points: Vec<Point> = (0..3000)
            .map(|_| {
                [
                    rng.random_range(-30.0..30.0),
                    rng.random_range(-30.0..30.0),
                    rng.random_range(-2.0..1.0),
                    0.3,
                ]
            })
            .filter(|p: &Point| boxes.iter().all(|b| (p[0] - b.x).hypot(p[1] - b.y) > 3.0))
            .collect();
        for b in &boxes {
            points.extend((0..200).map(|_| {
                let q = b.from_local([
                    rng.random_range(-0.45..0.45) * b.dx,
                    rng.random_range(-0.45..0.45) * b.dy,
                    rng.random_range(-0.45..0.45) * b.dz,
                ]);
                [q[0], q[1], q[2], 0.5]
            }));
        }
        Scene {
            points,
            boxes,
            classes: vec![ObjectClass::Car, ObjectClass::Pedestrian],
        }
    }

    type Step = Box<dyn Fn(&mut Scene)>;

    fn counts(s: &Scene) -> Vec<usize> {
        s.boxes.iter().map(|b| b.count_points_inside(&s.points)).collect()
    }

    fn close(a: &Scene, b: &Scene) -> bool {
        let p = a
            .points
            .iter()
            .zip(&b.points)
            .all(|(p, q)| (0..4).all(|k| (p[k] - q[k]).abs() < 1e-3));
        let bx = a
            .boxes
            .iter()
            .zip(&b.boxes)
            .all(|(p, q)| p.to_array().iter().zip(q.to_array()).all(|(u, v)| (u - v).abs() < 1e-3));
        p && bx
    }

    #[test]
    fn transforms_keep_box_point_counts() {
        let s = scene();
        let want = counts(&s);
        let cases: [(&str, Step); 5] = [
            ("rotate_z", Box::new(|s| rotate_z(s, 0.7))),
            ("flip_y", Box::new(flip_y)),
            ("scale", Box::new(|s| scale(s, 1.05))),
            ("shift_z", Box::new(|s| shift_z(s, 0.3))),
            ("rotate_box", Box::new(|s| rotate_box(s, 0, 0.15, 0.1))),
        ];
        for (name, f) in cases {
            let mut t = s.clone();
            f(&mut t);
            assert_eq!(counts(&t), want, "{name}");
        }
    }

    #[test]
    fn each_transform_has_its_inverse() {
        let s = scene();
        let mut t = s.clone();
        flip_y(&mut t);
        flip_y(&mut t);
        assert_eq!(t, s, "flip twice is the identity, exactly");
        let pairs: [(Step, Step); 4] = [
            (Box::new(|s| rotate_z(s, 0.6)), Box::new(|s| rotate_z(s, -0.6))),
            (Box::new(|s| scale(s, 0.95)), Box::new(|s| scale(s, 1.0 / 0.95))),
            (Box::new(|s| shift_z(s, -0.2)), Box::new(|s| shift_z(s, 0.2))),
            (
                Box::new(|s| rotate_box(s, 1, 0.1, 0.1)),
                Box::new(|s| rotate_box(s, 1, -0.1, 0.1)),
            ),
        ];
        for (f, g) in pairs {
            let mut t = s.clone();
            f(&mut t);
            g(&mut t);
            assert!(close(&t, &s));
        }
    }

    #[test]
    fn rotating_all_boxes_at_once_equals_rotating_them_in_turn() {
        // Overlapping boxes (the second's points include some the first moves), a box with
        // no angle, and one far from every point.
        let mut s = scene();
        s.boxes.push(Box3d::new(11.0, 3.5, -0.9, 4.0, 1.7, 1.5, -0.2));
        s.boxes.push(Box3d::new(50.0, 50.0, 0.0, 1.0, 1.0, 1.0, 0.0));
        s.classes.extend([ObjectClass::Car, ObjectClass::Car]);
        let angles = [0.15, -0.1, 0.3, 0.2];
        let mut one_by_one = s.clone();
        for (i, &a) in angles.iter().enumerate() {
            rotate_box(&mut one_by_one, i, a, 0.1);
        }
        let mut at_once = s.clone();
        rotate_boxes(&mut at_once, &angles, 0.1);
        assert_eq!(at_once, one_by_one);
        assert_ne!(at_once, s);
        let mut skipped = s.clone();
        rotate_boxes(&mut skipped, &[0.0, 0.0, 0.0, 0.0], 0.1);
        assert_eq!(skipped, s);
    }

    #[test]
    fn rotation_hand_values() {
        let mut s = Scene {
            points: vec![[1.0, 0.0, 0.0, 0.1]],
            boxes: vec![Box3d::new(2.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0)],
            classes: vec![ObjectClass::Car],
        };
        rotate_z(&mut s, std::f32::consts::FRAC_PI_2);
        assert!(s.points[0][0].abs() < 1e-6 && (s.points[0][1] - 1.0).abs() < 1e-6);
        assert!((s.boxes[0].y - 2.0).abs() < 1e-6 && (s.boxes[0].heading - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    }
}
