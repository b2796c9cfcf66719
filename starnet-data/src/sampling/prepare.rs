//! One frame from disk to model input, in the authors' order: augmentation (training only),
//! the center pool, center sampling, the one-ring dropout (training only), gathering.

use super::{
    CenterPoolConfig, CenterTarget, CenterZ, Centers, GatherConfig, Neighbourhoods, Sampler, center_pool, gather,
    level_centers, sample_centers,
};
use crate::augment::{AugmentConfig, AugmentDraw, GtDatabase, Scene, augment, ring_dropout};
use crate::cloud::WildPoints;
use crate::geometry::{GroundConfig, GroundModel};
use crate::kitti::{Frame, ObjectClass};
use crate::settings::{Checked, InvalidSetting, at_least_one, positive};
use crate::{Box3d, Point};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// Sampling and gathering settings (the defaults are the authors' KITTI car settings, with
/// fewer points per center: P = 512 does not fit a CPU budget).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PipelineConfig {
    /// Which points may become centers.
    pub pool: CenterPoolConfig,
    /// How centers are picked.
    pub sampler: Sampler,
    /// Centers sampled per frame.
    pub num_centers: usize,
    /// Which sampled centers the model sees (`all`, or `nearest:N`); C is what remains.
    pub target: CenterTarget,
    /// The z given to centers.
    pub center_z: CenterZ,
    /// Neighbourhood size and radius.
    pub gather: GatherConfig,
    /// The local ground, estimated per frame ([`GroundModel`]): when set, the pool's z band is
    /// measured from it rather than from the sensor (a road that rises or tilts is levelled to
    /// `reference_z`), and `center_z = "ground"` lifts the centers by it. `None`: the authors'
    /// flat-ground setting.
    pub ground: Option<GroundConfig>,
    /// Points beyond any sensor's range (a corrupt file): dropped and counted, or refused,
    /// when a frame is loaded ([`WildPoints`]; `limit = 1000.0` m, `action = "drop"`).
    pub wild_points: WildPoints,
}

impl PipelineConfig {
    /// Checks the center count, the pool and the gather (keys relative to the pipeline table).
    pub fn validate(&self) -> Checked {
        at_least_one("num_centers", self.num_centers)?;
        self.pool.validate().map_err(|e| e.within("pool"))?;
        match &self.ground {
            Some(g) => g.validate().map_err(|e| e.within("ground"))?,
            None if self.center_z == CenterZ::Ground => {
                return Err(InvalidSetting::new(
                    "center_z",
                    "\"ground\" needs the ground estimated: add a [pipeline.ground] table",
                ));
            }
            None => {}
        }
        self.gather.validate().map_err(|e| e.within("gather"))?;
        positive("wild_points.limit", f64::from(self.wild_points.limit))
    }

    /// The ground of `points`, when the config levels the cloud.
    pub fn fit_ground(&self, points: &[Point]) -> Option<GroundModel> {
        self.ground.as_ref().map(|g| GroundModel::fit(points, g))
    }
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            pool: CenterPoolConfig::kitti(),
            sampler: Sampler::Fps,
            num_centers: 768,
            target: CenterTarget::All,
            center_z: CenterZ::Zero,
            gather: GatherConfig {
                num_points: 64,
                radius: 3.75,
                metric: super::GatherMetric::Ball,
                reflectance: super::ReflectanceInput::Measured,
            },
            ground: None,
            wild_points: WildPoints::default(),
        }
    }
}

/// A frame ready to batch.
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedFrame {
    /// Frame id.
    pub id: String,
    /// The (augmented) cloud, after the ring dropout.
    pub points: Vec<Point>,
    /// Centers `[C, 3]`.
    pub centers: Centers,
    /// Neighbourhoods `[C, P, F]` and masks `[C, P]`.
    pub neighbourhoods: Neighbourhoods,
    /// Labelled boxes (every class but DontCare), augmented like the points.
    pub boxes: Vec<Box3d>,
    /// Their classes.
    pub classes: Vec<ObjectClass>,
    /// What augmentation drew, when it ran.
    pub draw: Option<AugmentDraw>,
}

/// Training-time augmentation for [`prepare_frame`].
#[derive(Debug, Clone, Copy)]
pub struct Augmentation<'a> {
    /// The steps.
    pub config: &'a AugmentConfig,
    /// The ground-truth database, for the paste step.
    pub database: Option<&'a GtDatabase>,
}

/// Prepares `frame`: augments it when `augmentation` is given, then samples `cfg.num_centers`
/// centers (the `seeds` first), keeps those `cfg.target` names and gathers their neighbourhoods.
pub fn prepare_frame(
    frame: &Frame,
    cfg: &PipelineConfig,
    augmentation: Option<Augmentation<'_>>,
    seeds: &[[f32; 3]],
    rng: &mut impl Rng,
) -> PreparedFrame {
    let (boxes, classes): (Vec<Box3d>, Vec<ObjectClass>) =
        frame.labelled_boxes().into_iter().map(|(o, b)| (b, o.class)).unzip();
    let mut scene = Scene {
        points: frame.points.clone(),
        boxes,
        classes,
    };
    let draw = augmentation.map(|a| augment(&mut scene, a.config, a.database, rng));
    // The pool is a property of the recording (the camera view that bounds the labels, the
    // ground band), so it is decided where the sensor saw each point: a globally rotated cloud
    // tested against the frame's own camera would drop a quarter of its labelled cars from the
    // pool. (OpenPCDet crops to the camera view before it augments; lingvo tests afterwards.)
    let recorded = draw.as_ref().map(|d| d.undo_global(&scene.points));
    let recorded = recorded.as_deref().unwrap_or(&scene.points);
    let recorded_ground = cfg.fit_ground(recorded);
    let pool = center_pool(
        recorded,
        &cfg.pool,
        Some((&frame.calib, frame.image_size)),
        recorded_ground.as_ref(),
    );
    let mut centers = sample_centers(
        &scene.points,
        &pool,
        cfg.num_centers,
        cfg.sampler,
        seeds,
        cfg.center_z,
        rng,
    );
    // The centers' z from the ground of the cloud the model sees (after the global z shift).
    let seen_ground = match &draw {
        Some(_) => cfg.fit_ground(&scene.points),
        None => recorded_ground,
    };
    if let Some(ground) = seen_ground {
        level_centers(&mut centers, cfg.center_z, &ground);
    }
    let centers = cfg.target.apply(centers);
    let points = match augmentation {
        Some(a) if a.config.ring_dropout => ring_dropout(&scene.points, a.config.ring_dropout_width, rng).0,
        _ => scene.points,
    };
    let neighbourhoods = gather(&points, &centers, &cfg.gather, rng);
    PreparedFrame {
        id: frame.id.clone(),
        points,
        centers,
        neighbourhoods,
        boxes: scene.boxes,
        classes: scene.classes,
        draw,
    }
}
