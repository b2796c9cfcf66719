//! Pictures on `plotters`: line charts and the bird's-eye view of a frame, drawn into an RGB
//! [`Canvas`] with the shipped DejaVu Sans and written as PNG.

mod bev;
mod canvas;
mod font;
mod plot;

pub use bev::{BevBox, BevOptions, CENTER, RenderOptions, SEEDED, render_bev, render_frame};
pub use canvas::{Canvas, Rgb};
pub use plot::{LinePlot, Series};
