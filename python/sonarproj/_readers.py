"""Readers of recorded sonar data: ``sonarproj.read_oculus`` (docs/sonars.md)."""

from __future__ import annotations

import os as _os
from typing import Optional, Union

from ._sonarproj import OculusPing


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
