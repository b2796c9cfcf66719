//! End-to-end tests of the `starnet` binary on the real KITTI sample
//! (`shared/kitti-sample`, or `STARNET_KITTI_SAMPLE`).

mod common;

use common::sample_root;
use std::path::Path;
use std::process::{Command, Output};

fn starnet(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_starnet"))
        .args(args)
        .output()
        .expect("run starnet")
}

fn stdout(o: &Output) -> String {
    assert!(
        o.status.success(),
        "starnet failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout.clone()).unwrap()
}

fn png_pixels(path: &Path) -> (u32, u32, Vec<u8>) {
    let mut reader = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    (info.width, info.height, buf)
}

#[test]
fn inspect_reports_points_and_labels() {
    let root = sample_root();
    let out = stdout(&starnet(&[
        "inspect",
        "--data",
        root.to_str().unwrap(),
        "--frame",
        "000000",
        "--json",
    ]));
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["num_points"], 115_384);
    assert_eq!(v["objects"][0]["class"], "Pedestrian");
    assert!(v["objects"][0]["num_points"].as_u64().unwrap() > 0);
    let table = stdout(&starnet(&[
        "inspect",
        "--data",
        root.to_str().unwrap(),
        "--frame",
        "000001",
    ]));
    assert!(table.starts_with("frame 000001: 120268 points"), "{table}");
    assert_eq!(table.matches("DontCare").count(), 4, "{table}");
}

#[test]
fn render_draws_ground_truth_and_predictions() {
    let root = sample_root();
    let dir = tempfile::tempdir().unwrap();
    // Predictions: the frame's own labels, moved 2 m to the side (so they do not cover the
    // ground truth), written as a result file.
    let results = dir.path().join("results");
    std::fs::create_dir_all(&results).unwrap();
    let labels = std::fs::read_to_string(root.join("training/label_2/000001.txt")).unwrap();
    let with_scores: String = labels
        .lines()
        .filter(|l| !l.starts_with("DontCare"))
        .map(|l| {
            let mut f: Vec<String> = l.split(' ').map(String::from).collect();
            f[11] = format!("{:.2}", f[11].parse::<f32>().unwrap() + 2.0);
            format!("{} 0.90\n", f.join(" "))
        })
        .collect();
    std::fs::write(results.join("000001.txt"), with_scores).unwrap();
    let out = dir.path().join("bev.png");
    let args = [
        "render",
        "--data",
        root.to_str().unwrap(),
        "--frame",
        "000001",
        "--out",
        out.to_str().unwrap(),
    ];
    let mut args = args.to_vec();
    args.extend(["--results", results.to_str().unwrap(), "--range", "80"]);
    stdout(&starnet(&args));
    let (w, h, px) = png_pixels(&out);
    assert_eq!((w, h), (880, 880));
    let count = |c: [u8; 3]| px.chunks_exact(3).filter(|p| *p == c).count();
    assert!(count([60, 230, 100]) > 100, "no ground-truth box drawn");
    assert!(count([255, 140, 20]) > 100, "no prediction drawn");
}

#[test]
fn bad_inputs_fail_with_the_file_named() {
    let root = sample_root();
    let dir = tempfile::tempdir().unwrap();
    for sub in ["velodyne", "label_2", "calib"] {
        std::fs::create_dir_all(dir.path().join("training").join(sub)).unwrap();
    }
    let t = |p: &str| dir.path().join("training").join(p);
    let bin = std::fs::read(root.join("training/velodyne/000000.bin")).unwrap();
    std::fs::write(t("velodyne/000000.bin"), &bin[..bin.len() - 5]).unwrap();
    std::fs::copy(root.join("training/label_2/000000.txt"), t("label_2/000000.txt")).unwrap();
    std::fs::copy(root.join("training/calib/000000.txt"), t("calib/000000.txt")).unwrap();
    let data = dir.path().to_str().unwrap();

    let o = starnet(&["inspect", "--data", data, "--frame", "000000"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("velodyne/000000.bin") && err.contains("not a multiple of 16"),
        "{err}"
    );

    let o = starnet(&["inspect", "--data", data, "--frame", "000009"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("000009.bin does not exist"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn synth_writes_a_kitti_root_prints_stats_and_keeps_existing_data() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("sim");
    let r = root.to_str().unwrap();
    let out = stdout(&starnet(&["synth", "--out", r, "--frames", "3", "--seed", "4"]));
    assert!(out.starts_with("wrote 3 frames"), "{out}");
    for f in [
        "training/velodyne/000002.bin",
        "training/label_2/000002.txt",
        "training/calib/000002.txt",
        "training/label_360/000002.txt",
        "ImageSets/train.txt",
        "ImageSets/val.txt",
        "synth.json",
    ] {
        assert!(root.join(f).is_file(), "{f} missing");
    }
    let stats = stdout(&starnet(&["synth", "--stats", r]));
    assert!(stats.starts_with("3 frames\n"), "{stats}");
    let points = stats
        .lines()
        .find(|l| l.starts_with("| points per frame, mean |"))
        .expect("points row");
    let generated: f64 = points.split('|').nth(2).unwrap().trim().parse().unwrap();
    assert!((100_000.0..135_000.0).contains(&generated), "{points}");
    // A second run into the same root must not mix frames of two runs.
    let o = starnet(&["synth", "--out", r, "--frames", "2"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("is not empty"));
    // The rendered 360° view draws the sidecar's objects too.
    let png = dir.path().join("sim.png");
    stdout(&starnet(&[
        "render",
        "--data",
        r,
        "--frame",
        "000000",
        "--out",
        png.to_str().unwrap(),
        "--full",
        "--range",
        "40",
    ]));
    assert_eq!(png_pixels(&png).0, 800);
}

/// The files under `root`, by relative path.
fn tree(root: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
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
fn a_killed_synth_leaves_no_root_and_the_same_command_finishes_it_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let args = |root: &str| ["synth", "--out", root, "--frames", "16", "--seed", "8"].map(String::from);
    let whole = dir.path().join("whole");
    stdout(&starnet(&args(whole.to_str().unwrap()).each_ref().map(String::as_str)));
    let cut = dir.path().join("cut");
    let cut_args = args(cut.to_str().unwrap());
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_starnet"))
        .args(&cut_args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Killed outright once some frames are written, none of its code runs again.
    let sidecars = dir.path().join(".cut.partial/training/label_360");
    let start = std::time::Instant::now();
    while std::fs::read_dir(&sidecars).map_or(0, |d| d.count()) < 3 {
        assert!(
            child.try_wait().unwrap().is_none(),
            "synth ended before it could be killed"
        );
        assert!(start.elapsed().as_secs() < 120, "no frames within 2 minutes");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !cut.exists(),
        "a killed generation left a root a later run would take for complete"
    );
    let out = stdout(&starnet(&cut_args.each_ref().map(String::as_str)));
    assert!(out.contains("continuing the interrupted writing"), "{out}");
    assert!(
        tree(&cut) == tree(&whole),
        "the continued set differs from the uninterrupted one"
    );
    let mut left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    left.sort();
    assert_eq!(left, ["cut", "whole"], "the partial folder or the lock stayed");
}

#[test]
fn prepare_coverage_and_augmented_render_on_simulated_data() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("sim");
    let r = root.to_str().unwrap();
    stdout(&starnet(&[
        "synth",
        "--out",
        r,
        "--frames",
        "6",
        "--seed",
        "2",
        "--val-fraction",
        "0.5",
    ]));
    let out = stdout(&starnet(&["prepare", "--data", r]));
    assert!(
        out.starts_with(&format!("wrote {}", root.join("gt_database.bin").display())),
        "{out}"
    );
    let db = starnet_data::augment::GtDatabase::read(&root.join("gt_database.bin")).unwrap();
    assert!(
        db.entries
            .iter()
            .any(|e| e.class == starnet_data::kitti::ObjectClass::Car)
    );

    let plot = dir.path().join("coverage.png");
    let table = stdout(&starnet(&[
        "coverage",
        "--data",
        r,
        "--samples",
        "16,64,256",
        "--plot",
        plot.to_str().unwrap(),
    ]));
    let rows: Vec<Vec<f64>> = table
        .lines()
        .filter(|l| l.starts_with("| Fps") || l.starts_with("| Random"))
        .map(|l| l.split('|').skip(2).filter_map(|v| v.trim().parse().ok()).collect())
        .collect();
    assert_eq!(rows.len(), 2, "{table}");
    assert!(
        rows.iter().all(|r| r.len() == 3 && r.windows(2).all(|w| w[0] <= w[1])),
        "coverage grows with centers: {table}"
    );
    assert_eq!(png_pixels(&plot).0, 960);

    let png = dir.path().join("aug.png");
    let args = [
        "render",
        "--data",
        r,
        "--frame",
        "000001",
        "--out",
        png.to_str().unwrap(),
        "--augment",
        "--centers",
        "fps:128",
    ];
    stdout(&starnet(&args));
    let (_, _, px) = png_pixels(&png);
    assert!(
        px.chunks_exact(3).filter(|p| *p == [255, 60, 220]).count() > 128 * 9,
        "centers drawn"
    );
    let bad = starnet(&[
        "render",
        "--data",
        r,
        "--frame",
        "000001",
        "--out",
        png.to_str().unwrap(),
        "--centers",
        "fps256",
    ]);
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("SAMPLER:COUNT"));

    // A corrupt database is named, not a panic.
    let bytes = std::fs::read(root.join("gt_database.bin")).unwrap();
    std::fs::write(root.join("gt_database.bin"), &bytes[..bytes.len() / 2]).unwrap();
    let o = starnet(&[
        "render",
        "--data",
        r,
        "--frame",
        "000001",
        "--out",
        png.to_str().unwrap(),
        "--augment",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && err.contains("gt_database.bin")
            && err.contains("truncated")
            && !err.contains("panicked"),
        "{err}"
    );
}

/// Every subcommand's help describes that subcommand alone: no other subcommand's summary
/// (its first clause) appears in it, so a doc comment cannot drift onto its neighbour.
#[test]
fn every_subcommand_help_describes_itself_only() {
    let top = stdout(&starnet(&["--help"]));
    let commands: Vec<(String, String)> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| {
            let (name, about) = l.trim().split_once(char::is_whitespace)?;
            let clause = about.trim().split([':', '.', ';', ',']).next()?.to_string();
            (name != "help").then(|| (name.to_string(), clause))
        })
        .collect();
    assert!(commands.len() >= 12, "{top}");
    for (name, _) in &commands {
        let help = stdout(&starnet(&[name, "--help"]));
        for (other, clause) in commands.iter().filter(|(o, _)| o != name) {
            assert!(
                !help.contains(clause.as_str()),
                "`starnet {name} --help` holds `{other}`'s summary \"{clause}\""
            );
        }
    }
}

/// Without the `rerun` feature `view` says how to build it, and writes nothing.
#[cfg(not(feature = "rerun"))]
#[test]
fn view_without_the_rerun_feature_names_the_feature() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scene.rrd");
    let root = sample_root();
    let o = starnet(&[
        "view",
        "--data",
        root.to_str().unwrap(),
        "--frame",
        "000001",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--features starnet-train/rerun") && err.contains("scene.rrd"),
        "{err}"
    );
    assert!(!out.exists());
}

/// `view` on two real frames with sampled centers: the recording holds each frame's points,
/// labelled boxes and centers.
#[cfg(feature = "rerun")]
#[test]
fn view_writes_a_recording_of_real_frames() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scene.rrd");
    let root = sample_root();
    let args = ["view", "--data", root.to_str().unwrap(), "--frame", "000001", "000002"];
    let mut args = args.to_vec();
    args.extend(["--centers", "fps:64", "--out", out.to_str().unwrap()]);
    assert!(stdout(&starnet(&args)).contains("2 frames"));
    let entities = starnet_train::render::read_rrd(&out).unwrap();
    let get = |path: &str| {
        entities
            .iter()
            .find(|e| e.path == path)
            .unwrap_or_else(|| panic!("{path}: {entities:?}"))
    };
    let ds = starnet_data::kitti::KittiDataset::open(&root, None).unwrap();
    let points: usize = ["000001", "000002"]
        .map(|id| ds.load(id).unwrap().points.len())
        .iter()
        .sum();
    assert_eq!((get("/world/points").rows, get("/world/points").instances), (2, points));
    assert_eq!(get("/world/centers").instances, 128);
    assert!(get("/world/ground_truth").instances > 0);
}
