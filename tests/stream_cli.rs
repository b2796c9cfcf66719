//! Streaming end to end: a tiny localized model and a tiny LSTM model trained on slices of
//! simulated 360° sweeps, then `starnet stream-eval` over several slice counts (seconds).

mod common;

use common::{ok, starnet, write_tiny_car};

/// The streaming settings over `common::TINY_CAR`.
const STREAM: &str = r#"
base = "tiny.toml"
seed = 5
[data]
labels = "label_360"
[pipeline.pool]
x_range = [-40.0, 40.0]
y_range = [-40.0, 40.0]
camera_frustum = false
[stream]
train_slices = [1, 2, 4]
eval_slices = 4
eval_range = 40.0
"#;

#[test]
fn train_on_slices_then_stream_eval() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_tiny_car(d, "tiny.toml");
    std::fs::write(d.join("s.toml"), STREAM).unwrap();
    std::fs::write(d.join("s-lstm.toml"), "base = \"s.toml\"\n[model]\nlstm_hidden = 8\n").unwrap();
    for cfg in ["s.toml", "s-lstm.toml"] {
        let out = ok(&starnet(&["train", "--config", cfg], d));
        // The end-of-training evaluation is the streamed one at stream.eval_slices.
        assert!(out.contains("n = 4 ("), "{out}");
    }
    let ckpt = |run: &str| d.join(format!("runs/{run}/checkpoints/best")).display().to_string();
    let out_dir = d.join("stream-out");
    let out = ok(&starnet(
        &[
            "stream-eval",
            "--checkpoint",
            &format!("{},{}", ckpt("s"), ckpt("s-lstm")),
            "--slices",
            "2,4",
            "--frames",
            "3",
            "--out",
            out_dir.to_str().unwrap(),
        ],
        d,
    ));
    // n = 1 is added as the whole-sweep reference: three slice counts per model.
    assert_eq!(out.matches("s: n = ").count(), 3, "{out}");
    assert_eq!(out.matches("s-lstm: n = ").count(), 3, "{out}");
    let table = std::fs::read_to_string(out_dir.join("stream.md")).unwrap();
    for row in [
        "| s | localized |",
        "| s | + stateful NMS |",
        "| s | global NMS |",
        "| s-lstm | + stateful NMS + LSTM |",
    ] {
        assert!(table.contains(row), "{row} missing:\n{table}");
    }
    assert!(
        table.contains("baseline (n = 1)") && table.contains("worst case ms") && table.contains("recall / precision"),
        "{table}"
    );
    for png in ["stream_ap.png", "stream_flops.png", "stream_latency.png"] {
        assert!(
            std::fs::read(out_dir.join(png)).unwrap().starts_with(b"\x89PNG"),
            "{png}"
        );
    }
    // Peak compute per slice is 1/n of the sweep's for the localized model (the LSTM adds a
    // fixed step per slice); with one slice the three NMS modes agree.
    let runs: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("stream.json")).unwrap()).unwrap();
    let reports = &runs[0]["reports"];
    for (i, n) in [(0, 1.0), (1, 2.0), (2, 4.0)] {
        assert_eq!(reports[i]["slices"].as_u64().unwrap() as f64, n);
        assert!((reports[i]["peak_fraction"].as_f64().unwrap() - 1.0 / n).abs() < 1e-9);
    }
    assert!(runs[1]["reports"][2]["peak_fraction"].as_f64().unwrap() > 0.25);
    let modes = &reports[0]["modes"];
    let ap = |m: usize| modes[m]["waymo"][0]["levels"][1]["ap"].as_f64().unwrap();
    assert!(ap(0) == ap(1) && ap(1) == ap(2), "{modes}");
    let boxes = |m: usize| &modes[m]["waymo"][0]["all_boxes"];
    assert!(boxes(0) == boxes(1) && boxes(1) == boxes(2), "{modes}");
    assert!(boxes(0)[1]["recall"].as_f64().is_some(), "{modes}");
    // The LSTM variant exports as a slice step, with how to loop it and a golden sweep.
    let o = starnet(&["export", "--checkpoint", &ckpt("s-lstm"), "--out", "x"], d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("x/golden_stream.safetensors").is_file());
    let spec: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("x/model.json")).unwrap()).unwrap();
    assert!(spec["streaming"]["lstm_hidden"].as_u64().unwrap() > 0, "{spec}");
}
