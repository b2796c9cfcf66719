//! A mutation fuzzer for every parser a user's files reach, on stable Rust: per target, seed
//! inputs from real files (the KITTI sample, simulator output, configs, a checkpoint, an
//! export) mutated byte-wise (bit flips, interesting bytes, deletions, duplications, splices,
//! truncation) and, for text, token-wise (numbers swapped for `nan`, `inf`, `-1`, `1e39`, …;
//! lines dropped, repeated or swapped). A parser passes when no input makes it panic; an error
//! is the right answer to garbage. Run by `tests/fuzz.rs`.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use starnet_data::Point;
use starnet_data::augment::GtDatabase;
use starnet_data::cloud::{CloudFormat, Intensity, PcdEncoding, PlyEncoding, PointCloud, decode_cloud, encode_cloud};
use starnet_data::custom::parse_custom_labels;
use starnet_data::kitti::parse_sidecar;
use starnet_data::kitti::{
    Calib, Frame, ImageSize, KittiDataset, decode_points, encode_points, format_labels, parse_labels,
};
use starnet_data::sampling::{CenterPoolConfig, GatherConfig, PipelineConfig, prepare_frame};
use starnet_sim::{SynthConfig, simulate_scene_frame};
use std::path::{Path, PathBuf};

/// Runs a parser on an input; returns whether it accepted it.
pub type Parse = Box<dyn Fn(&[u8]) -> bool>;

/// A parser under test: bytes in, any `Result` out (only panics fail).
pub struct Target {
    /// Its name in reports.
    pub name: &'static str,
    /// Seed inputs.
    pub corpus: Vec<Vec<u8>>,
    /// Whether inputs are text (adds token- and line-level mutations).
    pub text: bool,
    /// Runs the parser.
    pub run: Parse,
}

/// What a campaign found.
#[derive(Debug, Default)]
pub struct Outcome {
    /// Inputs run.
    pub execs: u64,
    /// Inputs the parser accepted.
    pub accepted: u64,
    /// Inputs that panicked (the first few), with the panic message.
    pub panics: Vec<(Vec<u8>, String)>,
    /// Panics in all.
    pub panic_count: u64,
}

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn sample_files(sample: &Path, sub: &str) -> Vec<Vec<u8>> {
    let dir = sample.join("training").join(sub);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files.iter().map(|f| std::fs::read(f).unwrap()).collect()
}

fn simulated(scene: u64) -> starnet_sim::SynthFrame {
    simulate_scene_frame(scene, 0, &SynthConfig::default(), &Calib::kitti_000000())
}

/// Text parsers see what `read_to_string` would hand them, or nothing (invalid UTF-8 is the
/// reader's error, named by the file).
fn text_of(bytes: &[u8]) -> Option<&str> {
    std::str::from_utf8(bytes).ok()
}

fn velodyne(sample: &Path) -> Target {
    // Whole sweeps are megabytes; their first few kilobytes hold every structure there is.
    let mut corpus: Vec<Vec<u8>> = sample_files(sample, "velodyne")
        .into_iter()
        .map(|b| b[..4096].to_vec())
        .collect();
    corpus.push(encode_points(&simulated(1).points[..300]));
    corpus.push(Vec::new());
    Target {
        name: "velodyne .bin",
        corpus,
        text: false,
        run: Box::new(|b| decode_points(b, Path::new("fuzz.bin")).map(through_pipeline).is_ok()),
    }
}

fn labels(sample: &Path) -> Target {
    let mut corpus = sample_files(sample, "label_2");
    corpus.push(format_labels(&simulated(2).labels).into_bytes());
    Target {
        name: "label_2 / results",
        corpus,
        text: true,
        run: Box::new(|b| text_of(b).is_some_and(|t| parse_labels(t, Path::new("fuzz.txt")).is_ok())),
    }
}

fn calib(sample: &Path) -> Target {
    let mut corpus = sample_files(sample, "calib");
    corpus.push(Calib::kitti_000000().format().into_bytes());
    Target {
        name: "calib",
        corpus,
        text: true,
        run: Box::new(|b| text_of(b).is_some_and(|t| Calib::parse(t, Path::new("fuzz.txt")).is_ok())),
    }
}

fn poses() -> Target {
    let row = |x: f64| format!("1 0 0 {x:e} 0 1 0 0.5 0 0 1 -0.25\n");
    Target {
        name: "poses.txt",
        corpus: vec![(0..4).map(|i| row(i as f64 * 1.3)).collect::<String>().into_bytes()],
        text: true,
        run: Box::new(|b| {
            text_of(b).is_some_and(|t| starnet_data::geometry::parse_poses(t, Path::new("poses.txt")).is_ok())
        }),
    }
}

fn split() -> Target {
    Target {
        name: "ImageSets split",
        corpus: vec![b"000000\n000001\n000002\n".to_vec(), b"000007".to_vec()],
        text: true,
        run: Box::new(|b| {
            text_of(b).is_some_and(|t| starnet_data::kitti::parse_split(t, Path::new("val.txt")).is_ok())
        }),
    }
}

fn sidecar() -> Target {
    let sim = simulated(3);
    let text: String = sim.objects.iter().map(|o| o.to_line() + "\n").collect();
    Target {
        name: "label_360 sidecar",
        corpus: vec![text.into_bytes()],
        text: true,
        run: Box::new(|b| text_of(b).is_some_and(|t| parse_sidecar(t, Path::new("fuzz.txt")).is_ok())),
    }
}

fn config() -> Target {
    let corpus = [
        "quickstart.toml",
        "stream-car-lstm.toml",
        "reference.toml",
        "kitti-ped-cyc.toml",
    ]
    .iter()
    .map(|f| std::fs::read(workspace().join("configs").join(f)).unwrap())
    .collect();
    Target {
        name: "experiment config",
        corpus,
        text: true,
        run: Box::new(|b| {
            text_of(b).is_some_and(|t| starnet_train::config::parse_config(t, Path::new("fuzz.toml"), &[]).is_ok())
        }),
    }
}

fn gt_database(sample: &Path) -> Target {
    let ds = KittiDataset::open(sample, None).unwrap();
    let db = GtDatabase::build(&ds, &|| {}).unwrap();
    let mut small = db.clone();
    small.entries.truncate(2);
    for e in &mut small.entries {
        e.points.truncate(20);
    }
    Target {
        name: "gt_database.bin",
        corpus: vec![small.encode()],
        text: false,
        run: Box::new(|b| GtDatabase::decode(b, Path::new("gt_database.bin")).is_ok()),
    }
}

/// A small model's config: checkpoints and exports of it are a few kilobytes.
fn tiny_config() -> starnet_train::config::ExperimentConfig {
    let mut cfg = starnet_train::config::ExperimentConfig::default();
    cfg.model.blocks = vec![[8, 8]];
    cfg.model.d_fc0 = 8;
    cfg.model.d_offset = 4;
    cfg
}

fn checkpoint() -> Target {
    use burn::module::Module;
    let cfg = tiny_config();
    let device = starnet_model::backend::default_device();
    let model = cfg.model_config().init(&device);
    let bytes = model.clone().into_record().into_bytes().unwrap().to_vec();
    let state = br#"{"step": 305, "best_metric": 12.5}"#.to_vec();
    Target {
        name: "checkpoint (model.bpk, state.json)",
        corpus: vec![bytes, state],
        text: false,
        run: Box::new(move |b| {
            let file = Path::new("model.bpk");
            let as_model = starnet_train::checkpoint::model_from_bytes(b.to_vec(), model.clone(), file).is_ok();
            let as_state =
                text_of(b).is_some_and(|t| starnet_train::checkpoint::parse_state(t, Path::new("state.json")).is_ok());
            as_model || as_state
        }),
    }
}

fn export() -> Target {
    let cfg = tiny_config();
    let model = cfg.model_config().init(&starnet_model::backend::default_device());
    let dir = tempfile::tempdir().unwrap();
    starnet_train::export::export(&model, &cfg, dir.path()).unwrap();
    let bytes = std::fs::read(dir.path().join("model.safetensors")).unwrap();
    Target {
        name: "export (model.safetensors)",
        corpus: vec![bytes],
        text: false,
        run: Box::new(|b| starnet_train::export::exported_from_bytes(b, Path::new("model.safetensors"), &[]).is_ok()),
    }
}

/// Every target, seeded from the KITTI sample at `sample` and the workspace's own files.
pub fn targets(sample: &Path) -> Vec<Target> {
    vec![
        velodyne(sample),
        labels(sample),
        calib(sample),
        poses(),
        split(),
        sidecar(),
        config(),
        gt_database(sample),
        checkpoint(),
        export(),
        custom_labels(),
        cloud(CloudFormat::Pcd(PcdEncoding::Ascii), "PCD ascii"),
        cloud(CloudFormat::Pcd(PcdEncoding::Binary), "PCD binary"),
        cloud(CloudFormat::Pcd(PcdEncoding::BinaryCompressed), "PCD binary_compressed"),
        cloud(CloudFormat::Ply(PlyEncoding::Ascii), "PLY ascii"),
        cloud(CloudFormat::Ply(PlyEncoding::BinaryLittleEndian), "PLY binary"),
        cloud(CloudFormat::Npy, "NumPy .npy"),
    ]
}

/// A simulated sweep's first points in `format`, read back by extension.
fn cloud(format: CloudFormat, name: &'static str) -> Target {
    let points = simulated(3).points[..200].to_vec();
    let path = PathBuf::from(format!("fuzz.{}", format.kind().extension()));
    let encode = |intensity| {
        encode_cloud(
            &PointCloud {
                points: points.clone(),
                intensity,
            },
            format,
            &path,
        )
        .unwrap()
    };
    Target {
        name,
        corpus: vec![encode(Intensity::Measured), encode(Intensity::Absent)],
        text: matches!(
            format,
            CloudFormat::Pcd(PcdEncoding::Ascii) | CloudFormat::Ply(PlyEncoding::Ascii)
        ),
        run: Box::new(move |b| decode_cloud(b, &path).map(|c| through_pipeline(c.points)).is_ok()),
    }
}

/// What follows a read in `starnet detect` and the loaders: the grid, FPS and gather of a frame's
/// preparation, here on the points as read (the wild-point limit left out, as a user's own
/// loop may leave it out), all around the sensor so that every point may become a center.
fn through_pipeline(points: Vec<Point>) {
    let cfg = PipelineConfig {
        pool: CenterPoolConfig::all_around(f32::INFINITY),
        num_centers: 16,
        gather: GatherConfig {
            num_points: 8,
            radius: 2.0,
            ..PipelineConfig::default().gather
        },
        ..PipelineConfig::default()
    };
    let frame = Frame {
        id: "fuzz".into(),
        points,
        objects: Vec::new(),
        calib: Calib::kitti_000000(),
        image_size: ImageSize::KITTI,
    };
    prepare_frame(&frame, &cfg, None, &[], &mut ChaCha8Rng::seed_from_u64(0));
}

fn custom_labels() -> Target {
    let text = "12.3456 -3.2100 -0.9500 3.9000 1.6300 1.5200 0.0100 Car\n4.0 1.5 -1.0 0.8 0.6 1.7 -3.1 Pedestrian\n";
    Target {
        name: "custom labels",
        corpus: vec![text.as_bytes().to_vec()],
        text: true,
        run: Box::new(|b| text_of(b).is_some_and(|t| parse_custom_labels(t, Path::new("fuzz.txt")).is_ok())),
    }
}

const INTERESTING_BYTES: [u8; 8] = [0, 0xff, 0x7f, 0x80, b'\n', b' ', b'-', b'9'];
const INTERESTING_TOKENS: [&str; 14] = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e39",
    "-1e39",
    "1e-46",
    "18446744073709551616",
    "",
    "x",
    "[",
    "\"",
    "é",
];

/// One mutation of `input` (several stacked), with `others` for splicing.
pub fn mutate(input: &[u8], others: &[Vec<u8>], text: bool, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut v = input.to_vec();
    for _ in 0..rng.random_range(1..=4) {
        if text && rng.random_bool(0.5) {
            v = mutate_text(&v, rng);
        } else {
            mutate_bytes(&mut v, others, rng);
        }
    }
    v
}

fn mutate_bytes(v: &mut Vec<u8>, others: &[Vec<u8>], rng: &mut ChaCha8Rng) {
    let n = v.len();
    let at = |rng: &mut ChaCha8Rng| if n == 0 { 0 } else { rng.random_range(0..n) };
    match rng.random_range(0..7) {
        0 if n > 0 => {
            let i = at(rng);
            v[i] ^= 1 << rng.random_range(0..8);
        }
        1 if n > 0 => {
            let i = at(rng);
            v[i] = INTERESTING_BYTES[rng.random_range(0..INTERESTING_BYTES.len())];
        }
        2 if n > 0 => {
            let i = at(rng);
            let len = rng.random_range(1..=(n - i).min(64));
            v.drain(i..i + len);
        }
        3 if n > 0 => {
            let i = at(rng);
            let len = rng.random_range(1..=(n - i).min(64));
            let chunk: Vec<u8> = v[i..i + len].to_vec();
            let j = rng.random_range(0..=n);
            v.splice(j..j, chunk);
        }
        4 => v.truncate(at(rng)),
        5 if !others.is_empty() => {
            let o = &others[rng.random_range(0..others.len())];
            let cut = if o.is_empty() { 0 } else { rng.random_range(0..o.len()) };
            v.truncate(at(rng));
            v.extend_from_slice(&o[cut..]);
        }
        _ => {
            // Overwrite a little-endian word: lengths and counts in binary headers.
            if n >= 4 {
                let i = rng.random_range(0..n - 3);
                let w: u32 = [0, 1, u32::MAX, 0x7fff_ffff, rng.random()][rng.random_range(0..5)];
                v[i..i + 4].copy_from_slice(&w.to_le_bytes());
            }
        }
    }
}

fn mutate_text(v: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let text = String::from_utf8_lossy(v);
    let mut lines: Vec<String> = text.split('\n').map(str::to_string).collect();
    let l = rng.random_range(0..lines.len());
    match rng.random_range(0..4) {
        0 => {
            // Swap one whitespace-separated token for an interesting one.
            let mut tokens: Vec<String> = lines[l].split(' ').map(str::to_string).collect();
            let t = rng.random_range(0..tokens.len());
            tokens[t] = INTERESTING_TOKENS[rng.random_range(0..INTERESTING_TOKENS.len())].to_string();
            lines[l] = tokens.join(" ");
        }
        1 => {
            lines.remove(l);
        }
        2 => {
            let copy = lines[l].clone();
            lines.insert(rng.random_range(0..=lines.len()), copy);
        }
        _ => {
            let m = rng.random_range(0..lines.len());
            lines.swap(l, m);
        }
    }
    lines.join("\n").into_bytes()
}

/// Runs `target` on `execs` inputs mutated from its corpus (input `i` from the RNG seeded with
/// `(seed, i)`), catching panics.
pub fn campaign(target: &Target, execs: u64, seed: u64) -> Outcome {
    let mut out = Outcome::default();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Accepted mutants join the pool: deeper inputs for the next mutations.
    let mut pool = target.corpus.clone();
    for input in &target.corpus {
        assert!(std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (target.run)(input))).is_ok());
    }
    while out.execs < execs {
        let base = &pool[rng.random_range(0..pool.len())];
        let input = mutate(base, &target.corpus, target.text, &mut rng);
        out.execs += 1;
        match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (target.run)(&input))) {
            Ok(true) => {
                out.accepted += 1;
                if pool.len() < 256 && input.len() < 1 << 20 {
                    pool.push(input);
                }
            }
            Ok(false) => {}
            Err(panic) => {
                out.panic_count += 1;
                if out.panics.len() < 3 {
                    let msg = panic
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    out.panics.push((input, msg));
                }
            }
        }
    }
    out
}
