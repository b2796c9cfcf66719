//! StarNet data: box geometry, KITTI I/O, center sampling, neighbourhoods, augmentation and the
//! loader. [`cloud`] reads and writes the point clouds of other LiDARs (PCD, PLY, `.npy`). No
//! deep-learning dependency: every function here is plain Rust on slices, so data-loader threads
//! can run it. The LiDAR simulator that writes the default dataset is the `starnet-sim` crate,
//! above this one.
//!
//! # Frames
//!
//! * **LiDAR frame** (everything in this workspace unless a name says otherwise): metres,
//!   x forward, y left, z up, sensor at the origin. On KITTI the ground lies at z ≈ −1.73.
//! * **Camera-rect frame** (KITTI `label_2` files): x right, y down, z forward, the rectified
//!   camera 0. Functions that cross frames carry both names, e.g.
//!   [`kitti::Calib::rect_to_lidar`].
//!
//! # Box layout
//!
//! A 3D box is `[x, y, z, dx, dy, dz, heading]` in the LiDAR frame ([`Box3d`]):
//! (x, y, z) is the box **centre**, `dx` the extent along the heading (length), `dy` the width,
//! `dz` the height; `heading` is counter-clockwise about +z from +x, wrapped to [−π, π).
//!
//! ```text
//!              heading →            corner order of Box3d::corners_bev()
//!        3 ──────────── 0           (counter-clockwise seen from above;
//!        │      y       │            corners_3d() repeats them at the bottom
//!        │      ↑       │            (0..4) and at the top (4..8))
//!        │      └─→ x   │
//!        2 ──────────── 1
//! ```
//!
//! KITTI conversion ([`kitti::Calib::label_to_box`]): centre = rect→LiDAR(x, y − h/2, z),
//! (dx, dy, dz) = (l, w, h), heading = −(ry + π/2).
//!
//! # Shape letters
//!
//! Docs and comments across the workspace use: `B` frames in a batch, `C` centers per frame,
//! `P` points per center, `F` per-point input features, `A` anchors per center, `K` classes,
//! `N` points in a cloud.

#![warn(missing_docs)]

pub mod augment;
pub mod class;
pub mod cloud;
pub mod convert;
pub mod custom;
pub mod error;
pub mod events;
pub mod geometry;
pub mod io;
pub mod kitti;
pub mod loader;
pub mod par;
pub mod sampling;
pub mod seed;
pub mod settings;
pub mod staging;
pub mod summary;

pub use error::{DataError, Result};
pub use geometry::{Box3d, Point, wrap_angle};
