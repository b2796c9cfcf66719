//! The anchor layout around a center (StarNet §3.3, lingvo `params/kitti.py`): a G × G grid
//! of xy offsets, each with R rotations of each size prior. Pure geometry, shared by the
//! coverage statistic, target assignment and the model's heads, which index anchors in the
//! order [`AnchorGrid::anchors_around`] produces: offset outermost, then rotation, then prior
//! (lingvo's cx, cy, rot, dim order).

use crate::Box3d;
use crate::kitti::ObjectClass;
use crate::settings::{Checked, at_least_one, finite, non_negative, positive};
use serde::{Deserialize, Serialize};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

/// A size prior: a class's mean box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AnchorPrior {
    /// Box size `[dx, dy, dz]` (length along the heading first; lingvo's KITTI priors put the
    /// width first, we do not).
    pub size: [f32; 3],
    /// z of the anchor centre (the center's own z is 0 in the authors' setting).
    pub z: f32,
}

/// The anchors around every center.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorGrid {
    /// Grid side G: offsets form a G × G grid.
    pub grid: usize,
    /// Half-extent of the grid (m): offsets span `linspace(-extent, extent, G)` in x and y.
    pub extent: f32,
    /// Headings, in order.
    pub rotations: Vec<f32>,
    /// Size priors, in order.
    pub priors: Vec<AnchorPrior>,
}

impl AnchorGrid {
    /// Checks the grid side, the extent, and that there is at least one finite rotation and
    /// one prior of positive size (keys relative to the anchors table).
    pub fn validate(&self) -> Checked {
        at_least_one("grid", self.grid)?;
        non_negative("extent", self.extent as f64)?;
        at_least_one("rotations", self.rotations.len())?;
        for &r in &self.rotations {
            finite("rotations", r as f64)?;
        }
        at_least_one("priors", self.priors.len())?;
        for (i, p) in self.priors.iter().enumerate() {
            for s in p.size {
                positive(&format!("priors[{i}].size"), s as f64)?;
            }
            finite(&format!("priors[{i}].z"), p.z as f64)?;
        }
        Ok(())
    }

    /// KITTI car anchors: 5 × 5 offsets over ±1.294 m, 4 rotations, the SECOND car size,
    /// centre z −1.0 (lingvo `StarNetCarModel0701`, with the length put first).
    pub fn kitti_car() -> Self {
        let priors = vec![AnchorPrior {
            size: [3.9, 1.6, 1.56],
            z: -1.0,
        }];
        Self {
            grid: 5,
            extent: 1.294,
            rotations: vec![0.0, FRAC_PI_2, FRAC_PI_4, 3.0 * FRAC_PI_4],
            priors,
        }
    }

    /// Pedestrian anchors: 3 × 3 offsets over ±0.31 m (lingvo 0704), 2 rotations.
    pub fn kitti_pedestrian() -> Self {
        let priors = vec![AnchorPrior {
            size: [0.8, 0.6, 1.73],
            z: -0.6,
        }];
        Self {
            grid: 3,
            extent: 0.31,
            rotations: vec![0.0, FRAC_PI_2],
            priors,
        }
    }

    /// Cyclist anchors: 3 × 3 offsets over ±0.31 m, 4 rotations.
    pub fn kitti_cyclist() -> Self {
        let priors = vec![AnchorPrior {
            size: [1.76, 0.6, 1.73],
            z: -0.6,
        }];
        Self {
            grid: 3,
            extent: 0.31,
            rotations: vec![0.0, FRAC_PI_2, FRAC_PI_4, 3.0 * FRAC_PI_4],
            priors,
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

    /// Anchors per center A: G² · rotations · priors.
    pub fn len(&self) -> usize {
        self.grid * self.grid * self.rotations.len() * self.priors.len()
    }

    /// The largest footprint radius of the priors (for distance pre-filters).
    pub fn max_radius(&self) -> f32 {
        self.priors
            .iter()
            .map(|p| 0.5 * p.size[0].hypot(p.size[1]))
            .fold(0.0, f32::max)
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

    /// The A anchors around a center: for each offset, each rotation, each prior. Anchor z is
    /// the center's z plus the prior's z.
    pub fn anchors_around(&self, center: [f32; 3]) -> Vec<Box3d> {
        let mut out = Vec::with_capacity(self.len());
        for [ox, oy] in self.offsets() {
            for &r in &self.rotations {
                for p in &self.priors {
                    let [dx, dy, dz] = p.size;
                    out.push(Box3d::new(
                        center[0] + ox,
                        center[1] + oy,
                        center[2] + p.z,
                        dx,
                        dy,
                        dz,
                        r,
                    ));
                }
            }
        }
        out
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
        let a = g.anchors_around([10.0, 5.0, 0.0]);
        assert_eq!(a.len(), 100);
        // Offset-major, rotation-minor: anchors 48..52 are the centre offset's four rotations.
        assert_eq!((a[48].x, a[48].y, a[48].z, a[48].heading), (10.0, 5.0, -1.0, 0.0));
        assert!((a[49].heading - FRAC_PI_2).abs() < 1e-6);
        // Priors vary fastest.
        let two = AnchorGrid {
            priors: vec![
                AnchorPrior { size: [1.0; 3], z: 0.0 },
                AnchorPrior { size: [2.0; 3], z: 0.0 },
            ],
            ..g
        };
        let b = two.anchors_around([0.0; 3]);
        assert_eq!(b.len(), 200);
        assert_eq!(
            (b[0].dx, b[1].dx, b[1].heading, b[2].heading),
            (1.0, 2.0, 0.0, FRAC_PI_2)
        );
    }
}
