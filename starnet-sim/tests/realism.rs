//! The realism report on a constructed KITTI folder whose statistics are known by hand.

use starnet_data::Box3d;
use starnet_data::kitti::{Calib, KittiObject, ObjectClass, format_labels, write_points};
use starnet_sim::realism::realism_report;
use std::path::Path;

/// One frame: a flat road 1.73 m below the sensor from 6 to 38 m ahead (|y| < 1 m, in the
/// camera's view), bright (0.3) up to 20 m and reading 0 beyond; a car 15 m ahead holding 40
/// returns, half of them 0 and a quarter more than 1.1 m above its bottom.
fn write_frame(training: &Path, calib: &Calib) {
    let mut points = Vec::new();
    for i in 0..64 {
        for j in 0..4 {
            let (x, y) = (6.0 + 0.5 * i as f32, -0.75 + 0.5 * j as f32);
            if (13.0..17.0).contains(&x) {
                continue; // under the car: no road return
            }
            points.push([x, y, -1.73, if x < 20.0 { 0.3 } else { 0.0 }]);
        }
    }
    let car = Box3d::new(15.0, 0.0, -0.95, 3.9, 1.6, 1.5, 0.0);
    for k in 0..40 {
        let z = if k % 4 == 0 { -0.3 } else { -1.2 };
        points.push([13.2 + 0.05 * k as f32, 0.1, z, if k % 2 == 0 { 0.0 } else { 0.2 }]);
    }
    write_points(&training.join("velodyne/000000.bin"), &points).unwrap();
    let cam = calib.box_to_label(&car);
    let bbox = calib.image_bbox(&cam, starnet_data::kitti::ImageSize::KITTI).unwrap();
    let label = KittiObject {
        class: ObjectClass::Car,
        truncated: 0.0,
        occluded: 0,
        alpha: 0.0,
        bbox,
        cam,
        score: None,
    };
    std::fs::write(training.join("label_2/000000.txt"), format_labels(&[label])).unwrap();
    std::fs::write(training.join("calib/000000.txt"), calib.format()).unwrap();
}

#[test]
fn a_constructed_frame_reports_its_known_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let training = dir.path().join("training");
    for sub in ["velodyne", "label_2", "calib"] {
        std::fs::create_dir_all(training.join(sub)).unwrap();
    }
    write_frame(&training, &Calib::kitti_000000());
    let r = realism_report(dir.path(), None, None).unwrap();
    assert_eq!(r.frames, 1);
    // Road: 5–10 m bright, 10–20 m bright, 20–30 m and 30–40 m all zero.
    let ground = &r.reflectance.ground;
    assert!(
        (ground[1].mean - 0.3).abs() < 1e-6 && ground[1].zero_percent == 0.0,
        "{ground:?}"
    );
    assert!((ground[3].zero_percent - 100.0).abs() < 1e-9 && ground[4].points > 0);
    // The car: 40 returns at 13–15 m, half zero, mean 0.1, a quarter high, seen end-on.
    let cars = &r.reflectance.cars;
    assert_eq!(cars[2].points, 40);
    assert!((cars[2].zero_percent - 50.0).abs() < 1e-9 && (cars[2].mean - 0.1).abs() < 1e-6);
    let bin = &r.cars[1];
    assert_eq!((bin.cars, bin.median_points), (1, 40.0));
    assert!(
        (bin.high_percent - 25.0).abs() < 1e-4 && bin.end_on_percent == 100.0,
        "{bin:?}"
    );
    // Nothing but road and car: no background.
    assert_eq!(r.reflectance.background.iter().map(|b| b.points).sum::<u64>(), 0);
}
