//! Pictures on `plotters`: line charts and the bird's-eye view of a frame, drawn into an RGB
//! [`Canvas`] with the shipped DejaVu Sans and written as PNG; with the cargo feature `rerun`,
//! frames in 3D as a Rerun recording (`write_rrd`). Both views show a [`FrameScene`].

mod bev;
mod canvas;
mod font;
mod frame_scene;
mod plot;
#[cfg(feature = "rerun")]
mod rrd;

pub use bev::{BevOptions, CENTER, SEEDED, render_bev, render_frame};
pub use canvas::{Canvas, Rgb};
pub use frame_scene::{FrameScene, RenderOptions, SceneBox, frame_scene};
pub use plot::{LinePlot, Series};
#[cfg(feature = "rerun")]
pub use rrd::{APPLICATION_ID, RrdEntity, read_rrd, write_rrd};
