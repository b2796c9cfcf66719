//! Waymo-style AP per subtended angle (the streaming paper's table 1): ground truth and
//! predictions are kept in a bin by the azimuth angle their own box subtends from the sensor,
//! and each bin is evaluated as a dataset of its own. Large angles are the objects most likely
//! to cross slice borders.

use super::waymo_ap::{WaymoFrame, waymo_ap};
use serde::{Deserialize, Serialize};
use starnet_data::kitti::ObjectClass;

/// The paper's bins, degrees: `[lo, hi)`; the last one is open.
pub const ANGLE_BINS_DEG: [(f32, f32); 5] = [(0.0, 5.0), (5.0, 15.0), (15.0, 25.0), (25.0, 35.0), (35.0, 360.0)];

/// The LEVEL_1 AP of one bin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AngleAp {
    /// Bin start, degrees.
    pub lo_deg: f32,
    /// Bin end, degrees (360 for the open last bin).
    pub hi_deg: f32,
    /// LEVEL_1 objects of the class in the bin.
    pub num_objects: usize,
    /// LEVEL_1 AP, percent.
    pub ap: f64,
}

/// LEVEL_1 AP of `class` per [`ANGLE_BINS_DEG`] bin.
pub fn ap_by_angle(frames: &[WaymoFrame], class: ObjectClass) -> Vec<AngleAp> {
    ANGLE_BINS_DEG
        .iter()
        .map(|&(lo, hi)| {
            // The open bin also holds boxes around the sensor (exactly 360°).
            let keep = |deg: f32| deg >= lo && (deg < hi || hi == 360.0);
            let subset: Vec<WaymoFrame> = frames
                .iter()
                .map(|f| WaymoFrame {
                    objects: f
                        .objects
                        .iter()
                        .filter(|o| keep(o.b.subtended_angle().to_degrees()))
                        .cloned()
                        .collect(),
                    detections: f
                        .detections
                        .iter()
                        .filter(|d| keep(d.b.subtended_angle().to_degrees()))
                        .cloned()
                        .collect(),
                })
                .collect();
            let r = waymo_ap(&subset, &[class]).remove(0);
            AngleAp {
                lo_deg: lo,
                hi_deg: hi,
                num_objects: r.num_objects[0],
                ap: r.levels[0].ap,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{WaymoDetection, WaymoObject};
    use starnet_data::Box3d;

    #[test]
    fn objects_and_detections_fall_in_their_own_bins() {
        // A car 20 m out, end on, subtends 5.7°; one 8 m out, side on, 31.4°. Only the far one
        // is detected.
        let far = Box3d::new(20.0, 0.0, -1.0, 4.0, 1.8, 1.5, 0.0);
        let near = Box3d::new(8.0, 0.0, -1.0, 4.0, 1.8, 1.5, 1.5);
        assert!((5.0..15.0).contains(&far.subtended_angle().to_degrees()));
        assert!((25.0..35.0).contains(&near.subtended_angle().to_degrees()));
        let obj = |b| WaymoObject {
            class: ObjectClass::Car,
            b,
            num_points: 50,
        };
        let frames = [WaymoFrame {
            objects: vec![obj(far), obj(near)],
            detections: vec![WaymoDetection {
                class: ObjectClass::Car,
                b: far,
                score: 0.9,
            }],
        }];
        let bins = ap_by_angle(&frames, ObjectClass::Car);
        let counts: Vec<usize> = bins.iter().map(|b| b.num_objects).collect();
        assert_eq!(counts, [0, 1, 0, 1, 0]);
        assert!((bins[1].ap - 100.0).abs() < 1e-4); // the Waymo library integrates in f32
        assert_eq!(bins[3].ap, 0.0);
    }
}
