"""The rig advisor, ``sonarproj.advise`` (docs/advise.md)."""

from __future__ import annotations

import os as _os
from typing import Any, Optional, Union


def advise(
    config: Union[str, "_os.PathLike[str]"],
    out_dir: Optional[Union[str, "_os.PathLike[str]"]] = None,
    *,
    backend: str = "auto",
) -> dict[str, Any]:
    """Runs the rig advisor of the TOML file `config` (``sonarproj advise``, the same code):
    candidate rotations of sonar 2 scored over the features both sonars see — correspondence
    (the mean range span or projection area), recovery (the median elevation sigma) or a mix —
    the best refined, and from the file's ``[from_pose]`` the best small move. With `out_dir`
    it also writes ``best.json``, ``candidates.parquet``, ``features.csv`` and
    ``landscape.png`` there. `backend` picks where to compute: "auto", "gpu", "cpu-fast" or
    "cpu".

    Returns a dict: ``candidates`` (numpy columns, one row per candidate evaluated: ``stage``
    — 0 the cover, 1 refinement, 2 the move's evaluations —, ``roll``, ``pitch``, ``yaw``
    (deg), ``tx``, ``ty``, ``tz`` (m), ``shared``, ``features``, ``metric_mean``,
    ``metric_median``, ``metric_p10``, ``metric_p90``, ``sigma_mean``, ``sigma_median``,
    ``sigma_p10``, ``sigma_p90``, ``score``; NaN where there is no value, and for the score of
    an infeasible candidate), ``ranked`` (the feasible candidates' rows, best first), ``best``
    (the best candidate as a dict, or None), ``next_move`` (a dict: ``now``, ``gradient``,
    ``best``, ``gain``; None without ``[from_pose]``), ``metric``, ``files`` (the paths
    written), ``seconds`` and ``device``.
    """
    from . import _backend, _native, _warn
    from ._apps import _path

    result, notice = _native.advise_run(
        _path("config", config), None if out_dir is None else _path("out_dir", out_dir), _backend(backend)
    )
    _warn(notice)
    return result
