//! Training and evaluation end to end, on a few simulated frames with a tiny model (seconds).

mod common;

use common::{starnet, write_tiny_car};

use burn::module::Module;
use burn::prelude::*;
use starnet_train::checkpoint::load_model;
use starnet_train::config::load_config;
use starnet_train::train::{TrainOptions, train};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// `common::TINY_CAR` with two blocks, a 0.3 score threshold and three epochs.
const TINY: &str = r#"
base = "tiny-car.toml"
seed = 3
[model]
blocks = [[16, 8], [16, 8]]
[nms]
score = [0.3]
[train]
epochs = 3
learning_rate = 0.002
decay_start_epoch = 1
workers = 2
"#;

fn tiny_config(dir: &Path) -> std::path::PathBuf {
    write_tiny_car(dir, "tiny-car.toml");
    let p = dir.join("tiny.toml");
    std::fs::write(&p, TINY).unwrap();
    p
}

fn parameters(path: &Path) -> Vec<f32> {
    let cfg = load_config(
        &path
            .parent()
            .unwrap()
            .parent()
            .unwrap()
            .parent()
            .unwrap()
            .join("config.toml"),
        &[],
    )
    .unwrap();
    let dev = starnet_model::backend::default_device();
    let model = load_model(path, cfg.model_config().init(&dev)).unwrap();
    let mut out = Vec::new();
    struct Collect<'a>(&'a mut Vec<f32>);
    impl burn::module::ModuleVisitor for Collect<'_> {
        fn visit_float<const D: usize>(&mut self, p: &burn::module::Param<Tensor<D>>) {
            self.0.extend(p.val().into_data().iter::<f32>());
        }
    }
    model.visit(&mut Collect(&mut out));
    out
}

#[test]
fn resuming_after_a_crash_gives_the_same_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = load_config(&tiny_config(dir.path()), &[]).unwrap();
    let (a, b) = (dir.path().join("run-a"), dir.path().join("run-b"));
    let full = train(&cfg, &a, &TrainOptions::default()).unwrap();
    assert!(full.steps > 3 && full.eval.is_some());
    // "Crash" after 3 steps: the run stops with its checkpoint written, as a kill between
    // checkpoints would leave the previous one.
    let part = train(
        &cfg,
        &b,
        &TrainOptions {
            max_steps: Some(3),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(part.steps, 3);
    let mut other = cfg.clone();
    other.train.learning_rate *= 2.0;
    assert!(
        matches!(
            train(&other, &b, &TrainOptions::default()),
            Err(starnet_train::TrainError::RunExists { .. })
        ),
        "an existing run of another config needs --resume"
    );
    // The same config run again continues the run, as --resume does.
    let resumed = train(&cfg, &b, &TrainOptions::default()).unwrap();
    assert_eq!(resumed.steps, full.steps);
    let last = |run: &Path| starnet_train::checkpoint::latest_checkpoint(&run.join("checkpoints")).unwrap();
    let (pa, pb) = (
        parameters(&last(&a).join("model.bpk")),
        parameters(&last(&b).join("model.bpk")),
    );
    assert!(!pa.is_empty());
    assert!(pa == pb, "resumed parameters differ from the uninterrupted run's");
    // So do the averaged weights the checkpoint keeps for evaluation.
    let (ea, eb) = (
        parameters(&last(&a).join("ema.bpk")),
        parameters(&last(&b).join("ema.bpk")),
    );
    assert!(ea == eb, "resumed EMA weights differ");
    assert!(ea != pa, "the EMA should lag the trained weights");
    // The log has one line per step of each run.
    let log = std::fs::read_to_string(b.join("log.jsonl")).unwrap();
    assert_eq!(
        log.lines().filter(|l| l.contains("\"loss\"")).count() as u64,
        full.steps
    );
}

/// The newest `step-*` checkpoint's step in `run`, once one exists.
fn newest_step(run: &Path) -> Option<u64> {
    std::fs::read_dir(run.join("checkpoints"))
        .ok()?
        .filter_map(|e| e.ok()?.file_name().to_str()?.strip_prefix("step-")?.parse().ok())
        .max()
}

/// A child process killed (SIGKILL) when dropped, so a failing test leaves no trainer behind.
struct KillOnDrop(std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The step of the last record of a run's `log.jsonl`.
fn last_logged_step(run: &Path) -> u64 {
    let log = std::fs::read_to_string(run.join("log.jsonl")).unwrap();
    let last: serde_json::Value = serde_json::from_str(log.lines().last().unwrap()).unwrap();
    last["step"].as_u64().unwrap()
}

#[test]
fn a_run_folder_takes_one_trainer_and_a_killed_run_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = tiny_config(dir.path());
    let cfg = cfg.to_str().unwrap();
    let run = dir.path().join("runs/tiny");
    // A first trainer with far more epochs than the test lets it run.
    let long = ["train", "--config", cfg, "--set", "train.epochs=100000"];
    let spawned = Command::new(env!("CARGO_BIN_EXE_starnet"))
        .args(long)
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut first = KillOnDrop(spawned);
    let start = Instant::now();
    while newest_step(&run).is_none() {
        assert!(first.0.try_wait().unwrap().is_none(), "the first trainer ended early");
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no checkpoint within 5 minutes"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    // A second trainer on the same folder, even resuming, is refused and names it.
    let second = starnet(&[&long[..], &["--resume"]].concat(), dir.path());
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{err}");
    assert!(err.contains("runs/tiny is in use"), "{err}");
    // Killed outright, the first cannot release anything itself; the run still resumes from
    // its newest checkpoint and trains on.
    drop(first);
    let resume_from = newest_step(&run).unwrap();
    let until = resume_from + 2;
    let extra = ["--resume", "--max-steps", &until.to_string()];
    let out = common::ok(&starnet(&[&long[..], &extra[..]].concat(), dir.path()));
    let expected = format!(
        "resuming from {}",
        Path::new("runs/tiny/checkpoints")
            .join(format!("step-{resume_from:08}"))
            .display()
    );
    assert!(out.contains(&expected), "{out}");
    assert_eq!(last_logged_step(&run), until);
    assert!(run.join("eval.json").is_file());
}

#[test]
fn train_then_eval_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = tiny_config(dir.path());
    let o = starnet(
        &["train", "--config", cfg.to_str().unwrap(), "--set", "train.epochs=1"],
        dir.path(),
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.contains("| Car | 0.7 | 3D |"), "{out}");
    let run = dir.path().join("runs/tiny");
    assert!(
        run.join("config.toml").is_file()
            && run.join("eval.json").is_file()
            && run.join("checkpoints/best/model.bpk").is_file()
    );
    let results = dir.path().join("eval-out");
    let o = starnet(
        &[
            "eval",
            "--checkpoint",
            run.join("checkpoints/best").to_str().unwrap(),
            "--centers",
            "16,32",
            "--points",
            "4,8",
            "--out",
            results.to_str().unwrap(),
        ],
        dir.path(),
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(out.matches("| Car | 0.7 | 3D |").count(), 4, "{out}");
    assert_eq!(out.matches("| Car | 0.7 | LEVEL_1 |").count(), 4, "{out}");
    for b in ["c16_p4", "c16_p8", "c32_p4", "c32_p8"] {
        assert!(results.join(b).join("eval.json").is_file(), "{b}");
    }
    // The sweep's table and plots.
    assert_eq!(
        std::fs::read_to_string(results.join("budget.md"))
            .unwrap()
            .lines()
            .count(),
        6
    );
    for png in ["budget_gflop.png", "budget_latency.png"] {
        assert!(
            std::fs::read(results.join(png)).unwrap().starts_with(b"\x89PNG"),
            "{png}"
        );
    }
    // The result files alone, scored as another detector's would be: the checkpoint's tables
    // and eval.json, exactly (and not vacuously: there are detections).
    let lines: usize = std::fs::read_dir(results.join("c32_p8"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "txt"))
        .map(|p| std::fs::read_to_string(p).unwrap().lines().count())
        .sum();
    assert!(lines > 0);
    let scored = dir.path().join("scored");
    let o = starnet(
        &[
            "eval",
            "--results",
            results.join("c32_p8").to_str().unwrap(),
            "--data",
            dir.path().join("data").to_str().unwrap(),
            "--out",
            scored.to_str().unwrap(),
        ],
        dir.path(),
    );
    let rescored = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let tables: String = rescored
        .lines()
        .skip(1)
        .take_while(|l| !l.starts_with("wrote"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(
        tables.contains("| Car | 0.7 | 3D |") && out.contains(&tables),
        "{rescored}\n---\n{out}"
    );
    let read = |p: &Path| -> serde_json::Value { serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap() };
    let (checkpoint, files) = (read(&results.join("c32_p8/eval.json")), read(&scored.join("eval.json")));
    for key in ["frames", "classes", "waymo", "by_range"] {
        assert_eq!(checkpoint[key], files[key], "{key}");
    }
    // Compute is linear in the centers at a fixed point count.
    let reports: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(results.join("budget.json")).unwrap()).unwrap();
    let gflop = |i: usize| reports[i]["gflop_per_frame"].as_f64().unwrap();
    assert!((gflop(2) / gflop(0) - 2.0).abs() < 1e-9 && (gflop(3) / gflop(1) - 2.0).abs() < 1e-9);
    // Targeting the 16 nearest of 32 sampled centers costs what 16 centers cost.
    let near = dir.path().join("near-out");
    let o = starnet(
        &[
            "eval",
            "--checkpoint",
            run.join("checkpoints/best").to_str().unwrap(),
            "--centers",
            "32",
            "--target",
            "nearest:16",
            "--out",
            near.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(near.join("c32_p8_nearest16/eval.json")).unwrap()).unwrap();
    assert_eq!(report["target"], "nearest:16");
    let c16: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(results.join("c16_p8/eval.json")).unwrap()).unwrap();
    assert_eq!(report["gflop_per_frame"], c16["gflop_per_frame"]);
    assert_eq!(report["by_range"].as_array().unwrap().len(), 8);
    // Export, then detect with the export on the three real KITTI sweeps (their calibs beside
    // them): well-formed result files that parse back, and the JSON for each.
    let export = dir.path().join("export");
    let o = starnet(
        &[
            "export",
            "--checkpoint",
            run.join("checkpoints/best").to_str().unwrap(),
            "--out",
            export.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let sample = common::sample_root();
    let detected = dir.path().join("detected");
    let o = starnet(
        &[
            "detect",
            "--model",
            export.to_str().unwrap(),
            "--input",
            sample.join("training/velodyne").to_str().unwrap(),
            "--out",
            detected.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for id in ["000000", "000001", "000002"] {
        starnet_data::kitti::read_labels(&detected.join(format!("{id}.txt"))).unwrap();
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(detected.join(format!("{id}.json"))).unwrap()).unwrap();
        assert_eq!(json["calibrated"], true);
        assert!(json["num_points"].as_u64().unwrap() > 100_000);
    }
    // Training curves from the run's log.
    let o = starnet(&["plot", "--run", run.to_str().unwrap()], dir.path());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for png in ["loss.png", "lr.png"] {
        assert!(std::fs::read(run.join(png)).unwrap().starts_with(b"\x89PNG"), "{png}");
    }
    // Result files for every validation frame, in the submission format.
    let val = std::fs::read_to_string(dir.path().join("data/ImageSets/val.txt")).unwrap();
    for id in val.lines() {
        let f = results.join(format!("c32_p8/{id}.txt"));
        starnet_data::kitti::read_labels(&f).unwrap();
    }
}

#[test]
fn bad_configs_and_checkpoints_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = tiny_config(dir.path());
    let o = starnet(
        &["train", "--config", cfg.to_str().unwrap(), "--set", "train.epocs=2"],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("train.epocs") && err.contains("unknown key"),
        "{err}"
    );
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[train]\nbatch_size = \"two\"\n").unwrap();
    let err =
        String::from_utf8_lossy(&starnet(&["train", "--config", bad.to_str().unwrap()], dir.path()).stderr).to_string();
    assert!(err.contains("bad.toml") && err.contains("train.batch_size"), "{err}");
    let ckpt = dir.path().join("broken");
    std::fs::create_dir_all(&ckpt).unwrap();
    std::fs::write(ckpt.join("model.bpk"), b"not a checkpoint").unwrap();
    let o = starnet(
        &[
            "eval",
            "--checkpoint",
            ckpt.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("broken/model.bpk") && !err.contains("panicked"),
        "{err}"
    );
}

/// The named float tensors of a checkpoint's `model.bpk` (the weights trained, not the EMA).
fn named_tensors(model_bpk: &Path, config: &Path) -> std::collections::BTreeMap<String, Vec<f32>> {
    use burn::store::ModuleSnapshot;
    let cfg = load_config(config, &[]).unwrap();
    let model = load_model(
        model_bpk,
        cfg.model_config().init(&starnet_model::backend::default_device()),
    )
    .unwrap();
    model
        .collect(None, None, false)
        .into_iter()
        .map(|t| {
            let bytes = t.to_bytes().unwrap();
            let values = bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
                .collect();
            (t.name.clone(), values)
        })
        .collect()
}

/// Cyclist anchors (2 rotations of one prior, where the car model has 4): the classification
/// and box heads no longer fit.
const TINY_CYCLIST: &str = r#"
base = "tiny.toml"
[data]
classes = ["Cyclist"]
[model.anchors]
grid = 5
extent = 1.294
rotations = [0.0, 1.5707964]
[[model.anchors.priors]]
size = [1.76, 0.6, 1.73]
z = -0.6
[train]
epochs = 2
keep_last = 5
freeze_featurizer_epochs = 1
"#;

#[test]
fn a_car_model_fine_tunes_to_cyclists_and_each_checkpoint_is_evaluated() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = tiny_config(dir.path());
    let sets = ["--set", "train.epochs=2", "--set", "train.keep_last=5"];
    let o = starnet(
        &[&["train", "--config", cfg.to_str().unwrap()][..], &sets].concat(),
        dir.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let car = dir.path().join("runs/tiny");
    // Every kept checkpoint evaluated, with the run's table and plot.
    let o = starnet(&["eval", "--run", car.to_str().unwrap()], dir.path());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let steps = starnet_train::checkpoint::step_checkpoints(&car.join("checkpoints"));
    assert_eq!(steps.len(), 2, "two epochs, two step checkpoints");
    assert_eq!(out.matches("headline AP").count(), 2, "{out}");
    let evals = car.join("eval-val");
    let table = std::fs::read_to_string(evals.join("run_eval.md")).unwrap();
    assert_eq!(table.lines().count(), 4, "{table}");
    assert!(table.contains(&format!("| {} |", steps[1].step)), "{table}");
    assert!(
        std::fs::read(evals.join("run_eval_ap.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    for c in &steps {
        assert!(evals.join(format!("step-{:08}/eval.json", c.step)).is_file());
    }
    // The last checkpoint's scores are the final evaluation's (the same weights, budget and seed).
    let read = |p: &Path| -> serde_json::Value { serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap() };
    let last = read(&evals.join(format!("step-{:08}/eval.json", steps[1].step)));
    assert_eq!(last["classes"], read(&car.join("eval.json"))["classes"]);

    // Fine-tune to cyclists from the car model's best checkpoint, the featurizer held for an epoch.
    std::fs::write(dir.path().join("cyclist.toml"), TINY_CYCLIST).unwrap();
    let best = car.join("checkpoints/best");
    let cyc_run = dir.path().join("runs/cyclist");
    let o = starnet(
        &[
            "train",
            "--config",
            "cyclist.toml",
            "--init",
            best.to_str().unwrap(),
            "--run",
            cyc_run.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("re-initialised") && out.contains("cls_head.weight"),
        "{out}"
    );
    let init = read(&cyc_run.join("init.json"));
    let fresh: Vec<&str> = init["reinitialised"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["name"].as_str().unwrap())
        .collect();
    for head in ["cls_head.weight", "cls_head.bias", "box_head.weight"] {
        assert!(fresh.contains(&head), "{head} not re-initialised: {fresh:?}");
    }
    assert!(fresh.iter().all(|n| n.contains("_head.")), "{fresh:?}");
    // The featurizer is the car model's after the frozen epoch, and trained after the next.
    let source = named_tensors(&best.join("ema.bpk"), &car.join("config.toml"));
    let cyc_steps = starnet_train::checkpoint::step_checkpoints(&cyc_run.join("checkpoints"));
    let cyc_config = cyc_run.join("config.toml");
    let after = |i: usize| named_tensors(&cyc_steps[i].path.join("model.bpk"), &cyc_config);
    let (frozen, trained) = (after(0), after(1));
    // Its weights, not the BatchNorm running statistics (which follow the data while frozen).
    let featurizer: Vec<&String> = source
        .keys()
        .filter(|k| k.starts_with("featurizer.") && !k.contains("running_"))
        .collect();
    assert!(!featurizer.is_empty());
    for k in &featurizer {
        assert_eq!(frozen[*k], source[*k], "{k} moved while frozen");
    }
    assert!(
        featurizer.iter().any(|k| trained[*k] != source[*k]),
        "the featurizer never trained"
    );
    assert!(
        frozen["proj.weight"] != source["proj.weight"],
        "the projection did not train while frozen"
    );
}

/// The tiny car model on the simulator's 360° labels, centers all around the sensor.
const TINY_360: &str = r#"
base = "tiny.toml"
[data]
labels = "label_360"
[pipeline.pool]
x_range = [-40.0, 40.0]
y_range = [-40.0, 40.0]
camera_frustum = false
"#;

#[test]
fn the_simulator_in_the_custom_layout_trains_to_the_same_figures() {
    let dir = tempfile::tempdir().unwrap();
    tiny_config(dir.path());
    std::fs::write(dir.path().join("tiny-360.toml"), TINY_360).unwrap();
    let train = |run: &str, sets: &[&str]| {
        let args = [&["train", "--config", "tiny-360.toml", "--run", run][..], sets].concat();
        let o = starnet(&args, dir.path());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let eval = std::fs::read_to_string(dir.path().join(run).join("eval.json")).unwrap();
        serde_json::from_str::<serde_json::Value>(&eval).unwrap()
    };
    let kitti = train("runs/kitti-layout", &[]);
    let data = dir.path().join("data");
    let custom = dir.path().join("custom");
    let convert = || {
        let args = [
            "convert",
            "--from",
            data.to_str().unwrap(),
            "--to",
            custom.to_str().unwrap(),
        ];
        starnet(&[&args[..], &["--layout", "custom"]].concat(), dir.path())
    };
    let o = convert();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(custom.join("points/000000.npy").is_file() && !custom.join("training").exists());
    let root = format!("data.root={:?}", custom.display().to_string());
    // A custom root with the camera's frustum is a config error naming the key.
    let o = starnet(
        &[
            "eval",
            "--checkpoint",
            "runs/kitti-layout/checkpoints/best",
            "--set",
            &root,
            "--set",
            "pipeline.pool.camera_frustum=true",
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("pipeline.pool.camera_frustum"),
        "{err}"
    );
    let own = train(
        "runs/custom-layout",
        &["--set", &root, "--set", "data.simulate_frames=0"],
    );
    // Training saw the same data: every step's losses to the bit (the log's speed aside).
    let losses = |run: &str| -> Vec<serde_json::Value> {
        std::fs::read_to_string(dir.path().join(run).join("log.jsonl"))
            .unwrap()
            .lines()
            .map(|l| {
                let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
                v.as_object_mut().unwrap().remove("frames_per_s");
                v
            })
            .collect()
    };
    let steps = losses("runs/kitti-layout");
    assert!(steps.len() >= 6 && steps.iter().all(|s| s["loss"].as_f64().unwrap() > 0.0));
    assert_eq!(steps, losses("runs/custom-layout"));
    // No KITTI metrics without a camera; the Waymo-style ones to the digit.
    assert_eq!(kitti["classes"], serde_json::json!([]));
    assert!(kitti["waymo"][0]["levels"][0]["ap"].as_f64().is_some(), "{kitti}");
    for key in ["frames", "classes", "waymo", "by_range"] {
        assert_eq!(kitti[key], own[key], "{key}");
    }
    // Converting into a folder that holds files is refused.
    let o = convert();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("not empty"));
}
