//! Your own data (issue #37): the shipped model loads on a fresh clone and reproduces its golden
//! outputs, and `starnet detect` gives the same detections on one real KITTI sweep whichever
//! point-cloud format holds it, and whatever wild point a corrupt file adds to it.

mod common;

use common::{ok, sample_root, starnet};
use starnet_data::cloud::{CloudFormat, Intensity, PcdEncoding, PlyEncoding, PointCloud, write_cloud};
use starnet_data::kitti::read_points;
use starnet_model::export::read_safetensors;
use starnet_train::export::golden;
use starnet_train::trained::TrainedModel;
use std::path::{Path, PathBuf};

fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/quickstart")
}

#[test]
fn the_shipped_model_loads_and_reproduces_its_golden_outputs() {
    let trained = TrainedModel::load(&shipped(), None, &[]).unwrap();
    let (file, _) = read_safetensors(&std::fs::read(shipped().join("golden.safetensors")).unwrap()).unwrap();
    let again = golden(&trained.model, 16, 32, trained.config.seed);
    assert!(again.len() >= 4);
    for t in &again {
        let want = &file[&t.name];
        assert_eq!(want.shape, t.shape, "{}", t.name);
        // Another CPU's matrix kernels round differently: the same to 1e-4, not to the bit.
        let worst = want
            .data
            .iter()
            .zip(&t.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "{}: {worst}", t.name);
    }
}

/// The detections `starnet detect` writes for the one sweep `input` with the shipped model.
fn detections(input: &Path, out: &Path) -> serde_json::Value {
    ok(&starnet(
        &[
            "detect",
            "--model",
            shipped().to_str().unwrap(),
            "--input",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        out.parent().unwrap(),
    ));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("000000.json")).unwrap()).unwrap();
    json["detections"].clone()
}

#[test]
fn detect_gives_the_same_boxes_from_every_point_cloud_format() {
    let bin = sample_root().join("training/velodyne/000000.bin");
    let cloud = PointCloud {
        points: read_points(&bin).unwrap(),
        intensity: Intensity::Measured,
    };
    let dir = tempfile::tempdir().unwrap();
    // A copy away from the sample's calib/ folder: every format is detected uncalibrated, the
    // centers all around the sensor.
    let copy = dir.path().join("bin/000000.bin");
    write_cloud(&copy, &cloud, CloudFormat::KittiBin).unwrap();
    let reference = detections(&copy, &dir.path().join("bin-out"));
    assert!(
        reference.as_array().is_some_and(|d| !d.is_empty()),
        "no detections to compare"
    );
    let formats = [
        ("pcd-ascii", "pcd", CloudFormat::Pcd(PcdEncoding::Ascii)),
        ("pcd-binary", "pcd", CloudFormat::Pcd(PcdEncoding::Binary)),
        ("pcd-compressed", "pcd", CloudFormat::Pcd(PcdEncoding::BinaryCompressed)),
        ("ply-ascii", "ply", CloudFormat::Ply(PlyEncoding::Ascii)),
        ("ply-binary", "ply", CloudFormat::Ply(PlyEncoding::BinaryLittleEndian)),
        ("npy", "npy", CloudFormat::Npy),
    ];
    for (name, ext, format) in formats {
        let file = dir.path().join(name).join(format!("000000.{ext}"));
        write_cloud(&file, &cloud, format).unwrap();
        let got = detections(&file, &dir.path().join(format!("{name}-out")));
        assert_eq!(got, reference, "{name}");
    }
    // Without intensity the reflectance-free model reads the same geometry: the same boxes.
    let geometry = PointCloud {
        points: cloud.points.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect(),
        intensity: Intensity::Absent,
    };
    let file = dir.path().join("xyz/000000.npy");
    write_cloud(&file, &geometry, CloudFormat::Npy).unwrap();
    assert_eq!(detections(&file, &dir.path().join("xyz-out")), reference, "N x 3 .npy");
}

#[test]
fn a_point_far_beyond_any_sensor_is_dropped_and_the_sweep_detects_as_without_it() {
    let points = read_points(&sample_root().join("training/velodyne/000000.bin")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, points: Vec<[f32; 4]>| {
        let file = dir.path().join(name).join("000000.bin");
        let cloud = PointCloud {
            points,
            intensity: Intensity::Measured,
        };
        write_cloud(&file, &cloud, CloudFormat::KittiBin).unwrap();
        file
    };
    let plain = write("plain", points.clone());
    let reference = detections(&plain, &dir.path().join("plain-out"));
    // The finding: one finite point at x = 1e20 (a corrupt file) crashed the grid.
    for (k, wild) in [[1e20, 0.0, 0.0, 0.5], [5.0, -f32::MAX, 1.0, 0.1], [0.0, 0.0, 2e3, 0.0]]
        .into_iter()
        .enumerate()
    {
        let mut with = points.clone();
        with.insert(1000 * k + 7, wild);
        let name = format!("wild{k}");
        let out = dir.path().join(format!("{name}-out"));
        let got = detections(&write(&name, with), &out);
        assert_eq!(got, reference, "with a point at {wild:?}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("000000.json")).unwrap()).unwrap();
        assert_eq!(json["wild_points_dropped"], 1, "{wild:?}");
        assert_eq!(json["num_points"].as_u64(), Some(points.len() as u64));
    }
}
