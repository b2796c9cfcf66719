//! Temporal seeding end to end: a tiny camera-view model, simulated sequences, `starnet eval
//! --sequences` over a (centers, previous-frame centers) grid, and a render of the seeds.

use std::path::Path;
use std::process::Command;

const TINY: &str = r#"
seed = 2
[data]
root = "DATA"
simulate_frames = 8
classes = ["Car"]
[pipeline]
num_centers = 32
[pipeline.gather]
num_points = 8
radius = 2.0
[model]
d_fc0 = 8
blocks = [[16, 8]]
d_offset = 8
[nms]
iou = [0.1]
score = [0.0]
[train]
epochs = 1
batch_size = 2
workers = 1
[eval]
num_centers = 32
num_points = 8
"#;

fn starnet(args: &[&str], cwd: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_starnet"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn sequences_with_previous_frame_centers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("t.toml"),
        TINY.replace("DATA", &d.join("data").display().to_string()),
    )
    .unwrap();
    ok(&starnet(&["train", "--config", "t.toml"], d));
    ok(&starnet(
        &[
            "synth",
            "--out",
            "seq",
            "--sequences",
            "2",
            "--length",
            "3",
            "--seed",
            "4",
        ],
        d,
    ));
    let ckpt = d.join("runs/t/checkpoints/best").display().to_string();
    let out = ok(&starnet(
        &[
            "eval",
            "--checkpoint",
            &ckpt,
            "--data",
            "seq",
            "--sequences",
            "--centers",
            "16,32",
            "--prev-centers",
            "0,8,50%",
            "--out",
            "temporal",
        ],
        d,
    ));
    let table = std::fs::read_to_string(d.join("temporal/temporal.md")).unwrap();
    // `8` and `50%` of 16 are one run, listed once (and evaluated once).
    assert_eq!(table.lines().count(), 2 + 5, "{table}");
    assert_eq!(out.matches("16 centers, 8 from t - 1").count(), 1, "{out}");
    assert!(
        table.contains("| 32 | 16 | 16 |") && table.contains("| 16 | 8 | 8 |"),
        "{table}"
    );
    assert!(out.contains("32 centers, 16 from t - 1"), "{out}");
    let reports: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("temporal/temporal.json")).unwrap()).unwrap();
    // Four of the six frames have a previous frame; with K = 8 each gets 8 seeds.
    assert_eq!(reports[1]["seeds"]["seeds"].as_u64(), Some(4 * 8));
    assert_eq!(reports[0]["seeds"]["seeds"].as_u64(), Some(0));
    assert!(
        std::fs::read(d.join("temporal/temporal_ap.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    // The render shows the seeded centers in their own colour.
    ok(&starnet(
        &[
            "render",
            "--data",
            "seq/sequences/0000",
            "--frame",
            "000001",
            "--checkpoint",
            &ckpt,
            "--prev-centers",
            "50%",
            "--centers",
            "fps:16",
            "--out",
            "seeded.png",
        ],
        d,
    ));
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(d.join("seeded.png")).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let seeded = buf[..info.buffer_size()]
        .chunks(3)
        .filter(|p| *p == starnet_train::render::SEEDED)
        .count();
    assert!(seeded > 0, "no seeded center drawn");
    // Without a previous frame (frame 0) nothing is seeded.
    ok(&starnet(
        &[
            "render",
            "--data",
            "seq/sequences/0000",
            "--frame",
            "000000",
            "--checkpoint",
            &ckpt,
            "--prev-centers",
            "50%",
            "--centers",
            "fps:16",
            "--out",
            "first.png",
        ],
        d,
    ));
}
