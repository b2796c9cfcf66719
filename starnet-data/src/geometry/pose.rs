//! Rigid poses and the KITTI odometry pose file (`poses.txt`: per frame one row-major 3 × 4
//! matrix `[R | t]` mapping that frame's sensor coordinates into a fixed world frame). Moving
//! something seen in frame t − 1 into frame t is `P_t⁻¹ · P_{t−1}` ([`Pose::between`]).

use super::{Box3d, wrap_angle};
use crate::io::{parse_finite_numbers, read_text};
use crate::{DataError, Result};
use std::path::Path;

/// A rigid transform `p ↦ R p + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Rotation, row-major.
    pub r: [[f64; 3]; 3],
    /// Translation.
    pub t: [f64; 3],
}

impl Pose {
    /// The identity.
    pub const IDENTITY: Pose = Pose {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: [0.0; 3],
    };

    /// A pose from a position and a yaw about z.
    pub fn from_xyz_yaw([x, y, z]: [f64; 3], yaw: f64) -> Self {
        let (s, c) = yaw.sin_cos();
        Self {
            r: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
            t: [x, y, z],
        }
    }

    /// The inverse: `p ↦ Rᵀ (p − t)`.
    pub fn inverse(&self) -> Self {
        let rt: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| self.r[j][i]));
        let t = std::array::from_fn(|i| -(0..3).map(|j| rt[i][j] * self.t[j]).sum::<f64>());
        Self { r: rt, t }
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Pose) -> Self {
        let r = std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| self.r[i][k] * other.r[k][j]).sum()));
        Self {
            r,
            t: self.apply_f64(other.t),
        }
    }

    /// The transform taking coordinates of the frame posed at `from` into the frame posed at
    /// `to` (both posed in the same world): `to⁻¹ ∘ from`.
    pub fn between(from: &Pose, to: &Pose) -> Self {
        to.inverse().compose(from)
    }

    fn apply_f64(&self, p: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| (0..3).map(|j| self.r[i][j] * p[j]).sum::<f64>() + self.t[i])
    }

    /// Transforms a point.
    pub fn apply(&self, p: [f32; 3]) -> [f32; 3] {
        self.apply_f64(p.map(f64::from)).map(|v| v as f32)
    }

    /// The rotation's yaw (about z), for boxes that stay upright.
    pub fn yaw(&self) -> f64 {
        self.r[1][0].atan2(self.r[0][0])
    }

    /// Transforms an upright box: its centre moves, its heading turns by the yaw.
    pub fn apply_box(&self, b: &Box3d) -> Box3d {
        let [x, y, z] = self.apply([b.x, b.y, b.z]);
        Box3d::new(x, y, z, b.dx, b.dy, b.dz, wrap_angle(b.heading + self.yaw() as f32))
    }
}

/// Reads a KITTI odometry pose file: one pose per non-empty line, twelve numbers each.
pub fn read_poses(path: &Path) -> Result<Vec<Pose>> {
    parse_poses(&read_text(path)?, path)
}

/// Parses the text of a pose file; errors name `path`, the line and the field.
pub fn parse_poses(text: &str, path: &Path) -> Result<Vec<Pose>> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, line)| {
            let v = parse_finite_numbers(line, path, i + 1, "pose")?;
            if v.len() != 12 {
                return Err(DataError::parse(
                    path,
                    i + 1,
                    "pose",
                    format!("expected 12 numbers (a row-major 3 × 4 matrix), found {}", v.len()),
                ));
            }
            Ok(Pose {
                r: [[v[0], v[1], v[2]], [v[4], v[5], v[6]], [v[8], v[9], v[10]]],
                t: [v[3], v[7], v[11]],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_and_between_round_trip() {
        let a = Pose::from_xyz_yaw([10.0, -3.0, 1.7], 0.4);
        let b = Pose::from_xyz_yaw([12.5, -2.1, 1.8], 0.55);
        let p = [3.0f32, 4.0, -0.5];
        let back = a.inverse().apply(a.apply(p));
        assert!(p.iter().zip(back).all(|(u, v)| (u - v).abs() < 1e-5));
        // A world point seen from a, moved into b's frame, equals b's own view of it.
        let world = a.apply(p);
        let in_b = Pose::between(&a, &b).apply(p);
        let direct = b.inverse().apply(world);
        assert!(in_b.iter().zip(direct).all(|(u, v)| (u - v).abs() < 1e-5));
        // Boxes: heading turns by the yaw difference, there and back.
        let bx = Box3d::new(5.0, 1.0, -1.0, 4.0, 1.7, 1.5, 3.0);
        let moved = Pose::between(&a, &b).apply_box(&bx);
        assert!((wrap_angle(moved.heading - (3.0 - 0.15)) as f64).abs() < 1e-5);
        let again = Pose::between(&b, &a).apply_box(&moved);
        assert!((again.x - bx.x).abs() < 1e-5 && (again.y - bx.y).abs() < 1e-5);
        assert!(wrap_angle(again.heading - bx.heading).abs() < 1e-5);
    }

    #[test]
    fn reads_kitti_lines_and_names_bad_ones() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("poses.txt");
        std::fs::write(&path, "1 0 0 0 0 1 0 0 0 0 1 0\n0 -1 0 2.5 1 0 0 -1 0 0 1 0.25\n").expect("write");
        let poses = read_poses(&path).expect("parses");
        assert_eq!(poses[0], Pose::IDENTITY);
        assert!((poses[1].yaw() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(poses[1].t, [2.5, -1.0, 0.25]);
        std::fs::write(&path, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n").expect("write");
        let e = read_poses(&path).unwrap_err().to_string();
        assert!(
            e.contains("poses.txt") && e.contains('2') && e.contains("found 11"),
            "{e}"
        );
        std::fs::write(&path, "1 0 0 x 0 1 0 0 0 0 1 0\n").expect("write");
        let e = read_poses(&path).unwrap_err().to_string();
        assert!(e.contains("`x`"), "{e}");
    }
}
