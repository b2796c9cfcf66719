//! `starnet inspect`: what a frame holds, as a table or JSON.

use serde::Serialize;
use starnet_data::Box3d;
use starnet_data::kitti::{Difficulty, Frame, ImageSize, ObjectClass};
use std::fmt;

/// One label of a frame, with its LiDAR-frame box and the points it holds.
#[derive(Debug, Clone, Serialize)]
pub struct ObjectReport {
    /// Object type.
    pub class: ObjectClass,
    /// The box in the LiDAR frame; `None` for DontCare regions, which have no 3D extent.
    pub box_lidar: Option<Box3d>,
    /// KITTI difficulty; `None` if the object meets no difficulty's criteria.
    pub difficulty: Option<Difficulty>,
    /// LiDAR points inside the box (`None` for DontCare).
    pub num_points: Option<usize>,
    /// Truncation as labelled.
    pub truncated: f32,
    /// Occlusion level as labelled.
    pub occluded: i32,
}

/// The summary `starnet inspect` prints.
#[derive(Debug, Clone, Serialize)]
pub struct FrameReport {
    /// Frame id.
    pub id: String,
    /// Points in the full scan.
    pub num_points: usize,
    /// Points inside the camera field of view.
    pub num_fov_points: usize,
    /// Image 2 size used for the field of view.
    pub image_size: ImageSize,
    /// One entry per label line, in file order.
    pub objects: Vec<ObjectReport>,
}

/// Builds the report of a loaded frame.
pub fn inspect_frame(frame: &Frame) -> FrameReport {
    let objects = frame
        .objects
        .iter()
        .map(|o| {
            let b = (o.class != ObjectClass::DontCare).then(|| frame.calib.label_to_box(&o.cam));
            ObjectReport {
                class: o.class,
                box_lidar: b,
                difficulty: if o.class == ObjectClass::DontCare {
                    None
                } else {
                    o.difficulty()
                },
                num_points: b.map(|b| b.count_points_inside(&frame.points)),
                truncated: o.truncated,
                occluded: o.occluded,
            }
        })
        .collect();
    FrameReport {
        id: frame.id.clone(),
        num_points: frame.points.len(),
        num_fov_points: frame.calib.crop_to_fov(&frame.points, frame.image_size).len(),
        image_size: frame.image_size,
        objects,
    }
}

impl fmt::Display for FrameReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "frame {}: {} points ({} in the camera view)",
            self.id, self.num_points, self.num_fov_points
        )?;
        writeln!(
            f,
            "{:<15} {:>8} {:>8} {:>7} {:>6} {:>6} {:>6} {:>8} {:>9} {:>7}",
            "class", "x", "y", "z", "dx", "dy", "dz", "heading", "difficulty", "points"
        )?;
        for o in &self.objects {
            let diff = o
                .difficulty
                .map_or("-".to_string(), |d| format!("{d:?}").to_lowercase());
            match o.box_lidar {
                Some(b) => writeln!(
                    f,
                    "{:<15} {:>8.2} {:>8.2} {:>7.2} {:>6.2} {:>6.2} {:>6.2} {:>8.3} {:>9} {:>7}",
                    o.class.as_str(),
                    b.x,
                    b.y,
                    b.z,
                    b.dx,
                    b.dy,
                    b.dz,
                    b.heading,
                    diff,
                    o.num_points.unwrap_or(0)
                )?,
                None => writeln!(f, "{:<15} {:>8} (2D region only)", o.class.as_str(), "-")?,
            }
        }
        Ok(())
    }
}
