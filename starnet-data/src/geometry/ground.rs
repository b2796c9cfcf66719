//! [`GroundModel`]: the local ground height under each (x, y) of one cloud, so that the center
//! pool and the centers' z follow a road that rises, falls or tilts (grade, camber, the sensor's
//! pitch and roll) instead of assuming the flat ground at the reference height KITTI's sensor
//! sees (z ≈ −1.73). Real streets are not flat: on `kitti-real-dev` the road 40 m ahead lies
//! 0.4 m above the road under the car, right at the authors' pool floor (z ≥ −1.35), so FPS
//! spends centers on it (ARCHITECTURE.md §"The ground").
//!
//! The estimate is a morphological erosion of a bird's-eye grid: each cell's `rank`-th lowest
//! return (the rank skips the odd return below the road), cells whose floor lies more than
//! `max_drop` below the lower quartile of the floors in their window dropped (real scans hold clusters of
//! returns 10 m below the road: reflections through glass), then the lowest floor over a window
//! of cells around each, wide enough to reach past a car to the road beside it. Pure: the same
//! points give the same model.

use crate::Point;
use crate::settings::{Checked, InvalidSetting, finite, positive, within};
use serde::{Deserialize, Serialize};

/// How the ground is estimated, and the flat ground the anchors and the pool's z band assume.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GroundConfig {
    /// Side of a bird's-eye cell (m).
    pub cell: f32,
    /// Cells on each side of a cell whose lows bound its ground: a window of `2 · window + 1`
    /// cells a side (10 m at the defaults, past a car's length).
    pub window: usize,
    /// Which of a cell's returns, from the lowest (0), stands for its floor.
    pub rank: usize,
    /// A floor more than this far below the lower quartile of its window's floors is not
    /// ground (m).
    pub max_drop: f32,
    /// Half-side of the square around the sensor that is modelled (m); beyond it the ground is
    /// the reference plane.
    pub extent: f32,
    /// The flat ground's z in the sensor frame (KITTI's HDL-64 sits 1.73 m above the road).
    pub reference_z: f32,
}

impl Default for GroundConfig {
    /// 2 m cells, a 5 × 5 window, the third-lowest return, 80 m, z = −1.73: on the 51 frames
    /// of `kitti-real-dev` the labelled cars' bottoms sit 0.00–0.09 m (medians by distance)
    /// above this estimate, against −0.07 to +0.17 m above the flat reference.
    fn default() -> Self {
        Self {
            cell: 2.0,
            window: 2,
            rank: 2,
            max_drop: 1.0,
            extent: 80.0,
            reference_z: -1.73,
        }
    }
}

impl GroundConfig {
    /// Checks the cell, the extent (at most 2,000 cells a side) and the reference (keys
    /// relative to the ground table).
    pub fn validate(&self) -> Checked {
        positive("cell", self.cell as f64)?;
        positive("max_drop", self.max_drop as f64)?;
        positive("extent", self.extent as f64)?;
        within("extent", (self.extent / self.cell) as f64, 0.5, 1000.0)
            .map_err(|_| InvalidSetting::new("extent", "must span 1 to 2,000 cells a side (extent / cell ≤ 1,000)"))?;
        finite("reference_z", self.reference_z as f64)
    }
}

/// The estimated ground of one cloud on a square grid around the sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundModel {
    cell: f32,
    extent: f32,
    side: usize,
    reference_z: f32,
    /// Per cell (row-major over x, then y): the ground's z, `None` where no return lies in the
    /// cell's window.
    heights: Vec<Option<f32>>,
}

impl GroundModel {
    /// Estimates the ground of `points` (any order; points outside the extent are ignored).
    pub fn fit(points: &[Point], cfg: &GroundConfig) -> Self {
        let side = ((2.0 * cfg.extent / cfg.cell).ceil() as usize).max(1);
        let mut model = Self {
            cell: cfg.cell,
            extent: cfg.extent,
            side,
            reference_z: cfg.reference_z,
            heights: Vec::new(),
        };
        let floors = model.cell_floors(points, cfg.rank);
        let floors = drop_pits(&floors, side, cfg.window, cfg.max_drop);
        model.heights = erode(&floors, side, cfg.window);
        model
    }

    /// The flat ground's z the model was fitted with.
    pub fn reference_z(&self) -> f32 {
        self.reference_z
    }

    /// The ground's z under `(x, y)`, or the reference where nothing was seen around it.
    pub fn height_at(&self, x: f32, y: f32) -> f32 {
        self.cell_of(x, y)
            .and_then(|c| self.heights[c])
            .unwrap_or(self.reference_z)
    }

    /// How far the ground under `(x, y)` lies above the reference plane: the z shift that
    /// levels the cloud there.
    pub fn rise_at(&self, x: f32, y: f32) -> f32 {
        self.height_at(x, y) - self.reference_z
    }

    /// The cell holding `(x, y)`, if inside the extent.
    fn cell_of(&self, x: f32, y: f32) -> Option<usize> {
        let index = |v: f32| {
            let i = ((v + self.extent) / self.cell).floor();
            (i >= 0.0 && i < self.side as f32).then_some(i as usize)
        };
        Some(index(x)? * self.side + index(y)?)
    }

    /// Each cell's `rank`-th lowest z (its highest when it holds fewer returns).
    fn cell_floors(&self, points: &[Point], rank: usize) -> Vec<Option<f32>> {
        let k = rank + 1;
        // Per cell its k lowest z, ascending; +∞ marks a slot not yet filled (private to this
        // function: the result says "no return" with `None`).
        let mut lows = vec![f32::INFINITY; self.side * self.side * k];
        for p in points {
            if let Some(c) = self.cell_of(p[0], p[1]) {
                keep_lowest(&mut lows[c * k..(c + 1) * k], p[2]);
            }
        }
        lows.chunks(k)
            .map(|l| l.iter().rev().copied().find(|z| z.is_finite()))
            .collect()
    }
}

/// Inserts `z` into the ascending `lows` (a fixed number of slots), dropping the largest.
fn keep_lowest(lows: &mut [f32], z: f32) {
    let last = lows.len() - 1;
    // A NaN z (no reader passes one) is no floor either.
    if z.is_nan() || z >= lows[last] {
        return;
    }
    let at = lows.partition_point(|&v| v <= z);
    lows.copy_within(at..last, at + 1);
    lows[at] = z;
}

/// `floors` without those lying more than `max_drop` below the lower quartile of the floors in
/// their `(2w + 1)²` window (the `n / 4`-th of the `n` floors there, ascending, from 0): a pit
/// stands out of the road around it, while ground beside walls, vans and hedges, whose floors
/// lie above it, stays as long as a quarter of its window is as low.
fn drop_pits(floors: &[Option<f32>], side: usize, w: usize, max_drop: f32) -> Vec<Option<f32>> {
    let mut window = Vec::with_capacity((2 * w + 1).pow(2));
    let mut out = floors.to_vec();
    for i in 0..side {
        for j in 0..side {
            let Some(z) = floors[i * side + j] else { continue };
            window.clear();
            for a in i.saturating_sub(w)..=(i + w).min(side - 1) {
                for b in j.saturating_sub(w)..=(j + w).min(side - 1) {
                    window.extend(floors[a * side + b]);
                }
            }
            window.sort_by(f32::total_cmp);
            if z < window[window.len() / 4] - max_drop {
                out[i * side + j] = None;
            }
        }
    }
    out
}

/// The lowest value over the `(2w + 1)²` window around each cell of a `side × side` grid:
/// a separable minimum, rows then columns.
fn erode(floors: &[Option<f32>], side: usize, w: usize) -> Vec<Option<f32>> {
    let min = |a: Option<f32>, b: Option<f32>| match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let pass = |src: &[Option<f32>], at: &dyn Fn(usize, usize) -> usize| {
        let mut out = vec![None; src.len()];
        for i in 0..side {
            for j in 0..side {
                let lo = j.saturating_sub(w);
                let hi = (j + w).min(side - 1);
                out[at(i, j)] = (lo..=hi).map(|k| src[at(i, k)]).fold(None, min);
            }
        }
        out
    };
    let along_y = pass(floors, &|i, j| i * side + j);
    pass(&along_y, &|i, j| j * side + i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> GroundConfig {
        GroundConfig {
            extent: 20.0,
            ..GroundConfig::default()
        }
    }

    /// A road rising 1 m in 20 m ahead, sampled every 0.5 m.
    fn sloped_road() -> Vec<Point> {
        let mut pts = Vec::new();
        for i in 0..80 {
            for j in -20..20 {
                let (x, y) = (i as f32 * 0.25, j as f32 * 0.5);
                pts.push([x, y, -1.73 + 0.05 * x, 0.1]);
            }
        }
        pts
    }

    #[test]
    fn follows_a_sloped_road_within_the_windows_reach() {
        let g = GroundModel::fit(&sloped_road(), &cfg());
        for x in [2.0f32, 9.0, 15.0] {
            let truth = -1.73 + 0.05 * x;
            let est = g.height_at(x, 1.0);
            // Erosion takes the window's lowest return: at most 2.5 cells (5 m) downhill of x.
            assert!(
                est <= truth + 1e-5 && est >= truth - 0.05 * 5.0 - 1e-5,
                "x {x}: {est} vs {truth}"
            );
        }
        assert!((g.rise_at(15.0, 1.0) - (g.height_at(15.0, 1.0) + 1.73)).abs() < 1e-6);
    }

    #[test]
    fn a_car_on_the_road_is_not_ground_and_a_stray_low_return_is_skipped() {
        let mut pts = sloped_road();
        // A car-sized block of returns 0.3–1.5 m above the road at x = 10.
        for i in 0..20 {
            for k in 0..6 {
                pts.push([9.0 + 0.1 * i as f32, 2.0, -1.73 + 0.5 + 0.3 + 0.2 * k as f32, 0.2]);
            }
        }
        // One return 3 m below the road, and a cluster of four 10 m below it two cells away,
        // as reflections through glass give.
        pts.push([10.0, 2.0, -4.5, 0.0]);
        for k in 0..4 {
            pts.push([14.5, 2.0 + 0.1 * k as f32, -11.4, 0.0]);
        }
        let g = GroundModel::fit(&pts, &cfg());
        let road = -1.73 + 0.05 * 10.0;
        let est = g.height_at(10.0, 2.0);
        assert!(est <= road && est > road - 0.3, "{est} vs the road's {road}");
    }

    #[test]
    fn outside_the_extent_or_in_empty_windows_the_reference_holds() {
        let g = GroundModel::fit(&[[1.0, 1.0, -1.5, 0.0]], &cfg());
        assert_eq!(g.height_at(1.0, 1.0), -1.5);
        assert_eq!(g.height_at(15.0, -15.0), -1.73);
        assert_eq!(g.height_at(1e20, 0.0), -1.73);
        assert_eq!(g.rise_at(f32::NAN, 0.0), 0.0);
        // A wild return far outside the extent does not grow the grid.
        let wild = GroundModel::fit(&[[1e20, 0.0, -100.0, 0.0], [1.0, 1.0, -1.5, 0.0]], &cfg());
        assert_eq!(wild.heights.len(), 20 * 20);
        assert_eq!(wild.height_at(1.0, 1.0), -1.5);
    }

    #[test]
    fn keep_lowest_keeps_the_k_smallest_in_order() {
        let mut l = [f32::INFINITY; 3];
        keep_lowest(&mut l, 3.0);
        assert_eq!(l, [3.0, f32::INFINITY, f32::INFINITY]);
        for z in [1.0, 4.0, 1.0, 5.0, 0.5, 2.0, f32::NAN] {
            keep_lowest(&mut l, z);
        }
        assert_eq!(l, [0.5, 1.0, 1.0]);
    }

    #[test]
    fn pits_far_below_their_windows_median_are_dropped() {
        // A 3 x 3 grid: flat floors at 0 but one pit at -5 and one dip at -0.5.
        let mut floors = vec![Some(0.0f32); 9];
        floors[4] = Some(-5.0);
        floors[2] = Some(-0.5);
        floors[6] = None;
        let kept = drop_pits(&floors, 3, 1, 1.0);
        let mut want = floors.clone();
        want[4] = None;
        assert_eq!(kept, want);
        // Road in three of nine cells, the rest 2 m up (a van, a wall's top): the road stays.
        let mut beside = vec![Some(2.0f32); 9];
        for k in [0, 3, 6] {
            beside[k] = Some(0.0);
        }
        assert_eq!(drop_pits(&beside, 3, 1, 1.0), beside);
    }

    #[test]
    fn erosion_matches_a_brute_force_window_minimum() {
        let side = 7;
        let floors: Vec<Option<f32>> = (0..side * side)
            .map(|k| (k % 5 != 0).then_some(((k * 37) % 11) as f32))
            .collect();
        let fast = erode(&floors, side, 2);
        for i in 0..side {
            for j in 0..side {
                let mut want: Option<f32> = None;
                for a in i.saturating_sub(2)..=(i + 2).min(side - 1) {
                    for b in j.saturating_sub(2)..=(j + 2).min(side - 1) {
                        if let Some(v) = floors[a * side + b] {
                            want = Some(want.map_or(v, |w: f32| w.min(v)));
                        }
                    }
                }
                assert_eq!(fast[i * side + j], want, "cell ({i}, {j})");
            }
        }
    }
}
