//! Wild points (issue #49): a finite point far beyond any sensor's range in a dataset's file is
//! dropped when the frame loads (or refused, as the config says), before anything sees it.

use starnet_data::cloud::{WildAction, WildPoints};
use starnet_data::kitti::{KittiDataset, read_points, write_points};
use starnet_sim::{SynthConfig, synth_frames};

#[test]
fn a_dataset_drops_or_refuses_a_point_beyond_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("sim");
    synth_frames(&root, 2, 11, &SynthConfig::default(), &|| {}).unwrap();
    let bin = root.join("training/velodyne/000000.bin");
    let clean = read_points(&bin).unwrap();
    let mut wild = clean.clone();
    wild.insert(3, [1e20, 0.0, 0.0, 0.5]);
    wild.push([0.0, -2e3, 0.0, 0.5]);
    write_points(&bin, &wild).unwrap();

    let ds = KittiDataset::open(&root, None).unwrap();
    assert_eq!(
        ds.load("000000").unwrap().points,
        clean,
        "the default drops them, keeping the order"
    );

    let strict = WildPoints {
        action: WildAction::Refuse,
        ..Default::default()
    };
    let err = ds.with_wild_points(strict).load("000000").unwrap_err().to_string();
    assert!(err.contains("000000.bin") && err.contains("point 3"), "{err}");

    let wider = WildPoints {
        limit: 1e21,
        action: WildAction::Refuse,
    };
    let ds = KittiDataset::open(&root, None).unwrap().with_wild_points(wider);
    assert_eq!(
        ds.load("000000").unwrap().points,
        wild,
        "within a wider limit nothing is dropped"
    );
}
