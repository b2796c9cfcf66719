//! Streaming input (the streaming-detection paper, §3.1–3.2): a sweep cut into `n` azimuth
//! slices of 360°/n, non-overlapping, in the order the laser sweeps them. Each slice is
//! prepared from what the sensor has delivered when it completes (the slice, and optionally the
//! previous one): its centers come from its own points and its neighbourhoods never read a
//! point of a later slice.
//!
//! Azimuth is `atan2(y, x)` in the LiDAR frame (0° = +x, forward; 90° = +y, left). A slice is
//! the azimuth interval `[start + s·w, start + (s+1)·w)` (w = 360°/n), measured in the rotation
//! sense.

use super::{Augmentation, Centers, PipelineConfig, PreparedFrame, center_pool, gather, level_centers, sample_centers};
use crate::augment::{augment, ring_dropout};
use crate::kitti::{Frame, ObjectClass};
use crate::seed::sub_seed;
use crate::settings::{Checked, within};
use crate::{Box3d, Point};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// How a sweep is cut and what a slice may see.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SliceConfig {
    /// Azimuth at which a sweep starts, degrees (180: directly behind the vehicle, where a
    /// Waymo-style spin begins and ends).
    pub start_azimuth_deg: f32,
    /// The laser turns clockwise seen from above (azimuth decreasing); false: counter-clockwise.
    pub clockwise: bool,
    /// Neighbourhoods may also read the previous slice's points (already delivered); the
    /// paper's localized model reads only its own slice.
    pub gather_previous: bool,
}

impl Default for SliceConfig {
    fn default() -> Self {
        Self {
            start_azimuth_deg: 180.0,
            clockwise: false,
            gather_previous: false,
        }
    }
}

impl SliceConfig {
    /// Checks that the start azimuth lies within one turn either way, degrees (keys relative to
    /// the slicing table).
    pub fn validate(&self) -> Checked {
        within("start_azimuth_deg", self.start_azimuth_deg as f64, -360.0, 360.0)
    }

    /// The slice (of `n`) that holds BEV position `(x, y)`.
    pub fn slice_of(&self, x: f32, y: f32, n: usize) -> usize {
        let az = y.atan2(x).to_degrees();
        let along = if self.clockwise {
            self.start_azimuth_deg - az
        } else {
            az - self.start_azimuth_deg
        };
        let s = (along.rem_euclid(360.0) / (360.0 / n as f32)) as usize;
        s.min(n - 1)
    }

    /// The inverse of [`SliceConfig::slice_of`]: slice `s`'s azimuth interval `[first, last)`,
    /// degrees in `(-180, 180]`, listed in the rotation sense (so for a clockwise laser `first`
    /// is the larger angle, modulo 360°).
    pub fn slice_bounds(&self, s: usize, n: usize) -> (f32, f32) {
        let w = 360.0 / n as f32;
        let sign = if self.clockwise { -1.0 } else { 1.0 };
        let at = |k: f32| wrap_deg(self.start_azimuth_deg + sign * k * w);
        (at(s as f32), at(s as f32 + 1.0))
    }
}

/// An angle in degrees, wrapped to `(-180, 180]`.
fn wrap_deg(a: f32) -> f32 {
    let w = a.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// The points of each of `n` slices, in sweep order (each point in exactly one slice, in its
/// original order within the slice): what the sensor delivers, slice after slice.
pub fn slice_points(points: &[Point], n: usize, cfg: &SliceConfig) -> Vec<Vec<Point>> {
    let mut slices = vec![Vec::new(); n];
    for p in points {
        slices[cfg.slice_of(p[0], p[1], n)].push(*p);
    }
    slices
}

/// Centers per slice when a sweep's budget is `total` centers over `n` slices.
pub fn centers_per_slice(total: usize, n: usize) -> usize {
    total.div_ceil(n).max(1)
}

/// One slice from the points delivered so far: `num_centers` centers sampled from the center
/// pool of `current` (the pool's range and z filters; no camera frustum), neighbourhoods
/// gathered from `current` (and `previous` when the config allows it). `boxes`/`classes` are the
/// sweep's labels, for target assignment. The returned frame's `points` are exactly the points
/// its neighbourhoods read from.
pub fn prepare_slice(
    id: &str,
    current: &[Point],
    previous: Option<&[Point]>,
    labels: (&[Box3d], &[ObjectClass]),
    cfg: &PipelineConfig,
    num_centers: usize,
    rng: &mut impl Rng,
) -> PreparedFrame {
    let points: Vec<Point> = match previous {
        Some(prev) => prev.iter().chain(current).copied().collect(),
        None => current.to_vec(),
    };
    // The ground from what has been delivered, never from slices still to come.
    let ground = cfg.fit_ground(&points);
    let pool = center_pool(current, &cfg.pool, None, ground.as_ref());
    let mut centers: Centers = sample_centers(current, &pool, num_centers, cfg.sampler, &[], cfg.center_z, rng);
    if let Some(ground) = &ground {
        level_centers(&mut centers, cfg.center_z, ground);
    }
    let neighbourhoods = gather(&points, &centers, &cfg.gather, rng);
    PreparedFrame {
        id: id.to_string(),
        points,
        centers,
        neighbourhoods,
        boxes: labels.0.to_vec(),
        classes: labels.1.to_vec(),
        draw: None,
    }
}

/// The RNG of slice `s` of a sweep whose randomness derives from `seed`: a slice's draws do
/// not depend on any other slice's points.
pub fn slice_rng(seed: u64, s: usize) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(sub_seed(seed, 41, s as u64))
}

/// A whole sweep as `n` prepared slices (training and offline use): augments the sweep when
/// `augmentation` is given (then drops a ring), cuts it, and prepares every slice with
/// [`prepare_slice`] at `ceil(cfg.num_centers / n)` centers.
pub fn prepare_sweep(
    frame: &Frame,
    cfg: &PipelineConfig,
    slicing: &SliceConfig,
    n: usize,
    augmentation: Option<Augmentation<'_>>,
    rng: &mut impl Rng,
) -> Vec<PreparedFrame> {
    let (boxes, classes): (Vec<Box3d>, Vec<ObjectClass>) =
        frame.labelled_boxes().into_iter().map(|(o, b)| (b, o.class)).unzip();
    let mut scene = crate::augment::Scene {
        points: frame.points.clone(),
        boxes,
        classes,
    };
    if let Some(a) = augmentation {
        augment(&mut scene, a.config, a.database, rng);
        if a.config.ring_dropout {
            scene.points = ring_dropout(&scene.points, a.config.ring_dropout_width, rng).0;
        }
    }
    let seed: u64 = rng.random();
    let slices = slice_points(&scene.points, n, slicing);
    let per = centers_per_slice(cfg.num_centers, n);
    (0..n)
        .map(|s| {
            let previous = (slicing.gather_previous && s > 0).then(|| slices[s - 1].as_slice());
            prepare_slice(
                &frame.id,
                &slices[s],
                previous,
                (&scene.boxes, &scene.classes),
                cfg,
                per,
                &mut slice_rng(seed, s),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(n: usize) -> Vec<Point> {
        (0..n)
            .map(|i| {
                let a = (i as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
                let r = 5.0 + (i % 7) as f32;
                [r * a.cos(), r * a.sin(), -0.5, 0.3]
            })
            .collect()
    }

    #[test]
    fn slices_follow_the_rotation_from_the_start_azimuth() {
        let ccw = SliceConfig::default();
        // Starting behind (180°), counter-clockwise: -170° (behind, right) comes first, +170° last.
        let at = |deg: f32, c: &SliceConfig, n| c.slice_of(deg.to_radians().cos(), deg.to_radians().sin(), n);
        assert_eq!(at(-170.0, &ccw, 4), 0);
        assert_eq!(at(-80.0, &ccw, 4), 1);
        assert_eq!(at(10.0, &ccw, 4), 2);
        assert_eq!(at(100.0, &ccw, 4), 3);
        assert_eq!(at(170.0, &ccw, 4), 3);
        let cw = SliceConfig { clockwise: true, ..ccw };
        assert_eq!(at(170.0, &cw, 4), 0);
        assert_eq!(at(-170.0, &cw, 4), 3);
        assert_eq!(at(45.0, &ccw, 1), 0);
    }

    #[test]
    fn bounds_invert_slice_of() {
        for clockwise in [false, true] {
            let cfg = SliceConfig {
                start_azimuth_deg: 37.0,
                clockwise,
                ..SliceConfig::default()
            };
            for n in [1, 2, 3, 8, 32] {
                for s in 0..n {
                    let (first, _) = cfg.slice_bounds(s, n);
                    // Just inside the slice, in the rotation sense, from its first edge.
                    let step = if clockwise { -1e-2 } else { 1e-2 } * 360.0 / n as f32;
                    let a = (first + step).to_radians();
                    assert_eq!(cfg.slice_of(a.cos(), a.sin(), n), s, "n {n} s {s} cw {clockwise}");
                }
                let (_, last) = cfg.slice_bounds(n - 1, n);
                assert!(
                    (wrap_deg(last - 37.0)).abs() < 1e-3,
                    "the last slice ends where the sweep began"
                );
            }
        }
    }

    #[test]
    fn every_point_lands_in_one_slice_in_order() {
        let pts = ring(1000);
        let slices = slice_points(&pts, 8, &SliceConfig::default());
        assert_eq!(slices.iter().map(Vec::len).sum::<usize>(), 1000);
        let cfg = SliceConfig::default();
        for (s, slice) in slices.iter().enumerate() {
            assert!(slice.iter().all(|p| cfg.slice_of(p[0], p[1], 8) == s));
            assert!(!slice.is_empty());
        }
    }

    #[test]
    fn a_slice_reads_no_later_point() {
        let mut frame = Frame {
            id: "000000".into(),
            points: ring(4000),
            objects: Vec::new(),
            calib: crate::kitti::Calib::kitti_000000(),
            image_size: crate::kitti::ImageSize::KITTI,
        };
        let cfg = PipelineConfig {
            pool: crate::sampling::CenterPoolConfig::all_around(50.0),
            num_centers: 64,
            ..PipelineConfig::default()
        };
        for gather_previous in [false, true] {
            let slicing = SliceConfig {
                gather_previous,
                ..SliceConfig::default()
            };
            let n = 8;
            let slices = prepare_sweep(&frame, &cfg, &slicing, n, None, &mut ChaCha8Rng::seed_from_u64(3));
            for (s, slice) in slices.iter().enumerate() {
                assert_eq!(slice.centers.len(), 8);
                // The cloud a slice gathers from holds only this slice's points (and the previous
                // slice's when allowed), and every gathered index points into it.
                let lo = if gather_previous { s.saturating_sub(1) } else { s };
                assert!(
                    slice
                        .points
                        .iter()
                        .all(|p| (lo..=s).contains(&slicing.slice_of(p[0], p[1], n)))
                );
                assert!(
                    slice
                        .neighbourhoods
                        .indices
                        .iter()
                        .flatten()
                        .all(|&i| (i as usize) < slice.points.len())
                );
                assert!(slice.centers.xyz.iter().all(|c| slicing.slice_of(c[0], c[1], n) == s));
            }
            // Moving every point of the last four slices changes nothing in the first four.
            let later = |p: &Point| slicing.slice_of(p[0], p[1], n) >= 4;
            let original = frame.points.clone();
            for p in frame.points.iter_mut().filter(|p| later(p)) {
                p[2] += 0.7;
                p[3] = 0.9;
            }
            let moved = prepare_sweep(&frame, &cfg, &slicing, n, None, &mut ChaCha8Rng::seed_from_u64(3));
            assert_eq!(&moved[..4], &slices[..4]);
            assert_ne!(&moved[4..], &slices[4..]);
            frame.points = original;
        }
    }
}
