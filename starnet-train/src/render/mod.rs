//! Pictures: a small raster canvas with a bitmap font, and the bird's-eye view of a frame.

mod bev;
mod canvas;
mod font;

pub use bev::{BevBox, BevOptions, render_bev, render_frame};
pub use canvas::{Canvas, Rgb};
