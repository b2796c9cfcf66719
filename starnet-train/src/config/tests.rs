use super::*;
use crate::TrainError;
use starnet_data::kitti::{LabelSource, ObjectClass};
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn reference_file_lists_the_defaults() {
    // `configs/reference.toml` is `starnet config` output under a comment header.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/reference.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let body: String = text
        .lines()
        .skip_while(|l| l.starts_with('#') || l.is_empty())
        .map(|l| format!("{l}\n"))
        .collect();
    assert_eq!(
        body,
        to_toml(&ExperimentConfig::default()),
        "regenerate configs/reference.toml with `starnet config`"
    );
}

#[test]
fn shipped_configs_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 5, "{names:?}");
    for path in names {
        let cfg = load_config(&path, &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(!cfg.model.anchors.priors.is_empty(), "{}", path.display());
    }
    // The presets say what they claim.
    let ped = load_config(&dir.join("sim-360-ped.toml"), &[]).unwrap();
    assert_eq!(ped.data.labels, LabelSource::AllAround);
    assert!(!ped.pipeline.pool.camera_frustum);
    let ped_cyc = load_config(&dir.join("sim-ped-cyc.toml"), &[]).unwrap();
    assert_eq!(ped_cyc.data.classes, [ObjectClass::Pedestrian, ObjectClass::Cyclist]);
    assert_eq!(ped_cyc.model.anchors.len(), 108, "lingvo's ped/cyc anchors per center");
    assert_eq!(ped_cyc.loss.class_weights, [3.5, 3.25]);
    // Focal alpha 0.25, not lingvo's 0.9 (issue #47, BENCHMARKS.md); the 360-degree preset keeps 0.9.
    assert_eq!((ped_cyc.loss.alpha, ped.loss.alpha), (0.25, 0.9));
    // The Pedestrian threshold set for alpha 0.25's scores; the 360-degree preset sets its own, lingvo's.
    assert_eq!(ped_cyc.nms.score, [0.15, 0.11]);
    assert_eq!(ped.nms.score, [0.23]);
    let car = load_config(&dir.join("kitti-car.toml"), &[]).unwrap();
    assert_eq!(car.model_config().featurizer.cell_dim(), 1440);
}

#[test]
fn defaults_round_trip_through_toml() {
    let d = ExperimentConfig::default();
    let back: ExperimentConfig = toml::from_str(&to_toml(&d)).unwrap();
    assert_eq!(back, d);
}

#[test]
fn bases_merge_and_sets_win() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "base.toml",
        "seed = 3\n[train]\nepochs = 7\nbatch_size = 4\n",
    );
    let p = write(
        dir.path(),
        "exp.toml",
        "base = \"base.toml\"\n[train]\nepochs = 9\nlearning_rate = 1\n",
    );
    let c = load_config(&p, &["train.batch_size=6".into(), "data.root=\"/x\"".into()]).unwrap();
    assert_eq!((c.seed, c.train.epochs, c.train.batch_size), (3, 9, 6));
    assert_eq!(c.train.learning_rate, 1.0, "integers widen to floats");
    assert_eq!(c.data.root, PathBuf::from("/x"));
    assert_eq!(
        c.model,
        ExperimentConfig::default().model,
        "untouched sections keep their defaults"
    );
}

#[test]
fn a_renamed_key_reads_in_its_old_spelling() {
    use starnet_data::sampling::SliceContext;
    let dir = tempfile::tempdir().unwrap();
    for (old, want) in [(true, SliceContext::Previous), (false, SliceContext::Own)] {
        let p = write(
            dir.path(),
            "old.toml",
            &format!("[stream.slicing]\ngather_previous = {old}\n"),
        );
        assert_eq!(load_config(&p, &[]).unwrap().stream.slicing.context, want);
        let set = format!("stream.slicing.gather_previous={old}");
        let text = parse_config("", Path::new("model.safetensors"), &[set]).unwrap();
        assert_eq!(text.stream.slicing.context, want, "--set and embedded configs alike");
    }
    let both = "[stream.slicing]\ngather_previous = true\ncontext = \"own\"\n";
    let e = load_config(&write(dir.path(), "both.toml", both), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("both.toml") && e.contains("stream.slicing.gather_previous"),
        "{e}"
    );
    assert!(e.contains("renamed to context"), "{e}");
    let odd = "[stream.slicing]\ngather_previous = 3\n";
    let e = load_config(&write(dir.path(), "odd.toml", odd), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stream.slicing.gather_previous") && e.contains("3 has no meaning"),
        "{e}"
    );
}

#[test]
fn errors_name_the_key_and_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "a.toml", "[train]\nlearning_rat = 0.1\n");
    let e = load_config(&p, &[]).unwrap_err().to_string();
    assert!(
        e.contains("a.toml") && e.contains("train.learning_rat") && e.contains("unknown key"),
        "{e}"
    );
    let p = write(dir.path(), "b.toml", "[train]\nepochs = \"many\"\n");
    let e = load_config(&p, &[]).unwrap_err().to_string();
    assert!(
        e.contains("train.epochs") && e.contains("expected integer, found string"),
        "{e}"
    );
    let p = write(dir.path(), "c.toml", "[data]\nclasses = [\"Bus\"]\n");
    let e = load_config(&p, &[]).unwrap_err().to_string();
    assert!(e.contains("c.toml") && e.contains("Bus"), "{e}");
    let p = write(dir.path(), "d.toml", "[train\n");
    assert!(load_config(&p, &[]).unwrap_err().to_string().contains("d.toml"));
    let p = write(dir.path(), "e.toml", "[nms]\niou = [0.1, 0.2]\n");
    assert!(
        load_config(&p, &[])
            .unwrap_err()
            .to_string()
            .contains("one value per class")
    );
    for (body, want) in [
        ("[nms]\nvote_iou = [0.5, 0.5]\n", "one value per class"),
        ("[nms]\nvote_iou = [1.5]\n", "1.5 is not an IoU"),
    ] {
        let p = write(dir.path(), "v.toml", body);
        let e = load_config(&p, &[]).unwrap_err().to_string();
        assert!(e.contains("nms.vote_iou") && e.contains(want), "{e}");
    }
    let p = write(dir.path(), "v.toml", "[nms]\nvote_iou = [0.5]\n");
    let c = load_config(&p, &[]).unwrap();
    assert_eq!(c.nms_config().per_class[0].vote_iou, Some(0.5));
    assert_eq!(
        ExperimentConfig::default().nms_config().per_class[0].vote_iou,
        None,
        "the paper's plain NMS"
    );
    let p = write(dir.path(), "f.toml", "base = \"f.toml\"\n");
    assert!(load_config(&p, &[]).unwrap_err().to_string().contains("cycle"));
    let ok = write(dir.path(), "g.toml", "");
    let e = load_config(&ok, &["train.nope=1".into()]).unwrap_err().to_string();
    assert!(e.contains("train.nope"), "{e}");
}

#[test]
fn issue_15_settings_are_checked_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let ok = write(dir.path(), "a.toml", "");
    for (set, key) in [
        ("augment.object_margin=-0.1", "augment.object_margin"),
        ("augment.object_margin=0.5", "augment.object_margin"),
        ("pipeline.gather.radius=0.0", "pipeline.gather.radius"),
        ("pipeline.gather.metric=\"sphere\"", "pipeline.gather.metric"),
    ] {
        let e = load_config(&ok, &[set.into()]).unwrap_err().to_string();
        assert!(e.contains(key), "{set}: {e}");
    }
    let c = load_config(
        &ok,
        &[
            "pipeline.gather.metric=\"cylinder\"".into(),
            "model.direction_classifier=true".into(),
        ],
    )
    .unwrap();
    assert_eq!(c.pipeline.gather.metric, starnet_data::sampling::GatherMetric::Cylinder);
    assert!(c.model_config().direction_classifier);
}

#[test]
fn the_ground_table_is_absent_by_default_and_checked_when_named() {
    use starnet_data::geometry::GroundConfig;
    let dir = tempfile::tempdir().unwrap();
    let none = write(dir.path(), "a.toml", "");
    assert_eq!(load_config(&none, &[]).unwrap().pipeline.ground, None);
    let empty = write(
        dir.path(),
        "b.toml",
        "[pipeline]\ncenter_z = \"ground\"\n[pipeline.ground]\n",
    );
    let c = load_config(&empty, &["pipeline.ground.window=3".into()]).unwrap();
    assert_eq!(c.pipeline.center_z, starnet_data::sampling::CenterZ::Ground);
    assert_eq!(
        c.pipeline.ground,
        Some(GroundConfig {
            window: 3,
            ..GroundConfig::default()
        })
    );
    // An integer where a float is due is widened, as everywhere else; a typo is an unknown key.
    let c = load_config(&empty, &["pipeline.ground.cell=1".into()]).unwrap();
    assert_eq!(c.pipeline.ground.map(|g| g.cell), Some(1.0));
    let e = load_config(&empty, &["pipeline.ground.cel=1.0".into()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("pipeline.ground.cel") && e.contains("unknown key"), "{e}");
}

#[test]
fn every_range_rule_rejects_a_bad_value_naming_its_key() {
    let dir = tempfile::tempdir().unwrap();
    let ok = write(dir.path(), "a.toml", "");
    let cases = [
        ("data.classes=[]", "data.classes"),
        ("pipeline.num_centers=0", "pipeline.num_centers"),
        ("pipeline.pool.x_range=[10.0, 0.0]", "pipeline.pool.x_range"),
        ("pipeline.pool.y_range=[1.0, -1.0]", "pipeline.pool.y_range"),
        ("pipeline.pool.z_range=[0.0, -1.0]", "pipeline.pool.z_range"),
        ("pipeline.center_z=\"ground\"", "pipeline.center_z"),
        ("pipeline.ground.cell=0.0", "pipeline.ground.cell"),
        ("pipeline.ground.extent=-5.0", "pipeline.ground.extent"),
        ("pipeline.ground.cell=0.001", "pipeline.ground.extent"),
        ("pipeline.ground.reference_z=nan", "pipeline.ground.reference_z"),
        ("pipeline.gather.num_points=0", "pipeline.gather.num_points"),
        ("pipeline.gather.radius=-1.0", "pipeline.gather.radius"),
        ("augment.object_margin=-0.1", "augment.object_margin"),
        ("augment.box_rotation.max=-0.1", "augment.box_rotation.max"),
        ("augment.flip_probability=1.5", "augment.flip_probability"),
        ("augment.global_rotation.max=-1.0", "augment.global_rotation.max"),
        ("augment.scaling_range=[1.05, 0.95]", "augment.scaling_range"),
        ("augment.scaling_range=[0.0, 1.0]", "augment.scaling_range"),
        ("augment.box_scaling.height=[1.1, 0.9]", "augment.box_scaling.height"),
        ("augment.box_scaling.width=[0.0, 1.0]", "augment.box_scaling.width"),
        ("augment.z_shift_sigma=-1.0", "augment.z_shift_sigma"),
        ("augment.ring_dropout_width=-0.1", "augment.ring_dropout_width"),
        ("model.d_fc0=0", "model.d_fc0"),
        ("model.blocks=[]", "model.blocks"),
        ("model.blocks=[[0, 64]]", "model.blocks[0]"),
        ("model.d_offset=0", "model.d_offset"),
        ("model.d_fc0=5000", "model.d_fc0"),
        ("model.blocks=[[64, 100000]]", "model.blocks[0]"),
        ("model.lstm_hidden=9999", "model.lstm_hidden"),
        ("model.anchors.grid=0", "model.anchors.grid"),
        ("model.anchors.extent=-1.0", "model.anchors.extent"),
        ("model.anchors.rotations=[]", "model.anchors.rotations"),
        ("model.anchors.priors=[]", "model.anchors.priors"),
        (
            "model.anchors.priors=[{size = [3.9, 0.0, 1.5], z = -1.0}]",
            "model.anchors.priors[0].size",
        ),
        ("assign.fg_iou=0.0", "assign.fg_iou"),
        ("assign.fg_iou=1.2", "assign.fg_iou"),
        ("assign.bg_iou=-0.1", "assign.bg_iou"),
        ("loss.alpha=1.5", "loss.alpha"),
        ("loss.gamma=-1.0", "loss.gamma"),
        ("loss.huber_delta=0.0", "loss.huber_delta"),
        ("loss.location_weight=-1.0", "loss.location_weight"),
        ("loss.dimension_weight=-1.0", "loss.dimension_weight"),
        ("loss.rotation_weight=-1.0", "loss.rotation_weight"),
        ("loss.localization_weight=-1.0", "loss.localization_weight"),
        ("loss.classification_weight=-1.0", "loss.classification_weight"),
        ("loss.direction_weight=-1.0", "loss.direction_weight"),
        ("loss.class_weights=[-1.0]", "loss.class_weights[0]"),
        ("loss.class_weights=[1.0, 2.0]", "loss.class_weights"),
        ("nms.iou=[1.5]", "nms.iou"),
        ("nms.score=[-0.1]", "nms.score"),
        ("nms.vote_iou=[1.5]", "nms.vote_iou"),
        ("nms.max_boxes=0", "nms.max_boxes"),
        ("train.epochs=0", "train.epochs"),
        ("train.batch_size=0", "train.batch_size"),
        ("train.learning_rate=0.0", "train.learning_rate"),
        ("train.decay_start_epoch=-1.0", "train.decay_start_epoch"),
        ("train.adam_epsilon=0.0", "train.adam_epsilon"),
        ("train.grad_clip_norm=0.0", "train.grad_clip_norm"),
        ("train.l2=-1.0", "train.l2"),
        ("train.ema_decay=1.0", "train.ema_decay"),
        ("train.workers=0", "train.workers"),
        ("train.prefetch=0", "train.prefetch"),
        ("eval.num_centers=0", "eval.num_centers"),
        ("eval.num_points=0", "eval.num_points"),
        ("eval.batch_size=0", "eval.batch_size"),
        ("stream.train_slices=[4, 0]", "stream.train_slices"),
        ("stream.eval_slices=0", "stream.eval_slices"),
        ("stream.scan_hz=0.0", "stream.scan_hz"),
        ("stream.eval_range=0.0", "stream.eval_range"),
        (
            "stream.slicing.start_azimuth_deg=inf",
            "stream.slicing.start_azimuth_deg",
        ),
        ("stream.slicing.spacing=0.0", "stream.slicing.spacing"),
        ("stream.slicing.peak=0.5", "stream.slicing.peak"),
        ("stream.slicing.context=\"later\"", "stream.slicing.context"),
    ];
    for (set, key) in cases {
        match load_config(&ok, &[set.into()]) {
            Err(TrainError::Config { key: k, .. }) => assert_eq!(k, key, "{set}"),
            other => panic!("{set}: expected an error naming {key}, got {other:?}"),
        }
    }
    // Spaced centers vary the steps per sweep: they stream, they do not train on slices.
    let spaced = [
        "stream.slicing.centers=\"spaced\"".to_string(),
        "stream.train_slices=[1, 8]".into(),
    ];
    // The LSTM's slice summary averages over every center: no half-mirrored slices.
    let lstm_mirrored = ["model.lstm_hidden=32".to_string(), "eval.views=\"alternate\"".into()];
    match load_config(&ok, &lstm_mirrored) {
        Err(TrainError::Config { key, message, .. }) => {
            assert_eq!(key, "eval.views");
            assert!(message.contains("as_seen"), "{message}");
        }
        other => panic!("expected mirrored centers under an LSTM to be refused, got {other:?}"),
    }
    assert!(load_config(&ok, &["eval.views=\"alternate\"".to_string()]).is_ok());
    match load_config(&ok, &spaced) {
        Err(TrainError::Config { key, message, .. }) => {
            assert_eq!(key, "stream.slicing.centers");
            assert!(message.contains("train_slices"), "{message}");
        }
        other => panic!("expected spaced training to be refused, got {other:?}"),
    }
    assert!(
        load_config(&ok, &spaced[..1]).is_ok(),
        "spaced streaming evaluation is fine"
    );
}

#[test]
fn class_keyed_tables_accept_class_names() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "a.toml",
        "[augment.db_paste.max_per_class]\nCar = 10\nPedestrian = 4\n",
    );
    let c = load_config(&p, &[]).unwrap();
    assert_eq!(c.augment.db_paste.max_per_class.get(&ObjectClass::Pedestrian), Some(&4));
}
