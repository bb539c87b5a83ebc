"""Sweeps, merges and the paper's simulations: ``sonarproj.sweep``, ``merge`` and ``paper``
(docs/sweeps.md, docs/paper.md), the command line's code behind each."""

from __future__ import annotations

import os as _os
from typing import Any, Callable, Optional, Union

import numpy as _np

from . import InputError, InputTypeError, _backend, _native, _number, _warn  # defined before this module loads


def _count(parameter: str, value: Any, *, optional: bool = False) -> Optional[int]:
    if value is None and optional:
        return None
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, (int, _np.integer)):
        raise InputTypeError(f"{parameter}: expected a whole number >= 1, got {value!r} ({type(value).__name__})")
    if value < 1:
        raise InputError(f"{parameter}: expected a whole number >= 1, got {value!r}")
    if value > 2**64 - 1:
        raise InputError(f"{parameter}: {value} is too large (at most {2**64 - 1})")
    return int(value)


def _path(parameter: str, value: Any) -> str:
    if isinstance(value, (bytes, bytearray)):
        value = _os.fsdecode(bytes(value))
    if not isinstance(value, (str, _os.PathLike)):
        raise InputTypeError(f"{parameter}: expected a path (str or os.PathLike), got {value!r} ({type(value).__name__})")
    path = _os.fspath(value)
    if not isinstance(path, str):
        path = _os.fsdecode(path)
    if path == "":
        raise InputError(f"{parameter}: expected a path, got an empty string")
    return path


def sweep(
    config: Union[str, "_os.PathLike[str]"],
    out_dir: Optional[Union[str, "_os.PathLike[str]"]] = None,
    *,
    shard: Optional[str] = None,
    chunk_poses: Optional[int] = None,
    max_chunks: Optional[int] = None,
    backend: str = "auto",
    progress: Optional[Callable[[int, int], None]] = None,
    format: str = "csv",
) -> dict[str, Any]:
    """Runs the sweep described by the TOML file `config` into the directory `out_dir`, with the
    command line's code (``sonarproj sweep``): ``sweep.csv`` (the grid's columns, then the
    metric columns; angles in deg, distances in m), ``sweep.json`` and, for a grid with one or
    two varying axes, the figure ``sweep-METRIC.png``. ``format="parquet"`` writes
    ``sweep.parquet`` instead: the same columns typed (integers for the index and counts,
    floats for the rest, null where the CSV leaves a cell empty), for ``pandas.read_parquet``,
    polars, pyarrow or DuckDB, and faster to write.

    Finished chunks of `chunk_poses` poses stay on disk, so calling it again resumes (None: the
    unfinished run's own size, else ``DEFAULT_CHUNK_POSES``, one Parquet row group, or
    ``DEFAULT_SUMMARY_CHUNK_POSES`` for summaries only); Ctrl-C
    (KeyboardInterrupt) stops it between chunks. `shard` ``"K/N"`` runs part K of N;
    `max_chunks` stops after that many chunks. `progress(done, total)` is called after each
    chunk. `backend` picks where to compute: "auto", "gpu", "cpu-fast" or "cpu".

    Returns a dict: ``file`` (the table, or None when stopped early or when the sweep file's
    ``[summary]`` says ``rows = false``), ``figure``, ``summary`` (the ``[summary]``'s
    reductions, the content of ``summary.json``, as a dict; None without one),
    ``summary_file``, ``poses``, ``computed``, ``resumed``, ``seconds``, ``device``.

    Without `out_dir` the sweep runs in memory and writes nothing: the dict's ``columns`` maps
    each column of the table to a numpy array (int64 for the index and counts, float64 for the
    rest, NaN where the CSV leaves a cell empty; ``pandas.DataFrame(result["columns"])`` is the
    table), or is None with ``rows = false``; ``summary`` is as above. Tables over 1 GiB are
    refused (give `out_dir`, or ask for summaries only); `max_chunks` and `format` need
    `out_dir`.
    """
    config = _path("config", config)
    if out_dir is not None:
        out_dir = _path("out_dir", out_dir)
    if not isinstance(format, str):
        raise InputTypeError(f'format: expected "csv" or "parquet", got {format!r} ({type(format).__name__})')
    if format not in ("csv", "parquet"):
        raise InputError(f'format: expected "csv" or "parquet", got {format!r}')
    if progress is not None and not callable(progress):
        raise InputTypeError(f"progress: expected a callable (done, total), got {type(progress).__name__}")
    if shard is not None and not isinstance(shard, str):
        raise InputTypeError(f'shard: expected "K/N", e.g. "1/4", got {shard!r} ({type(shard).__name__})')
    if out_dir is None:
        if max_chunks is not None:
            raise InputError("max_chunks: needs out_dir (a sweep in memory keeps nothing to resume)")
        if format != "csv":
            raise InputError(f"format: {format!r} needs out_dir (a sweep in memory returns its columns)")
        result, notice = _native.sweep_memory(
            _os.fspath(config),
            shard,
            _count("chunk_poses", chunk_poses, optional=True),
            _backend(backend),
            progress,
        )
        _warn(notice)
        return result
    result, notice = _native.sweep_run(
        _os.fspath(config),
        _os.fspath(out_dir),
        shard,
        _count("chunk_poses", chunk_poses, optional=True),
        _count("max_chunks", max_chunks, optional=True),
        _backend(backend),
        progress,
        format,
    )
    _warn(notice)
    return result


def merge(out_dir: Union[str, "_os.PathLike[str]"]) -> dict[str, Optional[str]]:
    """Joins the finished shards of a sweep in `out_dir` (run with ``shard="K/N"``) into
    ``sweep.csv`` (``sweep.parquet`` for Parquet shards), byte for byte the file one run would
    have written, and draws the figure, as
    ``sonarproj merge``. Refused with InputError, writing nothing, when a shard is missing or
    damaged, or when the shards were computed with different settings (backend, GPU adapter,
    precision or options, engine version: the message names the setting and both values).

    Returns a dict: ``file`` (the table; None when the sweep writes no rows), ``summary``
    (``summary.json``, when the sweep file has a ``[summary]``) and ``figure`` (None when the
    sweep draws none).
    """
    file, summary, figure = _native.sweep_merge(_path("out_dir", out_dir))
    path = lambda p: None if p is None else _os.fspath(p)  # noqa: E731
    return {"file": path(file), "summary": path(summary), "figure": path(figure)}


def paper(
    out_dir: Union[str, "_os.PathLike[str]"],
    *,
    angle_step: float = 1.0,
    step: Union[float, str] = 0.1,
    backend: str = "auto",
) -> dict[str, Any]:
    """Runs the paper's simulations (both directions, nine scenarios, angles every `angle_step`
    deg, arcs and surfaces sampled every `step` deg) with the command line's code (``sonarproj
    paper``) and writes ``fls-to-sss.csv``, ``sss-to-fls.csv``, the figures and ``findings.md``
    into `out_dir`. ``step="auto"`` is the smooth version: arcs every 0.001°, surfaces with auto
    sampling (the default 0.1° reproduces the published code, staircases included).
    ``step="exact"`` solves the FLS arcs in closed form and samples the SSS surfaces, which have
    no exact mode, at 0.1°.

    Returns a dict: ``findings`` (a list of dicts: ``claim``, ``holds``, ``evidence``),
    ``poses``, ``seconds`` (the run's time, its files written as it goes), ``device``, ``out_dir``.
    """
    result, notice = _native.paper_run(
        _path("out_dir", out_dir), _number("angle_step", angle_step), _paper_step(step), _backend(backend)
    )
    _warn(notice)
    return result


def _paper_step(value: Any) -> Union[float, str]:
    """Returns `paper`'s step in degrees, or ``"auto"`` or ``"exact"``."""
    if isinstance(value, str):
        if value.strip().lower() in ("auto", "exact"):
            return value.strip().lower()
        raise InputError(f"step: expected a number of degrees, 'auto' or 'exact', got {value!r}")
    return _number("step", value)
