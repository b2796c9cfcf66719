//! What a picture of a frame shows, gathered once for every view (the bird's-eye PNG of
//! [`super::render_frame`], the 3D recording of [`super::write_rrd`]): its points, ground-truth
//! boxes, predictions and centers, all in the LiDAR frame.

use crate::Result;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use starnet_data::augment::{AugmentConfig, GtDatabase, Scene, augment};
use starnet_data::kitti::read_sidecar;
use starnet_data::kitti::{Frame, KittiDataset, ObjectClass, read_labels};
use starnet_data::sampling::{CenterPoolConfig, CenterZ, Centers, Sampler, center_pool, sample_centers};
use starnet_data::{Box3d, Point};
use starnet_eval::{ResultFormat, read_detect_json};
use std::path::{Path, PathBuf};

/// A box to show, with its class and (for predictions) score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneBox {
    /// Object class, written beside the box.
    pub class: ObjectClass,
    /// The box in the LiDAR frame.
    pub b: Box3d,
    /// Detection score, written after the class.
    pub score: Option<f32>,
}

/// What a view of a frame shows besides its points and labels.
#[derive(Debug, Clone, Default)]
pub struct RenderOptions {
    /// A result folder to show as predictions: KITTI result files (`{id}.txt`) or `starnet
    /// detect`'s `{id}.json`.
    pub results: Option<PathBuf>,
    /// Show the simulator's 360° sidecar (`label_360`) as ground truth when the frame has one.
    pub all_around: bool,
    /// Augment the frame first (training augmentation, with `ROOT/gt_database.bin` if present).
    pub augment: bool,
    /// Sample and show centers: sampler and count.
    pub centers: Option<(Sampler, usize)>,
    /// Seed for augmentation and sampling.
    pub seed: u64,
    /// Centers to show instead of sampling (e.g. temporally seeded ones, from
    /// `temporal::seeded_centers`): the first `num_seeded` marked as seeded.
    pub given_centers: Option<Centers>,
}

/// One frame as a view shows it, in the LiDAR frame.
#[derive(Debug, Clone)]
pub struct FrameScene {
    /// The frame's id.
    pub id: String,
    /// The points `[x, y, z, reflectance]` (after augmentation, when asked for).
    pub points: Vec<Point>,
    /// Ground-truth boxes.
    pub gt: Vec<SceneBox>,
    /// Predicted boxes, with scores.
    pub predictions: Vec<SceneBox>,
    /// Sampled or given centers (none unless asked for).
    pub centers: Centers,
    /// A one-line description: the id, the augmentation drawn, the centers.
    pub title: String,
}

/// Loads frame `id` of `dataset` with the extras `extra` asks for. Ground truth comes from
/// `label_2`, or with `all_around` from the 360° sidecar when the frame has one; centers are
/// pooled within `reach` metres all around, or in the camera's view.
pub fn frame_scene(dataset: &KittiDataset, id: &str, extra: &RenderOptions, reach: f32) -> Result<FrameScene> {
    let frame = dataset.load(id)?;
    let sidecar = dataset.path("label_360", id, "txt");
    let labelled: Vec<(ObjectClass, Box3d)> = if extra.all_around && sidecar.is_file() {
        read_sidecar(&sidecar)?.into_iter().map(|o| (o.class, o.b)).collect()
    } else {
        frame.labelled_boxes().into_iter().map(|(o, b)| (o.class, b)).collect()
    };
    let mut scene = Scene {
        points: frame.points.clone(),
        boxes: labelled.iter().map(|l| l.1).collect(),
        classes: labelled.iter().map(|l| l.0).collect(),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(extra.seed);
    let mut title = format!("frame {id}");
    if extra.augment {
        title += &augment_scene(dataset, &mut scene, &mut rng)?;
    }
    let centers = scene_centers(&frame, &scene, extra, reach, &mut rng, &mut title);
    let gt = (scene.boxes.iter().zip(&scene.classes))
        .map(|(b, c)| SceneBox {
            class: *c,
            b: *b,
            score: None,
        })
        .collect();
    let predictions = match &extra.results {
        None => Vec::new(),
        Some(dir) => read_predictions(dir, &frame)?,
    };
    Ok(FrameScene {
        id: id.to_string(),
        points: scene.points,
        gt,
        predictions,
        centers,
        title,
    })
}

/// The training augmentation on `scene` (pasting from the root's database when it has one);
/// what was drawn, for the title.
fn augment_scene(dataset: &KittiDataset, scene: &mut Scene, rng: &mut ChaCha8Rng) -> Result<String> {
    let db_path = dataset.root().join("gt_database.bin");
    let db = if db_path.is_file() {
        Some(GtDatabase::read(&db_path)?)
    } else {
        None
    };
    let draw = augment(scene, &AugmentConfig::default(), db.as_ref(), rng);
    Ok(format!(
        "  augmented: +{} pasted, rotation {:.2}, scale {:.3}{}",
        draw.pasted.len(),
        draw.rotation,
        draw.scale,
        if draw.flipped { ", flipped" } else { "" }
    ))
}

/// The centers to show: the given (seeded) ones, or `extra.centers` sampled from the scene;
/// says which in the title.
fn scene_centers(
    frame: &Frame,
    scene: &Scene,
    extra: &RenderOptions,
    reach: f32,
    rng: &mut ChaCha8Rng,
    title: &mut String,
) -> Centers {
    match (&extra.given_centers, extra.centers) {
        (Some(given), _) => {
            *title += &format!("  {} centers, {} seeded from t - 1", given.len(), given.num_seeded);
            given.clone()
        }
        (None, Some((sampler, n))) => {
            let pool_cfg = if extra.all_around {
                CenterPoolConfig::all_around(reach)
            } else {
                CenterPoolConfig::kitti()
            };
            let pool = center_pool(&scene.points, &pool_cfg, Some((&frame.calib, frame.image_size)), None);
            *title += &format!("  {n} {} centers", sampler.label());
            sample_centers(&scene.points, &pool, n, sampler, &[], CenterZ::Point, rng)
        }
        (None, None) => sample_centers(&[], &[], 0, Sampler::Random, &[], CenterZ::Point, rng),
    }
}

/// The predictions for `frame` in a result folder, in the LiDAR frame: `{id}.txt` (KITTI result
/// lines, camera frame, DontCare aside) or `{id}.json` (`starnet detect`'s, LiDAR frame).
fn read_predictions(dir: &Path, frame: &Frame) -> Result<Vec<SceneBox>> {
    let boxes = match ResultFormat::of_folder(dir, &frame.id)? {
        ResultFormat::Kitti => read_labels(&dir.join(format!("{}.txt", frame.id)))?
            .iter()
            .filter(|o| o.class != ObjectClass::DontCare)
            .map(|o| SceneBox {
                class: o.class,
                b: frame.calib.label_to_box(&o.cam),
                score: o.score,
            })
            .collect(),
        ResultFormat::Detect => read_detect_json(&dir.join(format!("{}.json", frame.id)), &frame.id)?
            .detections
            .iter()
            .map(|d| SceneBox {
                class: d.class,
                b: Box3d::from_array(d.b),
                score: Some(d.score),
            })
            .collect(),
    };
    Ok(boxes)
}
