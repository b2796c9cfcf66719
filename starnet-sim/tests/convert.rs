//! The custom dataset layout (issue #37): the simulator's KITTI data converted to it and back,
//! byte for byte where the formats carry the same facts, and read by the same dataset type.

use starnet_data::convert::{custom_to_kitti, kitti_to_custom};
use starnet_data::kitti::{KittiDataset, LabelSource, Layout, MissingIntensity, read_sidecar};
use starnet_sim::{SynthConfig, synth_frames};
use std::collections::BTreeMap;
use std::path::Path;

/// Every file under `dir`, by path relative to `root`.
fn files(root: &Path, dir: &str) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.join(dir)];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(root).unwrap().display().to_string();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

#[test]
fn the_simulator_converts_to_the_custom_layout_and_back() {
    let dir = tempfile::tempdir().unwrap();
    let (sim, custom, kitti, again) = (
        dir.path().join("sim"),
        dir.path().join("custom"),
        dir.path().join("kitti"),
        dir.path().join("custom-again"),
    );
    synth_frames(&sim, 4, 5, &SynthConfig::default(), &|| {}).unwrap();
    let there = kitti_to_custom(&sim, &custom).unwrap();
    assert_eq!(there.frames, 4);
    assert_eq!(there.splits, ["train", "trainval", "val"]);
    let back = custom_to_kitti(&custom, &kitti).unwrap();
    assert_eq!(back.frames, 4);
    // The points and splits come back byte for byte, the 360° boxes and classes exactly.
    assert_eq!(files(&sim, "training/velodyne"), files(&kitti, "training/velodyne"));
    assert_eq!(files(&sim, "ImageSets"), files(&kitti, "ImageSets"));
    let boxes = |root: &Path, id: &str| -> Vec<_> {
        read_sidecar(&root.join(format!("training/label_360/{id}.txt")))
            .unwrap()
            .into_iter()
            .map(|o| (o.class, o.b.to_array()))
            .collect()
    };
    let mut objects = 0;
    for id in ["000000", "000001", "000002", "000003"] {
        assert_eq!(boxes(&sim, id), boxes(&kitti, id), "frame {id}");
        objects += boxes(&sim, id).len();
    }
    assert!(objects > 0, "the test needs objects");
    // Custom -> KITTI -> custom: the same bytes.
    kitti_to_custom(&kitti, &again).unwrap();
    assert_eq!(files(&custom, "points"), files(&again, "points"));
    assert_eq!(files(&custom, "labels"), files(&again, "labels"));
}

#[test]
fn a_custom_root_loads_as_the_simulators_360_labels_do() {
    let dir = tempfile::tempdir().unwrap();
    let (sim, custom) = (dir.path().join("sim"), dir.path().join("custom"));
    synth_frames(&sim, 3, 9, &SynthConfig::default(), &|| {}).unwrap();
    // Headings printed as ±3.1416 lie outside [−π, π): they parse to the other end of the range,
    // and must reach the custom layout as the same text, not as the parsed value printed again.
    let sidecar = sim.join("training/label_360/000000.txt");
    let mut text = std::fs::read_to_string(&sidecar).unwrap();
    text.push_str("Car 90 -20.0000 3.6490 -0.9952 3.4208 1.7636 1.4381 -3.1416 34 0 0\n");
    text.push_str("Cyclist 91 -9.0000 -3.6490 -0.9952 1.7600 0.6000 1.7300 3.1416 34 0 0\n");
    std::fs::write(&sidecar, text).unwrap();
    kitti_to_custom(&sim, &custom).unwrap();
    let kitti = KittiDataset::open(&sim, Some("trainval"))
        .unwrap()
        .with_labels(LabelSource::AllAround);
    let own = KittiDataset::open(&custom, Some("trainval")).unwrap();
    assert_eq!((kitti.layout(), own.layout()), (Layout::Kitti, Layout::Custom));
    assert_eq!(own.labels(), LabelSource::AllAround);
    assert_eq!(kitti.ids(), own.ids());
    for id in kitti.ids() {
        let (a, b) = (kitti.load(id).unwrap(), own.load(id).unwrap());
        assert_eq!(a.points, b.points);
        let boxes = |f: &starnet_data::kitti::Frame| -> Vec<_> {
            f.labelled_boxes()
                .iter()
                .map(|(o, b)| (o.class, b.to_array().map(f32::to_bits)))
                .collect()
        };
        assert_eq!(boxes(&a), boxes(&b), "frame {id}");
    }
    // Camera labels are not in this layout: asking for them names the root.
    let err = own.clone().with_labels(LabelSource::Camera).load("000000").unwrap_err();
    assert!(err.to_string().contains("label_360"), "{err}");
}

#[test]
fn points_without_intensity_need_a_model_that_ignores_it() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir_all(root.join("points")).unwrap();
    std::fs::create_dir_all(root.join("labels")).unwrap();
    let cloud = starnet_data::cloud::PointCloud {
        points: vec![[1.0, 2.0, -1.5, 0.0], [4.0, -1.0, -1.0, 0.0]],
        intensity: starnet_data::cloud::Intensity::Absent,
    };
    let npy = root.join("points/000000.npy");
    starnet_data::cloud::write_cloud(&npy, &cloud, starnet_data::cloud::CloudFormat::Npy).unwrap();
    std::fs::write(root.join("labels/000000.txt"), "1 2 -1 4 2 1.5 0 Car\n").unwrap();
    let ds = KittiDataset::open(root, None).unwrap();
    let err = ds.load("000000").unwrap_err();
    assert!(err.to_string().contains("000000.npy"), "{err}");
    let frame = ds
        .with_missing_intensity(MissingIntensity::Zero)
        .load("000000")
        .unwrap();
    assert_eq!(frame.points, cloud.points);
    assert_eq!(frame.labelled_boxes().len(), 1);
}
