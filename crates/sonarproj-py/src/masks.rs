//! `sonarproj.MaskEngine` (built once, kept between pings with its GPU buffers) and the masks
//! it returns.

use numpy::ndarray::{Array2, Array3, ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarproj::masks::{Noise, bounding_box};
use sonarproj::occupancy::Occupancy;
use sonarproj::{Counts, MaskEngine, Measurement, SonarKind};

use crate::pose::PyPose;
use crate::sonar::PySonar;
use crate::{backend, errors};

/// Draws correspondence masks for one sonar pair.
#[pyclass(name = "_MaskEngine", module = "sonarproj", frozen)]
pub(crate) struct PyMaskEngine {
    engine: MaskEngine,
    notice: Option<String>,
}

/// The masks of one ping.
#[pyclass(name = "MaskSet", module = "sonarproj", frozen, get_all)]
pub(crate) struct PyMaskSet {
    /// uint8 0/1, `(features, range_bins, beams)` or `(features, range_bins)`.
    masks: Py<PyArrayDyn<u8>>,
    /// uint8 0/1: every bin or pixel any feature may occupy.
    union: Py<PyArrayDyn<u8>>,
    /// uint32 counts like `masks`, or None.
    counts: Option<Py<PyArrayDyn<u32>>>,
    /// Per feature: a dict of range_min, range_max (m), azimuth_min, azimuth_max (deg), or
    /// None for an empty mask.
    boxes: Vec<Option<Py<PyDict>>>,
    /// Per feature, the ball radius (m) drawn around each cell.
    radius: Vec<f64>,
    /// Per feature, the noise radius (m): 0 without sigmas.
    noise_radius: Vec<f64>,
    /// Where the masks were drawn.
    device: String,
}

#[pymethods]
impl PyMaskSet {
    /// Returns what the set holds: its features, the masks' shape, the union's size and the
    /// device that drew it.
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        use numpy::PyUntypedArrayMethods;
        let masks = self.masks.bind(py);
        let shape: Vec<String> = masks.shape().iter().map(ToString::to_string).collect();
        let union = self.union.bind(py).call_method0("sum")?.extract::<u64>()?;
        Ok(format!(
            "<MaskSet: {} feature{}, masks ({}) uint8, {union} bins or pixels in the union, counts {}, drawn on {}>",
            self.radius.len(),
            if self.radius.len() == 1 { "" } else { "s" },
            shape.join(", "),
            if self.counts.is_some() {
                "drawn"
            } else {
                "not drawn"
            },
            self.device
        ))
    }
}

/// Returns the array of `occs` stacked along a first axis, each in sonar 2's layout.
fn stack<T: numpy::Element + Copy>(
    kind: SonarKind,
    rows: usize,
    beams: usize,
    layers: Vec<Vec<T>>,
) -> ArrayD<T> {
    let n = layers.len();
    let flat: Vec<T> = layers.into_iter().flatten().collect();
    match kind {
        SonarKind::Fls => Array3::from_shape_vec((n, rows, beams), flat)
            .expect("one value per pixel")
            .into_dyn(),
        SonarKind::Sss => Array2::from_shape_vec((n, rows), flat)
            .expect("one value per bin")
            .into_dyn(),
    }
}

/// Returns `occ` as an array in sonar 2's layout.
fn layer(kind: SonarKind, occ: &Occupancy) -> ArrayD<u8> {
    let bytes = occ.to_bytes(false, false);
    let shape = match kind {
        SonarKind::Fls => vec![occ.range_bins, occ.beams],
        SonarKind::Sss => vec![occ.range_bins],
    };
    ArrayD::from_shape_vec(IxDyn(&shape), bytes).expect("one byte per pixel")
}

impl PyMaskEngine {
    /// Returns the measurements of `ranges` and `azimuths` (deg; `None` for a sidescan), each
    /// checked against sonar 1 and named by its index.
    fn features(&self, ranges: &[f64], azimuths: Option<&[f64]>) -> PyResult<Vec<Measurement>> {
        ranges
            .iter()
            .enumerate()
            .map(|(k, &r)| {
                let az = azimuths.map_or(0.0, |a| a[k]);
                Measurement::of(self.engine.source(), r, az)
                    .map_err(|e| errors::engine(e.in_context(&format!("features row {k}"))))
            })
            .collect()
    }

    /// Returns the mask set of one ping.
    fn draw(
        &self,
        py: Python<'_>,
        pose: &PyPose,
        features: &[Measurement],
        noise: Option<&Noise>,
        counts: bool,
    ) -> PyResult<PyMaskSet> {
        let want = if counts { Counts::Draw } else { Counts::Skip };
        let set = py
            .detach(|| self.engine.masks(&pose.inner, features, noise, want))
            .map_err(errors::engine)?;
        let layout = self.engine.layout();
        let kind = self.engine.target().kind;
        let (rows, beams) = layout.data_shape();
        let boxes = set
            .masks
            .iter()
            .map(|m| {
                bounding_box(layout, &m.occupancy)
                    .map(|b| -> PyResult<Py<PyDict>> {
                        let d = PyDict::new(py);
                        d.set_item("range_min", b.range_min)?;
                        d.set_item("range_max", b.range_max)?;
                        d.set_item("azimuth_min", b.azimuth_min)?;
                        d.set_item("azimuth_max", b.azimuth_max)?;
                        Ok(d.unbind())
                    })
                    .transpose()
            })
            .collect::<PyResult<Vec<_>>>()?;
        let counts = if counts {
            let layers = set
                .masks
                .iter()
                .map(|m| m.counts.clone().unwrap_or_else(|| vec![0; rows * beams]))
                .collect();
            Some(stack(kind, rows, beams, layers).into_pyarray(py).unbind())
        } else {
            None
        };
        let layers = set
            .masks
            .iter()
            .map(|m| m.occupancy.to_bytes(false, false))
            .collect();
        Ok(PyMaskSet {
            masks: stack(kind, rows, beams, layers).into_pyarray(py).unbind(),
            union: layer(kind, &set.union).into_pyarray(py).unbind(),
            counts,
            boxes,
            radius: set.masks.iter().map(|m| m.radius).collect(),
            noise_radius: set.masks.iter().map(|m| m.noise_radius).collect(),
            device: self.engine.device(),
        })
    }
}

/// Returns the noise of `sigma` = [roll, pitch, yaw (deg), tx, ty, tz (m), range (m), azimuth
/// (deg)] at `coverage`.
fn noise(sigma: Option<[f64; 8]>, coverage: f64) -> PyResult<Option<Noise>> {
    let Some(s) = sigma else {
        if !(coverage > 0.0 && coverage < 1.0) {
            return Err(errors::input(
                "coverage",
                format!("{coverage} is invalid: must be in (0, 1), e.g. 0.99"),
            ));
        }
        return Ok(None);
    };
    Noise {
        rotation: [s[0], s[1], s[2]],
        translation: [s[3], s[4], s[5]],
        range: s[6],
        azimuth: s[7],
        coverage,
    }
    .validated()
    .map(Some)
    .map_err(errors::engine)
}

#[pymethods]
impl PyMaskEngine {
    /// Returns the engine for masks of features of `first` in `second`'s data, on `backend`.
    #[new]
    #[pyo3(signature = (first, second, backend="auto", counts=false))]
    fn new(py: Python<'_>, first: &PySonar, second: &PySonar, backend: &str, counts: bool) -> PyResult<Self> {
        let choice = backend::choice(backend)?;
        let want = if counts { Counts::Draw } else { Counts::Skip };
        let (source, target) = (first.inner.clone(), second.inner.clone());
        let (engine, notice) = py
            .detach(|| MaskEngine::select(source, target, choice, want, &backend::options()))
            .map_err(errors::engine)?;
        Ok(PyMaskEngine { engine, notice })
    }

    /// The notice of the backend's selection (`auto` falling back to the CPU says why), or None.
    #[getter]
    fn notice(&self) -> Option<String> {
        self.notice.clone()
    }

    /// Where masks are drawn.
    #[getter]
    fn device(&self) -> String {
        self.engine.device()
    }

    /// Returns the masks of one ping: features `ranges` (m) and `azimuths` (deg, or None for a
    /// sidescan sonar 1) under `pose`, widened by `sigma` at `coverage`.
    #[pyo3(signature = (pose, ranges, azimuths, sigma, coverage, counts))]
    #[expect(clippy::too_many_arguments, reason = "the Python method's parameters")]
    fn masks(
        &self,
        py: Python<'_>,
        pose: &PyPose,
        ranges: Vec<f64>,
        azimuths: Option<Vec<f64>>,
        sigma: Option<[f64; 8]>,
        coverage: f64,
        counts: bool,
    ) -> PyResult<PyMaskSet> {
        let noise = noise(sigma, coverage)?;
        let features = self.features(&ranges, azimuths.as_deref())?;
        self.draw(py, pose, &features, noise.as_ref(), counts)
    }

    /// Returns the masks of many pings, one pose and one set of features each, stopping on
    /// Ctrl-C between pings.
    #[pyo3(signature = (poses, ranges, azimuths, sigma, coverage, counts))]
    #[expect(clippy::too_many_arguments, reason = "the Python method's parameters")]
    fn masks_of_pings(
        &self,
        py: Python<'_>,
        poses: Vec<PyRef<'_, PyPose>>,
        ranges: Vec<Vec<f64>>,
        azimuths: Option<Vec<Vec<f64>>>,
        sigma: Option<[f64; 8]>,
        coverage: f64,
        counts: bool,
    ) -> PyResult<Vec<PyMaskSet>> {
        let noise = noise(sigma, coverage)?;
        let mut out = Vec::with_capacity(poses.len());
        for (k, pose) in poses.iter().enumerate() {
            let az = azimuths.as_ref().map(|a| a[k].as_slice());
            let features = self
                .features(&ranges[k], az)
                .map_err(|e| errors::input("pings", format!("ping {k}: {}", e.value(py))))?;
            out.push(self.draw(py, pose, &features, noise.as_ref(), counts)?);
            py.check_signals()?;
        }
        Ok(out)
    }
}
