//! Python arguments read strictly, as numpy users expect. A number is an `int` or a `float`
//! (numpy's too), never a `bool`, a complex or a string. A count is an integer that fits. A
//! vector or matrix has the stated shape. A bad argument raises an `InputError` whose message
//! starts with the argument's name, or an `InputTypeError` (also a `TypeError`) for a wrong
//! type. The named readers at the end are what `#[pyo3(from_py_with = …)]` takes.

use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyFloat, PyInt, PyString, PyType};

use crate::errors::{self, InputError};

/// The class of wrong-type errors, `InputTypeError(InputError, TypeError)`, made once.
static INPUT_TYPE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// Returns the `InputTypeError` class (a subclass of `InputError` and `TypeError`).
pub(crate) fn input_type_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    INPUT_TYPE_ERROR
        .get_or_try_init(py, || -> PyResult<Py<PyType>> {
            let builtins = py.import("builtins")?;
            let type_error = builtins.getattr("TypeError")?;
            let input = py.get_type::<InputError>();
            let bases = pyo3::types::PyTuple::new(py, [input.into_any(), type_error])?;
            let namespace = pyo3::types::PyDict::new(py);
            namespace.set_item("__module__", "sonarproj")?;
            namespace.set_item(
                "__doc__",
                "Bad input of the wrong type: an InputError that is also a TypeError; the \
                 message names the parameter.",
            )?;
            let class = builtins
                .getattr("type")?
                .call1(("InputTypeError", bases, namespace))?;
            Ok(class.cast_into::<PyType>()?.unbind())
        })
        .map(|t| t.bind(py))
}

/// Returns an `InputTypeError` for `name`: `message`.
pub(crate) fn wrong_type(py: Python<'_>, name: &str, message: impl std::fmt::Display) -> PyErr {
    match input_type_error(py) {
        Ok(class) => PyErr::from_type(class.clone(), format!("{name}: {message}")),
        Err(e) => e,
    }
}

/// Returns `ob` shown for a message: its repr (cut to 60 characters) and its type.
pub(crate) fn shown(ob: &Bound<'_, PyAny>) -> String {
    let repr = ob.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
    let repr = if repr.chars().count() > 60 {
        format!("{}…", repr.chars().take(60).collect::<String>())
    } else {
        repr
    };
    let type_name = ob
        .get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string());
    format!("{repr} ({type_name})")
}

/// Returns whether `ob` is a `bool` or a numpy bool.
fn is_bool(ob: &Bound<'_, PyAny>) -> bool {
    ob.is_instance_of::<PyBool>() || numpy_kind(ob) == Some('b')
}

/// Returns the numpy dtype kind of a numpy scalar or 0-d array `ob`, if it is one.
fn numpy_kind(ob: &Bound<'_, PyAny>) -> Option<char> {
    let dtype = ob.getattr("dtype").ok()?;
    let kind: String = dtype.getattr("kind").ok()?.extract().ok()?;
    let ndim: usize = ob.getattr("ndim").ok()?.extract().ok()?;
    (ndim == 0).then(|| kind.chars().next()).flatten()
}

/// Returns `ob` as a string for argument `name`; an `InputTypeError` naming it for anything else.
pub(crate) fn text(name: &str, ob: &Bound<'_, PyAny>) -> PyResult<String> {
    if ob.is_instance_of::<PyString>() {
        return ob.extract();
    }
    Err(wrong_type(
        ob.py(),
        name,
        format!("expected a string, got {}", shown(ob)),
    ))
}

/// Returns `ob` as a real number for argument `name`.
pub(crate) fn real(name: &str, ob: &Bound<'_, PyAny>) -> PyResult<f64> {
    let py = ob.py();
    if is_bool(ob) {
        return Err(wrong_type(
            py,
            name,
            format!("expected a number, got {}", shown(ob)),
        ));
    }
    let numeric = ob.is_instance_of::<PyFloat>()
        || ob.is_instance_of::<PyInt>()
        || matches!(numpy_kind(ob), Some('f' | 'i' | 'u'));
    if !numeric {
        return Err(wrong_type(
            py,
            name,
            format!("expected a number, got {}", shown(ob)),
        ));
    }
    ob.extract::<f64>()
        .map_err(|_| errors::input(name, format!("{} does not fit a float", shown(ob))))
}

/// Returns `ob` as a count (an integer in `[0, 2^32)`) for argument `name`. The caller checks
/// the range the sonar allows.
pub(crate) fn count(name: &str, ob: &Bound<'_, PyAny>) -> PyResult<u32> {
    let py = ob.py();
    let integer = !is_bool(ob) && (ob.is_instance_of::<PyInt>() || matches!(numpy_kind(ob), Some('i' | 'u')));
    if !integer {
        return Err(wrong_type(
            py,
            name,
            format!("expected an integer, got {}", shown(ob)),
        ));
    }
    ob.extract::<u32>().map_err(|_| {
        let text = ob.str().map_or_else(|_| "?".to_string(), |s| s.to_string());
        errors::input(
            name,
            format!("{text} is not a count: give an integer from 1 to {}", u32::MAX),
        )
    })
}

/// Returns `ob`, a sequence or array of numbers, as `f64` values in C order for argument
/// `name`, checked to have `shape`. `None` in `shape` allows any length there.
pub(crate) fn reals(name: &str, ob: &Bound<'_, PyAny>, shape: &[Option<usize>]) -> PyResult<Vec<f64>> {
    let py = ob.py();
    if ob.is_instance_of::<PyString>() || ob.is_instance_of::<pyo3::types::PyBytes>() {
        return Err(wrong_type(
            py,
            name,
            format!("expected numbers, got {}", shown(ob)),
        ));
    }
    let numpy = py.import("numpy")?;
    let array = numpy
        .call_method1("asarray", (ob,))
        .map_err(|e| wrong_type(py, name, format!("not an array of numbers ({})", e.value(py))))?;
    let kind: String = array.getattr("dtype")?.getattr("kind")?.extract()?;
    // numpy turns [0, 0, True] into integers, so look for a bool in a list item by item.
    let has_bool = !ob.hasattr("dtype")?
        && numpy
            .call_method1("asarray", (ob, "object"))?
            .call_method0("ravel")?
            .try_iter()?
            .any(|item| item.is_ok_and(|item| is_bool(&item)));
    if has_bool || !matches!(kind.as_str(), "f" | "i" | "u") {
        let dtype = array.getattr("dtype")?.str()?.to_string();
        return Err(wrong_type(
            py,
            name,
            format!("expected real numbers, got {} (dtype {dtype})", shown(ob)),
        ));
    }
    let got: Vec<usize> = array.getattr("shape")?.extract()?;
    let fits = got.len() == shape.len() && got.iter().zip(shape).all(|(g, s)| s.is_none_or(|s| *g == s));
    if !fits {
        let want: Vec<String> = shape
            .iter()
            .map(|s| s.map_or_else(|| "n".to_string(), |n| n.to_string()))
            .collect();
        let want = if want.len() == 1 {
            format!("({},)", want[0])
        } else {
            format!("({})", want.join(", "))
        };
        return Err(errors::input(
            name,
            format!("must have shape {want}, got {}", tuple(&got)),
        ));
    }
    let flat = array
        .call_method1("astype", ("float64",))?
        .call_method0("ravel")?
        .call_method0("tolist")?;
    flat.extract()
}

/// Returns `shape` written as Python writes a tuple.
pub(crate) fn tuple(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Returns `ob` as `N` reals for argument `name`.
pub(crate) fn vector<const N: usize>(name: &str, ob: &Bound<'_, PyAny>) -> PyResult<[f64; N]> {
    let v = reals(name, ob, &[Some(N)])?;
    Ok(std::array::from_fn(|i| v[i]))
}

/// Returns `ob` as a 3 × 3 matrix (rows) for argument `name`.
pub(crate) fn matrix3(name: &str, ob: &Bound<'_, PyAny>) -> PyResult<[[f64; 3]; 3]> {
    let v = reals(name, ob, &[Some(3), Some(3)])?;
    Ok(std::array::from_fn(|i| std::array::from_fn(|j| v[3 * i + j])))
}

/// The readers of named arguments, for `#[pyo3(from_py_with = …)]`.
pub(crate) mod arg {
    use pyo3::prelude::*;

    macro_rules! reals {
        ($($f:ident),* $(,)?) => {$(
            #[doc = concat!("Reads the number `", stringify!($f), "`.")]
            pub(crate) fn $f(ob: &Bound<'_, PyAny>) -> PyResult<f64> {
                super::real(stringify!($f), ob)
            }
        )*};
    }
    macro_rules! vectors {
        ($($f:ident: $n:literal),* $(,)?) => {$(
            #[doc = concat!("Reads the vector `", stringify!($f), "`.")]
            pub(crate) fn $f(ob: &Bound<'_, PyAny>) -> PyResult<[f64; $n]> {
                super::vector(stringify!($f), ob)
            }
        )*};
    }
    macro_rules! optional_vectors {
        ($($f:ident = $name:literal: $n:literal),* $(,)?) => {$(
            #[doc = concat!("Reads the optional vector `", $name, "`.")]
            pub(crate) fn $f(ob: &Bound<'_, PyAny>) -> PyResult<Option<[f64; $n]>> {
                if ob.is_none() { Ok(None) } else { super::vector($name, ob).map(Some) }
            }
        )*};
    }
    macro_rules! optional_counts {
        ($($f:ident),* $(,)?) => {$(
            #[doc = concat!("Reads the optional count `", stringify!($f), "`.")]
            pub(crate) fn $f(ob: &Bound<'_, PyAny>) -> PyResult<Option<u32>> {
                if ob.is_none() { Ok(None) } else { super::count(stringify!($f), ob).map(Some) }
            }
        )*};
    }
    macro_rules! optional_lists {
        ($($f:ident),* $(,)?) => {$(
            #[doc = concat!("Reads the optional list of numbers `", stringify!($f), "`.")]
            pub(crate) fn $f(ob: &Bound<'_, PyAny>) -> PyResult<Option<Vec<f64>>> {
                if ob.is_none() { Ok(None) } else { super::reals(stringify!($f), ob, &[None]).map(Some) }
            }
        )*};
    }
    reals!(
        roll,
        pitch,
        yaw,
        range_min,
        range_max,
        azimuth_aperture,
        elevation_aperture
    );
    vectors!(t: 3, feature: 3, place: 3, position: 3, quat_xyzw: 4);
    optional_vectors!(opt_quat_xyzw = "quat_xyzw": 4, rpy = "rpy": 3);
    optional_counts!(beams, sides);
    optional_lists!(beam_edges, beam_centres);

    /// Reads the string `kind`.
    pub(crate) fn kind(ob: &Bound<'_, PyAny>) -> PyResult<String> {
        super::text("kind", ob)
    }

    /// Reads the preset `name`.
    pub(crate) fn name(ob: &Bound<'_, PyAny>) -> PyResult<String> {
        super::text("name", ob)
    }

    /// Reads the file `path`: a string or an `os.PathLike`.
    pub(crate) fn path(ob: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
        ob.extract().map_err(|_| {
            super::wrong_type(
                ob.py(),
                "path",
                format!("expected a path (str or os.PathLike), got {}", super::shown(ob)),
            )
        })
    }

    /// Reads the optional string `name`.
    pub(crate) fn opt_name(ob: &Bound<'_, PyAny>) -> PyResult<Option<String>> {
        if ob.is_none() {
            Ok(None)
        } else {
            super::text("name", ob).map(Some)
        }
    }

    /// Reads the count `range_bins`.
    pub(crate) fn range_bins(ob: &Bound<'_, PyAny>) -> PyResult<u32> {
        super::count("range_bins", ob)
    }

    /// Reads the 3 × 3 `matrix`.
    pub(crate) fn matrix(ob: &Bound<'_, PyAny>) -> PyResult<[[f64; 3]; 3]> {
        super::matrix3("matrix", ob)
    }

    /// Reads the optional 3 × 3 `matrix`.
    pub(crate) fn opt_matrix(ob: &Bound<'_, PyAny>) -> PyResult<Option<[[f64; 3]; 3]>> {
        if ob.is_none() {
            Ok(None)
        } else {
            super::matrix3("matrix", ob).map(Some)
        }
    }
}
