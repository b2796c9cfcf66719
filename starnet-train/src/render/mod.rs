//! Pictures: a small raster canvas with a bitmap font, and the bird's-eye view of a frame.

mod bev;
mod canvas;
mod font;
mod plot;

pub use bev::{BevBox, BevOptions, CENTER, RenderOptions, SEEDED, render_bev, render_frame};
pub use canvas::{Canvas, Rgb};
pub use plot::{LinePlot, Series};
