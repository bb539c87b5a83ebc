//! `sonarproj.Sonar` and `sonarproj.presets()`.

use std::path::PathBuf;

use numpy::{PyArray1, ToPyArray};
use pyo3::prelude::*;
use sonarproj::{BeamLayout, Sonar, SonarKind};

use crate::errors;
use crate::pose::{hash_reals, list_text};
use crate::values::arg;

/// A sonar: kind, field of view (metres, degrees) and data layout.
///
/// `Sonar(kind, range_min, range_max, azimuth_aperture, elevation_aperture, range_bins,
/// beams=None, beam_edges=None, beam_centres=None, name=None, sides=None)`:
/// - `kind`: "fls" (imaging) or "sss" (sidescan).
/// - Ranges in m: `0 <= range_min < range_max <= 10000`.
/// - Full apertures in degrees: azimuth in (0, 360], elevation in (0, 180].
/// - `range_bins`: uniform bins, per side for a two-sided sidescan.
/// - For an imaging sonar, exactly one of `beams` (a count of equal beams), `beam_edges` (deg,
///   beams + 1 increasing values from -aperture/2, starboard, to +aperture/2, port) or
///   `beam_centres` (deg; edges at the midpoints).
/// - For a sidescan, `sides` 1 (default) or 2 (one row of both sides, as HoloOcean's
///   SidescanSonar).
///
/// Also `Sonar.preset(name)` and `Sonar.from_toml(path)`.
#[pyclass(name = "Sonar", module = "sonarproj", frozen)]
#[derive(Clone, Debug)]
pub(crate) struct PySonar {
    pub(crate) inner: Sonar,
}

/// The most beam edges a sonar's repr lists; a sonar of more is summarised.
const REPR_EDGES: usize = 17;

/// Returns `v` to six decimals at most, without trailing zeros: `1.96`, `-29.37`, `0`.
fn short(v: f64) -> String {
    let text = format!("{v:.6}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".to_string()
    } else {
        text.to_string()
    }
}

#[pymethods]
impl PySonar {
    /// Returns a sonar from its fields (see the Python docstring of `sonarproj.Sonar`).
    #[new]
    #[pyo3(signature = (kind, range_min, range_max, azimuth_aperture, elevation_aperture, range_bins, beams=None, beam_edges=None, beam_centres=None, name=None, sides=None))]
    #[expect(clippy::too_many_arguments, reason = "the sonar's fields, as Python keywords")]
    fn new(
        #[pyo3(from_py_with = arg::kind)] kind: String,
        #[pyo3(from_py_with = arg::range_min)] range_min: f64,
        #[pyo3(from_py_with = arg::range_max)] range_max: f64,
        #[pyo3(from_py_with = arg::azimuth_aperture)] azimuth_aperture: f64,
        #[pyo3(from_py_with = arg::elevation_aperture)] elevation_aperture: f64,
        #[pyo3(from_py_with = arg::range_bins)] range_bins: u32,
        #[pyo3(from_py_with = arg::beams)] beams: Option<u32>,
        #[pyo3(from_py_with = arg::beam_edges)] beam_edges: Option<Vec<f64>>,
        #[pyo3(from_py_with = arg::beam_centres)] beam_centres: Option<Vec<f64>>,
        #[pyo3(from_py_with = arg::opt_name)] name: Option<String>,
        #[pyo3(from_py_with = arg::sides)] sides: Option<u32>,
    ) -> PyResult<Self> {
        let kind = match kind.as_str() {
            "fls" => SonarKind::Fls,
            "sss" => SonarKind::Sss,
            other => {
                return Err(errors::input(
                    "kind",
                    format!("{other:?} is not a sonar kind; use \"fls\" (imaging) or \"sss\" (sidescan)"),
                ));
            }
        };
        let given = [beams.is_some(), beam_edges.is_some(), beam_centres.is_some()]
            .iter()
            .filter(|g| **g)
            .count();
        if given > 1 {
            return Err(errors::input(
                "beams",
                "give one of beams, beam_edges and beam_centres, not several",
            ));
        }
        if kind == SonarKind::Sss && given > 0 {
            return Err(errors::input(
                "beams",
                "a sidescan has no beams (sides=2 for a two-sided one); give beams, beam_edges or beam_centres for an fls only",
            ));
        }
        if kind == SonarKind::Fls && given == 0 {
            return Err(errors::input(
                "beams",
                "an fls needs its beams: give beams (a count), beam_edges or beam_centres (deg)",
            ));
        }
        let sides = match (kind, sides) {
            (_, None) => 1,
            (SonarKind::Sss, Some(n @ (1 | 2))) => n,
            (SonarKind::Sss, Some(n)) => {
                return Err(errors::input(
                    "sides",
                    format!("{n} is not 1 or 2: a sidescan has one side, or two in one row (HoloOcean's)"),
                ));
            }
            (SonarKind::Fls, Some(_)) => {
                return Err(errors::input("sides", "only a sidescan (kind \"sss\") has sides"));
            }
        };
        let layout = match (beams, beam_edges) {
            (Some(n), _) => BeamLayout::Uniform { count: n },
            (None, Some(edges)) => BeamLayout::Edges(edges),
            (None, None) => BeamLayout::Uniform { count: sides },
        };
        let sonar = Sonar {
            name: name.unwrap_or_else(|| format!("custom-{}", kind.name())),
            kind,
            range_min,
            range_max,
            azimuth_aperture,
            elevation_aperture,
            range_bins,
            beams: layout,
        };
        let sonar = match beam_centres {
            Some(c) => sonar.with_beam_centres(&c, Some(azimuth_aperture)),
            None => sonar.validated(),
        }
        .map_err(errors::engine)?;
        Ok(PySonar { inner: sonar })
    }

    /// Returns the preset called `name` (see `sonarproj.presets()`).
    #[staticmethod]
    fn preset(#[pyo3(from_py_with = arg::name)] name: String) -> PyResult<Self> {
        Sonar::preset(&name)
            .map(|inner| PySonar { inner })
            .ok_or_else(|| {
                errors::input(
                    "name",
                    format!(
                        "{name:?} is not a preset; the presets are {}",
                        Sonar::preset_names().join(", ")
                    ),
                )
            })
    }

    /// Returns the sonar described by the TOML file at `path`.
    #[staticmethod]
    fn from_toml(#[pyo3(from_py_with = arg::path)] path: PathBuf) -> PyResult<Self> {
        Sonar::from_toml_file(&path)
            .map(|inner| PySonar { inner })
            .map_err(errors::engine)
    }

    /// Returns the sonar HoloOcean simulates for `sensor`. That is a scenario's sensor entry (a
    /// dict with `sensor_type` and, optionally, `configuration`), or a `configuration` block with
    /// `sensor_type` given apart. Its layout is the frame HoloOcean returns, index for index
    /// (docs/sonars.md).
    #[staticmethod]
    #[pyo3(signature = (sensor, sensor_type=None, name=None))]
    fn from_holoocean(
        py: Python<'_>,
        sensor: &Bound<'_, PyAny>,
        sensor_type: Option<&Bound<'_, PyAny>>,
        name: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        use pyo3::types::{PyBool, PyDict, PyString};
        let sensor = sensor.cast::<PyDict>().map_err(|_| {
            crate::values::wrong_type(
                py,
                "sensor",
                "expected a dict: a scenario's sensor entry or its configuration block",
            )
        })?;
        let text = |arg: Option<&Bound<'_, PyAny>>, what: &str| -> PyResult<Option<String>> {
            match arg {
                None => Ok(None),
                Some(a) if a.is_none() => Ok(None),
                Some(a) => a
                    .extract::<String>()
                    .map(Some)
                    .map_err(|_| crate::values::wrong_type(py, what, "expected a string or None")),
            }
        };
        let sensor_type = text(sensor_type, "sensor_type")?;
        let name = text(name, "name")?;
        use sonarproj::geometry::holoocean::HoloValue;
        let entry = sensor.contains("sensor_type")? || sensor.contains("configuration")?;
        let (kind, config) = if entry {
            if sensor_type.is_some() {
                return Err(errors::input(
                    "sensor_type",
                    "given twice: the sensor entry has its own; leave the argument out",
                ));
            }
            let kind: String = match sensor.get_item("sensor_type")? {
                Some(t) => t.extract().map_err(|_| {
                    errors::input(
                        "sensor",
                        "sensor[\"sensor_type\"] must be a string, e.g. \"ImagingSonar\"",
                    )
                })?,
                None => {
                    return Err(errors::input(
                        "sensor",
                        "has a configuration but no \"sensor_type\"",
                    ));
                }
            };
            let config = match sensor.get_item("configuration")? {
                None => PyDict::new(sensor.py()),
                Some(c) => c
                    .cast_into::<PyDict>()
                    .map_err(|_| errors::input("sensor", "sensor[\"configuration\"] must be a dict"))?,
            };
            (kind, config)
        } else {
            let Some(kind) = sensor_type else {
                return Err(errors::input(
                    "sensor_type",
                    "missing: give a sensor entry with \"sensor_type\", or sensor_type=\"ImagingSonar\" or \"SidescanSonar\"",
                ));
            };
            (kind, sensor.clone())
        };
        let mut pairs = Vec::new();
        for (k, v) in config.iter() {
            let key: String = k
                .extract()
                .map_err(|_| errors::input("sensor", format!("configuration key {k} is not a string")))?;
            // Python and numpy numbers alike: anything with __float__ except a bool or a string. A
            // numpy bool has a dtype of kind "b", and is refused like a Python bool.
            let numpy_bool = v
                .getattr("dtype")
                .and_then(|d| d.getattr("kind"))
                .and_then(|k| k.extract::<String>())
                .is_ok_and(|k| k == "b");
            let value = if v.is_instance_of::<PyBool>() || numpy_bool {
                HoloValue::Other("bool")
            } else if v.is_instance_of::<PyString>() {
                HoloValue::Other("string")
            } else if v.hasattr("__float__")? {
                // An int too large for a float overflows: it is refused as not finite.
                HoloValue::Number(v.extract::<f64>().unwrap_or(f64::INFINITY))
            } else {
                HoloValue::Other("non-number")
            };
            pairs.push((key, value));
        }
        let name = name.unwrap_or_else(|| format!("holoocean-{kind}"));
        Sonar::from_holoocean(&name, &kind, &pairs)
            .map(|inner| PySonar { inner })
            .map_err(|e| errors::engine(e.in_context("sensor")))
    }

    /// Returns `(sonar, columns)` for a ROS `ProjectedSonarImage`'s beam table, with
    /// `elevation_aperture` (deg). `beam_directions` is n × 3 in the message's frame (X up, Y
    /// starboard, Z forward). `ranges` are the centres of evenly spaced bins (m). Beam `k` of the
    /// sonar is column `columns[k]` of the message's image.
    #[staticmethod]
    #[pyo3(signature = (beam_directions, ranges, elevation_aperture, name=None))]
    fn from_projected_sonar_image<'py>(
        py: Python<'py>,
        beam_directions: &Bound<'py, PyAny>,
        ranges: &Bound<'py, PyAny>,
        #[pyo3(from_py_with = arg::elevation_aperture)] elevation_aperture: f64,
        #[pyo3(from_py_with = arg::opt_name)] name: Option<String>,
    ) -> PyResult<(Self, Bound<'py, numpy::PyArray1<usize>>)> {
        use numpy::IntoPyArray;
        let dirs: Vec<[f64; 3]> = beam_directions.extract().map_err(|_| {
            crate::values::wrong_type(py, "beam_directions", "expected an (n, 3) array of numbers")
        })?;
        let ranges: Vec<f64> = ranges
            .extract()
            .map_err(|_| crate::values::wrong_type(py, "ranges", "expected a 1-D array of numbers"))?;
        let name = name.unwrap_or_else(|| "ros-projected-sonar-image".to_string());
        let (inner, columns) = Sonar::from_projected_sonar_image(&name, &dirs, &ranges, elevation_aperture)
            .map_err(errors::engine)?;
        Ok((PySonar { inner }, columns.into_pyarray(py)))
    }

    /// The sonar's name (a preset's name, the file, or the name given).
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// "fls" or "sss".
    #[getter]
    fn kind(&self) -> &'static str {
        self.inner.kind.name()
    }

    /// Minimum range (m).
    #[getter]
    fn range_min(&self) -> f64 {
        self.inner.range_min
    }

    /// Maximum range (m).
    #[getter]
    fn range_max(&self) -> f64 {
        self.inner.range_max
    }

    /// Full azimuth aperture (deg).
    #[getter]
    fn azimuth_aperture(&self) -> f64 {
        self.inner.azimuth_aperture
    }

    /// Full elevation aperture (deg).
    #[getter]
    fn elevation_aperture(&self) -> f64 {
        self.inner.elevation_aperture
    }

    /// Number of range bins.
    #[getter]
    fn range_bins(&self) -> u32 {
        self.inner.range_bins
    }

    /// Number of beams (1 for a sidescan).
    #[getter]
    fn beams(&self) -> u32 {
        self.inner.beam_count()
    }

    /// Beam edges (deg), increasing, `beams + 1` values from -aperture/2 (starboard) to
    /// +aperture/2 (port).
    #[getter]
    fn beam_edges<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.beam_edges_deg().to_pyarray(py)
    }

    /// The shape of the sonar's data as numpy holds it: `(range_bins, beams)` for an FLS,
    /// `(range_bins,)` for an SSS, `(2 * range_bins,)` for a two-sided one (port far to near,
    /// then starboard near to far).
    #[getter]
    fn shape<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        let bins = self.inner.range_bins as usize;
        match self.inner.kind {
            SonarKind::Fls => pyo3::types::PyTuple::new(py, [bins, self.inner.beam_count() as usize]),
            SonarKind::Sss => pyo3::types::PyTuple::new(py, [bins * self.inner.beam_count() as usize]),
        }
    }

    /// 2 for a two-sided sidescan (one row of port and starboard), 1 for any other sonar.
    #[getter]
    fn sides(&self) -> u32 {
        if self.inner.two_sided() { 2 } else { 1 }
    }

    /// Returns the call that makes this sonar, every number to the last digit. A sonar of more
    /// than [`REPR_EDGES`] beam edges (a real sonar's measured beams) is summarised instead:
    /// `<Sonar 'name': fls, 0–1.96 m in 700 range bins, 256 beams, edges -30.21° to 30.21°, …>`.
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let s = &self.inner;
        let name = pyo3::types::PyString::new(py, &s.name).repr()?;
        if let BeamLayout::Edges(edges) = &s.beams
            && edges.len() > REPR_EDGES
        {
            return Ok(format!(
                "<Sonar {name}: {}, {}–{} m in {} range bins, {} beams, edges {}° to {}°, \
                 elevation aperture {}°>",
                s.kind.name(),
                short(s.range_min),
                short(s.range_max),
                s.range_bins,
                edges.len() - 1,
                short(edges[0]),
                short(edges[edges.len() - 1]),
                short(s.elevation_aperture)
            ));
        }
        let layout = match (&s.kind, &s.beams) {
            (SonarKind::Fls, BeamLayout::Uniform { count }) => format!(", beams={count}"),
            (_, BeamLayout::Edges(edges)) => format!(", beam_edges={}", list_text(edges)),
            (SonarKind::Sss, _) if s.two_sided() => ", sides=2".to_string(),
            (SonarKind::Sss, _) => String::new(),
        };
        Ok(format!(
            "Sonar({:?}, range_min={:?}, range_max={:?}, azimuth_aperture={:?}, elevation_aperture={:?}, range_bins={}{layout}, name={name})",
            s.kind.name(),
            s.range_min,
            s.range_max,
            s.azimuth_aperture,
            s.elevation_aperture,
            s.range_bins
        ))
    }

    /// Sonars compare by value: every field, the name included.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<PySonar>().is_ok_and(|o| o.get().inner == self.inner)
    }

    /// Returns a hash of every field, equal for equal sonars.
    fn __hash__(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let s = &self.inner;
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (s.name.as_str(), s.kind.name(), s.range_bins).hash(&mut h);
        let mut numbers = vec![s.range_min, s.range_max, s.azimuth_aperture, s.elevation_aperture];
        match &s.beams {
            BeamLayout::Uniform { count } => numbers.push(f64::from(*count)),
            BeamLayout::Edges(edges) => numbers.extend(edges),
        }
        hash_reals(&numbers).hash(&mut h);
        h.finish()
    }

    /// Returns this sonar: it is immutable.
    fn __copy__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Returns this sonar: it is immutable.
    fn __deepcopy__(slf: Py<Self>, _memo: &Bound<'_, PyAny>) -> Py<Self> {
        slf
    }

    /// Pickles as the call of `Sonar(…)` that makes it.
    #[expect(
        clippy::type_complexity,
        reason = "the constructor's arguments, as pickle wants them"
    )]
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> (
        Bound<'py, pyo3::types::PyType>,
        (
            &'static str,
            f64,
            f64,
            f64,
            f64,
            u32,
            Option<u32>,
            Option<Vec<f64>>,
            Option<Vec<f64>>,
            String,
            Option<u32>,
        ),
    ) {
        let s = &self.inner;
        let (beams, edges, sides) = match (&s.kind, &s.beams) {
            (SonarKind::Fls, BeamLayout::Uniform { count }) => (Some(*count), None, None),
            (_, BeamLayout::Edges(edges)) => (None, Some(edges.clone()), None),
            (SonarKind::Sss, BeamLayout::Uniform { count }) => (None, None, Some(*count)),
        };
        (
            py.get_type::<PySonar>(),
            (
                s.kind.name(),
                s.range_min,
                s.range_max,
                s.azimuth_aperture,
                s.elevation_aperture,
                s.range_bins,
                beams,
                edges,
                None,
                s.name.clone(),
                sides,
            ),
        )
    }
}

/// Returns the names of the preset sonars.
#[pyfunction]
pub(crate) fn presets() -> Vec<&'static str> {
    Sonar::preset_names()
}
