//! `sonarproj.read_bag`: the sonar pings of a ROS 2 bag, read as they come.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::IntoPyArray;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use sonarproj::Sonar;
use sonarproj_apps::io::bag::{BagImage, BagPings, read_bag as read};

use crate::errors;
use crate::sonar::PySonar;

/// One ping of a bag's topic: its sonar, its image in the project's layout and its stamp.
#[pyclass(name = "BagPing", module = "sonarproj", frozen, get_all)]
pub(crate) struct PyBagPing {
    /// The ping's place among the topic's messages, from 0.
    index: usize,
    /// The header's stamp (s since the epoch), and in ns.
    time: f64,
    stamp_ns: i64,
    /// When the bag logged it (ns).
    log_time: u64,
    /// The header's frame.
    frame_id: String,
    /// The sonar of its beam table and ranges (the same object for pings of the same table).
    sonar: Py<PySonar>,
    /// uint8, uint16 or float32, `(ranges, beams)`: row 0 the nearest range, column 0 the
    /// starboard-most beam.
    image: Py<PyAny>,
}

#[pymethods]
impl PyBagPing {
    fn __repr__(&self, py: Python<'_>) -> String {
        let s = self.sonar.bind(py).borrow();
        format!(
            "<BagPing {} of {:?} at {:.9} s, frame {:?}: {} ranges × {} beams>",
            self.index,
            s.inner.name,
            self.time,
            self.frame_id,
            s.inner.range_bins,
            s.inner.beam_count()
        )
    }
}

/// The pings of one topic, read from the bag one at a time as they are asked for.
#[pyclass(name = "BagPings", module = "sonarproj")]
pub(crate) struct PyBagPings {
    /// The reader (its decompressors are `Send` but not `Sync`).
    inner: std::sync::Mutex<BagPings>,
    /// The last sonar given out, with the engine's sonar it was made from.
    last: Option<(Arc<Sonar>, Py<PySonar>)>,
}

#[pymethods]
impl PyBagPings {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<PyBagPing>> {
        let inner = self
            .inner
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let Some(p) = crate::runtime::detach(py, || inner.next()) else {
            return Ok(None);
        };
        let p = p.map_err(errors::apps)?;
        let sonar = match &self.last {
            Some((s, py_sonar)) if Arc::ptr_eq(s, &p.sonar) => py_sonar.clone_ref(py),
            _ => {
                let made = Py::new(
                    py,
                    PySonar {
                        inner: (*p.sonar).clone(),
                    },
                )?;
                self.last = Some((Arc::clone(&p.sonar), made.clone_ref(py)));
                made
            }
        };
        let shape = (p.sonar.range_bins as usize, p.sonar.beam_count() as usize);
        let image = match p.image {
            BagImage::U8(v) => Array2::from_shape_vec(shape, v).map(|a| a.into_pyarray(py).into_any()),
            BagImage::U16(v) => Array2::from_shape_vec(shape, v).map(|a| a.into_pyarray(py).into_any()),
            BagImage::F32(v) => Array2::from_shape_vec(shape, v).map(|a| a.into_pyarray(py).into_any()),
        }
        .expect("one sample per pixel")
        .unbind();
        #[expect(clippy::cast_precision_loss, reason = "a stamp in ns, to float seconds")]
        let time = p.stamp_ns as f64 * 1e-9;
        Ok(Some(PyBagPing {
            index: p.index,
            time,
            stamp_ns: p.stamp_ns,
            log_time: p.log_time,
            frame_id: p.frame_id,
            sonar,
            image,
        }))
    }
}

/// Returns the pings of `topic` of the bag at `path` (the first topic of ProjectedSonarImage
/// messages when None), read as they are asked for. `elevation` (deg) overrides the aperture
/// the messages' `tx_beamwidths` give.
#[pyfunction]
#[pyo3(signature = (path, topic=None, elevation=None))]
pub(crate) fn read_bag(path: PathBuf, topic: Option<String>, elevation: Option<f64>) -> PyResult<PyBagPings> {
    let inner = read(&path, topic.as_deref(), elevation).map_err(errors::apps)?;
    Ok(PyBagPings {
        inner: std::sync::Mutex::new(inner),
        last: None,
    })
}

/// Writes into `out` a mask image for every ping of the bag (see `sonarproj mask --bag`) and
/// returns what was written: `topic`, `masks_topic`, `pings`, `pings_with_features`,
/// `features`, `unmatched`, and the notice of the backend's selection.
#[pyfunction]
#[pyo3(signature = (bag, first, from_frame, features, out, topic, to_frame, elevation, sigma, coverage, backend_name))]
#[expect(clippy::too_many_arguments, reason = "the Python function's parameters")]
pub(crate) fn masks_of_bag<'py>(
    py: Python<'py>,
    bag: PathBuf,
    first: &PySonar,
    from_frame: String,
    features: PathBuf,
    out: PathBuf,
    topic: Option<String>,
    to_frame: Option<String>,
    elevation: Option<f64>,
    sigma: Option<[f64; 8]>,
    coverage: f64,
    backend_name: &str,
) -> PyResult<(Bound<'py, pyo3::types::PyDict>, Option<String>)> {
    use sonarproj::masks::{Counts, MaskEngine};
    use sonarproj_apps::io::bag_masks::{BagMasks, masks_of_bag as run};
    let noise = crate::masks::noise(sigma, coverage)?;
    let (choice, forked) = crate::backend::after_fork(crate::backend::choice(backend_name)?)?;
    crate::backend::touched(choice);
    let source = first.inner.clone();
    let notice = std::sync::Mutex::new(forked);
    let engine = |target: Sonar| -> sonarproj_apps::Result<MaskEngine> {
        let (engine, n) = MaskEngine::select(
            source.clone(),
            target,
            choice,
            Counts::Skip,
            &crate::backend::options(),
        )?;
        let mut held = notice.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if held.is_none() {
            *held = n.map(|n| n.render(&errors::name));
        }
        Ok(engine)
    };
    let job = BagMasks {
        bag: &bag,
        topic: topic.as_deref(),
        elevation,
        source: &source,
        from_frame: &from_frame,
        to_frame: to_frame.as_deref(),
        features: &features,
        noise,
    };
    let report = crate::runtime::detach(py, || run(&job, &engine, &out)).map_err(errors::apps)?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("topic", report.topic)?;
    d.set_item("masks_topic", report.masks_topic)?;
    d.set_item("pings", report.pings)?;
    d.set_item("pings_with_features", report.pings_with_features)?;
    d.set_item("features", report.features)?;
    d.set_item("unmatched", report.unmatched)?;
    let notice = notice
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    Ok((d, notice))
}
