//! Point clouds between files, numpy and the library.

use crate::errors::to_py;
use numpy::{PyArray2, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use starnet_data::cloud::{Intensity, PointCloud};
use std::path::{Path, PathBuf};

/// Reads a point cloud (KITTI `.bin`; PCD ascii, binary or binary_compressed; PLY ascii or
/// binary; NumPy `.npy`) as a float32 array: `[N, 4]` (x, y, z, intensity) when the file has an
/// intensity channel, `[N, 3]` when it has none. Rows with a NaN coordinate (no return) are
/// dropped, as every reader does.
#[pyfunction]
pub fn read_cloud<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let cloud = py.detach(|| starnet_data::cloud::read_cloud(&path)).map_err(to_py)?;
    let width = match cloud.intensity {
        Intensity::Measured => 4,
        Intensity::Absent => 3,
    };
    let rows: Vec<Vec<f32>> = cloud.points.iter().map(|p| p[..width].to_vec()).collect();
    if rows.is_empty() {
        return Ok(PyArray2::zeros(py, [0, width], false));
    }
    PyArray2::from_vec2(py, &rows).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// `value` (any array-like) as a C-ordered float32 numpy array of any shape.
pub fn f32_array<'py>(value: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArrayDyn<'py, f32>> {
    let numpy = value.py().import("numpy")?;
    let array = numpy.call_method1("ascontiguousarray", (value, "float32"))?;
    Ok(array.cast_into::<PyArrayDyn<f32>>()?.readonly())
}

/// `points` (`[N, 3]` or `[N, 4]`, any float dtype or layout) as a cloud, checked as a file's
/// points are; `source` names it in errors.
pub fn cloud_of(points: &Bound<'_, PyAny>, source: &Path) -> PyResult<PointCloud> {
    let array = f32_array(points)?;
    let shape = array.shape().to_vec();
    if shape.len() != 2 || (shape[1] != 3 && shape[1] != 4) {
        return Err(PyValueError::new_err(format!(
            "points: shape {shape:?}; expected [N, 3] (x, y, z) or [N, 4] (x, y, z, intensity)"
        )));
    }
    let values = array.as_slice().expect("ascontiguousarray gives a contiguous array");
    PointCloud::from_rows(values, shape[1], source).map_err(to_py)
}
