"""The rig advisor, ``sonarproj.advise`` (docs/advise.md)."""

from __future__ import annotations

import os as _os
from typing import Any, Optional, Union


class AdviceWarning(UserWarning):
    """Warned by :func:`advise` for each thing the advisor cannot help with, such as an objective
    its search cannot move (the recovery sigma of a rig whose sonar 2 only turns about a fixed
    origin); the same words are in the result's ``warnings``."""

    __module__ = "sonarproj"


def advise(
    config: Union[str, "_os.PathLike[str]"],
    out_dir: Optional[Union[str, "_os.PathLike[str]"]] = None,
    *,
    backend: str = "auto",
) -> dict[str, Any]:
    """Runs the rig advisor of the TOML file `config` (``sonarproj advise``, the same code):
    candidate rotations of sonar 2 scored over a draw of features — correspondence (the mean
    cost of finding a feature's match: its range span or projection area when both sonars see
    it, a blind search of sonar 2 when not), ambiguity (the mean metric of the shared features
    alone), recovery (the median elevation sigma) or a mix —, each score with its standard
    error over the draw; the best refined, the ties and the recommended pose, and from the
    file's ``[from_pose]`` the best small move, offered only when it gains more than twice its
    standard error. With `out_dir` it also writes ``best.json``, ``candidates.parquet``,
    ``pareto.csv``, ``features.csv`` and ``landscape.png`` there. `backend` picks where to
    compute: "auto", "gpu", "cpu-fast" or "cpu". Each of the advisor's warnings (an objective
    the search cannot move) is also warned as an :class:`AdviceWarning`.

    Returns a dict: ``candidates`` (numpy columns, one row per candidate evaluated: ``stage``
    — 0 the cover, 1 refinement, 2 the move's evaluations —, ``roll``, ``pitch``, ``yaw``
    (deg), ``x``, ``y``, ``z``, ``tx``, ``ty``, ``tz`` (m), ``shared``, ``shared_se``,
    ``examined``, ``features``, ``metric_mean``, ``metric_median``, ``metric_p10``,
    ``metric_p90``, ``sigma_mean``, ``sigma_median``, ``sigma_p10``, ``sigma_p90``, ``score``,
    ``score_se``, ``tied``; NaN where there is no value, and for the score of an infeasible
    candidate), ``ranked`` (the feasible candidates' rows, best first), ``best`` (the best
    candidate as a dict, or None), ``tied`` (how many ranked candidates are tied with the best),
    ``recommended``, ``recommended_index`` and ``recommended_because`` (the candidate the
    advisor recommends among the ties, its row, and the rule that chose it), ``pareto`` (the rows of the Pareto front), ``next_move`` (a dict:
    ``now``, ``gradient``, ``best``, ``gain``, ``gain_se``, ``stay``, ``words``; None without
    ``[from_pose]``), ``metric``, ``score_unit`` ("m", "m²", "deg" or "1"), ``warnings``,
    ``files`` (the paths written), ``seconds`` and ``device``.
    """
    from . import _backend, _native, _warn
    from ._apps import _path

    result, notice = _native.advise_run(
        _path("config", config), None if out_dir is None else _path("out_dir", out_dir), _backend(backend)
    )
    _warn(notice)
    import warnings

    for text in result["warnings"]:
        warnings.warn(text, AdviceWarning, stacklevel=2)
    return result
