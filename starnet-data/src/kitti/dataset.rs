//! A KITTI object-detection root: `ROOT/{training,testing}/{velodyne,label_2,calib,image_2}`
//! and `ROOT/ImageSets/*.txt`; with the simulator's data, `label_360/` may stand in for
//! `label_2/` (every object around the sensor, not only the camera's view). The same type reads
//! the custom layout of a LiDAR without a camera ([`crate::custom`]: `points/`, `labels/`).

use super::sidecar::read_sidecar;
use super::{Calib, ImageSize, KittiObject, ObjectClass, observation_angle, read_labels, read_points, read_split};
use crate::cloud::{Intensity, WildPoints, read_cloud};
use crate::custom::{CustomObject, POINTS_DIR, is_custom_layout, labels_path, points_path, read_custom_labels};
use crate::events::note;
use crate::{Box3d, DataError, Point, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Which labels a dataset reads.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum LabelSource {
    /// KITTI's `label_2/`: the objects in camera 2's view.
    #[default]
    #[serde(rename = "label_2")]
    Camera,
    /// The simulator's `label_360/` sidecar: every object around the sensor (Waymo-style).
    #[serde(rename = "label_360")]
    AllAround,
}

/// How a dataset's files are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// KITTI's object layout (`training/velodyne`, `label_2`, `calib`, ...).
    Kitti,
    /// The custom layout of a LiDAR without a camera ([`crate::custom`]).
    Custom,
}

/// What loading does with a point cloud that has no intensity channel (an N × 3 `.npy`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum MissingIntensity {
    /// An error: the model reads the reflectance, and zeros would be misread as dark surfaces.
    #[default]
    Refuse,
    /// The reflectance is 0: for a geometry-only model, which never reads it.
    Zero,
}

/// One loaded frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Frame id, e.g. `000001`.
    pub id: String,
    /// The full scan `[N, 4]`, LiDAR frame.
    pub points: Vec<Point>,
    /// Label lines (empty on the test subset), DontCare included.
    pub objects: Vec<KittiObject>,
    /// The frame's calibration.
    pub calib: Calib,
    /// Size of image 2: from the PNG header when `image_2/` has it, else 1242 × 375.
    pub image_size: ImageSize,
}

/// A frame's labels, calibration and image size, without its scan ([`KittiDataset::load_annotations`]).
#[derive(Debug, Clone)]
pub struct Annotations {
    /// Frame id, e.g. `000001`.
    pub id: String,
    /// Label lines (empty on the test subset), DontCare included.
    pub objects: Vec<KittiObject>,
    /// The frame's calibration.
    pub calib: Calib,
    /// Size of image 2: from the PNG header when `image_2/` has it, else 1242 × 375.
    pub image_size: ImageSize,
}

impl Frame {
    /// The non-DontCare objects with their LiDAR boxes.
    pub fn labelled_boxes(&self) -> Vec<(&KittiObject, Box3d)> {
        self.objects
            .iter()
            .filter(|o| o.class != ObjectClass::DontCare)
            .map(|o| (o, self.calib.label_to_box(&o.cam)))
            .collect()
    }
}

/// The frames of one KITTI subset (`training` or `testing`), optionally restricted to a split.
#[derive(Debug, Clone)]
pub struct KittiDataset {
    root: PathBuf,
    subset: &'static str,
    ids: Vec<String>,
    labels: LabelSource,
    layout: Layout,
    missing_intensity: MissingIntensity,
    wild_points: WildPoints,
}

impl KittiDataset {
    /// Opens `root`. With a split name (`train`, `val`, `test`, ...) the ids come from
    /// `ImageSets/{split}.txt` (the `test` split reads `testing/`); without one, every `.bin` in
    /// `training/velodyne/` (every `.npy` in `points/` of the custom layout) is listed in id
    /// order. A root with `points/` and no `training/` is in the custom layout, whose labels are
    /// all around the sensor ([`LabelSource::AllAround`]).
    pub fn open(root: impl AsRef<Path>, split: Option<&str>) -> Result<Self> {
        let root = root.as_ref().to_path_buf();
        let layout = match is_custom_layout(&root) {
            true => Layout::Custom,
            false => Layout::Kitti,
        };
        let subset = if split == Some("test") { "testing" } else { "training" };
        let ids = match (split, layout) {
            (Some(s), _) => read_split(&root.join("ImageSets").join(format!("{s}.txt")))?,
            (None, Layout::Kitti) => list_ids(&root.join(subset).join("velodyne"), "bin")?,
            (None, Layout::Custom) => list_ids(&root.join(POINTS_DIR), "npy")?,
        };
        Ok(Self {
            root,
            subset,
            ids,
            labels: match layout {
                Layout::Kitti => LabelSource::Camera,
                Layout::Custom => LabelSource::AllAround,
            },
            layout,
            missing_intensity: MissingIntensity::Refuse,
            wild_points: WildPoints::default(),
        })
    }

    /// How the files are laid out.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// The same frames, with point clouds that lack an intensity channel loaded as `missing`
    /// says (the default refuses them).
    pub fn with_missing_intensity(mut self, missing: MissingIntensity) -> Self {
        self.missing_intensity = missing;
        self
    }

    /// The same frames, with points beyond `wild`'s limit dropped (a note names the file and
    /// the count) or refused, as it says (the default drops those beyond 1 km).
    pub fn with_wild_points(mut self, wild: WildPoints) -> Self {
        self.wild_points = wild;
        self
    }

    /// The points of `path` within the limit of [`KittiDataset::with_wild_points`].
    fn tame(&self, points: Vec<Point>, path: &Path) -> Result<Vec<Point>> {
        let kept = self.wild_points.apply(points, path)?;
        if kept.dropped > 0 {
            note(format!(
                "{}: dropped {} points beyond {} m (pipeline.wild_points)",
                path.display(),
                kept.dropped,
                self.wild_points.limit
            ));
        }
        Ok(kept.points)
    }

    /// The same frames, labelled from `labels`.
    pub fn with_labels(mut self, labels: LabelSource) -> Self {
        self.labels = labels;
        self
    }

    /// Where the labels come from.
    pub fn labels(&self) -> LabelSource {
        self.labels
    }

    /// The frame ids, in split (or id) order.
    pub fn ids(&self) -> &[String] {
        &self.ids
    }

    /// The dataset root.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `ROOT/{subset}/{dir}/{id}.{ext}`.
    pub fn path(&self, dir: &str, id: &str, ext: &str) -> PathBuf {
        self.root.join(self.subset).join(dir).join(format!("{id}.{ext}"))
    }

    /// Loads a frame: points, calib and (on `training`) labels; all must exist. `label_360`
    /// objects become label lines through the calibration (no truncation; the 2D box is the
    /// projection, empty when the box is behind the camera). A frame of the custom layout has
    /// KITTI's calibration of frame 000000 as a stand-in, through which its labels pass as
    /// `label_360`'s do.
    pub fn load(&self, id: &str) -> Result<Frame> {
        if self.layout == Layout::Custom {
            return self.load_custom(id);
        }
        let velodyne = require_file(self.path("velodyne", id, "bin"), id)?;
        let points = self.tame(read_points(&velodyne)?, &velodyne)?;
        let a = self.load_annotations(id)?;
        Ok(Frame {
            id: a.id,
            points,
            objects: a.objects,
            calib: a.calib,
            image_size: a.image_size,
        })
    }

    /// A frame as [`KittiDataset::load`] reads it, without its scan: what the KITTI metrics
    /// need. The scan need not exist.
    pub fn load_annotations(&self, id: &str) -> Result<Annotations> {
        if self.layout == Layout::Custom {
            return self.custom_annotations(id);
        }
        let existing = |dir: &str, ext: &str| require_file(self.path(dir, id, ext), id);
        let calib = Calib::read(&existing("calib", "txt")?)?;
        let image = self.path("image_2", id, "png");
        let image_size = if image.is_file() {
            png_size(&image)?
        } else {
            ImageSize::KITTI
        };
        let objects = match (self.subset, self.labels) {
            ("training", LabelSource::Camera) => read_labels(&existing("label_2", "txt")?)?,
            ("training", LabelSource::AllAround) => read_sidecar(&existing("label_360", "txt")?)?
                .into_iter()
                .map(|o| {
                    let cam = calib.box_to_label(&o.b);
                    KittiObject {
                        class: o.class,
                        truncated: 0.0,
                        occluded: o.occlusion,
                        alpha: observation_angle(&cam),
                        bbox: calib.image_bbox(&cam, image_size).unwrap_or([0.0; 4]),
                        cam,
                        score: None,
                    }
                })
                .collect(),
            _ => Vec::new(),
        };
        Ok(Annotations {
            id: id.to_string(),
            objects,
            calib,
            image_size,
        })
    }
}

impl KittiDataset {
    /// A frame of the custom layout: `points/{id}.npy` and `labels/{id}.txt`, both required.
    /// The camera-frame labels only exist for the code that reads them.
    fn load_custom(&self, id: &str) -> Result<Frame> {
        self.refuse_camera_labels()?;
        let points_file = require_file(points_path(&self.root, id), id)?;
        let cloud = read_cloud(&points_file)?;
        if cloud.intensity == Intensity::Absent && self.missing_intensity == MissingIntensity::Refuse {
            return Err(DataError::MissingIntensity { path: points_file });
        }
        let a = self.custom_annotations(id)?;
        Ok(Frame {
            id: a.id,
            points: self.tame(cloud.points, &points_file)?,
            objects: a.objects,
            calib: a.calib,
            image_size: a.image_size,
        })
    }

    /// The labels of a custom-layout frame, through KITTI's calibration of frame 000000.
    fn custom_annotations(&self, id: &str) -> Result<Annotations> {
        self.refuse_camera_labels()?;
        let calib = Calib::kitti_000000();
        let objects = read_custom_labels(&require_file(labels_path(&self.root, id), id)?)?
            .iter()
            .map(|o| all_around_object(o, &calib))
            .collect();
        Ok(Annotations {
            id: id.to_string(),
            objects,
            calib,
            image_size: ImageSize::KITTI,
        })
    }

    /// The custom layout has no camera-view labels.
    fn refuse_camera_labels(&self) -> Result<()> {
        match self.labels {
            LabelSource::Camera => Err(DataError::CustomLayoutLabels {
                root: self.root.clone(),
            }),
            LabelSource::AllAround => Ok(()),
        }
    }
}

/// `path` when it is a file, else the frame's missing-file error.
fn require_file(path: PathBuf, frame: &str) -> Result<PathBuf> {
    match path.is_file() {
        true => Ok(path),
        false => Err(DataError::MissingFile {
            frame: frame.to_string(),
            path,
        }),
    }
}

/// A custom-layout object as a label line through `calib`, as a `label_360` object becomes one:
/// fully visible, not truncated.
fn all_around_object(o: &CustomObject, calib: &Calib) -> KittiObject {
    let cam = calib.box_to_label(&o.b);
    KittiObject {
        class: o.class,
        truncated: 0.0,
        occluded: 0,
        alpha: observation_angle(&cam),
        bbox: calib.image_bbox(&cam, ImageSize::KITTI).unwrap_or([0.0; 4]),
        cam,
        score: None,
    }
}

/// Ids of the `.{ext}` files in a folder, sorted.
fn list_ids(dir: &Path, ext: &str) -> Result<Vec<String>> {
    let entries = std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))?;
    let mut ids = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| DataError::io(dir, e))?.path();
        if path.extension().is_some_and(|e| e == ext)
            && let Some(stem) = path.file_stem()
        {
            ids.push(stem.to_string_lossy().into_owned());
        }
    }
    ids.sort();
    Ok(ids)
}

/// Width and height from a PNG header, without decoding the image.
fn png_size(path: &Path) -> Result<ImageSize> {
    let file = std::fs::File::open(path).map_err(|e| DataError::io(path, e))?;
    let reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .map_err(|e| DataError::io(path, std::io::Error::other(e)))?;
    let info = reader.info();
    Ok(ImageSize {
        width: info.width,
        height: info.height,
    })
}
