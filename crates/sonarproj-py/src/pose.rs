//! `sonarproj.Pose` (sonar 2 relative to sonar 1) and `sonarproj.Mount` (a sonar in a common
//! frame).

use glam::{DMat3, DQuat, DVec3};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, ToPyArray};
use pyo3::prelude::*;
use sonarproj::geometry::rig::{self, Mount};
use sonarproj::{RelativePose, Rotation};

use crate::errors;
use crate::values::arg;

/// The pose of sonar 2 relative to sonar 1: `p2 = R p1 + t` (m).
///
/// `Pose(roll=0, pitch=0, yaw=0, t=(0, 0, 0))`: roll, pitch, yaw in degrees with the paper's
/// `R = (Rz(yaw) Ry(pitch) Rx(roll))^T`, translation `t` in metres. Other forms:
/// `Pose.from_quat_xyzw`, `Pose.from_matrix`, `Pose.placement` (the paper's simulations) and
/// `Pose.from_mounts` (two sonars mounted in a common frame).
#[pyclass(name = "Pose", module = "sonarproj", frozen)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct PyPose {
    pub(crate) inner: RelativePose,
    /// The call that made it, which its repr writes again.
    made: Made,
}

/// The call that made a pose, by its numbers as given.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Made {
    /// `Pose(roll, pitch, yaw, t=…)`.
    RollPitchYaw([f64; 3]),
    /// `Pose.from_quat_xyzw(q, t=…)`.
    Quaternion([f64; 4]),
    /// `Pose.placement(feature, place, …)` with its rotation given as roll/pitch/yaw, a quaternion
    /// or a matrix.
    Placement {
        feature: [f64; 3],
        place: [f64; 3],
        rotation: Given,
    },
    /// Any other: `Pose.from_matrix(R, t=…)` with the pose's own matrix.
    Matrix,
}

/// A rotation as it was given.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Given {
    RollPitchYaw([f64; 3]),
    Quaternion([f64; 4]),
    Matrix([[f64; 3]; 3]),
}

impl Made {
    /// Returns this call as a kind and its numbers, for pickling (`Pose._from_parts`).
    fn to_parts(self) -> (&'static str, Vec<f64>) {
        let flat = |m: [[f64; 3]; 3]| m.iter().flatten().copied().collect::<Vec<f64>>();
        match self {
            Made::RollPitchYaw(a) => ("rpy", a.to_vec()),
            Made::Quaternion(q) => ("quat", q.to_vec()),
            Made::Placement {
                feature,
                place,
                rotation,
            } => {
                let (kind, r) = match rotation {
                    Given::RollPitchYaw(a) => ("placement-rpy", a.to_vec()),
                    Given::Quaternion(q) => ("placement-quat", q.to_vec()),
                    Given::Matrix(m) => ("placement-matrix", flat(m)),
                };
                (kind, feature.iter().chain(&place).chain(&r).copied().collect())
            }
            Made::Matrix => ("matrix", Vec::new()),
        }
    }

    /// Returns the call of `kind` and `numbers` ([`Made::to_parts`]), or `Matrix` when they do
    /// not describe one.
    fn from_parts(kind: &str, v: &[f64]) -> Made {
        let three = |k: usize| [v[k], v[k + 1], v[k + 2]];
        let given = match (kind, v.len()) {
            ("rpy", 3) => return Made::RollPitchYaw(three(0)),
            ("quat", 4) => return Made::Quaternion([v[0], v[1], v[2], v[3]]),
            ("placement-rpy", 9) => Given::RollPitchYaw(three(6)),
            ("placement-quat", 10) => Given::Quaternion([v[6], v[7], v[8], v[9]]),
            ("placement-matrix", 15) => Given::Matrix([three(6), three(9), three(12)]),
            _ => return Made::Matrix,
        };
        Made::Placement {
            feature: three(0),
            place: three(3),
            rotation: given,
        }
    }
}

/// Returns the rotation given by at most one of roll/pitch/yaw (non-zero), `quat_xyzw` and
/// `matrix`.
fn rotation(rpy: [f64; 3], quat_xyzw: Option<[f64; 4]>, matrix: Option<[[f64; 3]; 3]>) -> PyResult<Rotation> {
    let rpy_given = rpy.iter().any(|v| *v != 0.0);
    match (quat_xyzw, matrix) {
        (Some(_), Some(_)) => Err(errors::input(
            "quat_xyzw",
            "give one rotation: roll/pitch/yaw, quat_xyzw or matrix",
        )),
        (Some(_), None) | (None, Some(_)) if rpy_given => Err(errors::input(
            "roll/pitch/yaw",
            "give one rotation: roll/pitch/yaw, quat_xyzw or matrix",
        )),
        (Some([x, y, z, w]), None) => Ok(Rotation::QuaternionWxyz([w, x, y, z])),
        (None, Some(m)) => Ok(Rotation::Matrix(m)),
        (None, None) => Ok(Rotation::RollPitchYaw {
            roll: rpy[0],
            pitch: rpy[1],
            yaw: rpy[2],
        }),
    }
}

/// Returns the Python error of a pose constructor, naming the argument `t` before a translation
/// component (`t: tx = 1e300 is invalid: …`).
fn translation_error(e: sonarproj::Error) -> PyErr {
    let component = matches!(&e, sonarproj::Error::InvalidValue { field, .. } if ["tx", "ty", "tz"].iter().any(|c| field.is(c)));
    errors::engine(if component { e.in_context("t") } else { e })
}

#[pymethods]
impl PyPose {
    /// Returns the pose with roll, pitch, yaw (deg; the paper's `R = (Rz(yaw) Ry(pitch)
    /// Rx(roll))ᵀ`) and translation `t` (m).
    #[new]
    #[pyo3(signature = (roll=0.0, pitch=0.0, yaw=0.0, t=[0.0, 0.0, 0.0]), text_signature = "(roll=0.0, pitch=0.0, yaw=0.0, t=(0.0, 0.0, 0.0))")]
    fn new(
        #[pyo3(from_py_with = arg::roll)] roll: f64,
        #[pyo3(from_py_with = arg::pitch)] pitch: f64,
        #[pyo3(from_py_with = arg::yaw)] yaw: f64,
        #[pyo3(from_py_with = arg::t)] t: [f64; 3],
    ) -> PyResult<Self> {
        let r = Rotation::RollPitchYaw { roll, pitch, yaw };
        Ok(PyPose {
            inner: RelativePose::new(r, t).map_err(translation_error)?,
            made: Made::RollPitchYaw([roll, pitch, yaw]),
        })
    }

    /// Returns the pose whose rotation `R` is the unit quaternion `quat_xyzw` (x, y, z, w: the
    /// order of ROS and scipy) and translation `t` (m).
    #[staticmethod]
    #[pyo3(signature = (quat_xyzw, t=[0.0, 0.0, 0.0]), text_signature = "(quat_xyzw, t=(0.0, 0.0, 0.0))")]
    fn from_quat_xyzw(
        #[pyo3(from_py_with = arg::quat_xyzw)] quat_xyzw: [f64; 4],
        #[pyo3(from_py_with = arg::t)] t: [f64; 3],
    ) -> PyResult<Self> {
        let r = rotation([0.0; 3], Some(quat_xyzw), None)?;
        Ok(PyPose {
            inner: RelativePose::new(r, t).map_err(translation_error)?,
            made: Made::Quaternion(quat_xyzw),
        })
    }

    /// Returns the pose with the rotation matrix `matrix` (3×3, row-major) and translation `t`.
    #[staticmethod]
    #[pyo3(signature = (matrix, t=[0.0, 0.0, 0.0]), text_signature = "(matrix, t=(0.0, 0.0, 0.0))")]
    fn from_matrix(
        #[pyo3(from_py_with = arg::matrix)] matrix: [[f64; 3]; 3],
        #[pyo3(from_py_with = arg::t)] t: [f64; 3],
    ) -> PyResult<Self> {
        Ok(PyPose {
            inner: RelativePose::new(Rotation::Matrix(matrix), t).map_err(translation_error)?,
            made: Made::Matrix,
        })
    }

    /// Returns the placement pose of the paper's simulations: the feature's true point
    /// `feature` = (range, azimuth, elevation) in sonar 1 appears at `place` in sonar 2.
    #[staticmethod]
    #[pyo3(signature = (feature, place, roll=0.0, pitch=0.0, yaw=0.0, *, quat_xyzw=None, matrix=None))]
    fn placement(
        #[pyo3(from_py_with = arg::feature)] feature: [f64; 3],
        #[pyo3(from_py_with = arg::place)] place: [f64; 3],
        #[pyo3(from_py_with = arg::roll)] roll: f64,
        #[pyo3(from_py_with = arg::pitch)] pitch: f64,
        #[pyo3(from_py_with = arg::yaw)] yaw: f64,
        #[pyo3(from_py_with = arg::opt_quat_xyzw)] quat_xyzw: Option<[f64; 4]>,
        #[pyo3(from_py_with = arg::opt_matrix)] matrix: Option<[[f64; 3]; 3]>,
    ) -> PyResult<Self> {
        let r = rotation([roll, pitch, yaw], quat_xyzw, matrix)?;
        let given = match (quat_xyzw, matrix) {
            (Some(q), _) => Given::Quaternion(q),
            (None, Some(m)) => Given::Matrix(m),
            (None, None) => Given::RollPitchYaw([roll, pitch, yaw]),
        };
        Ok(PyPose {
            inner: RelativePose::placement(r, feature, place).map_err(errors::engine)?,
            made: Made::Placement {
                feature,
                place,
                rotation: given,
            },
        })
    }

    /// Returns the pose of sonar 2 relative to sonar 1 from their mounts in a common frame.
    #[staticmethod]
    fn from_mounts(first: &Bound<'_, PyAny>, second: &Bound<'_, PyAny>) -> PyResult<Self> {
        let mount = |name: &str, ob: &Bound<'_, PyAny>| -> PyResult<PyMount> {
            ob.cast::<PyMount>().map(|m| *m.get()).map_err(|_| {
                crate::values::wrong_type(
                    ob.py(),
                    name,
                    format!("expected a sonarproj.Mount, got {}", crate::values::shown(ob)),
                )
            })
        };
        let (first, second) = (mount("first", first)?, mount("second", second)?);
        Ok(PyPose {
            inner: rig::relative_pose(&first.inner, &second.inner).map_err(errors::engine)?,
            made: Made::Matrix,
        })
    }

    /// The rotation matrix `R` (3×3).
    #[getter]
    fn rotation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(self.inner.rotation).to_pyarray(py)
    }

    /// The translation `t` (m).
    #[getter]
    fn translation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.translation.to_array().to_pyarray(py)
    }

    /// Returns `R p + t` for points `p` (m) of sonar 1's frame, shape `(3,)` or `(n, 3)`: the
    /// points in sonar 2's frame, same shape.
    fn apply<'py>(
        &self,
        py: Python<'py>,
        p: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
        let numpy_module = py.import("numpy")?;
        let given = numpy_module
            .call_method1("asarray", (p,))
            .map_err(|e| errors::input("p", format!("not an array of numbers ({e})")))?;
        let kind: String = given.getattr("dtype")?.getattr("kind")?.extract()?;
        if !matches!(kind.as_str(), "f" | "i" | "u") {
            let dtype = given.getattr("dtype")?.str()?.to_string();
            return Err(crate::values::wrong_type(
                py,
                "p",
                format!("expected real numbers (float or integer), got dtype {dtype}"),
            ));
        }
        let converted = given.call_method1("astype", ("float64",))?;
        let array = converted
            .cast::<numpy::PyArrayDyn<f64>>()
            .map_err(|e| errors::input("p", e.to_string()))?
            .readonly();
        let a = array.as_array();
        let shape = a.shape().to_vec();
        if shape.last() != Some(&3) || shape.len() > 2 {
            let shape = crate::values::tuple(&shape);
            return Err(errors::input(
                "p",
                format!("must have shape (3,) or (n, 3), got {shape}"),
            ));
        }
        let flat: Vec<f64> = a.iter().copied().collect();
        let out: Vec<f64> = flat
            .chunks_exact(3)
            .flat_map(|c| self.inner.apply(DVec3::new(c[0], c[1], c[2])).to_array())
            .collect();
        Ok(numpy::ndarray::ArrayD::from_shape_vec(shape, out)
            .expect("same shape")
            .into_pyarray(py))
    }

    /// Returns the call that made this pose, every number to the last digit: `Pose(pitch=90.0,
    /// t=[1.0, 2.0, 3.0])` for `Pose(0, 90, 0, t=(1, 2, 3))`, likewise `Pose.from_quat_xyzw` and
    /// `Pose.placement`, and `Pose.from_matrix(R rows, t=…)` for any other.
    fn __repr__(&self) -> String {
        let t = self.inner.translation.to_array();
        let t_arg = if t.iter().all(|v| *v == 0.0) {
            String::new()
        } else {
            format!("t={}", list_text(&t))
        };
        let join = |parts: Vec<String>| {
            parts
                .into_iter()
                .filter(|p| !p.is_empty())
                .collect::<Vec<_>>()
                .join(", ")
        };
        match self.made {
            Made::RollPitchYaw(a) => format!("Pose({})", join(vec![angles_text(a), t_arg])),
            Made::Quaternion(q) => format!("Pose.from_quat_xyzw({})", join(vec![list_text(&q), t_arg])),
            Made::Placement {
                feature,
                place,
                rotation,
            } => {
                let r = match rotation {
                    Given::RollPitchYaw(a) => angles_text(a),
                    Given::Quaternion(q) => format!("quat_xyzw={}", list_text(&q)),
                    Given::Matrix(m) => format!("matrix={}", rows_text(&m)),
                };
                format!(
                    "Pose.placement({})",
                    join(vec![
                        format!("feature={}", list_text(&feature)),
                        format!("place={}", list_text(&place)),
                        r
                    ])
                )
            }
            Made::Matrix => format!("Pose.from_matrix({})", join(vec![rows_text(&self.rows()), t_arg])),
        }
    }

    /// Poses compare by value: the same rotation matrix and translation, number for number.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<PyPose>().is_ok_and(|o| o.get().inner == self.inner)
    }

    /// Returns a hash of the rotation and translation, equal for equal poses.
    fn __hash__(&self) -> u64 {
        hash_reals(
            self.rows()
                .iter()
                .flatten()
                .chain(&self.inner.translation.to_array()),
        )
    }

    /// Returns this pose: it is immutable.
    fn __copy__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Returns this pose: it is immutable.
    fn __deepcopy__(slf: Py<Self>, _memo: &Bound<'_, PyAny>) -> Py<Self> {
        slf
    }

    /// Pickles as its matrix and translation, which give back the same numbers, and the call
    /// that made it, which its repr writes.
    #[expect(clippy::type_complexity, reason = "the arguments of _from_parts")]
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Reduced<'py, (Rows, [f64; 3], (&'static str, Vec<f64>))>> {
        let make = py.get_type::<PyPose>().getattr("_from_parts")?;
        Ok((
            make,
            (
                self.rows(),
                self.inner.translation.to_array(),
                self.made.to_parts(),
            ),
        ))
    }

    /// Returns the pose of `matrix` and `t`, made by the call `made` (for pickling).
    #[staticmethod]
    fn _from_parts(
        #[pyo3(from_py_with = arg::matrix)] matrix: [[f64; 3]; 3],
        #[pyo3(from_py_with = arg::t)] t: [f64; 3],
        made: (String, Vec<f64>),
    ) -> PyResult<Self> {
        Ok(PyPose {
            inner: RelativePose::new(Rotation::Matrix(matrix), t).map_err(translation_error)?,
            made: Made::from_parts(&made.0, &made.1),
        })
    }
}

impl PyPose {
    /// Returns `R`'s rows.
    fn rows(&self) -> [[f64; 3]; 3] {
        let t = self.inner.rotation.transpose().to_cols_array_2d();
        [t[0], t[1], t[2]]
    }
}

/// A 3 × 3 matrix's rows.
type Rows = [[f64; 3]; 3];

/// What `__reduce__` returns: the callable that makes the value again, and its arguments.
pub(crate) type Reduced<'py, A> = (Bound<'py, PyAny>, A);

/// Returns `values` as a Python list literal, each number to the last digit.
pub(crate) fn list_text(values: &[f64]) -> String {
    let parts: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
    format!("[{}]", parts.join(", "))
}

/// Returns roll, pitch and yaw as keyword arguments, those that are zero left out.
fn angles_text(a: [f64; 3]) -> String {
    ["roll", "pitch", "yaw"]
        .iter()
        .zip(a)
        .filter(|(_, v)| *v != 0.0)
        .map(|(name, v)| format!("{name}={v:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Returns `rows` as a nested Python list literal.
fn rows_text(rows: &[[f64; 3]; 3]) -> String {
    let parts: Vec<String> = rows.iter().map(|r| list_text(r)).collect();
    format!("[{}]", parts.join(", "))
}

/// Returns a hash of `values` in which `0.0` and `-0.0` (equal numbers) hash alike.
pub(crate) fn hash_reals<'a>(values: impl IntoIterator<Item = &'a f64>) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for v in values {
        let v = if *v == 0.0 { 0.0f64 } else { *v };
        v.to_bits().hash(&mut h);
    }
    h.finish()
}

/// Returns the row-major array of `m`.
fn matrix(m: DMat3) -> Array2<f64> {
    let rows = m.transpose().to_cols_array();
    Array2::from_shape_vec((3, 3), rows.to_vec()).expect("nine values")
}

/// Where a sonar is mounted in a common frame (x forward, y left, z up):
/// `p_common = rotation · p_sonar + position`.
#[pyclass(name = "Mount", module = "sonarproj", frozen)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct PyMount {
    inner: Mount,
}

#[pymethods]
impl PyMount {
    /// Returns the mount at `position` (m) turned by `quat_xyzw` (x, y, z, w) or by URDF `rpy`
    /// (deg, fixed axes: Rz(yaw) Ry(pitch) Rx(roll)). No rotation when neither is given.
    #[new]
    #[pyo3(signature = (position, *, quat_xyzw=None, rpy=None))]
    fn new(
        #[pyo3(from_py_with = arg::position)] position: [f64; 3],
        #[pyo3(from_py_with = arg::opt_quat_xyzw)] quat_xyzw: Option<[f64; 4]>,
        #[pyo3(from_py_with = arg::rpy)] rpy: Option<[f64; 3]>,
    ) -> PyResult<Self> {
        let p = DVec3::from_array(position);
        let inner = match (quat_xyzw, rpy) {
            (Some(_), Some(_)) => {
                return Err(errors::input("quat_xyzw", "give quat_xyzw or rpy, not both"));
            }
            (Some([x, y, z, w]), None) => Mount::new(DQuat::from_xyzw(x, y, z, w), p),
            (None, Some([r, pi, y])) => Mount::from_rpy_deg(r, pi, y, p),
            (None, None) => Mount::new(DQuat::IDENTITY, p),
        }
        .map_err(errors::engine)?;
        Ok(PyMount { inner })
    }

    /// Returns the mount given in FRD axes (x forward, y starboard, z down; NED for a world
    /// frame), converted to the common FLU frame.
    #[staticmethod]
    fn from_frd(
        #[pyo3(from_py_with = arg::position)] position: [f64; 3],
        #[pyo3(from_py_with = arg::quat_xyzw)] quat_xyzw: [f64; 4],
    ) -> PyResult<Self> {
        let [x, y, z, w] = quat_xyzw;
        Ok(PyMount {
            inner: Mount::from_frd(DQuat::from_xyzw(x, y, z, w), DVec3::from_array(position))
                .map_err(errors::engine)?,
        })
    }

    /// The mount's rotation as a unit quaternion (x, y, z, w).
    #[getter]
    fn quat_xyzw(&self) -> [f64; 4] {
        self.inner.rotation().to_array()
    }

    /// The mount's position (m) in the common frame.
    #[getter]
    fn position(&self) -> [f64; 3] {
        self.inner.position().to_array()
    }

    /// Returns the call that makes this mount, every number to the last digit.
    fn __repr__(&self) -> String {
        format!(
            "Mount(position={}, quat_xyzw={})",
            list_text(&self.position()),
            list_text(&self.quat_xyzw())
        )
    }

    /// Mounts compare by value: the same quaternion and position, number for number.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<PyMount>().is_ok_and(|o| o.get().inner == self.inner)
    }

    /// Returns a hash of the quaternion and position, equal for equal mounts.
    fn __hash__(&self) -> u64 {
        hash_reals(self.quat_xyzw().iter().chain(&self.position()))
    }

    /// Returns this mount: it is immutable.
    fn __copy__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Returns this mount: it is immutable.
    fn __deepcopy__(slf: Py<Self>, _memo: &Bound<'_, PyAny>) -> Py<Self> {
        slf
    }

    /// Pickles as the mount's position and quaternion, which give back the same numbers.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Reduced<'py, ([f64; 3], [f64; 4])>> {
        let make = py.get_type::<PyMount>().getattr("_from_parts")?;
        Ok((make, (self.position(), self.quat_xyzw())))
    }

    /// Returns the mount of `position` and the unit quaternion `quat_xyzw` (for pickling).
    #[staticmethod]
    fn _from_parts(
        #[pyo3(from_py_with = arg::position)] position: [f64; 3],
        #[pyo3(from_py_with = arg::quat_xyzw)] quat_xyzw: [f64; 4],
    ) -> PyResult<Self> {
        let [x, y, z, w] = quat_xyzw;
        Ok(PyMount {
            inner: Mount::new(DQuat::from_xyzw(x, y, z, w), DVec3::from_array(position))
                .map_err(errors::engine)?,
        })
    }
}
