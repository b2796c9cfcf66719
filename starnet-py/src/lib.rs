//! The `starnet` Python package's native module, `starnet._starnet`: StarNet detection on
//! numpy points ([`detector`]), point clouds read from files ([`cloud`]) and the KITTI and
//! Waymo-style metrics ([`metrics`]). A thin layer: each function converts its arguments, calls
//! the library crates and converts the result; `python/starnet` holds the Python-side API and
//! its type stubs.
//!
//! Frames and boxes are the library's: points `[x, y, z(, intensity)]` in the LiDAR frame
//! (metres, x forward, y left, z up); a box `[x, y, z, dx, dy, dz, heading]` with `(x, y, z)` its
//! centre and `heading` the yaw about z.

pub mod cloud;
pub mod detector;
pub mod errors;
pub mod metrics;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _starnet(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("StarnetError", m.py().get_type::<errors::StarnetError>())?;
    m.add_class::<detector::Detector>()?;
    m.add_class::<detector::Detections>()?;
    m.add_function(wrap_pyfunction!(cloud::read_cloud, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::score_folder, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::score_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::kitti_folder, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::kitti_arrays, m)?)?;
    Ok(())
}
