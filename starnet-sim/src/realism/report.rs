//! The realism report of one folder: the statistics per frame and their summaries.

use super::{
    cars::CarBin, cars::CarSample, cars::ViewBin, cars::car_bins, cars::car_sample, cars::view_bins, clusters::Cluster,
    clusters::clusters, ground::GroundGrid, reflectance::ReflectanceBin, reflectance::ReflectanceSums,
    surfaces::LocalShape, surfaces::sampled_shapes,
};
use serde::{Deserialize, Serialize};
use starnet_data::geometry::{GroundConfig, GroundModel};
use starnet_data::kitti::{Frame, KittiDataset, ObjectClass};
use starnet_data::sampling::CenterPoolConfig;
use starnet_data::summary::{mean, quantile};
use starnet_data::{Point, Result};
use std::path::{Path, PathBuf};

/// Every `SURFACE_STRIDE`-th background return is measured for its shape.
const SURFACE_STRIDE: usize = 8;
/// Background shapes are measured between these ranges, metres (nearer, a 0.5 m ball holds
/// many rings; farther, too few returns).
const SURFACE_RANGE_M: (f32, f32) = (5.0, 30.0);
/// Off-road cells: beyond this lateral distance, within [`SURFACE_RANGE_M`].
const OFF_ROAD_Y_M: f32 = 8.0;
/// The road level: cells within this lateral distance.
const ROAD_Y_M: f32 = 3.0;

/// Reflectance by range for each kind of return.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ReflectanceTable {
    /// Every return in the camera's view.
    pub all: Vec<ReflectanceBin>,
    /// Ground returns ([`GroundGrid`]).
    pub ground: Vec<ReflectanceBin>,
    /// Returns inside labelled cars.
    pub cars: Vec<ReflectanceBin>,
    /// The rest: neither ground nor inside a labelled object.
    pub background: Vec<ReflectanceBin>,
}

/// The shape of the background and of the ground beside the road.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SurfaceStats {
    /// Background neighbourhoods measured.
    pub sampled: usize,
    /// Volumetric ones (foliage, clutter), percent.
    pub volumetric_percent: f64,
    /// Planar vertical ones (walls, fences), percent.
    pub vertical_percent: f64,
    /// Median height of background returns above their cell's lowest return, metres.
    pub background_height_p50: f64,
    /// 90th percentile of the lowest return of off-road cells above the road level, metres.
    pub off_road_p90: f64,
}

/// A per-frame figure's spread over the frames.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Percentiles {
    /// 10th percentile.
    pub p10: f64,
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
}

impl Percentiles {
    fn of(values: &[f64]) -> Self {
        let q = |p: f64| quantile(values, p).unwrap_or(0.0);
        Self {
            p10: q(0.1),
            p50: q(0.5),
            p90: q(0.9),
        }
    }
}

/// How the road rises ahead of the sensor and into the authors' flat center pool (z ≥ −1.35):
/// per frame, from the local ground ([`GroundModel`] at its defaults, reference z −1.73).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct GroundRiseStats {
    /// The ground's rise above the reference 20 m ahead (x = 20, y = 0), metres.
    pub rise_20m: Percentiles,
    /// The same 40 m ahead.
    pub rise_40m: Percentiles,
    /// Share of the flat pool's returns in the camera view lying within [`POOL_ROAD_BAND_M`] of
    /// the local ground: road that FPS may pick as a center, percent.
    pub pool_road_percent: Percentiles,
}

/// Returns this close above the local ground count as road in [`GroundRiseStats`], metres.
pub const POOL_ROAD_BAND_M: f32 = 0.3;

/// Car-sized clusters of background returns ([`clusters`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ClusterStats {
    /// Per frame, anywhere in the camera view.
    pub per_frame: f64,
    /// Per frame, 20–50 m from the sensor.
    pub per_frame_20_50: f64,
    /// Mean over those at 35–50 m of their mean reflectance (labelled cars there: [`CarBin`]).
    pub mean_reflectance_35_50: f64,
}

/// Per-frame spreads of the background (each frame's figure, then p10 / p50 / p90 over the
/// frames): a change that fits one street's averages but narrows the rest shows here.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct FrameSpreads {
    /// Car-sized background clusters in the camera view.
    pub car_sized_clusters: Percentiles,
    /// Share of the sampled background neighbourhoods that are volumetric, percent.
    pub volumetric_percent: Percentiles,
    /// Share that are planar and vertical, percent.
    pub vertical_percent: Percentiles,
    /// The frame's 90th percentile of off-road ground above its road, metres.
    pub off_road_p90: Percentiles,
}

/// The statistics of one folder.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RealismReport {
    /// The folder.
    pub root: PathBuf,
    /// Frames read.
    pub frames: usize,
    /// Mean returns per frame.
    pub points_per_frame: f64,
    /// Mean returns per frame in the camera's view.
    pub view_points_per_frame: f64,
    /// Reflectance by range.
    pub reflectance: ReflectanceTable,
    /// Labelled cars by distance.
    pub cars: Vec<CarBin>,
    /// Labelled cars by the angle they are seen from: how their ends' returns turn.
    #[serde(default)]
    pub views: Vec<ViewBin>,
    /// Background and ground shape.
    pub surfaces: SurfaceStats,
    /// Car-sized background clusters.
    pub clusters: ClusterStats,
    /// The road's rise, per frame.
    #[serde(default)]
    pub ground: GroundRiseStats,
    /// The background's statistics, per frame.
    #[serde(default)]
    pub spreads: FrameSpreads,
}

/// Running sums over frames.
#[derive(Default)]
struct Sums {
    points: Vec<f64>,
    view_points: Vec<f64>,
    all: ReflectanceSums,
    ground: ReflectanceSums,
    cars: ReflectanceSums,
    background: ReflectanceSums,
    car_samples: Vec<CarSample>,
    shapes: Vec<LocalShape>,
    heights: Vec<f64>,
    off_road: Vec<f64>,
    car_sized: Vec<Cluster>,
    rise_20: Vec<f64>,
    rise_40: Vec<f64>,
    pool_road: Vec<f64>,
    frame_clusters: Vec<f64>,
    frame_volumetric: Vec<f64>,
    frame_vertical: Vec<f64>,
    frame_off_road: Vec<f64>,
}

impl Sums {
    fn add(&mut self, frame: &Frame) {
        self.points.push(frame.points.len() as f64);
        let cloud = frame.calib.crop_to_fov(&frame.points, frame.image_size);
        self.view_points.push(cloud.len() as f64);
        let ground = GroundGrid::new(&cloud);
        let kinds = classify(frame, &cloud, &ground);
        for (p, kind) in cloud.iter().zip(&kinds) {
            let r = p[0].hypot(p[1]);
            match kind {
                Return::Car => self.cars.add(r, p[3]),
                Return::Ground => self.ground.add(r, p[3]),
                Return::Object => {}
                Return::Background => self.background.add(r, p[3]),
            }
            self.all.add(r, p[3]);
        }
        let background = |i: usize| kinds[i] == Return::Background;
        self.heights.extend(
            (0..cloud.len())
                .step_by(SURFACE_STRIDE)
                .filter(|&i| background(i))
                .map(|i| ground.height_above(&cloud[i]) as f64),
        );
        let near = |i: usize| (SURFACE_RANGE_M.0..SURFACE_RANGE_M.1).contains(&cloud[i][0].hypot(cloud[i][1]));
        self.add_shapes(sampled_shapes(&cloud, SURFACE_STRIDE, |i| background(i) && near(i)));
        let rest: Vec<Point> = (0..cloud.len()).filter(|&i| background(i)).map(|i| cloud[i]).collect();
        let car_sized: Vec<Cluster> = clusters(&rest).into_iter().filter(Cluster::car_sized).collect();
        self.frame_clusters.push(car_sized.len() as f64);
        self.car_sized.extend(car_sized);
        self.add_off_road(&ground);
        self.add_rise(&frame.points, &cloud);
        for (o, b) in frame.labelled_boxes() {
            if o.class == ObjectClass::Car {
                self.car_samples.extend(car_sample(&b, &cloud));
            }
        }
    }

    fn add_off_road(&mut self, ground: &GroundGrid) {
        let near = |x: f32| (SURFACE_RANGE_M.0..SURFACE_RANGE_M.1).contains(&x);
        let road = ground.cell_minima(|x, y| near(x) && y.abs() < ROAD_Y_M);
        let Some(level) = quantile(&road.iter().map(|z| *z as f64).collect::<Vec<_>>(), 0.5) else {
            return;
        };
        let off: Vec<f64> = ground
            .cell_minima(|x, y| near(x) && y.abs() > OFF_ROAD_Y_M)
            .iter()
            .map(|z| *z as f64 - level)
            .collect();
        self.frame_off_road.extend(quantile(&off, 0.9));
        self.off_road.extend(off);
    }

    /// One frame's background neighbourhoods.
    fn add_shapes(&mut self, shapes: Vec<LocalShape>) {
        if !shapes.is_empty() {
            let percent = |f: fn(&LocalShape) -> bool| {
                100.0 * shapes.iter().filter(|s| f(s)).count() as f64 / shapes.len() as f64
            };
            self.frame_volumetric.push(percent(LocalShape::volumetric));
            self.frame_vertical.push(percent(LocalShape::vertical));
        }
        self.shapes.extend(shapes);
    }

    /// The road's rise ahead and its share of the flat pool (`view`: the camera view's returns).
    fn add_rise(&mut self, points: &[Point], view: &[Point]) {
        let model = GroundModel::fit(points, &GroundConfig::default());
        self.rise_20.push(model.rise_at(20.0, 0.0) as f64);
        self.rise_40.push(model.rise_at(40.0, 0.0) as f64);
        let floor = CenterPoolConfig::kitti().z_range[0];
        let pool: Vec<&Point> = view.iter().filter(|p| p[2] >= floor).collect();
        if !pool.is_empty() {
            let road = pool
                .iter()
                .filter(|p| p[2] - model.height_at(p[0], p[1]) < POOL_ROAD_BAND_M)
                .count();
            self.pool_road.push(100.0 * road as f64 / pool.len() as f64);
        }
    }

    fn cluster_stats(&self, frames: usize) -> ClusterStats {
        let n = frames.max(1) as f64;
        let within = |lo: f32, hi: f32| self.car_sized.iter().filter(move |c| (lo..hi).contains(&c.distance));
        let far: Vec<f64> = within(35.0, 50.0).map(|c| c.mean_reflectance as f64).collect();
        ClusterStats {
            per_frame: self.car_sized.len() as f64 / n,
            per_frame_20_50: within(20.0, 50.0).count() as f64 / n,
            mean_reflectance_35_50: mean(&far),
        }
    }

    fn report(self, root: &Path, frames: usize) -> RealismReport {
        let shapes = self.shapes.len().max(1) as f64;
        let percent = |f: fn(&LocalShape) -> bool| 100.0 * self.shapes.iter().filter(|s| f(s)).count() as f64 / shapes;
        RealismReport {
            root: root.to_path_buf(),
            frames,
            points_per_frame: mean(&self.points),
            view_points_per_frame: mean(&self.view_points),
            reflectance: ReflectanceTable {
                all: self.all.bins(),
                ground: self.ground.bins(),
                cars: self.cars.bins(),
                background: self.background.bins(),
            },
            cars: car_bins(&self.car_samples),
            views: view_bins(&self.car_samples),
            clusters: self.cluster_stats(frames),
            ground: GroundRiseStats {
                rise_20m: Percentiles::of(&self.rise_20),
                rise_40m: Percentiles::of(&self.rise_40),
                pool_road_percent: Percentiles::of(&self.pool_road),
            },
            spreads: FrameSpreads {
                car_sized_clusters: Percentiles::of(&self.frame_clusters),
                volumetric_percent: Percentiles::of(&self.frame_volumetric),
                vertical_percent: Percentiles::of(&self.frame_vertical),
                off_road_p90: Percentiles::of(&self.frame_off_road),
            },
            surfaces: SurfaceStats {
                sampled: self.shapes.len(),
                volumetric_percent: percent(LocalShape::volumetric),
                vertical_percent: percent(LocalShape::vertical),
                background_height_p50: quantile(&self.heights, 0.5).unwrap_or(0.0),
                off_road_p90: quantile(&self.off_road, 0.9).unwrap_or(0.0),
            },
        }
    }
}

/// What a return of the camera view hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Return {
    /// Inside a labelled car.
    Car,
    /// Ground ([`GroundGrid`]), outside every labelled car.
    Ground,
    /// Inside another labelled object (DontCare aside), not ground.
    Object,
    /// The rest.
    Background,
}

/// Per point of `cloud`, what it hit.
fn classify(frame: &Frame, cloud: &[Point], ground: &GroundGrid) -> Vec<Return> {
    let (mut object, mut car) = (vec![false; cloud.len()], vec![false; cloud.len()]);
    for (o, b) in frame.labelled_boxes() {
        for i in b.points_inside(cloud) {
            object[i] = true;
            car[i] |= o.class == ObjectClass::Car;
        }
    }
    cloud
        .iter()
        .enumerate()
        .map(|(i, p)| match (car[i], ground.is_ground(p), object[i]) {
            (true, _, _) => Return::Car,
            (false, true, _) => Return::Ground,
            (false, false, true) => Return::Object,
            (false, false, false) => Return::Background,
        })
        .collect()
}

/// Measures the frames of `root` (those of `split` when given; at most `max_frames`, the
/// first in id order, when given).
pub fn realism_report(root: &Path, split: Option<&str>, max_frames: Option<usize>) -> Result<RealismReport> {
    let ds = KittiDataset::open(root, split)?;
    let ids = &ds.ids()[..ds.ids().len().min(max_frames.unwrap_or(usize::MAX))];
    let mut sums = Sums::default();
    for id in ids {
        sums.add(&ds.load(id)?);
    }
    Ok(sums.report(root, ids.len()))
}
