//! Scoring a split's detections against its labels, whatever produced them (a checkpoint, a
//! result folder of another detector): KITTI AP, Waymo-style AP/APH and AP per 10 m, printed
//! as the tables `starnet eval` shows.
//!
//! In camera view a detection is scored as its KITTI result line holds it (`%.4f`, as the
//! devkit would read the file), and its LiDAR box for the Waymo-style metric is that line's box
//! mapped back through the calibration; so a result folder scores exactly as the evaluation
//! that wrote it.

use crate::Result;
use crate::metrics::{
    ClassAp, KittiFrame, RangeAp, WaymoClassAp, WaymoDetection, WaymoFrame, WaymoObject, ap_by_range, kitti_ap,
    waymo_ap,
};
use crate::table::Table;
use serde::{Deserialize, Serialize};
use starnet_data::geometry::Detection;
use starnet_data::kitti::{
    Calib, Frame, ImageSize, KittiObject, LabelSource, ObjectClass, observation_angle, write_results,
};
use std::path::Path;

/// Distance bins of [`Scores::by_range`] reach this far, metres.
pub const RANGE_BINS_MAX_M: f32 = 80.0;

/// What a split's detections score.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Scores {
    /// Frames evaluated.
    pub frames: usize,
    /// KITTI AP per class (camera-view labels only).
    pub classes: Vec<ClassAp>,
    /// Waymo-style AP/APH per class (the labelled objects, LiDAR point counts from the scan).
    pub waymo: Vec<WaymoClassAp>,
    /// KITTI AP (moderate) of the first class per 10 m of distance.
    pub by_range: Vec<RangeAp>,
}

impl Scores {
    /// The headline: 3D AP (R40) at moderate difficulty of the first class, or with 360° labels
    /// (no KITTI metrics) its Waymo-style LEVEL_1 AP.
    pub fn headline(&self) -> f64 {
        self.classes
            .first()
            .map(|c| c.three_d[1].r40)
            .or_else(|| self.waymo.first().map(|w| w.levels[0].ap))
            .unwrap_or(0.0)
    }

    /// KITTI AP per class and metric (3D, BEV, 2D, AOS), R40 and R11 at each difficulty.
    fn kitti_table(&self) -> Table {
        let mut t = Table::new([
            "class",
            "IoU",
            "metric",
            "easy R40",
            "moderate R40",
            "hard R40",
            "easy R11",
            "moderate R11",
            "hard R11",
        ]);
        for c in &self.classes {
            let mut rows = vec![("3D", c.three_d), ("BEV", c.bev), ("2D", c.bbox)];
            if let Some(a) = c.aos {
                rows.push(("AOS", a));
            }
            for (name, ap) in rows {
                let head = [c.class.to_string(), format!("{:.1}", c.min_overlap), name.into()];
                let r40 = ap.iter().map(|d| format!("{:.2}", d.r40));
                let r11 = ap.iter().map(|d| format!("{:.2}", d.r11));
                t.row(head.into_iter().chain(r40).chain(r11));
            }
        }
        t
    }

    /// Waymo-style AP / APH per class and level, overall and per distance band.
    fn waymo_table(&self) -> Table {
        let mut t = Table::new([
            "class", "IoU", "level", "objects", "AP", "APH", "0-30 m", "30-50 m", "50+ m",
        ]);
        for c in &self.waymo {
            for l in 0..2 {
                let head = [
                    c.class.to_string(),
                    format!("{:.1}", c.iou),
                    format!("LEVEL_{}", l + 1),
                    c.num_objects[l].to_string(),
                    format!("{:.2}", c.levels[l].ap),
                    format!("{:.2}", c.levels[l].aph),
                ];
                let bands = c.ranges[l].iter().map(|r| format!("{:.2} / {:.2}", r.ap, r.aph));
                t.row(head.into_iter().chain(bands));
            }
        }
        t
    }
}

/// The tables, without a header line (an evaluation's report puts its budget above them).
impl std::fmt::Display for Scores {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if !self.classes.is_empty() {
            write!(f, "{}", self.kitti_table())?;
        }
        // A class the split never labels scores 0 by definition, which reads like a miss.
        for c in self.waymo.iter().filter(|c| c.num_objects[1] == 0) {
            writeln!(
                f,
                "{}: no labelled object in these frames; its AP is 0 by definition.",
                c.class
            )?;
        }
        writeln!(f, "\nWaymo-style 3D AP / APH (LEVEL_1 > 5 points, LEVEL_2 ≥ 1):")?;
        write!(f, "{}", self.waymo_table())?;
        if let (Some(c), false) = (self.classes.first(), self.by_range.is_empty()) {
            write!(
                f,
                "\n{} 3D AP R40 moderate by distance (objects that count at moderate):",
                c.class
            )?;
            for b in self.by_range.iter().filter(|b| b.num_objects > 0) {
                write!(f, " {}-{} m {:.1} ({});", b.lo, b.hi, b.three_d.r40, b.num_objects)?;
            }
            writeln!(f)?;
        }
        Ok(())
    }
}

/// A detection as a KITTI result line; `None` when its box does not project into image 2
/// (the KITTI evaluation needs the 2D box).
pub fn to_kitti(d: &Detection, calib: &Calib, image: ImageSize) -> Option<KittiObject> {
    let cam = calib.box_to_label(&d.b);
    let bbox = calib.image_bbox(&cam, image)?;
    Some(KittiObject {
        class: d.class,
        truncated: -1.0,
        occluded: -1,
        alpha: observation_angle(&cam),
        bbox,
        cam,
        score: Some(d.score),
    })
}

/// `o` as its result line holds it ([`KittiObject::to_result_line`] read back).
pub fn as_written(o: &KittiObject) -> Result<KittiObject> {
    let line = o.to_result_line();
    Ok(KittiObject::parse_line(&line, Path::new("(result line)"), 1)?)
}

/// `detections` (LiDAR frame) as the KITTI result lines that hold them: those that project
/// into the image, as read back from their lines.
pub(crate) fn written_results(detections: &[Detection], calib: &Calib, image: ImageSize) -> Result<Vec<KittiObject>> {
    detections
        .iter()
        .filter_map(|d| to_kitti(d, calib, image))
        .map(|o| as_written(&o))
        .collect()
}

/// The result lines of `classes`: the devkit leaves the others out.
pub(crate) fn of_classes(detections: &[KittiObject], classes: &[ObjectClass]) -> Vec<KittiObject> {
    detections
        .iter()
        .filter(|o| classes.contains(&o.class))
        .cloned()
        .collect()
}

/// A frame's labelled objects (DontCare aside) as Waymo ground truth, with the LiDAR returns
/// inside each box counted from the scan.
pub fn waymo_objects(frame: &Frame) -> Vec<WaymoObject> {
    frame
        .labelled_boxes()
        .into_iter()
        .map(|(o, b)| WaymoObject {
            class: o.class,
            num_points: b.count_points_inside(&frame.points) as u32,
            b,
        })
        .collect()
}

/// Collects frames and their detections and scores them. Frames are reduced to what scoring
/// needs as they arrive, so a split never sits in memory.
pub struct Scorer<'a> {
    classes: &'a [ObjectClass],
    camera_view: bool,
    results: Option<&'a Path>,
    frames: Vec<KittiFrame>,
    calibs: Vec<Calib>,
    waymo_frames: Vec<WaymoFrame>,
}

impl<'a> Scorer<'a> {
    /// Scores `classes` against `labels`; writes `{id}.txt` result files to `results` when
    /// given. Detections of a class outside `classes` are written but not scored.
    pub fn new(classes: &'a [ObjectClass], labels: LabelSource, results: Option<&'a Path>) -> Self {
        Self {
            classes,
            // KITTI's metrics need the camera-view labels; 360° labels get the Waymo-style ones only.
            camera_view: labels == LabelSource::Camera,
            results,
            frames: Vec::new(),
            calibs: Vec::new(),
            waymo_frames: Vec::new(),
        }
    }

    /// Adds a frame and its final detections (LiDAR frame). In camera view only those that
    /// project into the image count, as their result lines hold them.
    pub fn add(&mut self, frame: Frame, detections: &[Detection]) -> Result<()> {
        let (calib, image) = (&frame.calib, frame.image_size);
        let written = written_results(detections, calib, image)?;
        let lidar = match self.camera_view {
            true => self.lidar_of(&written, calib),
            false => detections
                .iter()
                .map(|d| WaymoDetection {
                    class: d.class,
                    b: d.b,
                    score: d.score,
                })
                .collect(),
        };
        self.push(frame, written, lidar)
    }

    /// Adds a frame and detections read from KITTI result lines (camera frame, with scores);
    /// detections of classes not scored are left out, as the devkit leaves them.
    pub fn add_results(&mut self, frame: Frame, detections: &[KittiObject]) -> Result<()> {
        let scored = of_classes(detections, self.classes);
        let lidar = self.lidar_of(&scored, &frame.calib);
        self.push(frame, scored, lidar)
    }

    /// Camera-frame detections as LiDAR boxes for the Waymo-style metric.
    fn lidar_of(&self, detections: &[KittiObject], calib: &Calib) -> Vec<WaymoDetection> {
        detections
            .iter()
            .map(|o| WaymoDetection {
                class: o.class,
                b: calib.label_to_box(&o.cam),
                score: o.score.unwrap_or(0.0),
            })
            .collect()
    }

    fn push(&mut self, frame: Frame, kitti: Vec<KittiObject>, lidar: Vec<WaymoDetection>) -> Result<()> {
        if let Some(dir) = self.results {
            write_results(&dir.join(format!("{}.txt", frame.id)), &kitti)?;
        }
        self.waymo_frames.push(WaymoFrame {
            objects: waymo_objects(&frame),
            detections: lidar,
        });
        self.calibs.push(frame.calib.clone());
        self.frames.push(KittiFrame {
            labels: frame.objects,
            detections: kitti,
        });
        Ok(())
    }

    /// The scores of the frames added.
    pub fn finish(self) -> Scores {
        let classes = self.classes;
        Scores {
            frames: self.frames.len(),
            classes: if self.camera_view {
                kitti_ap(&self.frames, classes)
            } else {
                Vec::new()
            },
            waymo: waymo_ap(&self.waymo_frames, classes),
            by_range: if self.camera_view {
                ap_by_range(&self.frames, &self.calibs, classes[0], RANGE_BINS_MAX_M)
            } else {
                Vec::new()
            },
        }
    }
}
