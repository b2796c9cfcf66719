//! Scoring result folders (`starnet eval --results`) on the real KITTI sample: the labels
//! themselves score as perfect detections, the two formats of one set of boxes score alike, and damaged folders
//! are named.

mod common;

use starnet_data::kitti::{KittiDataset, KittiObject, ObjectClass, write_results};
use starnet_eval::EvalError;
use starnet_eval::{DetectedBox, ResultFormat, Scores, SweepDetections, kitti_results, score_results, to_kitti};
use starnet_model::nms::Detection;
use std::path::Path;

const CLASSES: [ObjectClass; 3] = [ObjectClass::Car, ObjectClass::Pedestrian, ObjectClass::Cyclist];

fn sample() -> KittiDataset {
    KittiDataset::open(common::sample_root(), None).unwrap()
}

/// Each frame's labelled Car / Pedestrian / Cyclist objects, each with score `0.5 + i / 100`.
fn labels_as_detections(ds: &KittiDataset, id: &str) -> Vec<KittiObject> {
    let frame = ds.load(id).unwrap();
    frame
        .objects
        .into_iter()
        .filter(|o| CLASSES.contains(&o.class))
        .enumerate()
        .map(|(i, o)| KittiObject {
            score: Some(0.5 + i as f32 / 100.0),
            ..o
        })
        .collect()
}

fn json(s: &Scores) -> serde_json::Value {
    serde_json::to_value(s).unwrap()
}

#[test]
fn the_labels_as_results_score_as_perfect_detections() {
    let ds = sample();
    let dir = tempfile::tempdir().unwrap();
    for id in ds.ids() {
        write_results(&dir.path().join(format!("{id}.txt")), &labels_as_detections(&ds, id)).unwrap();
    }
    let scores = score_results(&ds, dir.path(), None, None).unwrap();
    assert_eq!(scores.frames, 3);
    // The sample labels one Car that counts at moderate (34 m, 33 px; the other is 22 px tall,
    // below every difficulty's 25, so ignored). The devkit samples precision at its recall
    // thresholds, one per 1/40 of the objects: with a single object, recall 1 is reached at the
    // first of the 41 points and the rest stay 0, so R11 = 1/11 of 100 and R40 (which skips the
    // first point) = 0 even for a perfect detection; easy has no car at all.
    let car = scores.classes.iter().find(|c| c.class == ObjectClass::Car).unwrap();
    for metric in [car.three_d, car.bev, car.bbox, car.aos.unwrap()] {
        let [easy, moderate, hard] = metric;
        assert_eq!((easy.r11, easy.r40), (0.0, 0.0), "{metric:?}");
        for d in [moderate, hard] {
            assert!((d.r11 - 100.0 / 11.0).abs() < 1e-9 && d.r40 == 0.0, "{metric:?}");
        }
    }
    let waymo = scores.waymo.iter().find(|w| w.class == ObjectClass::Car).unwrap();
    assert!(waymo.num_objects[0] > 0);
    for l in waymo.levels {
        assert!((l.ap - 100.0).abs() < 1e-4 && (l.aph - 100.0).abs() < 1e-4, "{l:?}");
    }
    // Only Car asked for: the other classes' detections and labels are left out.
    let only_car = score_results(&ds, dir.path(), Some(ResultFormat::Kitti), Some(&[ObjectClass::Car])).unwrap();
    assert_eq!(only_car.classes.len(), 1);
    assert_eq!(json(&only_car)["classes"][0], json(&scores)["classes"][0]);
}

/// Moves a labelled box by `dx` metres along the LiDAR x axis and shrinks it, so the scores
/// are neither 0 nor 100.
fn perturbed(ds: &KittiDataset, id: &str) -> Vec<Detection> {
    let frame = ds.load(id).unwrap();
    frame
        .labelled_boxes()
        .into_iter()
        .filter_map(|(o, mut b)| {
            let k = CLASSES.iter().position(|&c| c == o.class)?;
            b.x += 0.3 * (k as f32 + 1.0);
            b.dx *= 0.93;
            Some(Detection {
                b,
                class: o.class,
                score: 0.4 + 0.01 * b.dx,
            })
        })
        .collect()
}

#[test]
fn detect_json_and_kitti_lines_of_the_same_boxes_score_alike() {
    let ds = sample();
    let dir = tempfile::tempdir().unwrap();
    let mut total = 0;
    for id in ds.ids() {
        let frame = ds.load(id).unwrap();
        let dets = perturbed(&ds, id);
        total += dets.len();
        // As `starnet detect` writes them: the LiDAR boxes as JSON, the projected ones as lines.
        let lines: Vec<KittiObject> = dets
            .iter()
            .filter_map(|d| to_kitti(d, &frame.calib, frame.image_size))
            .collect();
        write_results(&dir.path().join(format!("{id}.txt")), &lines).unwrap();
        let sweep = SweepDetections {
            id: id.clone(),
            num_points: frame.points.len(),
            wild_points_dropped: 0,
            calibrated: true,
            detections: dets
                .iter()
                .map(|d| DetectedBox {
                    class: d.class,
                    score: d.score,
                    b: d.b.to_array(),
                })
                .collect(),
        };
        std::fs::write(
            dir.path().join(format!("{id}.json")),
            serde_json::to_string(&sweep).unwrap(),
        )
        .unwrap();
    }
    assert_eq!(total, 4, "a Car per frame and a Pedestrian, a Cyclist");
    let kitti = score_results(&ds, dir.path(), Some(ResultFormat::Kitti), None).unwrap();
    let detect = score_results(&ds, dir.path(), Some(ResultFormat::Detect), None).unwrap();
    assert_eq!(json(&kitti), json(&detect));
    assert_eq!(format!("{kitti}"), format!("{detect}"));
    // The KITTI AP alone, from labels and calibrations (no scan read), is the same figure.
    for format in [ResultFormat::Kitti, ResultFormat::Detect] {
        assert_eq!(
            kitti_results(&ds, dir.path(), Some(format), None).unwrap(),
            kitti.classes
        );
    }
    // The cars moved by 0.3 m still match at 3D IoU 0.7; the pedestrian and the cyclist, moved
    // by 0.6 and 0.9 m, no longer match at 0.5.
    let level_1 = |c: ObjectClass| kitti.waymo.iter().find(|w| w.class == c).unwrap().levels[0].ap;
    assert!((level_1(ObjectClass::Car) - 100.0).abs() < 1e-4, "{kitti}");
    assert_eq!(level_1(ObjectClass::Pedestrian), 0.0, "{kitti}");
    assert_eq!(level_1(ObjectClass::Cyclist), 0.0, "{kitti}");
}

fn error_of(ds: &KittiDataset, dir: &Path, format: Option<ResultFormat>) -> String {
    match score_results(ds, dir, format, None) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("{} scored", dir.display()),
    }
}

#[test]
fn damaged_result_folders_are_named() {
    let ds = sample();
    let dir = tempfile::tempdir().unwrap();
    let first = &ds.ids()[0];
    // Nothing there: the first frame's file names are given.
    let e = error_of(&ds, dir.path(), None);
    assert!(e.contains(&format!("{first}.txt or {first}.json")), "{e}");
    for id in ds.ids() {
        write_results(&dir.path().join(format!("{id}.txt")), &labels_as_detections(&ds, id)).unwrap();
    }
    // A missing frame, as the devkit refuses it.
    let last = ds.ids().last().unwrap();
    let last_file = dir.path().join(format!("{last}.txt"));
    std::fs::remove_file(&last_file).unwrap();
    let e = error_of(&ds, dir.path(), None);
    assert!(e.contains(&last_file.display().to_string()), "{e}");
    // A line without its score: file and line.
    std::fs::write(
        &last_file,
        "Car -1 -1 0.1 10 10 50 50 1.5 1.6 3.9 1.0 1.6 10.0 0.1 0.9\nCar -1 -1 0.1 10 10 50 50 1.5 1.6 3.9 1.0 1.6 10.0 0.1\n",
    )
    .unwrap();
    let e = error_of(&ds, dir.path(), None);
    assert!(e.contains(&format!("{}:2: score", last_file.display())), "{e}");
    // A JSON file that describes another frame.
    let json = dir.path().join(format!("{first}.json"));
    let other = SweepDetections {
        id: "999999".into(),
        num_points: 0,
        wild_points_dropped: 0,
        calibrated: true,
        detections: Vec::new(),
    };
    std::fs::write(&json, serde_json::to_string(&other).unwrap()).unwrap();
    let e = error_of(&ds, dir.path(), Some(ResultFormat::Detect));
    assert!(e.contains(&json.display().to_string()) && e.contains("999999"), "{e}");
    // A JSON file that is not one.
    std::fs::write(&json, "{\"id\": ").unwrap();
    let e = error_of(&ds, dir.path(), Some(ResultFormat::Detect));
    assert!(e.contains(&json.display().to_string()), "{e}");
    assert!(matches!(
        score_results(&ds, dir.path(), Some(ResultFormat::Detect), None),
        Err(EvalError::Data(_))
    ));
}
