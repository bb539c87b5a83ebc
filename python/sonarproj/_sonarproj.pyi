"""Type stubs of the native module. Angles in degrees, distances in metres."""

from os import PathLike
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str
METRIC_COLUMNS: list[str]
SPLAT_WORKGROUPS: list[int]
DEFAULT_CHUNK_POSES: int
DEFAULT_SUMMARY_CHUNK_POSES: int

class InputError(ValueError):
    """Bad input: the message names the parameter, the value and what is allowed."""

class InputTypeError(InputError, TypeError):
    """Bad input of the wrong type (a bool or a string where a number goes, complex values):
    an InputError that is also a TypeError; the message names the parameter."""

def configure_gpu(
    backends: Optional[list[str]],
    adapter: Optional[str],
    precision: Optional[str],
    cull: Optional[bool],
    filter: Optional[bool],
    workgroup: Optional[int],
) -> str: ...
def presets() -> list[str]:
    """Returns the names of the preset sonars."""

class Sonar:
    """A sonar: kind ("fls" imaging or "sss" sidescan), field of view and data layout.

    ``Sonar(kind, range_min, range_max, azimuth_aperture, elevation_aperture, range_bins,
    beams=None, beam_edges=None, beam_centres=None, name=None, sides=None)``: ranges in m
    (``0 <= range_min < range_max <= 10000``), full apertures in deg (azimuth in (0, 360],
    elevation in (0, 180]), and for an imaging sonar exactly one of ``beams`` (uniform count),
    ``beam_edges`` (deg, beams + 1 increasing values from -aperture/2 to +aperture/2) or
    ``beam_centres`` (deg; the edges are the midpoints). A sidescan takes none of them; its
    ``sides`` is 1 (default) or 2: one fan over port and starboard whose data is one row of
    ``2 * range_bins`` values, port far to near then starboard near to far (HoloOcean's
    SidescanSonar, whose ``RangeBins`` is ``2 * range_bins``).
    """

    def __init__(
        self,
        kind: str,
        range_min: float,
        range_max: float,
        azimuth_aperture: float,
        elevation_aperture: float,
        range_bins: int,
        beams: Optional[int] = None,
        beam_edges: Optional[Sequence[float]] = None,
        beam_centres: Optional[Sequence[float]] = None,
        name: Optional[str] = None,
        sides: Optional[int] = None,
    ) -> None: ...
    @staticmethod
    def preset(name: str) -> Sonar:
        """Returns the preset called `name` (see :func:`presets`)."""
    @staticmethod
    def from_toml(path: Union[str, PathLike[str]]) -> Sonar:
        """Returns the sonar described by a sonar TOML file (the command line's format)."""
    @staticmethod
    def from_projected_sonar_image(
        beam_directions: Any, ranges: Any, elevation_aperture: float, name: Optional[str] = None
    ) -> tuple[Sonar, npt.NDArray[np.uintp]]:
        """Returns ``(sonar, columns)`` for a ROS ``marine_acoustic_msgs/ProjectedSonarImage``'s
        beam table: ``beam_directions`` ((n, 3), the message's frame: X up, Y starboard, Z
        forward), ``ranges`` (bin centres, m, evenly spaced) and ``elevation_aperture`` (deg, the
        message's ``ping_info.tx_beamwidths`` in degrees). Beam ``k`` of the sonar is column
        ``columns[k]`` of the message's image: ``image[:, columns]`` is in this project's layout."""
    @staticmethod
    def from_holoocean(
        sensor: Mapping[str, Any], sensor_type: Optional[str] = None, name: Optional[str] = None
    ) -> Sonar:
        """Returns the sonar HoloOcean simulates for a scenario's sensor entry (``{"sensor_type":
        "ImagingSonar", "configuration": {...}}``), or for a configuration block with
        `sensor_type` given apart: ``ImagingSonar`` (an FLS of ``(RangeBins, AzimuthBins)``, column
        0 the starboard-most) or ``SidescanSonar`` (a two-sided sidescan, ``RangeBins / 2`` bins a
        side). Keys that only shape intensities are ignored; unknown keys are refused."""
    @property
    def name(self) -> str: ...
    @property
    def kind(self) -> str:
        """"fls" or "sss"."""
    @property
    def range_min(self) -> float:
        """Minimum range (m)."""
    @property
    def range_max(self) -> float:
        """Maximum range (m)."""
    @property
    def azimuth_aperture(self) -> float:
        """Full azimuth aperture (deg)."""
    @property
    def elevation_aperture(self) -> float:
        """Full elevation aperture (deg)."""
    @property
    def range_bins(self) -> int: ...
    @property
    def beams(self) -> int:
        """Number of beams (1 for a sidescan; 2 for a two-sided one: starboard, port)."""
    @property
    def sides(self) -> int:
        """2 for a two-sided sidescan (one row of port and starboard), else 1."""
    @property
    def beam_edges(self) -> npt.NDArray[np.float64]:
        """Beam edges (deg), from -aperture/2 (starboard) to +aperture/2 (port)."""
    @property
    def shape(self) -> tuple[int, ...]:
        """``(range_bins, beams)`` for an imaging sonar, ``(range_bins,)`` for a sidescan,
        ``(2 * range_bins,)`` for a two-sided one."""

class Pose:
    """The pose of sonar 2 relative to sonar 1: ``p2 = R p1 + t``.

    ``Pose(roll=0, pitch=0, yaw=0, t=(0, 0, 0))``: roll, pitch, yaw in deg with the paper's
    ``R = (Rz(yaw) Ry(pitch) Rx(roll))^T``, translation in m.
    """

    def __init__(
        self, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0, t: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> None: ...
    @staticmethod
    def from_quat_xyzw(quat_xyzw: Sequence[float], t: Sequence[float] = (0.0, 0.0, 0.0)) -> Pose:
        """Returns the pose whose R is the unit quaternion (x, y, z, w), the order of ROS and scipy."""
    @staticmethod
    def from_matrix(matrix: Any, t: Sequence[float] = (0.0, 0.0, 0.0)) -> Pose:
        """Returns the pose with the 3x3 rotation matrix R (orthonormal, det +1)."""
    @staticmethod
    def placement(
        feature: Sequence[float],
        place: Sequence[float],
        roll: float = 0.0,
        pitch: float = 0.0,
        yaw: float = 0.0,
        *,
        quat_xyzw: Optional[Sequence[float]] = None,
        matrix: Any = None,
    ) -> Pose:
        """Returns the paper's placement pose: the true point `feature` = (range m, azimuth deg,
        elevation deg) of sonar 1 appears at `place` in sonar 2: t = sph(place) - R sph(feature)."""
    @staticmethod
    def from_mounts(first: Mount, second: Mount) -> Pose:
        """Returns the pose of sonar 2 relative to sonar 1 from their mounts in a common frame."""
    @property
    def rotation(self) -> npt.NDArray[np.float64]:
        """R, 3x3."""
    @property
    def translation(self) -> npt.NDArray[np.float64]:
        """t (m)."""
    def apply(self, p: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Returns R p + t for points p (m) of sonar 1's frame, shape (3,) or (n, 3) of real
        numbers: the points in sonar 2's frame, same shape (float64)."""

class Mount:
    """Where a sonar is mounted in a common frame (x forward, y left, z up):
    ``p_common = rotation p_sonar + position``.

    ``Mount(position, *, quat_xyzw=None, rpy=None)``: position in m; rotation as a unit
    quaternion (x, y, z, w) or URDF roll, pitch, yaw in deg (fixed axes, Rz(yaw) Ry(pitch)
    Rx(roll)).
    """

    def __init__(
        self,
        position: Sequence[float],
        *,
        quat_xyzw: Optional[Sequence[float]] = None,
        rpy: Optional[Sequence[float]] = None,
    ) -> None: ...
    @staticmethod
    def from_frd(position: Sequence[float], quat_xyzw: Sequence[float]) -> Mount:
        """Returns the mount given in FRD axes (x forward, y starboard, z down)."""
    @property
    def quat_xyzw(self) -> list[float]: ...
    @property
    def position(self) -> list[float]: ...

class MaskSet:
    """The masks of one ping, in sonar 2's layout (row 0 = range_min, column 0 = the
    starboard-most beam)."""

    masks: Optional[npt.NDArray[np.uint8]]
    """0/1, ``(features, range_bins, beams)`` or ``(features, range_bins)`` (``(features,
    2 * range_bins)``, the row, for a two-sided sidescan); None with ``dense=False``."""
    runs: Optional[list[npt.NDArray[np.uint64]]]
    """With ``dense=False``: per feature ``(k, 2)`` runs ``[start, length]`` over one mask's
    pixels in row-major order; else None."""
    union: npt.NDArray[np.uint8]
    """0/1: every bin or pixel any feature may occupy."""
    counts: Optional[npt.NDArray[np.uint32]]
    """Per pixel, how many cells of the back-projected set may fall there (with counts=True)."""
    boxes: list[Optional[dict[str, float]]]
    """Per feature: range_min, range_max (m), azimuth_min, azimuth_max (deg), or None."""
    radius: list[float]
    """Per feature, the ball radius (m) drawn around each cell."""
    noise_radius: list[float]
    """Per feature, the widening for the sigmas (m), 0 without."""
    device: str
    def mask(self, k: int) -> npt.NDArray[np.uint8]:
        """Feature `k`'s mask as a dense 0/1 array in sonar 2's layout (from the runs with
        ``dense=False``)."""

class MaskSummary:
    """One ping's masks reduced (``MaskEngine.summary``): the numbers of :class:`MaskSet`
    without the masks' bits."""

    occupied: npt.NDArray[np.uint64]
    """Per feature, the bins or pixels of its mask."""
    boxes: list[Optional[dict[str, float]]]
    """Per feature: range_min, range_max (m), azimuth_min, azimuth_max (deg), or None."""
    union: npt.NDArray[np.uint8]
    """0/1: every bin or pixel any feature may occupy."""
    radius: list[float]
    """Per feature, the ball radius (m) drawn around each cell."""
    noise_radius: list[float]
    """Per feature, the widening for the sigmas (m), 0 without."""
    cells: list[int]
    """Per feature, the cells its back-projected set was cut into."""
    device: str

class _MaskEngine:
    def __init__(self, first: Sonar, second: Sonar, backend: str = "auto", counts: bool = False) -> None: ...
    @property
    def notice(self) -> Optional[str]: ...
    @property
    def device(self) -> str: ...
    def masks(
        self,
        pose: Pose,
        ranges: list[float],
        azimuths: Optional[list[float]],
        sigma: Optional[list[float]],
        coverage: float,
        counts: bool,
        dense: bool,
    ) -> MaskSet: ...
    def summary(
        self,
        pose: Pose,
        ranges: list[float],
        azimuths: Optional[list[float]],
        sigma: Optional[list[float]],
        coverage: float,
    ) -> MaskSummary: ...
    def summaries_of_pings(
        self,
        poses: list[Pose],
        ranges: list[list[float]],
        azimuths: Optional[list[list[float]]],
        sigma: Optional[list[float]],
        coverage: float,
    ) -> list[MaskSummary]: ...
    def masks_of_pings(
        self,
        poses: list[Pose],
        ranges: list[list[float]],
        azimuths: Optional[list[list[float]]],
        sigma: Optional[list[float]],
        coverage: float,
        counts: bool,
        dense: bool,
    ) -> list[MaskSet]: ...

def batch_columns(
    first: Sonar,
    second: Sonar,
    names: list[str],
    columns: list[npt.NDArray[np.float64]],
    step: Optional[float],
    area_grid: float,
    sigma_range: Optional[float],
    backend_name: str,
) -> tuple[dict[str, npt.NDArray[Any]], Optional[str]]: ...
def project_one(
    first: Sonar,
    second: Sonar,
    pose: Pose,
    range: float,
    azimuth: float,
    elevation: Optional[float],
    step: Optional[float],
    area_grid: float,
    sigma_range: Optional[float],
    occupancy: bool,
    backend_name: str,
) -> tuple[dict[str, Any], Optional[str]]: ...
def recover_one(
    first: Sonar,
    second: Sonar,
    pose: Pose,
    first_obs: tuple[float, float],
    second_obs: tuple[float, float],
    sigma_range: Optional[float],
    sigma_azimuth: Optional[float],
    curve_step: float,
) -> str: ...
def recover_columns(
    first: Sonar,
    second: Sonar,
    poses: list[Pose],
    columns: list[npt.NDArray[np.float64]],
    sigma_range: Optional[float],
    sigma_azimuth: Optional[float],
) -> dict[str, Any]: ...
def advise_run(
    config: str, out_dir: Optional[str], backend_name: str
) -> tuple[dict[str, Any], Optional[str]]: ...
def sweep_run(
    config: str,
    out_dir: str,
    shard: Optional[str],
    chunk_poses: Optional[int],
    max_chunks: Optional[int],
    backend_name: str,
    progress: Optional[Callable[[int, int], None]],
    format: str,
) -> tuple[dict[str, Any], Optional[str]]: ...
def sweep_memory(
    config: str,
    shard: Optional[str],
    chunk_poses: Optional[int],
    backend_name: str,
    progress: Optional[Callable[[int, int], None]],
) -> tuple[dict[str, Any], Optional[str]]: ...
def sweep_merge(out_dir: str) -> tuple[Optional[str], Optional[str], Optional[str]]: ...
def paper_run(
    out_dir: str, angle_step: float, step: Optional[float], backend_name: str
) -> tuple[dict[str, Any], Optional[str]]: ...


class OculusPing:
    """One saved Oculus ping (see :func:`sonarproj.read_oculus`)."""

    sonar: Sonar
    image: npt.NDArray[Any]
    """uint8 or uint16, ``(ranges, beams)``: row 0 the nearest range, column 0 the starboard-most beam."""
    gains: Optional[npt.NDArray[np.uint32]]
    bearings: list[float]
    """Degrees, positive to port."""
    ping_id: int
    frequency: float
    range_resolution: float
    offset: int
    version: int

def read_oculus(path: str, elevation: Optional[float] = None) -> list[OculusPing]: ...

class BagPing:
    """One ping of a ROS 2 bag's topic (see :func:`sonarproj.read_bag`)."""

    index: int
    time: float
    """The header's stamp, seconds since the epoch."""
    stamp_ns: int
    log_time: int
    frame_id: str
    sonar: Sonar
    image: npt.NDArray[Any]
    """uint8, uint16 or float32, ``(ranges, beams)``: row 0 the nearest range, column 0 the starboard-most beam."""

class BagPings:
    """The pings of one topic of a bag, read as they are asked for."""

    def __iter__(self) -> BagPings: ...
    def __next__(self) -> BagPing: ...

def read_bag(path: str, topic: Optional[str] = None, elevation: Optional[float] = None) -> BagPings: ...

def masks_of_bag(
    bag: str,
    first: Sonar,
    from_frame: str,
    features: str,
    out: str,
    topic: Optional[str],
    to_frame: Optional[str],
    elevation: Optional[float],
    sigma: Optional[list[float]],
    coverage: float,
    backend_name: str,
) -> tuple[dict[str, Any], Optional[str]]: ...
