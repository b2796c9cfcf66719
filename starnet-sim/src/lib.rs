//! The embedded default dataset: a deterministic LiDAR simulator that writes the KITTI layout.
//!
//! A ray-cast 64-beam spinning LiDAR (the HDL-64E as KITTI mounts it), tilted on its car,
//! scans procedurally built streets of four kinds (residential, arterial, urban canyon, open
//! road; [`StreetKind`]): ground with camber, vertical curves, embankments and
//! undulation, kerbs and sidewalks, building façades, poles, signs, trees and
//! bushes, and labelled objects (Car, Pedestrian, Cyclist, and the
//! distractors Van, Truck, Person_sitting, Misc) whose sizes, counts, distances and headings
//! follow the KITTI statistics of `kitti-format.md` §2. Occlusion comes from the ray casting;
//! truncation, the 2D box and alpha from projecting through a real KITTI calibration.
//!
//! [`synth_frames`] and [`synth_sequences`] write a KITTI-layout root (`velodyne/`, `label_2/`,
//! `calib/`, `ImageSets/`, and the all-around `label_360/` sidecar), so everything downstream
//! reads simulated and real frames through the same [`starnet_data::kitti`] loader. [`realism`]
//! measures how far one such root is from another (`starnet compare-data`).
//!
//! Frames, box layout and shape letters are those of [`starnet_data`]'s crate docs: metres, the
//! LiDAR frame (x forward, y left, z up), boxes `[x, y, z, dx, dy, dz, heading]` centred.
//!
//! Above `starnet-data` and below the model: nothing in `starnet-data` knows the simulator.

#![warn(missing_docs)]

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
mod street_kind;
mod synth;
mod tilt;
mod world;

pub mod realism;

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
pub use street::{Ground, GroundView, Parking, Street};
pub use street_kind::{Layout, MAX_LANES_PER_SIDE, StreetKind};
pub use synth::{
    SIMULATOR_VERSION, SynthConfig, SynthFrame, generated_version, pose_line, sensor_pose, simulate_frame,
    simulate_scene_frame, synth_frames, synth_sequences, write_frame,
};
pub use tilt::{Tilt, TiltRotation};
pub use world::{Moment, World};
