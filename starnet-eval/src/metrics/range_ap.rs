//! KITTI AP per distance bin (the StarNet workshop paper's figure 4, and lingvo's distance
//! breakdown): ground truth and detections are kept in a bin by their own bird's-eye-view
//! distance from the LiDAR, and each bin is evaluated as a dataset of its own.

use super::kitti_ap::{Ap, KittiFrame, kitti_ap};
use serde::{Deserialize, Serialize};
use starnet_data::kitti::{Calib, Difficulty, KittiObject, ObjectClass};

/// Width of a distance bin, metres.
pub const RANGE_BIN_M: f32 = 10.0;

/// The AP of one distance bin at moderate difficulty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RangeAp {
    /// Bin start, metres.
    pub lo: f32,
    /// Bin end, metres.
    pub hi: f32,
    /// Labelled objects of the class in the bin that count at moderate difficulty (easy or
    /// moderate by the devkit's thresholds): the objects its AP is computed over.
    pub num_objects: usize,
    /// 3D AP, moderate.
    pub three_d: Ap,
    /// Bird's-eye-view AP, moderate.
    pub bev: Ap,
}

/// AP of `class` per [`RANGE_BIN_M`] bin up to `max_range`; `calibs` are the frames'
/// calibrations, one per frame (for the LiDAR-frame distance). DontCare regions stay in every
/// bin.
pub fn ap_by_range(frames: &[KittiFrame], calibs: &[Calib], class: ObjectClass, max_range: f32) -> Vec<RangeAp> {
    assert_eq!(frames.len(), calibs.len(), "one calibration per frame");
    let bins = (max_range / RANGE_BIN_M).ceil() as usize;
    (0..bins)
        .map(|k| {
            let (lo, hi) = (k as f32 * RANGE_BIN_M, (k + 1) as f32 * RANGE_BIN_M);
            let keep = |o: &KittiObject, calib: &Calib| {
                let b = calib.label_to_box(&o.cam);
                o.class == ObjectClass::DontCare || (lo..hi).contains(&b.x.hypot(b.y))
            };
            let subset: Vec<_> = frames
                .iter()
                .zip(calibs)
                .map(|(f, c)| KittiFrame {
                    labels: f.labels.iter().filter(|o| keep(o, c)).cloned().collect(),
                    detections: f.detections.iter().filter(|o| keep(o, c)).cloned().collect(),
                })
                .collect();
            let counts =
                |o: &&KittiObject| o.class == class && o.difficulty().is_some_and(|d| d <= Difficulty::Moderate);
            let num_objects = subset.iter().flat_map(|f| &f.labels).filter(counts).count();
            let ap = kitti_ap(&subset, &[class]).remove(0);
            RangeAp {
                lo,
                hi,
                num_objects,
                three_d: ap.three_d[1],
                bev: ap.bev[1],
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_data::kitti::CameraBox;

    /// An easy car `z` metres ahead of the camera.
    fn car(z: f32, u: f32, score: Option<f32>) -> KittiObject {
        KittiObject {
            class: ObjectClass::Car,
            truncated: if score.is_some() { -1.0 } else { 0.0 },
            occluded: if score.is_some() { -1 } else { 0 },
            alpha: 0.0,
            bbox: [u, 150.0, u + 80.0, 210.0],
            cam: CameraBox {
                h: 1.5,
                w: 1.6,
                l: 3.9,
                x: 0.0,
                y: 1.7,
                z,
                ry: 0.0,
            },
            score,
        }
    }

    #[test]
    fn each_bin_is_evaluated_on_its_own_objects() {
        // Per frame one car at 5 m (found) and one at 25 m (missed): 40 frames so the devkit's
        // sampling reaches recall 1 in the near bin. A largely occluded car at 15 m counts at
        // hard only: its bin shows no object at moderate.
        let hard_only = KittiObject {
            occluded: 2,
            ..car(15.0, 250.0, None)
        };
        let frames: Vec<_> = (0..40)
            .map(|k| {
                let gt = vec![car(5.0, 100.0, None), hard_only.clone(), car(25.0, 400.0, None)];
                let detections = vec![car(5.0, 100.0, Some(0.5 + 0.01 * k as f32))];
                KittiFrame { labels: gt, detections }
            })
            .collect();
        let calibs = vec![Calib::kitti_000000(); frames.len()];
        let bins = ap_by_range(&frames, &calibs, ObjectClass::Car, 30.0);
        assert_eq!(bins.len(), 3);
        assert_eq!(
            [bins[0].num_objects, bins[1].num_objects, bins[2].num_objects],
            [40, 0, 40]
        );
        // 40 objects fill samples 0..=39 of 41 (see kitti_ap): R40 = 39/40.
        assert!((bins[0].three_d.r40 - 97.5).abs() < 1e-4, "{:?}", bins[0]);
        assert_eq!(bins[1].three_d.r40, 0.0);
        assert_eq!(bins[2].three_d.r40, 0.0);
    }
}
