"""Readers of recorded sonar data: ``sonarproj.read_oculus`` and ``sonarproj.read_bag``
(docs/sonars.md)."""

from __future__ import annotations

import os as _os
from typing import Any, Mapping, Optional, Union

from ._sonarproj import BagPing, BagPings, OculusPing


def read_oculus(path: Union[str, "_os.PathLike[str]"], *, elevation: Optional[float] = None) -> list[OculusPing]:
    """Returns the pings of a saved Oculus (Blueprint Subsea M-series) file: its simple ping
    results, version 1 or 2, other messages skipped. Each :class:`OculusPing` has ``.sonar`` (a
    :class:`Sonar` with the ping's exact beams and its range lines as bins from 0) and
    ``.image`` (numpy ``(ranges, beams)``, uint8 or uint16: row 0 the nearest range line,
    column 0 the starboard-most beam, which is the image as the sonar sends it: a positive
    Oculus bearing is to port), ``.gains`` (uint32 per range line, or None), ``.bearings``
    (deg), ``.ping_id``, ``.frequency`` (Hz), ``.range_resolution`` (m), ``.offset`` and
    ``.version``. `elevation` (deg) is the elevation aperture for a frequency whose aperture is
    not known (20° at 750 kHz, 1.2 and 3 MHz, 12° at 2.1 MHz).

    Raises InputError naming the byte offset and the field for a foreign or truncated file.
    """
    from . import InputTypeError, _native, _number

    if not isinstance(path, (str, _os.PathLike)):
        raise InputTypeError(f"path: expected a path, got {path!r} ({type(path).__name__})")
    return _native.read_oculus(_os.fspath(path), _number("elevation", elevation, optional=True))


def read_bag(
    path: Union[str, "_os.PathLike[str]"], topic: Optional[str] = None, *, elevation: Optional[float] = None
) -> BagPings:
    """Returns the pings of a ROS 2 bag (MCAP): the ``marine_acoustic_msgs/ProjectedSonarImage``
    messages of `topic` (the bag's first topic of them when None), read one at a time as the
    loop asks for them, so memory stays bounded whatever the bag's size. Each :class:`BagPing`
    has ``.sonar`` (a :class:`Sonar` from the message's beam table and ranges; pings of the same
    table share it), ``.image`` (numpy ``(ranges, beams)``, uint8, uint16 or float32: row 0 the
    nearest range, column 0 the starboard-most beam), ``.time`` (the header's stamp, s),
    ``.stamp_ns``, ``.log_time`` (ns), ``.frame_id`` and ``.index``. `elevation` (deg) is the
    elevation aperture when the messages' ``ping_info.tx_beamwidths`` do not give it.

    Raises InputError naming the bag, topic and message for a missing topic (with the topics
    there are), a topic of another type, a truncated or foreign file, or a message that makes no
    sonar or image; the loop ends at the first error.
    """
    from . import InputTypeError, _native, _number

    if not isinstance(path, (str, _os.PathLike)):
        raise InputTypeError(f"path: expected a path, got {path!r} ({type(path).__name__})")
    if topic is not None and not isinstance(topic, str):
        raise InputTypeError(f"topic: expected a string or None, got {topic!r} ({type(topic).__name__})")
    return _native.read_bag(_os.fspath(path), topic, _number("elevation", elevation, optional=True))


def masks_of_bag(
    bag: Union[str, "_os.PathLike[str]"],
    first: Any,
    from_frame: str,
    features: Union[str, "_os.PathLike[str]"],
    out: Union[str, "_os.PathLike[str]"],
    *,
    topic: Optional[str] = None,
    to_frame: Optional[str] = None,
    elevation: Optional[float] = None,
    sigma: Optional[Mapping[str, float]] = None,
    covariance: Any = None,
    coverage: float = 0.99,
    backend: str = "auto",
) -> dict[str, Any]:
    """Writes `out` (an MCAP): for every ProjectedSonarImage ping of the bag's `topic`, the union
    of the masks of the features sonar `first` measured at the ping's stamp, as a ``mono8``
    ``sensor_msgs/Image`` (255 inside a mask; the ping's rows and columns, stamp and frame) on
    ``TOPIC/masks``, so Foxglove shows it beside the pings. The pose comes from the bag's
    ``/tf_static`` and ``/tf`` at each stamp: `from_frame` is sonar 1's frame (x forward,
    y left, z up); sonar 2's is each ping's own (the message's axes: X up, Z forward), or
    `to_frame` (x forward, y left, z up). `features` is a CSV of ``stamp`` (s) or ``stamp_ns``,
    ``range`` and, for an imaging `first`, ``azimuth``; a feature belongs to the ping of its
    stamp (within 1 µs). `sigma`/`covariance` and `coverage` widen the masks as in
    :func:`masks`. The same as ``sonarproj mask --bag``.

    Returns a dict: ``topic``, ``masks_topic``, ``pings``, ``pings_with_features``,
    ``features`` (drawn) and ``unmatched`` (features of no ping's stamp). Raises InputError
    naming the bag, ping or features row; `out` is written whole or not at all.
    """
    from . import InputTypeError, _backend, _coverage, _native, _number, _sigma, _sonar, _warn
    from ._apps import _path

    for name, value in (("from_frame", from_frame), ("topic", topic), ("to_frame", to_frame)):
        if value is not None and not isinstance(value, str):
            raise InputTypeError(f"{name}: expected a string, got {value!r} ({type(value).__name__})")
    result, notice = _native.masks_of_bag(
        _path("bag", bag),
        _sonar("first", first),
        from_frame,
        _path("features", features),
        _path("out", out),
        topic,
        to_frame,
        _number("elevation", elevation, optional=True),
        _sigma(sigma, covariance),
        _coverage(coverage),
        _backend(backend),
    )
    _warn(notice)
    return result
