//! `starnet.Detector`: a trained model on numpy points, the same boxes as `starnet detect`.

use crate::cloud::cloud_of;
use crate::errors::to_py;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use starnet_data::kitti::Calib;
use starnet_train::budget::Budget;
use starnet_train::detect::{DetectedSweep, detect_sweep};
use starnet_train::detector::frame_seed;
use starnet_train::trained::TrainedModel;
use std::path::PathBuf;

/// A trained StarNet model at one center/point budget.
///
/// `model` is an export folder (holding `model.safetensors`, e.g. `models/quickstart`) or a
/// checkpoint (a folder or `model.bpk`, with its run's `config.toml` or `config`). `centers` and
/// `points` pick the budget (default: the config's evaluation budget); `seed` seeds the center
/// sampling (default: the config's seed), as `starnet detect` does.
#[pyclass(module = "starnet._starnet", frozen)]
pub struct Detector {
    inner: starnet_train::detector::Detector,
    seed: u64,
}

#[pymethods]
impl Detector {
    #[new]
    #[pyo3(signature = (model, *, config = None, centers = None, points = None, seed = None))]
    fn new(
        py: Python<'_>,
        model: PathBuf,
        config: Option<PathBuf>,
        centers: Option<usize>,
        points: Option<usize>,
        seed: Option<u64>,
    ) -> PyResult<Self> {
        if centers == Some(0) || points == Some(0) {
            return Err(PyValueError::new_err("centers and points must be positive"));
        }
        let trained = py
            .detach(|| TrainedModel::load(&model, config.as_deref(), &[]))
            .map_err(to_py)?;
        let detector = trained.detector();
        let at = detector.budget();
        let budget = Budget {
            num_centers: centers.unwrap_or(at.num_centers),
            num_points: points.unwrap_or(at.num_points),
            target: at.target,
        };
        Ok(Self {
            inner: detector.at_budget(budget),
            seed: seed.unwrap_or(trained.config.seed),
        })
    }

    /// The classes the model detects, in its order.
    #[getter]
    fn classes(&self) -> Vec<String> {
        self.inner.classes.iter().map(|c| c.as_str().to_string()).collect()
    }

    /// Centers sampled per frame.
    #[getter]
    fn centers(&self) -> usize {
        self.inner.budget().num_centers
    }

    /// Points gathered per center.
    #[getter]
    fn points(&self) -> usize {
        self.inner.budget().num_points
    }

    /// Forward GFLOP per frame at this budget.
    #[getter]
    fn gflop_per_frame(&self) -> f64 {
        self.inner.gflop_per_frame()
    }

    /// Detects the objects of one sweep.
    ///
    /// `points`: `[N, 4]` (x, y, z, intensity) or `[N, 3]` (for a model that ignores intensity),
    /// LiDAR frame, any float dtype. `calib`: a KITTI calib file; with one the centers are sampled
    /// in camera 2's view and `kitti_lines` holds KITTI result lines, without one all around
    /// the sensor. `index`: the sweep's place in a sequence of calls, which seeds its sampling
    /// (`starnet detect` gives the i-th file of a folder index i). `id` names the sweep.
    #[pyo3(signature = (points, *, calib = None, index = 0, id = None))]
    fn detect(
        &self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        calib: Option<PathBuf>,
        index: usize,
        id: Option<String>,
    ) -> PyResult<Detections> {
        let id = id.unwrap_or_else(|| format!("{index:06}"));
        let source = PathBuf::from(format!("points of sweep {id}"));
        let cloud = cloud_of(points, &source)?;
        let seed = frame_seed(self.seed, index);
        let detected = py
            .detach(|| {
                let calib = calib.as_deref().map(Calib::read).transpose()?;
                detect_sweep(&self.inner, cloud, &source, &id, calib, seed)
            })
            .map_err(to_py)?;
        Detections::new(py, detected)
    }

    /// Detects each sweep of `sweeps` (a list of point arrays) as `detect` would with `index`
    /// its place in the list; `calibs`, if given, one calib file (or None) per sweep.
    #[pyo3(signature = (sweeps, *, calibs = None))]
    fn detect_many(
        &self,
        py: Python<'_>,
        sweeps: Vec<Bound<'_, PyAny>>,
        calibs: Option<Vec<Option<PathBuf>>>,
    ) -> PyResult<Vec<Detections>> {
        let calibs = calibs.unwrap_or_else(|| vec![None; sweeps.len()]);
        if calibs.len() != sweeps.len() {
            return Err(PyValueError::new_err(format!(
                "calibs: {} for {} sweeps; give one per sweep (None for none)",
                calibs.len(),
                sweeps.len()
            )));
        }
        let calls = sweeps.iter().zip(calibs).enumerate();
        calls
            .map(|(index, (points, calib))| self.detect(py, points, calib, index, None))
            .collect()
    }

    fn __repr__(&self) -> String {
        let b = self.inner.budget();
        format!(
            "Detector(classes={:?}, centers={}, points={}, seed={})",
            self.classes(),
            b.num_centers,
            b.num_points,
            self.seed
        )
    }
}

/// The detections of one sweep.
#[pyclass(module = "starnet._starnet", frozen, get_all)]
pub struct Detections {
    /// The sweep's id.
    id: String,
    /// `[M, 7]` float32: `x, y, z, dx, dy, dz, heading` per box, LiDAR frame, best first.
    boxes: Py<PyArray2<f32>>,
    /// `[M]` float32 scores in [0, 1].
    scores: Py<PyArray1<f32>>,
    /// The class name of each box.
    classes: Vec<String>,
    /// Points detected on (after dropping rows without a return and beyond-range points).
    num_points: usize,
    /// Points beyond `pipeline.wild_points.limit`, dropped.
    wild_points_dropped: usize,
    /// KITTI result lines (camera frame, boxes that project into image 2) when a calibration
    /// was given, else None.
    kitti_lines: Option<Vec<String>>,
}

impl Detections {
    fn new(py: Python<'_>, detected: DetectedSweep) -> PyResult<Self> {
        let sweep = detected.sweep;
        let rows: Vec<Vec<f32>> = sweep.detections.iter().map(|d| d.b.to_vec()).collect();
        let boxes = if rows.is_empty() {
            PyArray2::zeros(py, [0, 7], false)
        } else {
            PyArray2::from_vec2(py, &rows).map_err(|e| PyValueError::new_err(e.to_string()))?
        };
        let scores: Vec<f32> = sweep.detections.iter().map(|d| d.score).collect();
        Ok(Self {
            id: sweep.id,
            boxes: boxes.unbind(),
            scores: PyArray1::from_vec(py, scores).unbind(),
            classes: sweep.detections.iter().map(|d| d.class.as_str().to_string()).collect(),
            num_points: sweep.num_points,
            wild_points_dropped: sweep.wild_points_dropped,
            kitti_lines: detected
                .kitti
                .map(|lines| lines.iter().map(|o| o.to_result_line()).collect()),
        })
    }
}

#[pymethods]
impl Detections {
    fn __len__(&self) -> usize {
        self.classes.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Detections(id={:?}, boxes={}, num_points={})",
            self.id,
            self.classes.len(),
            self.num_points
        )
    }
}
