//! The 3D view (cargo feature `rerun`): frames logged as a Rerun recording (`.rrd`) that the
//! Rerun viewer opens (`pip install rerun-sdk && rerun scene.rrd`, or `cargo install rerun-cli`),
//! also from a headless server where the file was written. The LiDAR frame is the world frame
//! (x forward, y left, z up, metres); each frame is one step of the `frame` timeline.
//!
//! Entities: `world/points` (coloured by height, as the bird's-eye view), `world/ground_truth`
//! and `world/predictions` (boxes labelled with their class, and score; a heading mark from the
//! centre to the front face under `…/heading`), `world/centers` (sampled centers; those seeded
//! from the previous frame under `world/centers/seeded`) and `title`, the frame's description.

use super::bev::{GT, PRED, height_colour};
use super::frame_scene::{FrameScene, SceneBox};
use super::{CENTER, Rgb, SEEDED};
use crate::{Result, TrainError};
use rerun::external::arrow::array::Array as _;
use rerun::external::re_log_encoding::{DecoderApp, RRD_FOURCC, StreamFooter};
use rerun::log::{Chunk, LogMsg};
use std::path::Path;

/// The Rerun application id recordings are written under.
pub const APPLICATION_ID: &str = "starnet";

/// One entity of a recording and what was logged to it, over every frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RrdEntity {
    /// The entity path, e.g. `/world/points`.
    pub path: String,
    /// Rows logged (one per frame it appears in, at most).
    pub rows: usize,
    /// Instances over those rows: points, boxes or heading marks.
    pub instances: usize,
}

fn recording_error(path: &Path, e: impl std::fmt::Display) -> TrainError {
    TrainError::Recording {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Writes `scenes` as one recording at `path`, frame `i` at step `i` of the `frame` timeline.
/// The file appears whole or not at all (written beside it, then renamed).
pub fn write_rrd(scenes: &[FrameScene], path: &Path) -> Result<()> {
    let tmp = starnet_data::io::temp_path(path);
    let written = write_to(scenes, &tmp).and_then(|()| std::fs::rename(&tmp, path).map_err(|e| e.to_string()));
    written.map_err(|message| {
        let _ = std::fs::remove_file(&tmp);
        recording_error(path, message)
    })
}

fn write_to(scenes: &[FrameScene], tmp: &Path) -> std::result::Result<(), String> {
    let rec = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
        .send_properties(false)
        .save(tmp)
        .map_err(|e| e.to_string())?;
    rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())
        .map_err(|e| e.to_string())?;
    for (i, scene) in scenes.iter().enumerate() {
        rec.set_time_sequence("frame", i as i64);
        log_scene(&rec, scene).map_err(|e| e.to_string())?;
    }
    rec.flush_blocking().map_err(|e| e.to_string())?;
    // The file sink writes its footer when the last handle drops.
    drop(rec);
    Ok(())
}

fn log_scene(rec: &rerun::RecordingStream, scene: &FrameScene) -> rerun::RecordingStreamResult<()> {
    rec.log("title", &rerun::TextLog::new(scene.title.as_str()))?;
    let points = rerun::Points3D::new(scene.points.iter().map(|p| [p[0], p[1], p[2]]))
        .with_colors(scene.points.iter().map(|p| color(height_colour(p[2]))))
        .with_radii([0.02f32]);
    rec.log("world/points", &points)?;
    log_boxes(rec, "world/ground_truth", &scene.gt, GT)?;
    log_boxes(rec, "world/predictions", &scene.predictions, PRED)?;
    let c = &scene.centers;
    let (seeded, sampled) = c.xyz.split_at(c.num_seeded);
    rec.log("world/centers", &center_points(sampled, CENTER))?;
    rec.log("world/centers/seeded", &center_points(seeded, SEEDED))
}

fn color([r, g, b]: Rgb) -> rerun::Color {
    rerun::Color::from_rgb(r, g, b)
}

fn center_points(xyz: &[[f32; 3]], rgb: Rgb) -> rerun::Points3D {
    rerun::Points3D::new(xyz.iter().copied())
        .with_colors([color(rgb)])
        .with_radii([0.12f32])
}

/// Boxes under `entity` and their heading marks under `entity/heading`.
fn log_boxes(
    rec: &rerun::RecordingStream,
    entity: &str,
    boxes: &[SceneBox],
    rgb: Rgb,
) -> rerun::RecordingStreamResult<()> {
    let labels = boxes.iter().map(|b| match b.score {
        Some(s) => format!("{} {s:.2}", b.class.as_str()),
        None => b.class.as_str().to_string(),
    });
    let archetype = rerun::Boxes3D::from_centers_and_half_sizes(
        boxes.iter().map(|s| [s.b.x, s.b.y, s.b.z]),
        boxes.iter().map(|s| [s.b.dx / 2.0, s.b.dy / 2.0, s.b.dz / 2.0]),
    )
    .with_quaternions(boxes.iter().map(|s| heading_quaternion(s.b.heading)))
    .with_colors([color(rgb)])
    .with_labels(labels);
    rec.log(entity, &archetype)?;
    let marks = boxes.iter().map(|s| {
        let (sin, cos) = s.b.heading.sin_cos();
        let front = [s.b.x + cos * s.b.dx / 2.0, s.b.y + sin * s.b.dx / 2.0, s.b.z];
        [[s.b.x, s.b.y, s.b.z], front]
    });
    rec.log(
        format!("{entity}/heading"),
        &rerun::LineStrips3D::new(marks).with_colors([color(rgb)]),
    )
}

/// The rotation by `heading` about +z, as Rerun's quaternion `[x, y, z, w]`.
fn heading_quaternion(heading: f32) -> rerun::Quaternion {
    let (s, c) = (heading / 2.0).sin_cos();
    rerun::Quaternion::from_xyzw([0.0, 0.0, s, c])
}

/// What a recording holds: each entity with data (properties aside), its rows and instances,
/// sorted by path. Reads any complete `.rrd` file, ours or another program's; one cut short is
/// an error.
pub fn read_rrd(path: &Path) -> Result<Vec<RrdEntity>> {
    let err = |e: &dyn std::fmt::Display| recording_error(path, e);
    let bytes = std::fs::read(path).map_err(|e| err(&e))?;
    if !ends_complete(&bytes) {
        return Err(err(
            &"no stream footer at its end: the file was cut short (or is still being written)",
        ));
    }
    let mut entities: Vec<RrdEntity> = Vec::new();
    for msg in DecoderApp::decode_eager(bytes.as_slice()).map_err(|e| err(&e))? {
        let LogMsg::ArrowMsg(_, arrow) = msg.map_err(|e| err(&e))? else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).map_err(|e| err(&e))?;
        let path = chunk.entity_path().to_string();
        let i = match entities.iter().position(|e| e.path == path) {
            Some(i) => i,
            None => {
                entities.push(RrdEntity {
                    path,
                    rows: 0,
                    instances: 0,
                });
                entities.len() - 1
            }
        };
        entities[i].rows += chunk.num_rows();
        entities[i].instances += instances(&chunk);
    }
    entities.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(entities)
}

/// Whether `bytes` end with the stream footer (`RRF2`, `FOOT`, a count) that a finished recording
/// ends with. Rerun's decoder reads a stream up to wherever it stops without complaint, since it
/// also reads recordings still being written.
fn ends_complete(bytes: &[u8]) -> bool {
    let n = bytes.len();
    n >= 12 && bytes[n - 12..n - 8] == RRD_FOURCC && bytes[n - 8..n - 4] == StreamFooter::RRD_IDENTIFIER
}

/// The instances of a chunk's positional component: point positions, box half-sizes or strips.
fn instances(chunk: &Chunk) -> usize {
    let positional = [
        rerun::Points3D::descriptor_positions().component,
        rerun::Boxes3D::descriptor_half_sizes().component,
        rerun::LineStrips3D::descriptor_strips().component,
    ];
    positional
        .into_iter()
        .find_map(|c| chunk.components().get_array(c))
        .map_or(0, |list| (0..list.len()).map(|i| list.value_length(i) as usize).sum())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{RenderOptions, frame_scene};
    use starnet_data::kitti::KittiDataset;
    use starnet_data::sampling::Sampler;
    use starnet_sim::{SynthConfig, synth_frames};

    fn entity<'a>(entities: &'a [RrdEntity], path: &str) -> &'a RrdEntity {
        entities
            .iter()
            .find(|e| e.path == path)
            .unwrap_or_else(|| panic!("no {path} in {entities:?}"))
    }

    /// Two simulated frames with their labels as predictions (a score appended) and 64 centers.
    fn scenes(root: &Path) -> Vec<FrameScene> {
        synth_frames(root, 2, 7, &SynthConfig::default(), &|| ()).unwrap();
        let results = root.join("results");
        std::fs::create_dir_all(&results).unwrap();
        for id in ["000000", "000001"] {
            let labels = std::fs::read_to_string(root.join(format!("training/label_2/{id}.txt"))).unwrap();
            let scored: String = labels.lines().map(|l| format!("{l} 0.75\n")).collect();
            std::fs::write(results.join(format!("{id}.txt")), scored).unwrap();
        }
        let ds = KittiDataset::open(root, None).unwrap();
        let extra = RenderOptions {
            results: Some(results),
            centers: Some((Sampler::Fps, 64)),
            ..Default::default()
        };
        ["000000", "000001"]
            .map(|id| frame_scene(&ds, id, &extra, 80.0).unwrap())
            .into()
    }

    /// The scenes of [`scenes`], written as `root/scene.rrd`.
    fn recorded(root: &Path) -> (Vec<FrameScene>, std::path::PathBuf) {
        let scenes = scenes(root);
        let path = root.join("scene.rrd");
        write_rrd(&scenes, &path).unwrap();
        (scenes, path)
    }

    #[test]
    fn a_recording_reads_back_with_every_point_box_and_center_of_each_frame() {
        let dir = tempfile::tempdir().unwrap();
        let (scenes, path) = recorded(dir.path());
        let got = read_rrd(&path).unwrap();
        let sum = |f: &dyn Fn(&FrameScene) -> usize| scenes.iter().map(f).sum::<usize>();
        let (points, gt, preds) = (
            sum(&|s| s.points.len()),
            sum(&|s| s.gt.len()),
            sum(&|s| s.predictions.len()),
        );
        assert!(points > 10_000 && gt > 0, "{points} points, {gt} boxes");
        // Every labelled box came back as a prediction (DontCare aside in both).
        assert_eq!(preds, gt);
        let check = |path: &str, rows: usize, instances: usize| {
            let e = entity(&got, path);
            assert_eq!((e.rows, e.instances), (rows, instances), "{path}");
        };
        check("/world/points", 2, points);
        check("/world/ground_truth", 2, gt);
        check("/world/ground_truth/heading", 2, gt);
        check("/world/predictions", 2, preds);
        check("/world/predictions/heading", 2, preds);
        check("/world/centers", 2, 128);
        check("/world/centers/seeded", 2, 0);
        assert_eq!(entity(&got, "/title").rows, 2);
        // The coordinate system, logged once and static.
        assert_eq!(entity(&got, "/world").rows, 1);
        // No temporary file was left beside it.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert!(!names.iter().any(|n| n.to_string_lossy().starts_with('.')), "{names:?}");
    }

    #[test]
    fn a_truncated_recording_and_an_unwritable_one_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let (scenes, path) = recorded(dir.path());
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let err = read_rrd(&path).unwrap_err().to_string();
        assert!(err.contains("scene.rrd"), "{err}");
        let nowhere = dir.path().join("missing/scene.rrd");
        let err = write_rrd(&scenes, &nowhere).unwrap_err().to_string();
        assert!(err.contains("missing/scene.rrd"), "{err}");
        assert!(!nowhere.exists());
    }

    #[test]
    fn the_heading_quaternion_turns_x_onto_the_heading() {
        // Rotating +x by q = (0, 0, sin h/2, cos h/2) gives (cos h, sin h, 0).
        for h in [0.0f32, 0.5, -2.0, 3.0] {
            let [x, y, z, w] = heading_quaternion(h).0;
            let rotated = [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y + w * z),
                2.0 * (x * z - w * y),
            ];
            let expected = [h.cos(), h.sin(), 0.0];
            for (a, b) in rotated.iter().zip(expected) {
                assert!((a - b).abs() < 1e-6, "{h}: {rotated:?} vs {expected:?}");
            }
        }
    }
}
