//! The ground under a scan, without a model of it: the lowest return of each 2 m cell.
//! A point is ground when it lies within 0.2 m of its cell's lowest return and that return
//! is below the sensor by more than 1.2 m (a cell holding only a wall's face has no ground).

use starnet_data::Point;
use std::collections::HashMap;

/// Cell side, metres.
pub const GROUND_CELL_M: f32 = 2.0;
/// Height above the cell's lowest return still counted as ground, metres.
pub const GROUND_BAND_M: f32 = 0.2;
/// A cell's lowest return must lie this far below the sensor to be ground, metres.
const GROUND_BELOW_SENSOR_M: f32 = -1.2;

/// The lowest return of each cell of a cloud.
#[derive(Debug, Clone, Default)]
pub struct GroundGrid {
    lowest: HashMap<(i32, i32), f32>,
}

fn cell(p: &Point) -> (i32, i32) {
    (
        (p[0] / GROUND_CELL_M).floor() as i32,
        (p[1] / GROUND_CELL_M).floor() as i32,
    )
}

impl GroundGrid {
    /// The grid of `points`.
    pub fn new(points: &[Point]) -> Self {
        let mut lowest = HashMap::new();
        for p in points {
            let z = lowest.entry(cell(p)).or_insert(f32::INFINITY);
            *z = z.min(p[2]);
        }
        Self { lowest }
    }

    /// Height of `p` above its cell's lowest return (a point of the grid's cloud).
    pub fn height_above(&self, p: &Point) -> f32 {
        p[2] - self.lowest.get(&cell(p)).copied().unwrap_or(p[2])
    }

    /// Whether `p` is a ground return.
    pub fn is_ground(&self, p: &Point) -> bool {
        let low = self.lowest.get(&cell(p)).copied().unwrap_or(p[2]);
        low < GROUND_BELOW_SENSOR_M && p[2] - low < GROUND_BAND_M
    }

    /// The lowest returns of the cells whose centres satisfy `keep(x, y)`.
    pub fn cell_minima(&self, keep: impl Fn(f32, f32) -> bool) -> Vec<f32> {
        let mut out: Vec<(i32, i32, f32)> = self
            .lowest
            .iter()
            .filter(|((i, j), _)| {
                let c = |k: i32| (k as f32 + 0.5) * GROUND_CELL_M;
                keep(c(*i), c(*j))
            })
            .map(|((i, j), z)| (*i, *j, *z))
            .collect();
        // A fixed order: the HashMap's is not.
        out.sort_by_key(|(i, j, _)| (*i, *j));
        out.into_iter().map(|(_, _, z)| z).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ground_is_the_band_over_each_cells_lowest_return() {
        let pts = vec![
            [1.0, 1.0, -1.7, 0.0],  // ground
            [1.5, 1.2, -1.55, 0.0], // 0.15 above: ground
            [1.2, 0.5, -1.0, 0.0],  // 0.7 above: not
            [5.0, 5.0, 0.5, 0.0],   // a cell with only a wall's face: no ground
        ];
        let g = GroundGrid::new(&pts);
        let ground: Vec<bool> = pts.iter().map(|p| g.is_ground(p)).collect();
        assert_eq!(ground, [true, true, false, false]);
        assert!((g.height_above(&pts[2]) - 0.7).abs() < 1e-6);
        assert_eq!(g.cell_minima(|x, _| x < 2.0), vec![-1.7]);
    }
}
