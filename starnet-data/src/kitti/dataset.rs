//! A KITTI object-detection root: `ROOT/{training,testing}/{velodyne,label_2,calib,image_2}`
//! and `ROOT/ImageSets/*.txt`; with the simulator's data, `label_360/` may stand in for
//! `label_2/` (every object around the sensor, not only the camera's view).

use super::sidecar::read_sidecar;
use super::{Calib, ImageSize, KittiObject, ObjectClass, observation_angle, read_labels, read_points, read_split};
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
}

impl KittiDataset {
    /// Opens `root`. With a split name (`train`, `val`, `test`, ...) the ids come from
    /// `ImageSets/{split}.txt` (the `test` split reads `testing/`); without one, every `.bin` in
    /// `training/velodyne/` is listed in id order.
    pub fn open(root: impl AsRef<Path>, split: Option<&str>) -> Result<Self> {
        let root = root.as_ref().to_path_buf();
        let subset = if split == Some("test") { "testing" } else { "training" };
        let ids = match split {
            Some(s) => read_split(&root.join("ImageSets").join(format!("{s}.txt")))?,
            None => list_ids(&root.join(subset).join("velodyne"))?,
        };
        Ok(Self {
            root,
            subset,
            ids,
            labels: LabelSource::Camera,
        })
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
    /// projection, empty when the box is behind the camera).
    pub fn load(&self, id: &str) -> Result<Frame> {
        let existing = |dir: &str, ext: &str| -> Result<PathBuf> {
            let p = self.path(dir, id, ext);
            if p.is_file() {
                Ok(p)
            } else {
                Err(DataError::MissingFile {
                    frame: id.to_string(),
                    path: p,
                })
            }
        };
        let points = read_points(&existing("velodyne", "bin")?)?;
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
        Ok(Frame {
            id: id.to_string(),
            points,
            objects,
            calib,
            image_size,
        })
    }
}

/// Ids of the `.bin` files in a velodyne folder, sorted.
fn list_ids(dir: &Path) -> Result<Vec<String>> {
    let entries = std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))?;
    let mut ids = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| DataError::io(dir, e))?.path();
        if path.extension().is_some_and(|e| e == "bin")
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
