//! Training-time augmentation, in the authors' order (lingvo `params/kitti.py`, ARCHITECTURE.md §5):
//! database paste, per-box rotation, (ours, off by default: per-box scaling, [`BoxScale`]), flip y, global rotation, global scaling, global z shift,
//! then the reflectance step (ours, off by default: [`ReflectanceAugment`]), and — after center
//! selection, so it only thins the gathered neighbourhoods — a one-ring dropout. Every step
//! first draws its parameters from the RNG it is given, then applies them to points and boxes
//! together; [`augment`] returns what it drew.

mod box_scaling;
mod database_home;
mod frame;
mod gtdb;
mod near;
mod paste;
mod reflectance;
mod transforms;

pub use box_scaling::{BoxScale, scale_box, scale_boxes, scaled_box, scaled_point};
pub use database_home::{Writability, cache_dir, database_location, writability};
pub use frame::{AugmentConfig, AugmentDraw, ScalingStep, UniformStep, augment, ring_dropout};
pub use gtdb::{GTDB_CAPTURE_MARGIN, GTDB_VERSION, GtDatabase, GtEntry, database_path};
pub use paste::{DbPasteConfig, paste_from_database};
pub use reflectance::{ReflectanceAugment, ReflectanceDraw, augment_reflectance};
pub use transforms::{Scene, flip_y, rotate_box, rotate_boxes, rotate_z, scale, shift_z};
