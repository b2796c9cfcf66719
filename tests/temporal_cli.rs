//! Temporal seeding end to end: a tiny camera-view model, simulated sequences, `starnet eval
//! --sequences` over a (centers, previous-frame centers) grid, and a render of the seeds.

mod common;

use common::{ok, starnet, write_tiny_car};

#[test]
fn sequences_with_previous_frame_centers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_tiny_car(d, "t.toml");
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
        table.contains("| 32 | 16 | 16.0 |") && table.contains("| 16 | 8 | 8.0 |"),
        "{table}"
    );
    assert!(out.contains("32 centers, 16 from t - 1"), "{out}");
    let reports: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("temporal/temporal.json")).unwrap()).unwrap();
    // Four of the six frames have a previous frame; with K = 8 each gets 8 seeds (the tiny model
    // keeps at least three boxes per frame, three seeds each).
    assert_eq!(reports[1]["seeds"]["seeds"].as_u64(), Some(4 * 8));
    assert_eq!(reports[1]["seeds"]["frames"].as_u64(), Some(4));
    assert_eq!(reports[0]["seeds"]["seeds"].as_u64(), Some(0));
    assert!(
        std::fs::read(d.join("temporal/temporal_ap.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    // The render shows the seeded centers in their own colour; frame 0 has no previous frame,
    // so nothing is seeded there.
    let seeded_pixels = |frame: &str| {
        let png_path = format!("seeded-{frame}.png");
        ok(&starnet(
            &[
                "render",
                "--data",
                "seq/sequences/0000",
                "--frame",
                frame,
                "--checkpoint",
                &ckpt,
                "--prev-centers",
                "50%",
                "--centers",
                "fps:16",
                "--out",
                &png_path,
            ],
            d,
        ));
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(d.join(&png_path)).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf[..info.buffer_size()]
            .chunks(3)
            .filter(|p| *p == starnet_train::render::SEEDED)
            .count()
    };
    assert!(seeded_pixels("000001") > 0, "no seeded center drawn");
    assert_eq!(seeded_pixels("000000"), 0, "frame 0 has no previous frame to seed from");
}
