//! The embedded default dataset: a deterministic LiDAR simulator that writes the KITTI layout.
//!
//! A ray-cast 64-beam spinning LiDAR (the HDL-64E as KITTI mounts it), tilted on its car,
//! scans procedurally built streets: ground with camber, vertical curves, embankments and
//! undulation, kerbs and sidewalks, building façades, poles, signs, trees and
//! bushes, and labelled objects (Car, Pedestrian, Cyclist, and the
//! distractors Van, Truck, Person_sitting, Misc) whose sizes, counts, distances and headings
//! follow the KITTI statistics of `kitti-format.md` §2. Occlusion comes from the ray casting;
//! truncation, the 2D box and alpha from projecting through a real KITTI calibration.

mod actor;
mod actors;
mod annotation;
mod intensity;
mod labels;
mod negatives;
mod placement;
mod raycast;
mod scenery;
mod sensor;
mod shapes;
mod solids;
mod stats;
mod street;
mod synth;
mod tilt;
mod world;

pub use actor::Actor;
pub use actors::{Part, build_parts, sample_size, size_stats, tight_box};
pub use annotation::AnnotationMargin;
pub use intensity::{Finish, IntensityModel, Surface};
pub use labels::{DONT_CARE_DISTANCE, INVISIBLE_BLOCKED, camera_label, label_frame, occlusion_level};
pub use raycast::{Primitive, Scan, Terrain, scan};
pub use sensor::{LidarConfig, hdl64_elevations};
pub use shapes::{Ray, Shape};
pub use solids::Scenery;
pub use stats::{DatasetStats, StatRow, dataset_stats};
pub use street::{Ground, GroundView, Street};
pub use synth::{
    SIMULATOR_VERSION, SynthConfig, SynthFrame, generated_version, pose_line, sensor_pose, simulate_frame,
    simulate_scene_frame, synth_frames, synth_sequences, write_frame,
};
pub use tilt::{Tilt, TiltRotation};
pub use world::{Moment, World};
