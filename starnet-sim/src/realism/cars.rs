//! What a labelled car looks like to the sensor, by distance: its points, their reflectance,
//! how high they sit, from which side the sensor sees it, and how its box sits on them (the
//! annotator's margins: `sim::AnnotationMargin`).

use super::axis::principal_angle;
use serde::{Deserialize, Serialize};
use starnet_data::summary::{mean, quantile};
use starnet_data::{Box3d, Point};

/// Distance bin edges for cars, metres.
pub const CAR_EDGES_M: [f32; 6] = [0.0, 10.0, 20.0, 30.0, 40.0, 80.0];
/// Height above a car's bottom face beyond which its points count as "high", metres.
pub const HIGH_POINT_M: f32 = 1.1;

/// Returns this far outside a car's box still count as the car's when its box fit is measured
/// (range noise scatters them about the surfaces), metres ([`Box3d::grown`]).
pub const FIT_REACH_M: f32 = 0.2;
/// Returns this far above a box's bottom are the car's, not the road's, metres.
const FIT_ABOVE_ROAD_M: f32 = 0.3;
/// The returns of a car's end: those within this depth of the box's end, metres.
pub const END_ZONE_M: f32 = 0.6;
/// The end's returns within the box's width, at least this many, give its tilt.
const END_TILT_MIN_POINTS: usize = 8;
/// View-angle bin edges for the end's tilt, degrees from end-on.
pub const VIEW_EDGES_DEG: [f32; 5] = [0.0, 15.0, 30.0, 45.0, 90.0];
/// A box's fit is measured on cars with at least this many of the car's returns.
pub const FIT_MIN_POINTS: usize = 30;
/// The road beside a car: returns within this distance of its footprint (and outside the
/// footprint grown by [`FIT_REACH_M`] + 0.1 m), within ±0.5 m of its bottom, metres.
const ROAD_RING_M: f32 = 1.5;
/// The road's level beside a car: this quantile of those returns' heights.
const ROAD_QUANTILE: f64 = 0.15;

/// How a labelled box sits on its car's returns, metres: where annotators put the faces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxFit {
    /// The box top above the 99th percentile of the returns' heights.
    pub top_gap: f32,
    /// The box end facing the sensor past the 99th percentile of the returns along the length
    /// (negative: returns beyond the box's end).
    pub end_gap: f32,
    /// The median depth behind the box's end (the sensor's end) of the returns within
    /// [`END_ZONE_M`] of it: how rounded the end is (a flat face: about 0); `None` when no
    /// return lies there.
    pub end_depth: Option<f32>,
    /// How far the line through those returns (the ones within the box's width) is turned
    /// from the box's end, degrees, positive when it turns towards facing the sensor: an end
    /// seen obliquely returns most where it faces the sensor, so the rounder its corners the more
    /// it turns. `None` with fewer than 8 such returns.
    pub end_tilt_deg: Option<f32>,
    /// The road beside the car above the box's bottom (the 15th percentile of the heights of
    /// the returns within 1.5 m of its footprint and 0.5 m of its bottom; kerbs and sidewalks
    /// raise the median on one side); `None` with fewer than 10 such returns.
    pub road_gap: Option<f32>,
}

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
    /// How its box sits on its returns; `None` below [`FIT_MIN_POINTS`].
    pub fit: Option<BoxFit>,
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
        fit: box_fit(b, cloud),
    })
}

/// How box `b` sits on its returns in `cloud` (see [`BoxFit`]).
pub fn box_fit(b: &Box3d, cloud: &[Point]) -> Option<BoxFit> {
    let bottom = b.z - 0.5 * b.dz;
    let local: Vec<[f32; 3]> = b
        .grown(FIT_REACH_M)
        .points_inside(cloud)
        .into_iter()
        .map(|i| b.to_local([cloud[i][0], cloud[i][1], cloud[i][2]]))
        .filter(|q| q[2] + 0.5 * b.dz > FIT_ABOVE_ROAD_M)
        .collect();
    if local.len() < FIT_MIN_POINTS {
        return None;
    }
    let p99 = |v: Vec<f64>| quantile(&v, 0.99).unwrap_or(0.0) as f32;
    // The end the sensor sees: the sign of the sensor's position along the car's length.
    let sensor = b.to_local([0.0, 0.0, 0.0]);
    let toward = sensor[0].signum();
    let end_zone: Vec<f64> = local
        .iter()
        .map(|q| 0.5 * b.dx - toward * q[0])
        .filter(|d| *d < END_ZONE_M)
        .map(f64::from)
        .collect();
    Some(BoxFit {
        top_gap: 0.5 * b.dz - p99(local.iter().map(|q| q[2] as f64).collect()),
        end_gap: 0.5 * b.dx - p99(local.iter().map(|q| (toward * q[0]) as f64).collect()),
        end_depth: quantile(&end_zone, 0.5).map(|d| d as f32),
        end_tilt_deg: end_tilt(b, &local, sensor),
        road_gap: road_level(b, cloud).map(|z| z - bottom),
    })
}

/// [`BoxFit::end_tilt_deg`] of box `b` from its returns `local` and the sensor, both in the
/// box's frame.
fn end_tilt(b: &Box3d, local: &[[f32; 3]], sensor: [f32; 3]) -> Option<f32> {
    let toward = sensor[0].signum();
    let end_face: Vec<[f32; 2]> = local
        .iter()
        .filter(|q| 0.5 * b.dx - toward * q[0] < END_ZONE_M && q[1].abs() <= 0.5 * b.dy)
        .map(|q| [q[0], q[1]])
        .collect();
    // The line turned by α from the across axis faces the sensor's side when α has the sign
    // opposite to `toward · side`.
    (end_face.len() >= END_TILT_MIN_POINTS).then(|| -toward * sensor[1].signum() * across_tilt(&end_face).to_degrees())
}

/// The angle from the box's across axis (`v`) to the principal direction of points `[u, v]`
/// in the box's frame, radians in (−π/2, π/2], positive towards +u from +v.
fn across_tilt(points: &[[f32; 2]]) -> f32 {
    // The principal axis lies at θ from +u; from +v towards +u that is π/2 − θ, folded.
    let theta = principal_angle(points.iter().copied());
    let a = std::f32::consts::FRAC_PI_2 - theta;
    if a > std::f32::consts::FRAC_PI_2 {
        a - std::f32::consts::PI
    } else {
        a
    }
}

/// The road's height beside box `b` ([`ROAD_RING_M`], [`ROAD_QUANTILE`]).
fn road_level(b: &Box3d, cloud: &[Point]) -> Option<f32> {
    let bottom = b.z - 0.5 * b.dz;
    let ring = Box3d {
        dx: b.dx + 2.0 * ROAD_RING_M,
        dy: b.dy + 2.0 * ROAD_RING_M,
        z: bottom,
        dz: 1.0,
        ..*b
    };
    let hole = Box3d {
        dx: b.dx + 2.0 * (FIT_REACH_M + 0.1),
        dy: b.dy + 2.0 * (FIT_REACH_M + 0.1),
        ..ring
    };
    let in_hole = hole.point_test();
    let heights: Vec<f64> = ring
        .points_inside(cloud)
        .into_iter()
        .filter(|&i| !in_hole(&cloud[i]))
        .map(|i| cloud[i][2] as f64)
        .collect();
    (heights.len() >= 10).then(|| quantile(&heights, ROAD_QUANTILE).unwrap_or(0.0) as f32)
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
    /// Cars whose box fit was measured ([`FIT_MIN_POINTS`]).
    pub fitted: usize,
    /// Median over them of [`BoxFit::top_gap`], metres.
    pub top_gap_m: Option<f64>,
    /// Median over them of [`BoxFit::end_gap`], metres.
    pub end_gap_m: Option<f64>,
    /// Median over them of [`BoxFit::end_depth`], metres.
    pub end_depth_m: Option<f64>,
    /// Median of [`BoxFit::road_gap`] over those with a road beside them, metres.
    pub road_gap_m: Option<f64>,
}

/// The bins of [`CAR_EDGES_M`] over `cars`.
pub fn car_bins(cars: &[CarSample]) -> Vec<CarBin> {
    CAR_EDGES_M
        .windows(2)
        .map(|w| {
            let bin: Vec<&CarSample> = cars.iter().filter(|c| (w[0]..w[1]).contains(&c.distance)).collect();
            let of = |f: fn(&CarSample) -> f64| bin.iter().map(|c| f(c)).collect::<Vec<f64>>();
            let fits: Vec<BoxFit> = bin.iter().filter_map(|c| c.fit).collect();
            let median = |v: Vec<f64>| quantile(&v, 0.5);
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
                fitted: fits.len(),
                top_gap_m: median(fits.iter().map(|f| f.top_gap as f64).collect()),
                end_gap_m: median(fits.iter().map(|f| f.end_gap as f64).collect()),
                end_depth_m: median(fits.iter().filter_map(|f| f.end_depth.map(f64::from)).collect()),
                road_gap_m: median(fits.iter().filter_map(|f| f.road_gap.map(f64::from)).collect()),
            }
        })
        .collect()
}

/// The cars seen from one range of angles from end-on ([`VIEW_EDGES_DEG`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ViewBin {
    /// Bin start, degrees.
    pub lo: f32,
    /// Bin end, degrees.
    pub hi: f32,
    /// Cars whose end's tilt was measured.
    pub cars: usize,
    /// Median over them of [`BoxFit::end_tilt_deg`], degrees.
    pub end_tilt_deg: Option<f64>,
}

/// The bins of [`VIEW_EDGES_DEG`] over `cars`: how their ends' returns turn.
pub fn view_bins(cars: &[CarSample]) -> Vec<ViewBin> {
    VIEW_EDGES_DEG
        .windows(2)
        .map(|w| {
            let last = w[1] == VIEW_EDGES_DEG[VIEW_EDGES_DEG.len() - 1];
            let tilts: Vec<f64> = cars
                .iter()
                .filter(|c| c.view_deg >= w[0] && (c.view_deg < w[1] || last))
                .filter_map(|c| c.fit.and_then(|f| f.end_tilt_deg).map(f64::from))
                .collect();
            ViewBin {
                lo: w[0],
                hi: w[1],
                cars: tilts.len(),
                end_tilt_deg: quantile(&tilts, 0.5),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_fit_reads_the_gaps_to_the_returns_and_the_road() {
        // 10 m ahead, pointing away: the sensor sees its rear end, at x = 8. Bottom −1.7, top −0.1.
        let car = Box3d::new(10.0, 0.0, -0.9, 4.0, 1.6, 1.6, 0.0);
        // 40 returns on a rear face 5 cm inside the box, the highest 6 cm under its top.
        let mut cloud: Vec<Point> = (0..40)
            .map(|i| [8.05, -0.7 + 0.035 * i as f32, -1.3 + 1.14 * i as f32 / 39.0, 0.2])
            .collect();
        // A return of the road under the car (inside the footprint: not the road beside it) and
        // twelve on the road beside it, 5 cm above the box's bottom.
        cloud.push([9.0, 0.0, -1.69, 0.1]);
        cloud.extend((0..12).map(|i| [7.0 + 0.2 * i as f32, 1.5, -1.65, 0.1]));
        let fit = box_fit(&car, &cloud).expect("40 returns");
        let close = |a: f32, b: f32| (a - b).abs() < 1e-4;
        assert!(close(fit.end_gap, 0.05) && close(fit.top_gap, 0.06), "{fit:?}");
        // Every return lies on the face 5 cm behind the end.
        assert!(close(fit.end_depth.expect("returns at the end"), 0.05), "{fit:?}");
        // A flat end face square to the box: no tilt.
        assert!(fit.end_tilt_deg.expect("40 returns at the end").abs() < 1e-3, "{fit:?}");
        assert!(close(fit.road_gap.expect("12 road returns"), 0.05), "{fit:?}");
        // Turned end for end, the sensor still faces the same end: the same gap.
        let turned = Box3d {
            heading: std::f32::consts::PI,
            ..car
        };
        assert!(close(box_fit(&turned, &cloud).unwrap().end_gap, 0.05));
        // Too few returns: no fit; no road beside it: no road gap.
        assert_eq!(box_fit(&car, &cloud[..29]), None);
        assert_eq!(box_fit(&car, &cloud[..40]).unwrap().road_gap, None);
    }

    #[test]
    fn an_end_face_turned_towards_the_sensor_tilts_positive() {
        // 10 m ahead and 3 m to the right, pointing away: the sensor (local u −10, v +3) sees the
        // rear end (u = −2) and the left side (+v). Returns on a line through u = −1.9 whose
        // normal, (−1, 0) for the end, is turned β towards +v: direction (sin β, cos β).
        let car = Box3d::new(10.0, -3.0, -0.9, 4.0, 1.6, 1.6, 0.0);
        for beta_deg in [10.0f32, -6.0] {
            let (s, c) = beta_deg.to_radians().sin_cos();
            let cloud: Vec<Point> = (0..40)
                .map(|i| {
                    let t = -0.7 + 1.4 * i as f32 / 39.0;
                    [10.0 - 1.9 + t * s, -3.0 + t * c, -0.9, 0.2]
                })
                .collect();
            let tilt = box_fit(&car, &cloud).and_then(|f| f.end_tilt_deg).expect("40 returns");
            assert!((tilt - beta_deg).abs() < 1e-3, "{tilt} for {beta_deg}");
            // Seen atan(3 / 10) = 16.7° from end-on: the 15–30° bin holds it.
            let bins = view_bins(&[car_sample(&car, &cloud).expect("returns")]);
            let counts: Vec<usize> = bins.iter().map(|b| b.cars).collect();
            assert_eq!(counts, [0, 1, 0, 0]);
            assert!((bins[1].end_tilt_deg.unwrap() - beta_deg as f64).abs() < 1e-3);
            // Mirrored across the car's axis (the sensor on the other side), the same turn.
            let mirrored = Box3d { y: 3.0, ..car };
            let cloud: Vec<Point> = cloud.iter().map(|p| [p[0], -p[1], p[2], p[3]]).collect();
            let tilt = box_fit(&mirrored, &cloud).and_then(|f| f.end_tilt_deg).unwrap();
            assert!((tilt - beta_deg).abs() < 1e-3, "mirrored: {tilt} for {beta_deg}");
        }
    }

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
