"""sonarproj: the epipolar geometry of sonar, from Python.

Given a feature measured by one sonar (a forward-looking imaging sonar, "fls", or a sidescan,
"sss") and the pose of a second sonar, sonarproj computes where in the second sonar's data the
feature can be: metrics of the projection (visible samples, range span, projection area),
occupancy in the second sonar's own layout, correspondence masks, and recovery of the coordinate
a sonar loses. The computation runs in the Rust engine (GPU when a hardware adapter exists, else
all CPU cores) with no subprocess and no temporary files.

Units at this boundary are those of the command line and its CSV columns: **metres** for ranges
and translations, **degrees** for every angle (azimuths, elevations, apertures, roll, pitch,
yaw, sigmas of angles). Conventions:

* A point at range ``r``, azimuth ``az``, elevation ``el`` of a sonar is
  ``(r cos el cos az, r cos el sin az, r sin el)``: x forward, y to port (left), z up. Positive
  azimuth is port; beam 0 of an imaging sonar is the starboard-most beam (-aperture/2).
* The pose of sonar 2 relative to sonar 1 maps a point of sonar 1's frame into sonar 2's:
  ``p2 = R p1 + t``. From roll, pitch, yaw (the paper's convention)
  ``R = (Rz(yaw) Ry(pitch) Rx(roll))^T``.
* Data layouts, as numpy holds them: an imaging sonar's image is ``(range_bins, beams)`` with
  row 0 at ``range_min`` and column 0 the starboard-most beam; a sidescan ping is
  ``(range_bins,)``, and a two-sided sidescan's (``Sonar.sides == 2``, HoloOcean's) one row of
  ``2 * range_bins``: port far to near, then starboard near to far. These are the layouts of
  the command line's NPY files (``Sonar.shape``).

>>> import sonarproj
>>> pose = sonarproj.Pose.placement(feature=(5, 10, 0), place=(15, 0, 0), pitch=90)
>>> m = sonarproj.project("paper-fls", "paper-sss", pose, (5, 10), step=0.1, backend="cpu-fast")
>>> m["visible"] == m["total"]
True
"""

from __future__ import annotations

import collections.abc as _abc
import json as _json
import os as _os
import warnings as _warnings
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

import numpy as _np

# Mesa's Vulkan device-select layer connects to a Wayland display to order the GPUs and prints
# "error: XDG_RUNTIME_DIR is invalid or not set" where there is none (a headless machine, a
# container); the engine chooses its adapter itself, so the layer is switched off there, as the
# command line does, unless the user set NODEVICE_SELECT.
if "XDG_RUNTIME_DIR" not in _os.environ and "NODEVICE_SELECT" not in _os.environ:
    _os.environ["NODEVICE_SELECT"] = "1"

from . import _sonarproj as _native  # noqa: E402
from ._sonarproj import (
    DEFAULT_CHUNK_POSES,
    DEFAULT_SUMMARY_CHUNK_POSES,
    METRIC_COLUMNS,
    BagPing,
    BagPings,
    InputError,
    InputTypeError,
    MaskSet,
    MaskSummary,
    Mount,
    OculusPing,
    Pose,
    Sonar,
    __version__,
    presets,
)

__all__ = [
    "PAPER_AREA_GRID",
    "AdviceWarning",
    "BackendNotice",
    "BagPing",
    "BagPings",
    "InputError",
    "InputTypeError",
    "MaskEngine",
    "MaskSet",
    "MaskSummary",
    "METRIC_COLUMNS",
    "Mount",
    "OculusPing",
    "Pose",
    "Sonar",
    "advise",
    "batch",
    "configure_gpu",
    "masks",
    "merge",
    "paper",
    "presets",
    "project",
    "masks_of_bag",
    "read_bag",
    "read_oculus",
    "recover",
    "recover_many",
    "sweep",
    "__version__",
]

SonarLike = Union[Sonar, str, "_os.PathLike[str]"]
"""A :class:`Sonar`, a preset name (see :func:`presets`), or the path of a sonar TOML file."""

PAPER_AREA_GRID = 0.08
"""The cell side (m) of the paper's projection-area grid: the default `area_grid`."""
_SIGMA_KEYS = ("roll", "pitch", "yaw", "tx", "ty", "tz", "range", "azimuth")
_PLAUSIBLE_ROTATION_SIGMA_DEG = 20.0
"""Above this 1-σ rotation (deg), a covariance is probably in deg² rather than rad²: warned."""


class BackendNotice(UserWarning):
    """Warned once per process when ``backend="auto"`` runs on the CPU, saying why (no GPU
    adapter, or only a software one, which is slower than the CPU path). It is shown as one
    line, ``sonarproj: note: …``, without the source line. ``backend="cpu-fast"`` chooses the
    CPU and is not warned; ``warnings.filterwarnings("ignore", category=sonarproj.BackendNotice)``
    silences it otherwise."""


_SILENCE = '; backend="cpu-fast" skips this note'
"""What every BackendNotice ends with: how to choose the CPU and be told nothing."""

_warned: set[str] = set()


def _warn(notice: Optional[str]) -> None:
    """Warns `notice` once per process (the backends are opened once and kept)."""
    if notice and notice not in _warned:
        _warned.add(notice)
        _warnings.warn(notice.removeprefix("note: ") + _SILENCE, BackendNotice, stacklevel=3)


_formatwarning = _warnings.formatwarning


def _format_notice(message, category, filename, lineno, line=None):  # type: ignore[no-untyped-def]
    """Formats a BackendNotice as one line, ``sonarproj: note: …``: where the call was says
    nothing of the machine. Every other warning is formatted as before."""
    if isinstance(category, type) and issubclass(category, BackendNotice):
        return f"sonarproj: note: {message}\n"
    return _formatwarning(message, category, filename, lineno, line)


_warnings.formatwarning = _format_notice


def _sonar(parameter: str, value: Any) -> Sonar:
    """Returns the sonar `value` names, or raises InputError naming `parameter`."""
    if isinstance(value, Sonar):
        return value
    if isinstance(value, (str, _os.PathLike)):
        text = _os.fspath(value)
        if isinstance(value, str) and text in presets():
            return Sonar.preset(text)
        if _os.path.isfile(text):
            return Sonar.from_toml(text)
        raise InputError(
            f"{parameter}: {text!r} is neither a preset ({', '.join(presets())}) nor a sonar TOML file"
        )
    raise InputTypeError(
        f"{parameter}: expected a Sonar, a preset name or a sonar file path, got {type(value).__name__}"
    )


def _pose(parameter: str, value: Any) -> Pose:
    if isinstance(value, Pose):
        return value
    raise InputTypeError(
        f"{parameter}: expected a sonarproj.Pose (Pose(roll, pitch, yaw, t=...), Pose.from_quat_xyzw, "
        f"Pose.from_matrix, Pose.placement or Pose.from_mounts), got {type(value).__name__}"
    )


def _number(parameter: str, value: Any, *, optional: bool = False) -> Optional[float]:
    """Returns `value` as a float, or raises InputError naming `parameter`."""
    if value is None and optional:
        return None
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, (int, float, _np.integer, _np.floating)):
        raise InputTypeError(f"{parameter}: expected a number, got {value!r} ({type(value).__name__})")
    try:
        return float(value)
    except OverflowError:
        raise InputError(f"{parameter}: {value} is too large for a float") from None


def _flag(parameter: str, value: Any) -> bool:
    """Returns `value`, which must be True or False, or raises InputTypeError naming `parameter`."""
    if isinstance(value, (bool, _np.bool_)):
        return bool(value)
    raise InputTypeError(f"{parameter}: expected True or False, got {value!r} ({type(value).__name__})")


def _real_array(parameter: str, value: Any) -> _np.ndarray:
    """Returns `value` as a float64 array, refusing non-numeric, boolean and complex dtypes."""
    try:
        a = _np.asarray(value)
    except Exception as e:  # ragged sequences and the like
        raise InputError(f"{parameter}: not an array of numbers ({e})") from None
    if a.dtype.kind not in "fiu":
        raise InputTypeError(
            f"{parameter}: dtype {a.dtype} is not a real number type; give float or integer values"
        )
    return _np.ascontiguousarray(a, dtype=_np.float64)


def _column(parameter: str, value: Any) -> _np.ndarray:
    a = _real_array(parameter, value)
    if a.ndim != 1:
        raise InputError(f"{parameter}: must be a 1-D array, got shape {a.shape}")
    return a


def _backend(value: Any) -> str:
    if not isinstance(value, str):
        raise InputTypeError(
            f'backend: expected "auto", "gpu", "cpu-fast" or "cpu", got {value!r} ({type(value).__name__})'
        )
    return value


def configure_gpu(
    *,
    adapter: Optional[str] = None,
    precision: Optional[str] = None,
    cull: Optional[bool] = None,
    filter: Optional[bool] = None,
    workgroup: Optional[int] = None,
    backends: Optional[Sequence[str]] = None,
) -> str:
    """Sets how the GPU is opened and the projection's splat stage built, for every backend and
    mask engine opened from now on (those opened before are forgotten and opened again on their
    next use). Every argument left ``None`` takes the engine's choice; results do not depend on
    ``cull``, ``filter`` or ``workgroup``.

    * ``adapter``: part of the adapter's name (case-insensitive), e.g. ``"H100"``; default the
      high-performance adapter.
    * ``precision``: ``"f64"`` or ``"double-f32"`` (the arithmetic of GPUs without f64, measured
      on one that has it); default f64 where the adapter has it.
    * ``cull``, ``filter``: the splat stage's block culling and f32 filter; default on for a
      hardware GPU, off for a software one such as lavapipe.
    * ``workgroup``: threads a workgroup of the splat stage, 32, 64, 128 or 256; default 64.
    * ``backends``: the wgpu backends to look on, e.g. ``["vulkan"]``; default Vulkan, Metal and
      DX12.

    Returns a short description of the options set. Raises :class:`InputTypeError` naming the
    argument for a value of the wrong type, :class:`InputError` for one not allowed.

    >>> sonarproj.configure_gpu(workgroup=128)
    '128 threads a workgroup'
    """
    if adapter is not None and not isinstance(adapter, str):
        raise InputTypeError(f"adapter: expected a string or None, got {adapter!r}")
    if precision is not None and not isinstance(precision, str):
        raise InputTypeError(f'precision: expected "f64", "double-f32" or None, got {precision!r}')
    for name, value in (("cull", cull), ("filter", filter)):
        if value is not None and not isinstance(value, (bool, _np.bool_)):
            raise InputTypeError(f"{name}: expected True, False or None, got {value!r}")
    cull, filter = (None if v is None else bool(v) for v in (cull, filter))
    sizes = _native.SPLAT_WORKGROUPS
    if workgroup is not None and (isinstance(workgroup, bool) or not isinstance(workgroup, (int, _np.integer))):
        raise InputTypeError(f"workgroup: expected one of {', '.join(map(str, sizes))} or None, got {workgroup!r}")
    if workgroup is not None and int(workgroup) not in sizes:
        raise InputError(f"workgroup: expected one of {', '.join(map(str, sizes))} or None, got {workgroup!r}")
    names: Optional[list[str]] = None
    if backends is not None:
        if isinstance(backends, str) or not hasattr(backends, "__iter__"):
            raise InputTypeError(f'backends: expected a list of names such as ["vulkan"], got {backends!r}')
        names = list(backends)
        if not all(isinstance(b, str) for b in names):
            raise InputTypeError(f'backends: expected a list of names such as ["vulkan"], got {backends!r}')
    return _native.configure_gpu(
        names, adapter, precision, cull, filter, None if workgroup is None else int(workgroup)
    )


def _step(value: Any) -> Union[None, float, str]:
    """Returns `step` for the engine: a number of degrees, ``"auto"``, ``"exact"`` or None."""
    if isinstance(value, str):
        if value.strip().lower() in ("auto", "exact"):
            return value.strip().lower()
        raise InputError(f"step: expected a number of degrees, 'auto', 'exact' or None, got {value!r}")
    return _number("step", value, optional=True)


def _columns_of(parameter: str, table: Any) -> tuple[list[str], Callable[[str], Any]]:
    """Returns the column names of a mapping or DataFrame and a getter."""
    if hasattr(table, "keys") and hasattr(table, "__getitem__"):
        keys = list(table.keys())
        for k in keys:
            if not isinstance(k, str):
                raise InputTypeError(f"{parameter}: column names must be strings, got {k!r} ({type(k).__name__})")
        return keys, lambda k: table[k]
    raise InputTypeError(
        f"{parameter}: expected a mapping of column name to 1-D array (a dict or a pandas DataFrame), "
        f"got {type(table).__name__}"
    )


def _same_length_columns(parameter: str, order: Sequence[str], get: Callable[[str], Any]) -> list[_np.ndarray]:
    """Returns the columns `order` of a table as 1-D float64 arrays of one length."""
    cols = [_column(f"{parameter}[{n!r}]", get(n)) for n in order]
    if len({len(c) for c in cols}) > 1:
        detail = ", ".join(f"{n}: {len(c)}" for n, c in zip(order, cols))
        raise InputError(f"{parameter}: the columns have different lengths ({detail})")
    return cols


def _require(parameter: str, names: Sequence[str], wanted: Sequence[str]) -> None:
    """Raises InputError naming the columns of `wanted` missing from `names`."""
    missing = [n for n in wanted if n not in names]
    if missing:
        raise InputError(f"{parameter}: missing column(s) {', '.join(missing)}")


def batch(
    first: SonarLike,
    second: SonarLike,
    poses: Mapping[str, Any],
    *,
    step: Optional[float] = None,
    area_grid: float = PAPER_AREA_GRID,
    sigma_range: Optional[float] = None,
    backend: str = "auto",
) -> dict[str, _np.ndarray]:
    """Returns the metrics of many projections of features of sonar `first` into sonar `second`.

    `poses` is a mapping (a dict of 1-D arrays, or a pandas DataFrame) with the columns of the
    command line's ``batch`` input: ``range`` (and ``azimuth`` for an imaging `first`: the
    measurement, m and deg); the rotation ``R`` of ``p2 = R p1 + t`` as ``roll, pitch, yaw``
    (deg, the paper's convention), a unit quaternion ``qw, qx, qy, qz`` (scalar first) or the
    matrix ``r11 … r33`` (row-major); and either ``place_range, place_azimuth,
    place_elevation`` (where the true point appears in `second`: m, deg, deg; then ``azimuth``
    and ``elevation``, the feature's true point in `first`, are required) or ``tx, ty, tz``
    (m; ``elevation`` optional). `step` is the sampling step (deg) of the arc or surface as in
    the published code (e.g. 0.1); None (or ``"auto"``) chooses it from `second`'s resolution;
    ``"exact"`` solves an imaging `first`'s arc in closed form (no samples: ``visible`` and
    ``total`` are 0, ``visible_fraction`` the visible share of the arc). `area_grid` is
    the cell side (m) of the grid ``projection_area`` counts (the paper's 0.08 m).
    `sigma_range` is the range error (m) ``sigma_elevation`` is computed for (None: the bin
    width over √12 of the sonar whose range pins the elevation). `backend`
    is ``"auto"`` (GPU on a hardware adapter, else every CPU core, with a
    :class:`BackendNotice`), ``"gpu"``, ``"cpu-fast"`` or ``"cpu"`` (the f64 reference).

    Returns a dict of 1-D arrays named as the command line's metric columns (``visible, total,
    range_min, range_max, span, azimuth_min, azimuth_max, occupied, occupied_measure,
    projection_area, range_per_elevation, sigma_elevation``): counts as int64, the rest
    float64 in m, deg, and m (sidescan) or m² (imaging) for ``occupied_measure``, m² for
    ``projection_area``, m/deg and deg for the local precision at the feature's true point;
    NaN where the command line leaves a cell empty (nothing visible; ``projection_area`` for a
    sidescan `second`; the local precision without the true point, or for two sidescans).
    The numbers are those of ``sonarproj batch`` for the same inputs, bit for bit on the CPU
    backends. Runs without the GIL; Ctrl-C stops it between chunks of 65 536 poses.

    Raises InputError (a ValueError) naming the column and row for bad input.
    """
    s1, s2 = _sonar("first", first), _sonar("second", second)
    names, get = _columns_of("poses", poses)
    cols = _same_length_columns("poses", names, get)
    result, notice = _native.batch_columns(
        s1,
        s2,
        names,
        cols,
        _step(step),
        _area_grid(area_grid),
        _number("sigma_range", sigma_range, optional=True),
        _backend(backend),
    )
    _warn(notice)
    return result


def _area_grid(value: Any) -> float:
    return _number("area_grid", value) or 0.0


def _feature(parameter: str, source: Sonar, feature: Any) -> tuple[float, float]:
    """Returns (range, azimuth) of one measurement of `source`."""
    a = _real_array(parameter, feature).reshape(-1)
    if source.kind == "fls":
        if a.shape != (2,):
            raise InputError(
                f"{parameter}: an imaging-sonar feature is (range, azimuth) in m and deg, got {feature!r}"
            )
        return float(a[0]), float(a[1])
    if a.shape != (1,):
        raise InputError(
            f"{parameter}: a sidescan feature is its range (m) alone; a sidescan measures no azimuth, got {feature!r}"
        )
    return float(a[0]), 0.0


def project(
    first: SonarLike,
    second: SonarLike,
    pose: Pose,
    feature: Any,
    *,
    elevation: Optional[float] = None,
    step: Optional[float] = None,
    area_grid: float = PAPER_AREA_GRID,
    sigma_range: Optional[float] = None,
    occupancy: bool = False,
    backend: str = "auto",
) -> dict[str, Any]:
    """Returns the projection of one feature of sonar `first` into sonar `second` under `pose`.

    `feature` is what `first` measured: ``(range, azimuth)`` (m, deg) for an imaging sonar, the
    range (m) for a sidescan. `pose` is a :class:`Pose` (``p2 = R p1 + t``). `elevation`
    (deg), when given, completes the feature's true point (with azimuth 0 for a sidescan) for
    ``range_per_elevation`` and ``sigma_elevation``. `step`, `area_grid`, `sigma_range` and
    `backend` as in :func:`batch`.

    Returns a dict with the metrics (the names of :func:`batch`'s columns, as Python numbers;
    NaN where nothing is visible), ``device``, and with ``occupancy=True`` the key
    ``"occupancy"``: a uint8 0/1 array in `second`'s layout, ``(range_bins, beams)`` for an
    imaging sonar (row 0 = range_min, column 0 = the starboard-most beam) or ``(range_bins,)``
    for a sidescan (``(2 * range_bins,)`` for a two-sided one), as the command line's NPY files.
    """
    s1, s2 = _sonar("first", first), _sonar("second", second)
    p = _pose("pose", pose)
    r, az = _feature("feature", s1, feature)
    result, notice = _native.project_one(
        s1,
        s2,
        p,
        r,
        az,
        _number("elevation", elevation, optional=True),
        _step(step),
        _area_grid(area_grid),
        _number("sigma_range", sigma_range, optional=True),
        _flag("occupancy", occupancy),
        _backend(backend),
    )
    _warn(notice)
    return result


def _sigma(sigma: Any, covariance: Any) -> Optional[list[float]]:
    """Returns the eight sigmas [roll, pitch, yaw (deg), tx, ty, tz (m), range (m), azimuth
    (deg)] of `sigma` and `covariance`, or None when neither is given."""
    if sigma is None and covariance is None:
        return None
    values = dict.fromkeys(_SIGMA_KEYS, 0.0)
    if sigma is not None:
        if not isinstance(sigma, Mapping):
            raise InputTypeError(
                f"sigma: expected a dict with keys among {', '.join(_SIGMA_KEYS)}, got {type(sigma).__name__}"
            )
        for k, v in sigma.items():
            if k not in values:
                raise InputError(f"sigma: unknown key {k!r}; the keys are {', '.join(_SIGMA_KEYS)}")
            values[k] = _number(f"sigma[{k!r}]", v)
    if covariance is not None:
        if sigma is not None and any(k in sigma for k in _SIGMA_KEYS[:6]):
            raise InputError(
                "covariance: give the pose's uncertainty once: a covariance, or sigmas of "
                "roll/pitch/yaw/tx/ty/tz, not both (sigma may still give range and azimuth)"
            )
        c = _real_array("covariance", covariance)
        if c.shape != (6, 6):
            raise InputError(
                f"covariance: must be a 6x6 array (x, y, z, roll, pitch, yaw; m² and rad²), got shape {c.shape}"
            )
        if not _np.all(_np.isfinite(c)):
            raise InputError("covariance: holds values that are not finite")
        scale = max(float(_np.max(_np.abs(c))), 1e-300)
        if float(_np.max(_np.abs(c - c.T))) > 1e-9 * scale:
            raise InputError("covariance: is not symmetric")
        for name, block, unit in (("translation", c[:3, :3], "m²"), ("rotation", c[3:, 3:], "rad²")):
            lam = _np.linalg.eigvalsh(block)
            if lam[0] < -1e-9 * scale:
                raise InputError(
                    f"covariance: its {name} block has a negative eigenvalue ({lam[0]:.3g} {unit}): not a covariance"
                )
        # Conservative per-axis bounds: each axis gets the standard deviation along the block's
        # worst direction, sqrt of its largest eigenvalue.
        st = float(_np.sqrt(max(_np.linalg.eigvalsh(c[:3, :3])[-1], 0.0)))
        sr = float(_np.degrees(_np.sqrt(max(_np.linalg.eigvalsh(c[3:, 3:])[-1], 0.0))))
        # The engine's bounds on the sigmas these become, said in the covariance's own terms.
        for block, sd, most, unit in (("rotation", sr, 180.0, "°"), ("translation", st, 10_000.0, " m")):
            if sd > most:
                raise InputError(
                    f"covariance: its {block} block's largest standard deviation is {sd:.4g}{unit}, "
                    f"more than the {most:g}{unit} a sigma may be"
                )
        if sr > _PLAUSIBLE_ROTATION_SIGMA_DEG:
            largest = float(_np.max(_np.diag(c)[3:]))
            _warnings.warn(
                f"covariance: a rotation variance of {largest:.4g} rad² is a standard deviation of "
                f"{sr:.3g}°, more than any pose estimate holds: is the covariance in deg² instead of "
                f"rad²? (In deg² that variance would be {_np.sqrt(largest):.3g}°.) It is used as given.",
                UserWarning,
                stacklevel=3,
            )
        values.update(roll=sr, pitch=sr, yaw=sr, tx=st, ty=st, tz=st)
    return [values[k] for k in _SIGMA_KEYS]


def _features(parameter: str, source: Sonar, features: Any) -> tuple[list[float], Optional[list[float]]]:
    """Returns the ranges and azimuths (None for a sidescan) of a ping's features."""
    a = _real_array(parameter, features)
    if source.kind == "fls":
        if a.ndim == 1 and a.shape == (2,):
            a = a.reshape(1, 2)
        if a.ndim != 2 or a.shape[1] != 2:
            raise InputError(
                f"{parameter}: imaging-sonar features are an (n, 2) array of (range m, azimuth deg), got shape {a.shape}"
            )
        return a[:, 0].tolist(), a[:, 1].tolist()
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise InputError(
            f"{parameter}: sidescan features are a 1-D array of ranges (m); a sidescan measures no azimuth, got shape {a.shape}"
        )
    return a.tolist(), None


def _coverage(value: Any) -> float:
    return _number("coverage", value)


class MaskEngine:
    """Draws correspondence masks of features of sonar `first` in sonar `second`'s data; built
    once and used for every ping (on a GPU it keeps its buffers between pings).

    `backend` as in :func:`batch` (``"cpu"`` and ``"cpu-fast"`` are the same for masks: f64 on
    every core). `counts=True` makes the engine able to return per-pixel counts (drawn on the
    CPU only; ``"auto"`` then chooses the CPU).
    """

    def __init__(self, first: SonarLike, second: SonarLike, *, backend: str = "auto", counts: bool = False):
        self.first = _sonar("first", first)
        self.second = _sonar("second", second)
        self._backend = _backend(backend)
        self._counts = _flag("counts", counts)
        self._engine = _native._MaskEngine(self.first, self.second, self._backend, self._counts)
        _warn(self._engine.notice)

    def __repr__(self) -> str:
        """The call that makes this engine, and where it draws."""
        def sonar(s: Sonar) -> str:
            return repr(s.name) if s.name in presets() and Sonar.preset(s.name) == s else repr(s)

        counts = ", counts=True" if self._counts else ""
        return f"MaskEngine({sonar(self.first)}, {sonar(self.second)}, backend={self._backend!r}{counts})"

    @property
    def device(self) -> str:
        """Where masks are drawn."""
        return self._engine.device

    def masks(
        self,
        pose: Pose,
        features: Any,
        *,
        sigma: Optional[Mapping[str, float]] = None,
        covariance: Any = None,
        coverage: float = 0.99,
        counts: bool = False,
        dense: bool = True,
    ) -> MaskSet:
        """Returns the masks of one ping's features under `pose`.

        `features`: an ``(n, 2)`` array of (range m, azimuth deg) for an imaging sonar `first`,
        a 1-D array of ranges (m) for a sidescan. `sigma`: standard deviations as a dict with
        keys among ``roll, pitch, yaw`` (deg), ``tx, ty, tz`` (m), ``range`` (m), ``azimuth``
        (deg). `covariance`: a 6×6 pose covariance from a navigation filter in the order
        ``x, y, z, roll, pitch, yaw`` (m², rad², as ROS's PoseWithCovariance), bounded
        conservatively by the largest eigenvalue of its translation and rotation blocks. The
        masks are widened so the true pixel lies inside with probability at least `coverage`.

        Returns a :class:`MaskSet`: ``masks`` (uint8, ``(n, range_bins, beams)``, ``(n,
        range_bins)`` or for a two-sided sidescan ``(n, 2 * range_bins)``; row 0 = range_min,
        column 0 = the starboard-most beam), ``union``,
        ``boxes`` (per feature a dict of range_min, range_max in m and azimuth_min,
        azimuth_max in deg, or None), ``counts`` (uint32 like ``masks``, with ``counts=True``),
        ``radius``, ``noise_radius`` and ``device``.

        Dense masks take one byte a pixel a feature; more than 1 GiB of them (with counts, five
        bytes) is refused with :class:`InputError`. ``dense=False`` returns ``runs`` instead of
        ``masks``: per feature a uint64 ``(k, 2)`` array of ``[start, length]`` runs over one
        mask's pixels in row-major order (``masks[f].ravel()``); ``MaskSet.mask(f)`` gives one
        feature's mask as an array either way. The call runs without the GIL, in chunks of
        features, and Ctrl-C stops it between chunks.
        """
        p = _pose("pose", pose)
        ranges, azimuths = _features("features", self.first, features)
        return self._engine.masks(
            p, ranges, azimuths, _sigma(sigma, covariance), _coverage(coverage), _flag("counts", counts),
            _flag("dense", dense),
        )

    def summary(
        self,
        pose: Pose,
        features: Any,
        *,
        sigma: Optional[Mapping[str, float]] = None,
        covariance: Any = None,
        coverage: float = 0.99,
    ) -> MaskSummary:
        """Returns one ping's masks reduced to what a matcher looks at first, without their
        bits: a :class:`MaskSummary` with ``occupied`` (uint64, pixels per feature), ``boxes``,
        ``union``, ``radius``, ``noise_radius``, ``cells`` and ``device``, the same numbers as
        :meth:`masks` gives on this engine. On a GPU the masks are reduced there and only the
        union and 20 bytes a feature are read back. Parameters as in :meth:`masks`."""
        p = _pose("pose", pose)
        ranges, azimuths = _features("features", self.first, features)
        return self._engine.summary(p, ranges, azimuths, _sigma(sigma, covariance), _coverage(coverage))

    def summaries_of_pings(
        self,
        poses: Sequence[Pose],
        features: Sequence[Any],
        *,
        sigma: Optional[Mapping[str, float]] = None,
        covariance: Any = None,
        coverage: float = 0.99,
    ) -> list[MaskSummary]:
        """Returns :meth:`summary` of each ping, ``poses[k]`` with ``features[k]``; on a GPU two
        pings are in flight (the next uploaded while the one before is drawn). Ctrl-C stops it
        between groups of 64 pings."""
        ps, ranges, azimuths = self._pings(poses, features)
        return self._engine.summaries_of_pings(ps, ranges, azimuths, _sigma(sigma, covariance), _coverage(coverage))

    def _pings(self, poses: Sequence[Pose], features: Sequence[Any]) -> tuple[list, list, Optional[list]]:
        for name, value in (("poses", poses), ("features", features)):
            if isinstance(value, (Pose, str, bytes)) or not isinstance(value, _abc.Iterable):
                raise InputTypeError(
                    f"{name}: expected a sequence with one entry a ping, got {type(value).__name__}"
                )
        poses = list(poses)
        features = list(features)
        if len(poses) != len(features):
            raise InputError(
                f"features: {len(features)} pings of features for {len(poses)} poses; give one per pose"
            )
        ps = [_pose(f"poses[{k}]", p) for k, p in enumerate(poses)]
        fs = [_features(f"features[{k}]", self.first, f) for k, f in enumerate(features)]
        azimuths = None if self.first.kind == "sss" else [f[1] for f in fs]
        return ps, [f[0] for f in fs], azimuths

    def masks_of_pings(
        self,
        poses: Sequence[Pose],
        features: Sequence[Any],
        *,
        sigma: Optional[Mapping[str, float]] = None,
        covariance: Any = None,
        coverage: float = 0.99,
        counts: bool = False,
        dense: bool = True,
    ) -> list[MaskSet]:
        """Returns the masks of a sequence of pings: ``poses[k]`` and ``features[k]`` (as in
        :meth:`masks`) per ping, one :class:`MaskSet` each. On a GPU without counts two pings
        are in flight (the next is submitted while the one before is drawn) and Ctrl-C stops it
        between groups of 64 pings; otherwise between pings."""
        ps, ranges, azimuths = self._pings(poses, features)
        return self._engine.masks_of_pings(
            ps, ranges, azimuths, _sigma(sigma, covariance), _coverage(coverage), _flag("counts", counts),
            _flag("dense", dense),
        )


def masks(
    first: SonarLike,
    second: SonarLike,
    pose: Pose,
    features: Any,
    *,
    sigma: Optional[Mapping[str, float]] = None,
    covariance: Any = None,
    coverage: float = 0.99,
    counts: bool = False,
    dense: bool = True,
    backend: str = "auto",
) -> MaskSet:
    """Returns the correspondence masks of one ping: where each of `features` (measured by
    `first`) can be in `second`'s data under `pose`. A one-off :class:`MaskEngine`; build one
    and call :meth:`MaskEngine.masks` for a stream of pings. Parameters as there."""
    engine = MaskEngine(first, second, backend=backend, counts=counts)
    return engine.masks(pose, features, sigma=sigma, covariance=covariance, coverage=coverage, counts=counts,
                        dense=dense)


def _observation(parameter: str, sonar: Sonar, value: Any) -> tuple[float, float]:
    r, az = _feature(parameter, sonar, value)
    return (r, az) if sonar.kind == "fls" else (r, float("nan"))


def recover(
    first: SonarLike,
    second: SonarLike,
    pose: Pose,
    first_obs: Any,
    second_obs: Any,
    *,
    sigma_range: Optional[float] = None,
    sigma_azimuth: Optional[float] = None,
    curve_step: float = 0.01,
) -> dict[str, Any]:
    """Returns the 3-D point(s) of one correspondence: the coordinate each sonar lost, recovered
    from both measurements and the pose.

    `first_obs` and `second_obs` are what each sonar measured: ``(range, azimuth)`` (m, deg)
    for an imaging sonar, the range (m) for a sidescan. `sigma_range` (m) and `sigma_azimuth`
    (deg) give first-order sigmas of the recovered elevation. For two sidescans the answer is
    the visible part of a circle, sampled every `curve_step` m.

    Returns the command line's ``recover`` JSON as a dict: ``candidates`` (best first; each with
    ``point_first``, ``point_second`` in m, ``first``, ``second`` as [range m, azimuth deg,
    elevation deg], ``in_view`` and more), ``flags`` and ``curve``.
    """
    s1, s2 = _sonar("first", first), _sonar("second", second)
    p = _pose("pose", pose)
    text = _native.recover_one(
        s1,
        s2,
        p,
        _observation("first_obs", s1, first_obs),
        _observation("second_obs", s2, second_obs),
        _number("sigma_range", sigma_range, optional=True),
        _number("sigma_azimuth", sigma_azimuth, optional=True),
        _number("curve_step", curve_step),
    )
    return _json.loads(text)


def recover_many(
    first: SonarLike,
    second: SonarLike,
    pose: Union[Pose, Sequence[Pose]],
    correspondences: Mapping[str, Any],
    *,
    sigma_range: Optional[float] = None,
    sigma_azimuth: Optional[float] = None,
) -> dict[str, Any]:
    """Returns the recovery of many correspondences, vectorised.

    `pose` is one :class:`Pose` for every correspondence, or a sequence of poses, one per
    correspondence (a robot that moved between them). `correspondences` is a mapping of 1-D arrays: ``first_range``, ``second_range`` (m), and
    ``first_azimuth`` / ``second_azimuth`` (deg) for the imaging sonars among the two.

    Returns a dict of arrays, one value per correspondence: ``candidates`` (int64), the best
    candidate's ``in_view`` (bool), ``x_first, y_first, z_first, x_second, y_second, z_second``
    (m), ``range_first, azimuth_first, elevation_first, range_second, azimuth_second,
    elevation_second`` (m, deg), ``range_per_elevation`` (m/deg), ``sigma_elevation`` (deg),
    ``azimuth_residual`` (deg), ``consistent`` (1.0, 0.0 or NaN) — NaN where there is no single
    best point — ``curve_length`` (m, two sidescans) and ``flags`` (a list of ';'-joined names).
    """
    s1, s2 = _sonar("first", first), _sonar("second", second)
    if isinstance(pose, Pose):
        poses = [pose]
    elif isinstance(pose, Sequence) and not isinstance(pose, (str, bytes)):
        poses = [_pose(f"pose[{i}]", p) for i, p in enumerate(pose)]
    else:
        poses = [_pose("pose", pose)]
    names, get = _columns_of("correspondences", correspondences)
    wanted = ["first_range", "second_range"]
    if s1.kind == "fls":
        wanted.append("first_azimuth")
    if s2.kind == "fls":
        wanted.append("second_azimuth")
    unknown = [n for n in names if n not in wanted]
    if unknown:
        raise InputError(
            f"correspondences: unexpected column(s) {', '.join(unknown)} for a {s1.kind}+{s2.kind} pair; "
            f"the columns are {', '.join(wanted)}"
        )
    _require("correspondences", names, wanted)
    cols = dict(zip(wanted, _same_length_columns("correspondences", wanted, get)))
    nan = _np.full(len(cols["first_range"]), _np.nan)
    ordered = [
        cols["first_range"],
        cols.get("first_azimuth", nan),
        cols["second_range"],
        cols.get("second_azimuth", nan),
    ]
    return _native.recover_columns(
        s1,
        s2,
        poses,
        ordered,
        _number("sigma_range", sigma_range, optional=True),
        _number("sigma_azimuth", sigma_azimuth, optional=True),
    )


from ._advise import AdviceWarning, advise  # noqa: E402
from ._readers import masks_of_bag, read_bag, read_oculus  # noqa: E402
from ._apps import merge, paper, sweep  # noqa: E402


def __dir__() -> list[str]:
    """The public API only (PEP 562): what ``__all__`` names."""
    return sorted(__all__)
