//! The anchor layout around a center (StarNet §3.3, lingvo `params/kitti.py`): a G × G grid
//! of xy offsets, each with R rotations of the class's mean box. Pure geometry, shared by the
//! coverage statistic, target assignment and the model's heads (which index anchors in the
//! order [`AnchorGrid::anchors_around`] produces: offset-major, rotation-minor).

use crate::Box3d;
use crate::kitti::ObjectClass;
use serde::{Deserialize, Serialize};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

/// Anchors of one class around every center.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorGrid {
    /// Grid side G: offsets form a G × G grid.
    pub grid: usize,
    /// Half-extent of the grid (m): offsets span `linspace(-extent, extent, G)` in x and y.
    pub extent: f32,
    /// z of the anchor centres (the center's z is 0 in the authors' setting).
    pub z: f32,
    /// Box size `[dx, dy, dz]` (length along the heading first).
    pub size: [f32; 3],
    /// Headings, in order.
    pub rotations: Vec<f32>,
}

impl AnchorGrid {
    /// KITTI car anchors: 5 × 5 offsets over ±1.294 m, 4 rotations, the SECOND car size,
    /// centre z −1.0 (lingvo `StarNetCarModel0701`, with the length put first).
    pub fn kitti_car() -> Self {
        Self {
            grid: 5,
            extent: 1.294,
            z: -1.0,
            size: [3.9, 1.6, 1.56],
            rotations: vec![0.0, FRAC_PI_2, FRAC_PI_4, 3.0 * FRAC_PI_4],
        }
    }

    /// Pedestrian anchors: 3 × 3 offsets over ±0.31 m (lingvo 0704), 2 rotations.
    pub fn kitti_pedestrian() -> Self {
        Self {
            grid: 3,
            extent: 0.31,
            z: -0.6,
            size: [0.8, 0.6, 1.73],
            rotations: vec![0.0, FRAC_PI_2],
        }
    }

    /// Cyclist anchors: 3 × 3 offsets over ±0.31 m, 4 rotations.
    pub fn kitti_cyclist() -> Self {
        Self {
            grid: 3,
            extent: 0.31,
            z: -0.6,
            size: [1.76, 0.6, 1.73],
            rotations: vec![0.0, FRAC_PI_2, FRAC_PI_4, 3.0 * FRAC_PI_4],
        }
    }

    /// The preset for a class (cars' for vehicle-like classes, pedestrians' for people).
    pub fn for_class(class: ObjectClass) -> Self {
        match class {
            ObjectClass::Pedestrian | ObjectClass::PersonSitting => Self::kitti_pedestrian(),
            ObjectClass::Cyclist => Self::kitti_cyclist(),
            _ => Self::kitti_car(),
        }
    }

    /// Anchors per center: G² · R.
    pub fn len(&self) -> usize {
        self.grid * self.grid * self.rotations.len()
    }

    /// Whether the grid has no anchor.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The offsets, row-major over (x, y).
    pub fn offsets(&self) -> Vec<[f32; 2]> {
        let step = if self.grid > 1 {
            2.0 * self.extent / (self.grid - 1) as f32
        } else {
            0.0
        };
        let at = |i: usize| {
            if self.grid > 1 {
                -self.extent + step * i as f32
            } else {
                0.0
            }
        };
        (0..self.grid)
            .flat_map(|i| (0..self.grid).map(move |j| [at(i), at(j)]))
            .collect()
    }

    /// The anchors around a center `(x, y)`: for each offset, each rotation.
    pub fn anchors_around(&self, center: [f32; 2]) -> Vec<Box3d> {
        let [dx, dy, dz] = self.size;
        self.offsets()
            .into_iter()
            .flat_map(|[ox, oy]| {
                self.rotations
                    .iter()
                    .map(move |&r| Box3d::new(center[0] + ox, center[1] + oy, self.z, dx, dy, dz, r))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn car_grid_matches_lingvo() {
        let g = AnchorGrid::kitti_car();
        assert_eq!(g.len(), 100);
        let o = g.offsets();
        assert_eq!(o[0], [-1.294, -1.294]);
        assert!((o[1][1] + 0.647).abs() < 1e-6, "step 0.647: {:?}", o[1]);
        assert_eq!(o[12], [0.0, 0.0]);
        let a = g.anchors_around([10.0, 5.0]);
        assert_eq!(a.len(), 100);
        // Offset-major, rotation-minor: anchors 48..52 are the centre offset's four rotations.
        assert_eq!((a[48].x, a[48].y, a[48].heading), (10.0, 5.0, 0.0));
        assert!((a[49].heading - FRAC_PI_2).abs() < 1e-6);
    }
}
