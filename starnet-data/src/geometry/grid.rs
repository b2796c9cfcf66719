//! [`SpatialGrid`]: points bucketed by (x, y) cell, for radius queries by a [`GatherMetric`]
//! (the neighbourhood gathering, the paste augmentation's and the realism statistics' nearby
//! points).

use crate::Point;
use serde::{Deserialize, Serialize};

/// How the distance from a center is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GatherMetric {
    /// 3D distance: a ball (the paper's).
    #[default]
    Ball,
    /// Distance in bird's-eye view (x, y): a vertical cylinder. Centers sit at z = 0 by default,
    /// about 1 m above a car's middle, so a ball of radius R reaches only about 0.9 R sideways
    /// at car height; the cylinder reaches R at every height.
    Cylinder,
}

impl GatherMetric {
    /// Squared distance of offset `(dx, dy, dz)`.
    pub fn distance2(self, dx: f32, dy: f32, dz: f32) -> f32 {
        match self {
            Self::Ball => dx * dx + dy * dy + dz * dz,
            Self::Cylinder => dx * dx + dy * dy,
        }
    }
}

/// Points bucketed by (x, y) cell in a dense grid over the cloud's extent, copied into cell
/// order so a query reads contiguous memory.
#[derive(Debug, Clone)]
pub struct SpatialGrid {
    cell: f32,
    origin: [f32; 2],
    dims: [usize; 2],
    /// Cell `c` holds `sorted[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    /// The points in cell order, and their indices in the original cloud.
    sorted: Vec<Point>,
    order: Vec<u32>,
}

/// The most cells a [`SpatialGrid`] allocates (4 MiB of cell starts).
const MAX_CELLS: f64 = (1u64 << 20) as f64;

/// The side of the cells over the extent `lo..hi`: `cell`, doubled until at most
/// `MAX_CELLS` cover the extent.
fn cell_side(lo: [f32; 2], hi: [f32; 2], cell: f32) -> f32 {
    let extent = [0, 1].map(|a| f64::from(hi[a]) - f64::from(lo[a]));
    let mut side = f64::from(cell);
    while (extent[0] / side + 1.0) * (extent[1] / side + 1.0) > MAX_CELLS {
        side *= 2.0;
    }
    side as f32
}

impl SpatialGrid {
    /// Buckets `points` into square cells of side `cell` (a counting sort). A cloud spread
    /// wider than `MAX_CELLS` (2^20) cells of that side (a wild point kilometres away) gets cells
    /// doubled in side until it fits: queries stay exact, only slower.
    pub fn new(points: &[Point], cell: f32) -> Self {
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for p in points {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        if points.is_empty() {
            (lo, hi) = ([0.0; 2], [0.0; 2]);
        }
        let cell = cell_side(lo, hi, cell);
        // f64: the extent of two far points can pass f32's range; the cast saturates.
        let span = |a: usize| ((f64::from(hi[a]) - f64::from(lo[a])) / f64::from(cell)) as usize + 1;
        let dims = [span(0), span(1)];
        let cell_of = |p: &Point| {
            (((p[0] - lo[0]) / cell) as usize).min(dims[0] - 1) * dims[1]
                + (((p[1] - lo[1]) / cell) as usize).min(dims[1] - 1)
        };
        let mut starts = vec![0u32; dims[0] * dims[1] + 1];
        let cells: Vec<usize> = points.iter().map(cell_of).collect();
        cells.iter().for_each(|&c| starts[c + 1] += 1);
        for c in 1..starts.len() {
            starts[c] += starts[c - 1];
        }
        let mut fill = starts.clone();
        let mut order = vec![0u32; points.len()];
        for (i, &c) in cells.iter().enumerate() {
            order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        let sorted = order.iter().map(|&i| points[i as usize]).collect();
        Self {
            cell,
            origin: lo,
            dims,
            starts,
            sorted,
            order,
        }
    }

    /// Appends to `out` the indices of the points within `radius` of `c` by `metric`, in a
    /// fixed order.
    pub fn within(&self, c: [f32; 3], radius: f32, metric: GatherMetric, out: &mut Vec<u32>) {
        let r2 = radius * radius;
        let range = |a: usize| {
            let lo = ((c[a] - radius - self.origin[a]) / self.cell).floor().max(0.0) as usize;
            let hi = ((c[a] + radius - self.origin[a]) / self.cell).floor();
            (
                lo,
                if hi < 0.0 {
                    None
                } else {
                    Some((hi as usize).min(self.dims[a] - 1))
                },
            )
        };
        let ((x0, Some(x1)), (y0, Some(y1))) = (range(0), range(1)) else {
            return;
        };
        // A query beyond the grid's extent on either side touches no cell (centers can lie
        // outside it: the ring dropout runs after center selection and may remove the extremes).
        if y0 > y1 {
            return;
        }
        for gx in x0..=x1 {
            let row = gx * self.dims[1];
            let (s, e) = (self.starts[row + y0] as usize, self.starts[row + y1 + 1] as usize);
            // Cells y0..=y1 of one grid row are contiguous in `sorted`.
            for k in s..e {
                let p = &self.sorted[k];
                let (dx, dy, dz) = (p[0] - c[0], p[1] - c[1], p[2] - c[2]);
                if metric.distance2(dx, dy, dz) <= r2 {
                    out.push(self.order[k]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn near_cloud() -> Vec<Point> {
        (0..200)
            .map(|i| {
                let t = i as f32 * 0.37;
                [t.sin() * 10.0, t.cos() * 7.0, (t * 0.3).sin(), 0.5]
            })
            .collect()
    }

    fn query(grid: &SpatialGrid, c: [f32; 3]) -> Vec<u32> {
        let mut out = Vec::new();
        grid.within(c, 3.0, GatherMetric::Ball, &mut out);
        out.sort_unstable();
        out
    }

    #[test]
    fn a_point_far_beyond_any_sensor_leaves_the_grid_small_and_the_queries_exact() {
        let near = near_cloud();
        let plain = SpatialGrid::new(&near, 0.5);
        for far in [1e20, f32::MAX, -f32::MAX] {
            let mut wild = near.clone();
            wild.push([far, -far, 0.0, 0.0]);
            let grid = SpatialGrid::new(&wild, 0.5);
            assert!(
                grid.starts.len() as f64 <= MAX_CELLS + 1.0,
                "{} cells",
                grid.starts.len()
            );
            for c in [[0.0, 0.0, 0.0], [9.0, 2.0, 0.5], [-5.0, -6.0, 0.0]] {
                assert_eq!(query(&grid, c), query(&plain, c), "at {c:?} with a point at {far}");
            }
        }
    }
}
