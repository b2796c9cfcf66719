//! The sensor's tilt: how far the LiDAR's axes lean from the level frame that has the same yaw.
//!
//! A LiDAR is mounted on its car at a small pitch and roll, and the car's load and suspension
//! move it, so real scans see a flat road rise or fall ahead (on `kitti-real-dev` the road 20 m
//! ahead lies 0.10 m above the sensor's reference at the median frame). The simulator casts its
//! rays in the level frame and reports the returns in the tilted sensor frame.

use serde::{Deserialize, Serialize};

/// Pitch (nose up) and roll (left side up) of the sensor, radians.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Tilt {
    /// Rotation about the sensor's y axis; positive lifts +x.
    pub pitch: f32,
    /// Rotation about the sensor's x axis; positive lifts +y.
    pub roll: f32,
}

impl Tilt {
    /// The rotation `R = Ry(−pitch) · Rx(roll)`: a sensor-frame vector `v` is `R v` in the
    /// level frame (rows of the matrix).
    pub fn matrix(self) -> [[f32; 3]; 3] {
        self.matrix_f64().map(|row| row.map(|v| v as f32))
    }

    /// The same rotation in f64 (orthonormal to f64's precision: what a pose file carries).
    pub fn matrix_f64(self) -> [[f64; 3]; 3] {
        let (sp, cp) = f64::from(self.pitch).sin_cos();
        let (sr, cr) = f64::from(self.roll).sin_cos();
        [[cp, -sp * sr, -sp * cr], [0.0, cr, -sr], [sp, cp * sr, cp * cr]]
    }

    /// The rotation, built once for many vectors (a scan turns every ray and return).
    pub fn rotation(self) -> TiltRotation {
        TiltRotation(self.matrix())
    }

    /// A sensor-frame vector in the level frame.
    pub fn to_level(self, v: [f32; 3]) -> [f32; 3] {
        self.rotation().to_level(v)
    }

    /// A level-frame vector in the sensor frame (the inverse of [`Tilt::to_level`]).
    pub fn to_sensor(self, v: [f32; 3]) -> [f32; 3] {
        self.rotation().to_sensor(v)
    }

    /// A level-frame heading (about z) as the sensor frame sees it: the heading of the
    /// direction's projection on the sensor's xy plane.
    pub fn heading_to_sensor(self, heading: f32) -> f32 {
        let (s, c) = heading.sin_cos();
        let d = self.to_sensor([c, s, 0.0]);
        d[1].atan2(d[0])
    }

    /// A sensor-frame heading in the level frame (the inverse of [`Tilt::heading_to_sensor`]
    /// for the small tilts of a car).
    pub fn heading_to_level(self, heading: f32) -> f32 {
        let (s, c) = heading.sin_cos();
        // The level direction whose sensor projection has this heading: intersect the sensor's
        // vertical plane through it with the level plane.
        let up = self.to_level([0.0, 0.0, 1.0]);
        let d = self.to_level([c, s, 0.0]);
        let k = d[2] / up[2];
        (d[1] - k * up[1]).atan2(d[0] - k * up[0])
    }
}

/// A [`Tilt`]'s rotation matrix ([`Tilt::matrix`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiltRotation([[f32; 3]; 3]);

impl TiltRotation {
    /// A sensor-frame vector in the level frame.
    pub fn to_level(&self, v: [f32; 3]) -> [f32; 3] {
        self.0.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
    }

    /// A level-frame vector in the sensor frame (the inverse of [`TiltRotation::to_level`]).
    pub fn to_sensor(&self, v: [f32; 3]) -> [f32; 3] {
        let m = &self.0;
        [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f32; 3], b: [f32; 3]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5)
    }

    #[test]
    fn round_trips() {
        let t = Tilt {
            pitch: 0.03,
            roll: -0.02,
        };
        for v in [[1.0, 0.0, 0.0], [0.3, -2.0, 1.5], [-7.0, 4.0, -1.73]] {
            assert!(close(t.to_sensor(t.to_level(v)), v));
            assert!(close(t.to_level(t.to_sensor(v)), v));
        }
        for h in [-3.1, -1.0, 0.0, 0.4, 2.9] {
            let back = t.heading_to_level(t.heading_to_sensor(h));
            assert!(starnet_data::wrap_angle(back - h).abs() < 1e-5, "{h} -> {back}");
        }
    }

    #[test]
    fn nose_up_lifts_x_and_roll_lifts_y() {
        let p = Tilt { pitch: 0.1, roll: 0.0 }.to_level([1.0, 0.0, 0.0]);
        assert!(close(p, [0.1f32.cos(), 0.0, 0.1f32.sin()]));
        let r = Tilt { pitch: 0.0, roll: 0.1 }.to_level([0.0, 1.0, 0.0]);
        assert!(close(r, [0.0, 0.1f32.cos(), 0.1f32.sin()]));
        // Nose down: the level road 20 m ahead, 1.73 m below the sensor, reads higher.
        let road = Tilt {
            pitch: -0.005,
            roll: 0.0,
        }
        .to_sensor([20.0, 0.0, -1.73]);
        assert!((road[2] - (-1.73 + 20.0 * 0.005)).abs() < 0.01, "{road:?}");
    }

    #[test]
    fn orthonormal() {
        let m = Tilt { pitch: 0.2, roll: 0.3 }.matrix();
        for i in 0..3 {
            for j in 0..3 {
                let dot: f32 = (0..3).map(|k| m[i][k] * m[j][k]).sum();
                assert!((dot - f32::from(u8::from(i == j))).abs() < 1e-6);
            }
        }
    }
}
