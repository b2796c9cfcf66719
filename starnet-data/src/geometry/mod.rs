//! Box geometry in the LiDAR frame: the [`Box3d`] type, the scored [`Detection`], angle wrapping, rotated BEV and 3D
//! IoU by convex polygon clipping, a pairwise IoU matrix, points-in-box tests, the local ground of a cloud, and rigid poses
//! (KITTI odometry `poses.txt`).

mod box3d;
mod detection;
mod grid;
mod ground;
mod iou;
mod point;
mod polygon;
mod pose;

pub use box3d::{Box3d, wrap_angle};
pub use detection::Detection;
pub use grid::{GatherMetric, SpatialGrid};
pub use ground::{GroundConfig, GroundModel};
pub use iou::{
    IouKind, PreparedBox, iou_3d, iou_3d_prepared, iou_bev, iou_bev_prepared, iou_bev_upper_bound, iou_matrix,
};
pub use point::Point;
pub use polygon::{convex_intersection_area, convex_separated, polygon_area};
pub use pose::{Pose, parse_poses, read_poses};
