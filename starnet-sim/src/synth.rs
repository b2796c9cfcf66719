//! Generating a dataset on disk: independent scenes (`starnet synth --frames N`) or sequences
//! of consecutive frames (`--sequences M --length L`), in the KITTI object layout.
//!
//! ```text
//! ROOT/training/{velodyne,label_2,calib,label_360}/%06d.*   frames (label_360: sidecar.rs)
//! ROOT/ImageSets/{train,val,trainval}.txt                   split by scene
//! ROOT/sequences/%04d/training/...                           one KITTI root per sequence
//! ROOT/sequences/%04d/poses.txt                              LiDAR pose of frame i in frame 0
//! ROOT/synth.json                                            what generated the set
//! ```
//!
//! The set is written into a partial folder beside `ROOT` and renamed to `ROOT` when complete
//! ([`Staging`]): a run killed at any moment leaves no `ROOT`, and the next run with the same
//! arguments keeps the frames it finished and writes the rest.
//!
//! Determinism: every scene draws from its own RNG seeded from (seed, scene index), and every
//! frame's sensor noise from (scene seed, frame index), so the bytes do not depend on how the
//! work is spread over threads.

use super::labels::{label_frame, occlusion_level};
use super::{LidarConfig, Tilt, World, scan};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use starnet_data::geometry::Pose;
use starnet_data::io::atomic_write;
use starnet_data::kitti::{
    Calib, Frame, ImageSize, KittiObject, ObjectClass, format_c_exp, format_labels, write_points, write_split,
};
use starnet_data::kitti::{SimObject, write_sidecar};
use starnet_data::par::parallel_for;
use starnet_data::seed::sub_seed;
use starnet_data::staging::{Claim, Outcome, Staging};
use starnet_data::{Point, Result};
use std::path::Path;
use std::sync::Mutex;

/// Simulation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthConfig {
    /// The sensor.
    pub lidar: LidarConfig,
    /// Share of scenes in the validation split (KITTI: 3769 of 7481).
    pub val_fraction: f32,
    /// Time between frames of a sequence, seconds (10 Hz).
    pub frame_interval: f32,
    /// Camera image size for the labels.
    pub image: ImageSize,
}

impl Default for SynthConfig {
    fn default() -> Self {
        Self {
            lidar: LidarConfig::default(),
            val_fraction: 0.5,
            frame_interval: 0.1,
            image: ImageSize::KITTI,
        }
    }
}

/// One simulated frame.
#[derive(Debug, Clone)]
pub struct SynthFrame {
    /// The scan, LiDAR frame, KITTI point order.
    pub points: Vec<Point>,
    /// `label_2` lines.
    pub labels: Vec<KittiObject>,
    /// Every object (the sidecar).
    pub objects: Vec<SimObject>,
    /// Per point, the index in `objects` of the object it lies on.
    pub owners: Vec<Option<u32>>,
    /// Sensor pose in the scene's first frame's level frame: `[x, y, z, yaw]`.
    pub pose: [f32; 4],
    /// The sensor's tilt from the level frame of `pose`.
    pub tilt: Tilt,
}

impl SynthFrame {
    /// The frame as a dataset would load it (KITTI image size, `calib`, the `label_2` objects):
    /// for detecting on a simulated scene without writing it out.
    pub fn into_frame(self, id: impl Into<String>, calib: Calib) -> Frame {
        Frame {
            id: id.into(),
            points: self.points,
            objects: self.labels,
            calib,
            image_size: ImageSize::KITTI,
        }
    }
}

/// Frame `index` of `world`, with sensor noise drawn from `noise_seed`.
pub fn simulate_frame(world: &World, index: usize, noise_seed: u64, cfg: &SynthConfig, calib: &Calib) -> SynthFrame {
    let (moment, ground) = world.moment(index as f32 * cfg.frame_interval);
    let mut rng = ChaCha8Rng::seed_from_u64(noise_seed);
    let s = scan(
        &moment.prims,
        &ground,
        world.actors.len(),
        &cfg.lidar,
        moment.tilt,
        &mut rng,
    );
    let mut counts = vec![0u32; world.actors.len()];
    for o in s.owners.iter().flatten() {
        counts[*o as usize] += 1;
    }
    let mut objects: Vec<SimObject> = world
        .actors
        .iter()
        .enumerate()
        .map(|(i, a)| SimObject {
            class: a.class,
            track_id: a.track_id,
            b: moment.boxes[i],
            num_points: counts[i],
            rays_toward: s.rays_toward[i],
            rays_hit: s.rays_hit[i],
            occlusion: occlusion_level(s.rays_toward[i], s.rays_hit[i]),
            in_camera: false,
        })
        .collect();
    let (labels, in_camera) = label_frame(&objects, calib, cfg.image);
    for (o, seen) in objects.iter_mut().zip(in_camera) {
        o.in_camera = seen;
    }
    SynthFrame {
        points: s.points,
        labels,
        objects,
        owners: s.owners,
        pose: moment.pose,
        tilt: moment.tilt,
    }
}

/// A single-frame scene for dataset entry `index`: redrawn (deterministically) until image 2
/// shows at least one labelled object, as every real KITTI training frame does.
pub fn simulate_scene_frame(seed: u64, index: usize, cfg: &SynthConfig, calib: &Calib) -> SynthFrame {
    for attempt in 0u64.. {
        let scene_seed = sub_seed(seed, attempt, index as u64);
        let world = World::generate(&cfg.lidar, 0.0, &mut ChaCha8Rng::seed_from_u64(scene_seed));
        let frame = simulate_frame(&world, 0, sub_seed(scene_seed, 1, 0), cfg, calib);
        if frame.labels.iter().any(|l| l.class != ObjectClass::DontCare) {
            return frame;
        }
    }
    unreachable!("the attempt counter is unbounded")
}

/// Writes a frame's velodyne, label_2, calib and label_360 files under `training`.
pub fn write_frame(training: &Path, id: &str, frame: &SynthFrame, calib: &Calib) -> Result<()> {
    write_points(&training.join("velodyne").join(format!("{id}.bin")), &frame.points)?;
    atomic_write(
        &training.join("label_2").join(format!("{id}.txt")),
        format_labels(&frame.labels).as_bytes(),
    )?;
    calib.write(&training.join("calib").join(format!("{id}.txt")))?;
    write_sidecar(&training.join("label_360").join(format!("{id}.txt")), &frame.objects)
}

/// The simulator's version, written to `synth.json`: a set generated by another version holds
/// other scans for the same seed (2: the intensity model, glass, foliage and clutter of issue
/// #33; 3: vehicles labelled with KITTI's annotation margins, [`super::AnnotationMargin`], and
/// car bodies with rounded ends; 4: roads with vertical curves, embankments, a tilted sensor,
/// hard negatives and façade relief, issue #47; 5: four kinds of street drawn per scene,
/// [`super::StreetKind`], with angled parking bays; sets without the field are version 1).
pub const SIMULATOR_VERSION: u32 = 5;

/// What a generation writes to `synth.json`, and the job its partial folder is kept for.
fn manifest(mut what: serde_json::Value) -> serde_json::Value {
    what["simulator_version"] = SIMULATOR_VERSION.into();
    what
}

fn write_manifest(root: &Path, what: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(what).expect("JSON values serialise") + "\n";
    atomic_write(&root.join("synth.json"), text.as_bytes())
}

/// Whether frame `id` under `training` was written whole by an interrupted run: its sidecar,
/// the last of its four files, exists (each is written atomically).
fn frame_done(training: &Path, id: &str) -> bool {
    training.join("label_360").join(format!("{id}.txt")).is_file()
}

/// The simulator version that generated the set at `root` (from its `synth.json`; 1 when the
/// file has no version), or `None` when `root` has no `synth.json` (not a generated set).
pub fn generated_version(root: &Path) -> Result<Option<u32>> {
    let path = root.join("synth.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(starnet_data::DataError::io(&path, e)),
    };
    let value: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| starnet_data::DataError::parse(&path, e.line(), "synth.json", e.to_string()))?;
    Ok(Some(
        value
            .get("simulator_version")
            .and_then(|v| v.as_u64())
            .map_or(1, |v| v as u32),
    ))
}

/// Writes `frames` independent scenes with train/val splits as `root` ([`Staging`]: nothing
/// appears at `root` until the set is complete, and an interrupted run is continued), or
/// returns [`Outcome::AlreadyPresent`] when `root` already holds something. `progress` is
/// called once per finished frame (from worker threads).
pub fn synth_frames(
    root: &Path,
    frames: usize,
    seed: u64,
    cfg: &SynthConfig,
    progress: &(dyn Fn() + Sync),
) -> Result<Outcome> {
    let what =
        manifest(serde_json::json!({ "generator": "starnet synth", "frames": frames, "seed": seed, "config": cfg }));
    let staging = match Staging::claim(root, &what)? {
        Claim::Exists => return Ok(Outcome::AlreadyPresent),
        Claim::Write(staging) => staging,
    };
    let dir = staging.path();
    let calib = Calib::kitti_000000();
    let training = dir.join("training");
    parallel_for(frames, |i| {
        let id = format!("{i:06}");
        if !frame_done(&training, &id) {
            let frame = simulate_scene_frame(seed, i, cfg, &calib);
            write_frame(&training, &id, &frame, &calib)?;
        }
        progress();
        Ok(())
    })?;
    let ids: Vec<String> = (0..frames).map(|i| format!("{i:06}")).collect();
    let is_val = |i: usize| ChaCha8Rng::seed_from_u64(sub_seed(seed, 7, i as u64)).random::<f32>() < cfg.val_fraction;
    let (mut train, mut val) = (Vec::new(), Vec::new());
    for (i, id) in ids.iter().enumerate() {
        if is_val(i) { &mut val } else { &mut train }.push(id.clone());
    }
    write_split(&dir.join("ImageSets/train.txt"), &train)?;
    write_split(&dir.join("ImageSets/val.txt"), &val)?;
    write_split(&dir.join("ImageSets/trainval.txt"), &ids)?;
    write_manifest(dir, &what)?;
    staging.finish()?;
    Ok(Outcome::Written)
}

/// Writes `sequences` sequences of `length` frames as `root/sequences/%04d/`, each a KITTI
/// root with a `poses.txt`; staged and continued as [`synth_frames`] is.
pub fn synth_sequences(
    root: &Path,
    sequences: usize,
    length: usize,
    seed: u64,
    cfg: &SynthConfig,
    progress: &(dyn Fn() + Sync),
) -> Result<Outcome> {
    let what = manifest(
        serde_json::json!({ "generator": "starnet synth", "sequences": sequences, "length": length, "seed": seed, "config": cfg }),
    );
    let staging = match Staging::claim(root, &what)? {
        Claim::Exists => return Ok(Outcome::AlreadyPresent),
        Claim::Write(staging) => staging,
    };
    let dir = staging.path();
    let calib = Calib::kitti_000000();
    let duration = length as f32 * cfg.frame_interval;
    let worlds: Vec<(u64, World)> = (0..sequences)
        .map(|s| {
            let scene_seed = sub_seed(seed, 2, s as u64);
            (
                scene_seed,
                World::generate(&cfg.lidar, duration, &mut ChaCha8Rng::seed_from_u64(scene_seed)),
            )
        })
        .collect();
    let poses: Vec<Mutex<Vec<Pose>>> = (0..sequences)
        .map(|_| Mutex::new(vec![Pose::IDENTITY; length]))
        .collect();
    parallel_for(sequences * length, |k| {
        let (s, i) = (k / length, k % length);
        let (scene_seed, world) = &worlds[s];
        let training = dir.join(format!("sequences/{s:04}/training"));
        let id = format!("{i:06}");
        let pose = if frame_done(&training, &id) {
            // The frame is on disk: its pose is the world's at that moment, as the scan's was.
            let (moment, _) = world.moment(i as f32 * cfg.frame_interval);
            sensor_pose(moment.pose, moment.tilt)
        } else {
            let frame = simulate_frame(world, i, sub_seed(*scene_seed, 1, i as u64), cfg, &calib);
            write_frame(&training, &id, &frame, &calib)?;
            sensor_pose(frame.pose, frame.tilt)
        };
        poses[s].lock().expect("no panics while holding it")[i] = pose;
        progress();
        Ok(())
    })?;
    for (s, p) in poses.into_iter().enumerate() {
        let p = p.into_inner().expect("no panics while holding it");
        let first = p[0].inverse();
        let text: String = p.iter().map(|q| pose_line(&first.compose(q)) + "\n").collect();
        atomic_write(&dir.join(format!("sequences/{s:04}/poses.txt")), text.as_bytes())?;
    }
    write_manifest(dir, &what)?;
    staging.finish()?;
    Ok(Outcome::Written)
}

/// The sensor's pose in the scene's level world frame: `[x, y, z, yaw]`, then its tilt.
pub fn sensor_pose([x, y, z, yaw]: [f32; 4], tilt: Tilt) -> Pose {
    let tilted = Pose {
        r: tilt.matrix_f64(),
        t: [0.0; 3],
    };
    Pose::from_xyz_yaw([x, y, z].map(f64::from), f64::from(yaw)).compose(&tilted)
}

/// A pose as a KITTI odometry line: the row-major 3 × 4 matrix `[R | t]`.
pub fn pose_line(pose: &Pose) -> String {
    let [r0, r1, r2] = pose.r;
    let [x, y, z] = pose.t;
    let m = [r0[0], r0[1], r0[2], x, r1[0], r1[1], r1[2], y, r2[0], r2[1], r2[2], z];
    // A frame composed with its own inverse leaves rounding residue off the diagonal: it prints
    // as 0. `+ 0.0` turns −0 into 0, as C writers print it.
    m.iter()
        .map(|v| format_c_exp(if v.abs() < 1e-12 { 0.0 } else { *v } + 0.0, 6))
        .collect::<Vec<_>>()
        .join(" ")
}
