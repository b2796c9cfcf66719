//! The simulator against its contract (issue #3): the KITTI loader reads every frame, files
//! rewrite byte for byte, a seed fixes the bytes, and labels agree with the points and with
//! the camera.

use starnet_data::kitti::{
    Calib, KittiDataset, ObjectClass, format_labels, observation_angle, parse_labels, read_sidecar,
};
use starnet_data::wrap_angle;
use starnet_sim::{
    SIMULATOR_VERSION, SynthConfig, generated_version, simulate_scene_frame, synth_frames, synth_sequences,
};
use std::collections::BTreeMap;
use std::path::Path;

fn files(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(
                    p.strip_prefix(root).unwrap().display().to_string(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    out
}

#[test]
fn frames_load_rewrite_exactly_and_reproduce_from_the_seed() {
    let (a, b, c) = (
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
    );
    let cfg = SynthConfig::default();
    synth_frames(a.path(), 6, 42, &cfg, &|| {}).unwrap();
    synth_frames(b.path(), 6, 42, &cfg, &|| {}).unwrap();
    synth_frames(c.path(), 6, 43, &cfg, &|| {}).unwrap();
    let (fa, fb) = (files(a.path()), files(b.path()));
    assert_eq!(fa.len(), 6 * 4 + 4, "{:?}", fa.keys().collect::<Vec<_>>());
    assert!(fa == fb, "the same seed must write the same bytes");
    assert_ne!(
        fa.get("training/velodyne/000000.bin"),
        files(c.path()).get("training/velodyne/000000.bin")
    );

    assert_eq!(generated_version(a.path()).unwrap(), Some(SIMULATOR_VERSION));
    assert_eq!(
        generated_version(&a.path().join("training")).unwrap(),
        None,
        "no synth.json there"
    );

    let ds = KittiDataset::open(a.path(), None).unwrap();
    assert_eq!(ds.ids().len(), 6);
    let train = KittiDataset::open(a.path(), Some("train")).unwrap();
    let val = KittiDataset::open(a.path(), Some("val")).unwrap();
    assert_eq!(train.ids().len() + val.ids().len(), 6);
    assert!(train.ids().iter().all(|id| !val.ids().contains(id)));
    for id in ds.ids() {
        let frame = ds.load(id).unwrap();
        assert!(
            (100_000..=135_000).contains(&frame.points.len()),
            "{id}: {} points",
            frame.points.len()
        );
        assert!(
            frame.objects.iter().any(|o| o.class != ObjectClass::DontCare),
            "{id} has no labelled object"
        );
        let label_path = ds.path("label_2", id, "txt");
        let text = std::fs::read_to_string(&label_path).unwrap();
        assert_eq!(format_labels(&parse_labels(&text, &label_path).unwrap()), text);
        let calib_path = ds.path("calib", id, "txt");
        let text = std::fs::read_to_string(&calib_path).unwrap();
        assert_eq!(Calib::parse(&text, &calib_path).unwrap().format(), text);
        let sidecar_path = ds.path("label_360", id, "txt");
        let text = std::fs::read_to_string(&sidecar_path).unwrap();
        let rewritten: String = read_sidecar(&sidecar_path)
            .unwrap()
            .iter()
            .map(|o| o.to_line() + "\n")
            .collect();
        assert_eq!(rewritten, text);
    }
}

#[test]
fn boxes_contain_the_points_that_hit_their_object() {
    let cfg = SynthConfig::default();
    let calib = Calib::kitti_000000();
    // Range noise is truncated at 2.5 σ = 5 cm along the ray, so a return lies at most that far
    // outside the object's tight box.
    let margin = 2.0 * 2.5 * cfg.lidar.range_noise + 1e-3;
    let mut checked = 0;
    for index in 0..6 {
        let f = simulate_scene_frame(7, index, &cfg, &calib);
        for (k, obj) in f.objects.iter().enumerate() {
            let hits: Vec<_> = f
                .points
                .iter()
                .zip(&f.owners)
                .filter(|(_, o)| **o == Some(k as u32))
                .map(|(p, _)| *p)
                .collect();
            assert_eq!(hits.len() as u32, obj.num_points);
            if obj.occlusion == 3 || hits.len() < 5 {
                continue;
            }
            // Objects stand upright in the level frame; their boxes stand upright in the sensor's
            // frame, tilted from it (as KITTI labels cars on a slope): a corner moves by up to
            // the tilt times the box's half-diagonal.
            let tilt = f.tilt.pitch.abs() + f.tilt.roll.abs();
            let lean = 2.0 * tilt * 0.5 * obj.b.dx.hypot(obj.b.dy).hypot(obj.b.dz);
            let grown = starnet_data::Box3d {
                dx: obj.b.dx + margin + lean,
                dy: obj.b.dy + margin + lean,
                dz: obj.b.dz + margin + lean,
                ..obj.b
            };
            assert_eq!(
                grown.count_points_inside(&hits),
                hits.len(),
                "frame {index}: {} {:?}",
                obj.class,
                obj.b
            );
            checked += 1;
        }
    }
    assert!(checked > 30, "only {checked} objects checked");
}

#[test]
fn written_labels_agree_with_the_camera() {
    let dir = tempfile::tempdir().unwrap();
    synth_frames(dir.path(), 8, 5, &SynthConfig::default(), &|| {}).unwrap();
    let ds = KittiDataset::open(dir.path(), None).unwrap();
    let mut checked = 0;
    for id in ds.ids() {
        let frame = ds.load(id).unwrap();
        for o in frame.objects.iter().filter(|o| o.class != ObjectClass::DontCare) {
            // Label fields are rounded to 0.01 (m or rad): the centre moves by up to 5 mm per
            // axis and a corner by the heading's 0.005 rad times the half-diagonal, which moves
            // the projection by f ≈ 707 px times that over the nearest corner's depth (a car
            // right in front, truncated, has corners far nearer than its centre).
            let half_diagonal = 0.5 * o.cam.l.hypot(o.cam.w);
            let nearest = (o.cam.z - half_diagonal).max(0.5);
            let tol = 0.5 + 707.0 * (0.0071 + 0.005 * half_diagonal) / nearest;
            let proj = frame
                .calib
                .image_bbox(&o.cam, frame.image_size)
                .expect("labelled objects are in view");
            let err = proj.iter().zip(o.bbox).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
            assert!(
                err <= tol,
                "{id} {}: 2D box {:?} vs projection {proj:?}",
                o.class,
                o.bbox
            );
            assert!(
                (wrap_angle(o.alpha - observation_angle(&o.cam))).abs() <= 0.011,
                "{id}: alpha {} vs ry {}",
                o.alpha,
                o.cam.ry
            );
            assert!((0.0..=1.0).contains(&o.truncated) && (0..=3).contains(&o.occluded));
            checked += 1;
        }
        // DontCare lines come last.
        let first_dc = frame
            .objects
            .iter()
            .position(|o| o.class == ObjectClass::DontCare)
            .unwrap_or(frame.objects.len());
        assert!(
            frame.objects[first_dc..]
                .iter()
                .all(|o| o.class == ObjectClass::DontCare)
        );
    }
    assert!(checked > 15, "{checked}");
}

#[test]
fn sequences_have_poses_and_stable_tracks() {
    let dir = tempfile::tempdir().unwrap();
    synth_sequences(dir.path(), 2, 5, 9, &SynthConfig::default(), &|| {}).unwrap();
    for s in ["0000", "0001"] {
        let root = dir.path().join("sequences").join(s);
        let poses = std::fs::read_to_string(root.join("poses.txt")).unwrap();
        let rows: Vec<Vec<f64>> = poses
            .lines()
            .map(|l| l.split(' ').map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 5);
        assert!(rows.iter().all(|r| r.len() == 12));
        assert_eq!(rows[0], [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        // The ego drives forward at 5–12 m/s: 0.5–1.2 m per frame.
        let step = rows[4][3] / 4.0;
        assert!((0.45..=1.25).contains(&step), "{step}");
        let ds = KittiDataset::open(&root, None).unwrap();
        assert_eq!(ds.ids().len(), 5);
        let tracks = |id: &str| -> Vec<(u32, ObjectClass)> {
            read_sidecar(&ds.path("label_360", id, "txt"))
                .unwrap()
                .iter()
                .map(|o| (o.track_id, o.class))
                .collect()
        };
        for id in ds.ids() {
            ds.load(id).unwrap();
            assert_eq!(tracks(id), tracks("000000"), "objects keep their track ids");
        }
    }
}
