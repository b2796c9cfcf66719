//! The points near a box, found through a coarse grid: what the paste augmentation and the
//! per-box transforms move with their boxes.

use crate::geometry::{GatherMetric, SpatialGrid};
use crate::{Box3d, Point};

/// Grid cell (m) for finding the points near a box: a car's bird's-eye circle (r ≈ 2.2 m)
/// spans about 3 × 3 cells.
const NEAR_CELL_M: f32 = 2.0;

/// A grid of `points` for [`points_near`].
pub(super) fn near_grid(points: &[Point]) -> SpatialGrid {
    SpatialGrid::new(points, NEAR_CELL_M)
}

/// Replaces `out` with the indices of the gridded points (at their positions when gridded)
/// that `b`'s point test can hold: those within its bird's-eye circle, with a margin.
pub(super) fn points_near(grid: &SpatialGrid, b: &Box3d, out: &mut Vec<u32>) {
    out.clear();
    let r = b.bev_radius() + 0.01;
    grid.within([b.x, b.y, 0.0], r, GatherMetric::Cylinder, out);
}
