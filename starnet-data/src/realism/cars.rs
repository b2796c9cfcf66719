//! What a labelled car looks like to the sensor, by distance: its points, their reflectance,
//! how high they sit, and from which side the sensor sees it.

use crate::summary::{mean, quantile};
use crate::{Box3d, Point};
use serde::{Deserialize, Serialize};

/// Distance bin edges for cars, metres.
pub const CAR_EDGES_M: [f32; 6] = [0.0, 10.0, 20.0, 30.0, 40.0, 80.0];
/// Height above a car's bottom face beyond which its points count as "high", metres.
pub const HIGH_POINT_M: f32 = 1.1;

/// One labelled car as scanned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarSample {
    /// Bird's-eye distance of its centre, metres.
    pub distance: f32,
    /// Returns inside its box.
    pub points: usize,
    /// Their mean reflectance.
    pub mean_reflectance: f32,
    /// Share of them reading exactly 0.
    pub zero_share: f32,
    /// Share of them more than [`HIGH_POINT_M`] above the box's bottom.
    pub high_share: f32,
    /// Angle between its length axis and the line of sight, folded to [0°, 90°]: 0 end-on
    /// (front or rear), 90 side-on.
    pub view_deg: f32,
}

/// The scan of car `b` in `cloud`; `None` when no return lies inside it.
pub fn car_sample(b: &Box3d, cloud: &[Point]) -> Option<CarSample> {
    let inside: Vec<&Point> = b.points_inside(cloud).into_iter().map(|i| &cloud[i]).collect();
    if inside.is_empty() {
        return None;
    }
    let n = inside.len() as f32;
    let bottom = b.z - 0.5 * b.dz;
    let sight = b.y.atan2(b.x);
    let off = (b.heading - sight).rem_euclid(std::f32::consts::PI);
    Some(CarSample {
        distance: b.x.hypot(b.y),
        points: inside.len(),
        mean_reflectance: inside.iter().map(|p| p[3]).sum::<f32>() / n,
        zero_share: inside.iter().filter(|p| p[3] == 0.0).count() as f32 / n,
        high_share: inside.iter().filter(|p| p[2] - bottom > HIGH_POINT_M).count() as f32 / n,
        view_deg: off.min(std::f32::consts::PI - off).to_degrees(),
    })
}

/// The cars of one distance bin.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct CarBin {
    /// Bin start, metres.
    pub lo: f32,
    /// Bin end, metres.
    pub hi: f32,
    /// Cars with at least one return.
    pub cars: usize,
    /// Median returns per car.
    pub median_points: f64,
    /// Mean over cars of their mean reflectance.
    pub mean_reflectance: f64,
    /// Mean over cars of their share of zero reflectance, percent.
    pub zero_percent: f64,
    /// Mean over cars of their share of high points, percent.
    pub high_percent: f64,
    /// Cars seen end-on (view < 30°), percent.
    pub end_on_percent: f64,
    /// Cars seen three-quarter (30°–60°), percent.
    pub three_quarter_percent: f64,
    /// Cars seen side-on (> 60°), percent.
    pub side_percent: f64,
}

/// The bins of [`CAR_EDGES_M`] over `cars`.
pub fn car_bins(cars: &[CarSample]) -> Vec<CarBin> {
    CAR_EDGES_M
        .windows(2)
        .map(|w| {
            let bin: Vec<&CarSample> = cars.iter().filter(|c| (w[0]..w[1]).contains(&c.distance)).collect();
            let of = |f: fn(&CarSample) -> f64| bin.iter().map(|c| f(c)).collect::<Vec<f64>>();
            let percent = |f: fn(&CarSample) -> bool| {
                100.0 * bin.iter().filter(|c| f(c)).count() as f64 / bin.len().max(1) as f64
            };
            CarBin {
                lo: w[0],
                hi: w[1],
                cars: bin.len(),
                median_points: quantile(&of(|c| c.points as f64), 0.5).unwrap_or(0.0),
                mean_reflectance: mean(&of(|c| c.mean_reflectance as f64)),
                zero_percent: 100.0 * mean(&of(|c| c.zero_share as f64)),
                high_percent: 100.0 * mean(&of(|c| c.high_share as f64)),
                end_on_percent: percent(|c| c.view_deg < 30.0),
                three_quarter_percent: percent(|c| (30.0..=60.0).contains(&c.view_deg)),
                side_percent: percent(|c| c.view_deg > 60.0),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_car_ahead_pointing_away_is_end_on_and_one_beside_is_side_on() {
        // 10 m ahead (bottom at −1.7 m), heading along the line of sight; two returns, the second
        // 1.3 m above the bottom and reading 0.
        let ahead = Box3d::new(10.0, 0.0, -0.9, 4.0, 1.6, 1.6, 0.0);
        let cloud = [[8.1, 0.0, -1.5, 0.4], [8.1, 0.2, -0.4, 0.0]];
        let s = car_sample(&ahead, &cloud).unwrap();
        assert_eq!(s.points, 2);
        assert!(s.view_deg.abs() < 1e-4 && (s.mean_reflectance - 0.2).abs() < 1e-6);
        assert!(
            (s.zero_share - 0.5).abs() < 1e-6 && (s.high_share - 0.5).abs() < 1e-6,
            "{s:?}"
        );
        // Facing the sensor is end-on too; crossing the line of sight is side-on.
        let facing = Box3d {
            heading: std::f32::consts::PI,
            ..ahead
        };
        assert!(car_sample(&facing, &cloud).unwrap().view_deg < 1e-3);
        let beside = Box3d::new(0.0, 10.0, -0.9, 4.0, 1.6, 1.6, 0.0);
        let s = car_sample(&beside, &[[0.0, 9.3, -1.0, 0.2]]).unwrap();
        assert!((s.view_deg - 90.0).abs() < 1e-3);
        assert_eq!(car_sample(&beside, &cloud), None);
        let bins = car_bins(&[s]);
        assert_eq!(
            (bins[1].cars, bins[1].side_percent, bins[1].end_on_percent),
            (1, 100.0, 0.0)
        );
    }
}
