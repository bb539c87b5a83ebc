//! `sonarproj.read_oculus`: saved Oculus pings as sonars and images.

use std::path::PathBuf;

use numpy::IntoPyArray;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use sonarproj_apps::io::oculus::{OculusImage, Pick, read_oculus as read};

use crate::errors;
use crate::sonar::PySonar;

/// One saved Oculus ping: its sonar and its image in the project's layout.
#[pyclass(name = "OculusPing", module = "sonarproj", frozen, get_all)]
pub(crate) struct PyOculusPing {
    /// The sonar of the ping: its exact beams, its range lines as bins from 0.
    sonar: Py<PySonar>,
    /// uint8 or uint16, `(ranges, beams)`: row 0 the nearest range line, column 0 the
    /// starboard-most beam.
    image: Py<PyAny>,
    /// float32 gain per range line, or None.
    gains: Option<Py<PyAny>>,
    /// The bearings (deg, positive to port).
    bearings: Vec<f64>,
    /// The ping's id, frequency (Hz; its repr says MHz), metres per range line.
    ping_id: u32,
    frequency: f64,
    range_resolution: f64,
    /// The message's byte offset in the file and its layout version (1 or 2).
    offset: usize,
    version: u8,
}

#[pymethods]
impl PyOculusPing {
    fn __repr__(&self, py: Python<'_>) -> String {
        let s = self.sonar.bind(py).borrow();
        format!(
            "<OculusPing {} at byte {} (v{}): {} ranges × {} beams, {}>",
            self.ping_id,
            self.offset,
            self.version,
            s.inner.range_bins,
            s.inner.beam_count(),
            sonarproj_apps::io::oculus::megahertz(self.frequency)
        )
    }
}

/// Returns the simple ping results of the Oculus file at `path`. `elevation` (deg) overrides
/// the aperture the frequency gives.
#[pyfunction]
#[pyo3(signature = (path, elevation=None))]
pub(crate) fn read_oculus(
    py: Python<'_>,
    path: PathBuf,
    elevation: Option<f64>,
) -> PyResult<Vec<PyOculusPing>> {
    let pings = crate::runtime::detach(py, || read(&path, elevation, Pick::All)).map_err(errors::apps)?;
    pings
        .into_iter()
        .map(|p| {
            let shape = (p.sonar.range_bins as usize, p.sonar.beam_count() as usize);
            let image = match p.image {
                OculusImage::U8(v) => Array2::from_shape_vec(shape, v)
                    .expect("one sample per pixel")
                    .into_pyarray(py)
                    .into_any()
                    .unbind(),
                OculusImage::U16(v) => Array2::from_shape_vec(shape, v)
                    .expect("one sample per pixel")
                    .into_pyarray(py)
                    .into_any()
                    .unbind(),
            };
            Ok(PyOculusPing {
                sonar: Py::new(py, PySonar { inner: p.sonar })?,
                image,
                gains: p.gains.map(|g| g.into_pyarray(py).into_any().unbind()),
                bearings: p.bearings_deg,
                ping_id: p.ping_id,
                frequency: p.frequency,
                range_resolution: p.range_resolution,
                offset: p.offset,
                version: p.version,
            })
        })
        .collect()
}
