//! `sonarproj.MaskEngine` and the masks it returns. The engine is built once and kept between
//! pings, with its GPU buffers.

use numpy::ndarray::{Array2, Array3, ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArray2, PyArrayDyn};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarproj::limits::MAX_MASK_BITSET_BYTES;
use sonarproj::masks::run_lengths;
use sonarproj::masks::{Noise, bounding_box};
use sonarproj::occupancy::Occupancy;
use sonarproj::stream::{Flow, Stop};
use sonarproj::{Counts, MaskEngine, Measurement, SonarKind};
use sonarproj_apps::limits::MAX_DENSE_MASK_BYTES;
use std::time::Instant;

use crate::pose::PyPose;
use crate::sonar::PySonar;
use crate::{backend, errors};

/// Draws correspondence masks for one sonar pair.
#[pyclass(name = "_MaskEngine", module = "sonarproj", frozen)]
pub(crate) struct PyMaskEngine {
    engine: MaskEngine,
    notice: Option<String>,
    /// The process that opened it: a GPU device does not survive a fork.
    owner: u32,
}

/// The masks of one ping.
#[pyclass(name = "MaskSet", module = "sonarproj", frozen, get_all)]
pub(crate) struct PyMaskSet {
    /// uint8 0/1, `(features, range_bins, beams)` or `(features, range_bins)`; None when the
    /// masks were asked for as runs (`dense=False`).
    masks: Option<Py<PyArrayDyn<u8>>>,
    /// With `dense=False`, per feature a uint64 array `(k, 2)` of runs `[start, length]` over
    /// one mask's pixels in row-major order (`masks[f].ravel()`); else None.
    runs: Option<Vec<Py<PyArray2<u64>>>>,
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
        let form = match &self.masks {
            Some(masks) => {
                let shape: Vec<String> = masks.bind(py).shape().iter().map(ToString::to_string).collect();
                format!("masks ({}) uint8", shape.join(", "))
            }
            None => "masks as runs".to_string(),
        };
        let union = self.union.bind(py).call_method0("sum")?.extract::<u64>()?;
        Ok(format!(
            "<MaskSet: {} feature{}, {form}, {union} bins or pixels in the union, counts {}, drawn on {}>",
            self.radius.len(),
            if self.radius.len() == 1 { "" } else { "s" },
            if self.counts.is_some() {
                "drawn"
            } else {
                "not drawn"
            },
            self.device
        ))
    }

    /// Returns the mask of feature `k` as a dense uint8 array in sonar 2's layout (from the
    /// runs when the set holds runs).
    fn mask<'py>(&self, py: Python<'py>, k: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.radius.len();
        // An index as numpy reads one (int or numpy integer, not a bool), from 0 to n - 1.
        if k.is_instance_of::<pyo3::types::PyBool>() || !k.hasattr("__index__")? {
            return Err(crate::values::wrong_type(py, "k", "expected an integer index"));
        }
        let index: i128 = k.call_method0("__index__")?.extract().unwrap_or(i128::MAX);
        let Some(k) = usize::try_from(index).ok().filter(|&k| k < n) else {
            return Err(errors::input(
                "k",
                format!(
                    "{index} is not a feature: the set has {n}, from 0 to {}",
                    n.saturating_sub(1)
                ),
            ));
        };
        if let Some(masks) = &self.masks {
            return masks.bind(py).get_item(k);
        }
        let union = self.union.bind(py);
        let zeros = union.call_method1("__mul__", (0u8,))?;
        let flat = zeros.call_method0("ravel")?;
        let runs = self.runs.as_ref().expect("runs when there are no dense masks")[k].bind(py);
        let runs: numpy::PyReadonlyArray2<'_, u64> = runs.extract()?;
        for run in runs.as_array().rows() {
            let slice = pyo3::types::PySlice::new(
                py,
                isize::try_from(run[0]).unwrap_or(isize::MAX),
                isize::try_from(run[0] + run[1]).unwrap_or(isize::MAX),
                1,
            );
            flat.set_item(slice, 1u8)?;
        }
        Ok(zeros)
    }
}

/// A ping's masks reduced: what `MaskEngine.summary` returns (on a GPU, all that is read back).
#[pyclass(name = "MaskSummary", module = "sonarproj", frozen, get_all)]
pub(crate) struct PyMaskSummary {
    /// uint64 `(features,)`: the bins or pixels of each feature's mask.
    occupied: Py<PyArrayDyn<u64>>,
    /// Per feature: a dict of range_min, range_max (m), azimuth_min, azimuth_max (deg), or
    /// None for an empty mask.
    boxes: Vec<Option<Py<PyDict>>>,
    /// uint8 0/1: every bin or pixel any feature may occupy.
    union: Py<PyArrayDyn<u8>>,
    /// Per feature, the ball radius (m) drawn around each cell.
    radius: Vec<f64>,
    /// Per feature, the noise radius (m): 0 without sigmas.
    noise_radius: Vec<f64>,
    /// Per feature, the cells its set was cut into.
    cells: Vec<u64>,
    /// Where the masks were drawn.
    device: String,
}

#[pymethods]
impl PyMaskSummary {
    /// Returns what the summary holds: its features, how many sonar 2 sees, the union's size and
    /// the device.
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let union = self.union.bind(py).call_method0("sum")?.extract::<u64>()?;
        let seen = self.boxes.iter().filter(|b| b.is_some()).count();
        Ok(format!(
            "<MaskSummary: {} feature{} ({seen} seen by sonar 2), {union} bins or pixels in the union, drawn on {}>",
            self.radius.len(),
            if self.radius.len() == 1 { "" } else { "s" },
            self.device
        ))
    }
}

/// Returns `b` as a dict of range_min, range_max (m), azimuth_min, azimuth_max (deg).
fn box_dict(py: Python<'_>, b: &sonarproj::masks::BoundingBox) -> PyResult<Py<PyDict>> {
    let d = PyDict::new(py);
    d.set_item("range_min", b.range_min)?;
    d.set_item("range_max", b.range_max)?;
    d.set_item("azimuth_min", b.azimuth_min)?;
    d.set_item("azimuth_max", b.azimuth_max)?;
    Ok(d.unbind())
}

/// What one chunk of features gave, made without the GIL.
struct Part {
    /// Dense bytes of its masks (empty for runs).
    dense: Vec<u8>,
    /// Its counts (empty without them).
    counts: Vec<u32>,
    /// Its runs (empty when dense).
    runs: Vec<Vec<[u64; 2]>>,
    boxes: Vec<Option<sonarproj::masks::BoundingBox>>,
    /// Its union: range bins, beams and words.
    union: (usize, usize, Vec<u32>),
    radius: Vec<(f64, f64)>,
}

impl Part {
    /// Returns the part of the mask set `set` in `layout`: its masks as dense bytes (`dense`)
    /// or runs, their counts when `counts`, boxes, union and radii.
    fn of(
        set: &sonarproj::masks::MaskSet,
        layout: &sonarproj::occupancy::Layout,
        dense: bool,
        counts: bool,
    ) -> Part {
        let (rows, beams) = layout.data_shape();
        let pixels = rows * beams;
        let mut part = Part {
            dense: Vec::new(),
            counts: Vec::new(),
            runs: Vec::new(),
            boxes: set
                .masks
                .iter()
                .map(|m| bounding_box(layout, &m.occupancy))
                .collect(),
            union: (set.union.range_bins, set.union.beams, set.union.words.clone()),
            radius: set.masks.iter().map(|m| (m.radius, m.noise_radius)).collect(),
        };
        for m in &set.masks {
            if dense {
                part.dense.extend(m.occupancy.to_bytes(false, false));
            } else {
                part.runs.push(run_lengths(&m.occupancy));
            }
            if counts {
                match &m.counts {
                    Some(c) => part.counts.extend_from_slice(c),
                    None => part.counts.extend(std::iter::repeat_n(0, pixels)),
                }
            }
        }
        part
    }
}

/// The parts of one ping's masks gathered in order.
#[derive(Default)]
struct Gathered {
    dense: Vec<u8>,
    counts: Vec<u32>,
    runs: Vec<Vec<[u64; 2]>>,
    boxes: Vec<Option<sonarproj::masks::BoundingBox>>,
    radius: Vec<(f64, f64)>,
    /// The union so far (`None` before the first part).
    union: Option<(usize, usize, Vec<u32>)>,
}

impl Gathered {
    fn add(&mut self, part: Part) {
        if self.dense.is_empty() {
            self.dense = part.dense;
        } else {
            self.dense.extend(part.dense);
        }
        self.counts.extend(part.counts);
        self.runs.extend(part.runs);
        self.boxes.extend(part.boxes);
        self.radius.extend(part.radius);
        match &mut self.union {
            None => self.union = Some(part.union),
            Some(u) => u.2.iter_mut().zip(&part.union.2).for_each(|(a, b)| *a |= b),
        }
    }
}

/// Returns `flat` (n masks of `rows × beams` values, one after the other) as an array of `n`
/// masks in sonar 2's layout.
fn shaped<T: numpy::Element>(
    kind: SonarKind,
    n: usize,
    rows: usize,
    beams: usize,
    flat: Vec<T>,
) -> ArrayD<T> {
    match kind {
        SonarKind::Fls => Array3::from_shape_vec((n, rows, beams), flat)
            .expect("one value per pixel")
            .into_dyn(),
        SonarKind::Sss => Array2::from_shape_vec((n, rows * beams), flat)
            .expect("one value per bin")
            .into_dyn(),
    }
}

/// Chunk sizes of a ping's features: the first chunk, the smallest and largest later ones, and
/// the time one chunk aims at (s). Short enough that Ctrl-C is answered at once, long enough
/// that a GPU gets whole pings, since most pings have fewer features than the first chunk.
const FIRST_CHUNK_FEATURES: usize = 128;
const MIN_CHUNK_FEATURES: usize = 8;
const MAX_CHUNK_FEATURES: usize = 8192;
const CHUNK_SECONDS: f64 = 0.05;

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
    fn summary_to_py(
        &self,
        py: Python<'_>,
        summary: &sonarproj::masks::PingSummary,
    ) -> PyResult<PyMaskSummary> {
        let kind = self.engine.target().kind;
        let f = &summary.features;
        Ok(PyMaskSummary {
            occupied: ArrayD::from_shape_vec(IxDyn(&[f.len()]), f.iter().map(|s| s.occupied).collect())
                .expect("one count per feature")
                .into_pyarray(py)
                .unbind(),
            boxes: f
                .iter()
                .map(|s| s.bounding_box.as_ref().map(|b| box_dict(py, b)).transpose())
                .collect::<PyResult<Vec<_>>>()?,
            union: layer(kind, &summary.union).into_pyarray(py).unbind(),
            radius: f.iter().map(|s| s.radius).collect(),
            noise_radius: f.iter().map(|s| s.noise_radius).collect(),
            cells: f.iter().map(|s| s.cells).collect(),
            device: self.engine.device(),
        })
    }

    /// Returns an error when this is a forked child of the process that opened the engine's GPU
    /// device. A device does not survive a fork.
    fn in_this_process(&self) -> PyResult<()> {
        if self.engine.draws_on_gpu() && !crate::runtime::same_process(self.owner) {
            return Err(PyRuntimeError::new_err(
                "this MaskEngine's GPU device was opened by the parent of this forked process and \
                 cannot be used here: make a new MaskEngine in this process",
            ));
        }
        Ok(())
    }

    /// Returns the features of ping `k` of many (`ranges[k]`, `azimuths[k]`). Errors name the ping
    /// counted from 1.
    fn ping_features(
        &self,
        py: Python<'_>,
        k: usize,
        ranges: &[Vec<f64>],
        azimuths: Option<&[Vec<f64>]>,
    ) -> PyResult<Vec<Measurement>> {
        self.features(&ranges[k], azimuths.map(|a| a[k].as_slice()))
            .map_err(|e| {
                errors::input(
                    "pings",
                    format!("ping {} (counted from 1): {}", k + 1, e.value(py)),
                )
            })
    }

    /// Returns the pings of `poses`, `ranges` and `azimuths`, one pose and set of features each.
    /// Errors name the ping counted from 1.
    fn pings(
        &self,
        py: Python<'_>,
        poses: &[PyRef<'_, PyPose>],
        ranges: &[Vec<f64>],
        azimuths: Option<&[Vec<f64>]>,
    ) -> PyResult<Vec<(sonarproj::RelativePose, Vec<Measurement>)>> {
        poses
            .iter()
            .enumerate()
            .map(|(k, pose)| Ok((pose.inner, self.ping_features(py, k, ranges, azimuths)?)))
            .collect()
    }

    /// Returns the measurements of `ranges` and `azimuths` (deg; `None` for a sidescan), each
    /// checked against sonar 1 and named by its index.
    fn features(&self, ranges: &[f64], azimuths: Option<&[f64]>) -> PyResult<Vec<Measurement>> {
        // A ping's limit, as the command line's: the calls below are cut into chunks, so the
        // engine alone would not see it.
        let most = sonarproj::limits::MAX_PING_FEATURES;
        if ranges.len() > most {
            return Err(errors::input(
                "features",
                format!("{} features: at most {most} a ping; split it", ranges.len()),
            ));
        }
        ranges
            .iter()
            .enumerate()
            .map(|(k, &r)| {
                let az = azimuths.map_or(0.0, |a| a[k]);
                Measurement::of(self.engine.source(), r, az)
                    .map_err(|e| errors::engine(e.in_context(format!("features row {k}"))))
            })
            .collect()
    }

    /// Returns an error when `n` features' dense masks (with `counts`) would exceed what one
    /// call returns ([`MAX_DENSE_MASK_BYTES`]), or counts are asked for as runs.
    fn check_dense(&self, n: usize, counts: bool, dense: bool) -> PyResult<()> {
        if counts && !dense {
            return Err(errors::input(
                "counts",
                "needs dense=True: counts are one number per pixel",
            ));
        }
        if dense {
            let (rows, beams) = self.engine.layout().data_shape();
            let pixels = rows * beams;
            let per_pixel: u64 = if counts { 5 } else { 1 };
            let bytes = (n as u64).saturating_mul(pixels as u64).saturating_mul(per_pixel);
            if bytes > MAX_DENSE_MASK_BYTES {
                return Err(errors::input(
                    "features",
                    format!(
                        "{n} features × {pixels} pixels of dense masks{} make {bytes} bytes, more \
                         than the {MAX_DENSE_MASK_BYTES} one call returns: pass dense=False for \
                         per-feature runs, or fewer features per call",
                        if counts { " with counts" } else { "" }
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Returns the most features one engine call draws: their masks and a union within what
    /// it holds as bitsets ([`MAX_MASK_BITSET_BYTES`]).
    fn most_features_a_call(&self) -> usize {
        usize::try_from(MAX_MASK_BITSET_BYTES / self.engine.bitset_bytes() - 1)
            .unwrap_or(usize::MAX)
            .max(1)
    }

    /// Returns an error when the dense arrays of `pings` pings with `features` features in all
    /// would exceed what one call returns ([`MAX_DENSE_MASK_BYTES`]). That is a union per ping,
    /// plus with `dense` a mask per feature (with counts when `counts`).
    fn check_pings_dense(&self, pings: usize, features: u64, counts: bool, dense: bool) -> PyResult<()> {
        let (rows, beams) = self.engine.layout().data_shape();
        let pixels = (rows * beams) as u64;
        let masks = if dense { features } else { 0 };
        let per_mask = if counts { 5 } else { 1 };
        let bytes = masks
            .saturating_mul(pixels * per_mask)
            .saturating_add((pings as u64).saturating_mul(pixels));
        if bytes > MAX_DENSE_MASK_BYTES {
            return Err(errors::input(
                "poses",
                format!(
                    "{} pings' dense unions{} of {pixels} pixels make {bytes} bytes, more than the \
                     {MAX_DENSE_MASK_BYTES} one call returns: fewer pings per call",
                    pings,
                    if masks > 0 {
                        format!(" and {masks} dense masks")
                    } else {
                        String::new()
                    },
                ),
            ));
        }
        Ok(())
    }

    /// Returns the mask set of one ping. Features are drawn without the GIL in chunks of about
    /// 50 ms, and Ctrl-C is checked between chunks. Dense masks past [`MAX_DENSE_MASK_BYTES`] are
    /// refused up front. `dense = false` gives runs instead.
    fn draw(
        &self,
        py: Python<'_>,
        pose: &PyPose,
        features: &[Measurement],
        noise: Option<&Noise>,
        counts: bool,
        dense: bool,
    ) -> PyResult<PyMaskSet> {
        self.in_this_process()?;
        let n = features.len();
        self.check_dense(n, counts, dense)?;
        let want = if counts { Counts::Draw } else { Counts::Skip };
        let mut gathered = Gathered::default();
        let most = self.most_features_a_call();
        let (mut start, mut chunk) = (0, FIRST_CHUNK_FEATURES.min(most));
        while start < n || gathered.union.is_none() {
            let end = (start + chunk).min(n);
            let began = Instant::now();
            let part = crate::runtime::detach(py, || -> sonarproj::Result<Part> {
                let set = self
                    .engine
                    .masks(&pose.inner, &features[start..end], noise, want)?;
                Ok(Part::of(&set, self.engine.layout(), dense, counts))
            })
            .map_err(errors::engine)?;
            gathered.add(part);
            py.check_signals()?;
            // The next chunk takes about CHUNK_SECONDS at this chunk's pace.
            let per_feature = began.elapsed().as_secs_f64() / (end - start).max(1) as f64;
            let fits = CHUNK_SECONDS / per_feature.max(1e-9);
            chunk = [
                MIN_CHUNK_FEATURES,
                16,
                32,
                64,
                128,
                256,
                512,
                1024,
                2048,
                4096,
                MAX_CHUNK_FEATURES,
            ]
            .into_iter()
            .rev()
            .find(|&c| c as f64 <= fits)
            .unwrap_or(MIN_CHUNK_FEATURES)
            .min(most);
            start = end;
        }
        self.to_py(py, n, gathered, counts, dense)
    }

    /// Returns the gathered parts of one ping's `n` masks as Python's `MaskSet`.
    fn to_py(
        &self,
        py: Python<'_>,
        n: usize,
        gathered: Gathered,
        counts: bool,
        dense: bool,
    ) -> PyResult<PyMaskSet> {
        let kind = self.engine.target().kind;
        let (rows, beams) = self.engine.layout().data_shape();
        let Gathered {
            dense: dense_bytes,
            counts: all_counts,
            runs,
            boxes,
            radius,
            union,
        } = gathered;
        let (union_rows, union_beams, words) = union.expect("at least one part");
        let union = Occupancy::from_words(union_rows, union_beams, words);
        let boxes = boxes
            .iter()
            .map(|b| b.as_ref().map(|b| box_dict(py, b)).transpose())
            .collect::<PyResult<Vec<_>>>()?;
        let counts = counts.then(|| shaped(kind, n, rows, beams, all_counts).into_pyarray(py).unbind());
        let (masks, runs) = if dense {
            (
                Some(
                    shaped(kind, n, rows, beams, dense_bytes)
                        .into_pyarray(py)
                        .unbind(),
                ),
                None,
            )
        } else {
            let arrays = runs
                .into_iter()
                .map(|r| {
                    let k = r.len();
                    let flat: Vec<u64> = r.into_iter().flatten().collect();
                    Array2::from_shape_vec((k, 2), flat)
                        .expect("two numbers a run")
                        .into_pyarray(py)
                        .unbind()
                })
                .collect();
            (None, Some(arrays))
        };
        Ok(PyMaskSet {
            masks,
            runs,
            union: layer(kind, &union).into_pyarray(py).unbind(),
            counts,
            boxes,
            radius: radius.iter().map(|r| r.0).collect(),
            noise_radius: radius.iter().map(|r| r.1).collect(),
            device: self.engine.device(),
        })
    }
}

/// Returns the noise of `sigma` = [roll, pitch, yaw (deg), tx, ty, tz (m), range (m), azimuth
/// (deg)] at `coverage`.
pub(crate) fn noise(sigma: Option<[f64; 8]>, coverage: f64) -> PyResult<Option<Noise>> {
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
        let (choice, forked) = backend::after_fork(backend::choice(backend)?)?;
        backend::touched(choice);
        let want = if counts { Counts::Draw } else { Counts::Skip };
        let (source, target) = (first.inner.clone(), second.inner.clone());
        let (engine, notice) = crate::runtime::detach(py, || {
            MaskEngine::select(source, target, choice, want, &backend::options())
        })
        .map_err(errors::engine)?;
        Ok(PyMaskEngine {
            engine,
            notice: forked.or_else(|| notice.map(|n| n.render(&errors::name))),
            owner: std::process::id(),
        })
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
    #[pyo3(signature = (pose, ranges, azimuths, sigma, coverage, counts, dense))]
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
        dense: bool,
    ) -> PyResult<PyMaskSet> {
        let noise = noise(sigma, coverage)?;
        let features = self.features(&ranges, azimuths.as_deref())?;
        self.draw(py, pose, &features, noise.as_ref(), counts, dense)
    }

    /// Returns the summary of one ping's masks (each mask's pixel count and box, and their
    /// union), features and noise as in `masks`.
    #[pyo3(signature = (pose, ranges, azimuths, sigma, coverage))]
    fn summary(
        &self,
        py: Python<'_>,
        pose: &PyPose,
        ranges: Vec<f64>,
        azimuths: Option<Vec<f64>>,
        sigma: Option<[f64; 8]>,
        coverage: f64,
    ) -> PyResult<PyMaskSummary> {
        self.in_this_process()?;
        let noise = noise(sigma, coverage)?;
        let features = self.features(&ranges, azimuths.as_deref())?;
        let summary =
            crate::runtime::detach(py, || self.engine.summary(&pose.inner, &features, noise.as_ref()))
                .map_err(errors::engine)?;
        self.summary_to_py(py, &summary)
    }

    /// Returns the summaries of many pings, one pose and one set of features each (two pings in
    /// flight on a GPU), stopping on Ctrl-C between groups of 64 pings.
    #[pyo3(signature = (poses, ranges, azimuths, sigma, coverage))]
    fn summaries_of_pings(
        &self,
        py: Python<'_>,
        poses: Vec<PyRef<'_, PyPose>>,
        ranges: Vec<Vec<f64>>,
        azimuths: Option<Vec<Vec<f64>>>,
        sigma: Option<[f64; 8]>,
        coverage: f64,
    ) -> PyResult<Vec<PyMaskSummary>> {
        self.in_this_process()?;
        let noise = noise(sigma, coverage)?;
        let pings = self.pings(py, &poses, &ranges, azimuths.as_deref())?;
        self.check_pings_dense(pings.len(), 0, false, false)?;
        let summaries = crate::runtime::detach_watching(py, |stop| {
            let stopped = || stop.load(std::sync::atomic::Ordering::Relaxed);
            self.engine
                .summaries_of_pings(&pings, noise.as_ref(), Stop::when(&stopped))
        })?
        .map_err(errors::engine)?;
        summaries.iter().map(|s| self.summary_to_py(py, s)).collect()
    }

    /// Returns the masks of many pings, one pose and one set of features each. On a GPU without
    /// counts, with pings of at most [`FIRST_CHUNK_FEATURES`] features each, two pings are in
    /// flight (the next submitted while the one before is drawn), and Ctrl-C is checked between
    /// groups of 64 pings. Otherwise pings go one by one, with Ctrl-C checked between chunks of
    /// features.
    #[pyo3(signature = (poses, ranges, azimuths, sigma, coverage, counts, dense))]
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
        dense: bool,
    ) -> PyResult<Vec<PyMaskSet>> {
        let noise = noise(sigma, coverage)?;
        let pings = self.pings(py, &poses, &ranges, azimuths.as_deref())?;
        // Counts need dense masks. Say so before counting any bytes.
        self.check_dense(0, counts, dense)?;
        let features = pings.iter().map(|(_, f)| f.len() as u64).sum();
        self.check_pings_dense(pings.len(), features, counts, dense)?;
        // Draw together only pings that `draw` would draw in one chunk, so on the same engine
        // (GPU or CPU under `auto`) and with the same masks either way.
        if counts
            || !self.engine.draws_on_gpu()
            || pings
                .iter()
                .any(|(_, f)| f.len() > FIRST_CHUNK_FEATURES.min(self.most_features_a_call()))
        {
            return pings
                .iter()
                .zip(&poses)
                .map(|((_, features), pose)| self.draw(py, pose, features, noise.as_ref(), counts, dense))
                .collect();
        }
        self.in_this_process()?;
        for (k, (_, features)) in pings.iter().enumerate() {
            self.check_dense(features.len(), counts, dense).map_err(|e| {
                errors::input(
                    "pings",
                    format!("ping {} (counted from 1): {}", k + 1, e.value(py)),
                )
            })?;
        }
        let mut parts = Vec::with_capacity(pings.len());
        crate::runtime::detach_watching(py, |stop| {
            let stopped = || stop.load(std::sync::atomic::Ordering::Relaxed);
            let layout = self.engine.layout();
            self.engine
                .masks_of_pings_each(&pings, noise.as_ref(), Stop::when(&stopped), &mut |set| {
                    parts.push(Part::of(&set, layout, dense, false));
                    Ok(Flow::Continue(()))
                })
                // Stopped by Ctrl-C: the masks are not returned in part.
                .and_then(|flow| match flow {
                    Flow::Continue(()) => Ok(()),
                    Flow::Break(()) => Err(sonarproj::Error::Stopped),
                })
        })?
        .map_err(errors::engine)?;
        parts
            .into_iter()
            .zip(&pings)
            .map(|(part, (_, features))| {
                let mut gathered = Gathered::default();
                gathered.add(part);
                self.to_py(py, features.len(), gathered, false, dense)
            })
            .collect()
    }
}
