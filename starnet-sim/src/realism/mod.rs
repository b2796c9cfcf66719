//! `starnet compare-data`: how far one set of scans is from another, in the statistics that
//! decide whether a detector trained on one finds objects in the other (issue #33): the
//! reflectance by range and by what was hit (ground, cars, the rest), the share of returns
//! reading exactly 0, the points, reflectance, height and viewpoint of labelled cars by
//! distance, how volumetric the background is, how many car-sized clusters it holds, how
//! rough the ground beside the road, and how the road rises ahead and into the center pool
//! (per frame: p10 / p50 / p90).
//!
//! Everything is measured in the camera's field of view (where KITTI labels objects), in the
//! LiDAR frame, on any KITTI-layout folder: the simulator's, real KITTI, or a user's own sensor
//! written in that layout.

mod axis;
mod cars;
mod clusters;
mod compare;
mod ground;
mod reflectance;
mod report;
mod surfaces;

pub use cars::{
    BoxFit, CAR_EDGES_M, CarBin, CarSample, END_ZONE_M, FIT_MIN_POINTS, FIT_REACH_M, HIGH_POINT_M, VIEW_EDGES_DEG,
    ViewBin, box_fit, car_bins, car_sample, view_bins,
};
pub use clusters::{CAR_SIZED, CLUSTER_CELL_M, CLUSTER_MIN_POINTS, Cluster, clusters};
pub use compare::{ComparisonRow, RealismComparison};
pub use ground::{GROUND_BAND_M, GROUND_CELL_M, GroundGrid};
pub use reflectance::{RANGE_EDGES_M, ReflectanceBin, ReflectanceSums, range_bin};
pub use report::{
    ClusterStats, FrameSpreads, GroundRiseStats, POOL_ROAD_BAND_M, Percentiles, RealismReport, ReflectanceTable,
    SurfaceStats, realism_report,
};
pub use surfaces::{
    LocalShape, SURFACE_MIN_NEIGHBOURS, SURFACE_RADIUS_M, VERTICAL_NORMAL_Z, VOLUMETRIC_SCATTER, local_shape,
    sampled_shapes,
};
