"""``sonarproj.advise`` against the command line and its own files: the same advisor, so the
same bytes written on a CPU backend, and the columns returned are the candidates file's."""

import json
import math

import numpy as np
import pyarrow.parquet as pq
import pytest

import sonarproj


def test_advise_writes_what_the_command_line_writes(tmp_path, cli, root):
    config = root / "data" / "example-advise.toml"
    cli("advise", "--config", config, "--out", tmp_path / "cli", "--backend", "cpu-fast")
    result = sonarproj.advise(config, tmp_path / "py", backend="cpu-fast")
    for name in ("best.json", "candidates.parquet", "pareto.csv", "features.csv", "landscape.png"):
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    assert result["files"]["best"] == tmp_path / "py" / "best.json"
    best = json.loads((tmp_path / "py" / "best.json").read_text())
    assert best["ranked"][0] == result["best"]
    assert result["next_move"] == best["next_move"]


def test_advise_columns_are_the_candidates_file(tmp_path, root):
    result = sonarproj.advise(root / "data" / "example-advise.toml", tmp_path, backend="cpu-fast")
    columns = result["candidates"]
    table = pq.read_table(tmp_path / "candidates.parquet").to_pydict()
    assert set(columns) == set(table) - {"index"}
    n = len(table["index"])
    for name, values in columns.items():
        assert len(values) == n, name
        expected = np.array([math.nan if v is None else v for v in table[name]], dtype=float)
        np.testing.assert_array_equal(np.asarray(values, dtype=float), expected, err_msg=name)
    # The ranking: feasible rows, best first, each score at most the next.
    ranked = result["ranked"]
    scores = columns["score"][ranked]
    assert np.all(np.isfinite(scores)) and np.all(np.diff(scores) >= 0)
    assert scores[0] == np.nanmin(columns["score"])
    assert result["best"]["score"] == scores[0]
    assert result["best"]["rotation"] == [columns[a][ranked[0]] for a in ("roll", "pitch", "yaw")]
    # Infeasible rows have no score; the stages are the cover's, the refinement's, the move's.
    assert set(np.unique(columns["stage"])) <= {0, 1, 2}
    assert np.all(np.isnan(columns["score"][columns["shared"] < 0.5]))


def test_advise_in_memory_writes_nothing(tmp_path, root, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = sonarproj.advise(root / "data" / "example-advise.toml", backend="cpu-fast")
    assert result["files"] == {} and list(tmp_path.iterdir()) == []
    assert result["metric"] == "occupied_measure"
    assert result["next_move"]["gain"] > 0


def test_bad_advise_input_names_the_parameter_or_key(tmp_path, root):
    with pytest.raises(sonarproj.InputError, match="config"):
        sonarproj.advise(42)
    with pytest.raises(sonarproj.InputError, match="out_dir"):
        sonarproj.advise(root / "data" / "example-advise.toml", out_dir=3)
    with pytest.raises(sonarproj.InputError, match="backend"):
        sonarproj.advise(root / "data" / "example-advise.toml", backend="fast")
    bad = tmp_path / "bad.toml"
    bad.write_text('from = "paper-fls"\nto = "paper-fls"\nmin_shared = 3\n[features]\ncount = 5\n[rig]\norigin = [0, 0, 0]\n')
    with pytest.raises(sonarproj.InputError, match="min_shared = 3"):
        sonarproj.advise(bad)
    with pytest.raises(sonarproj.InputError, match="cannot read"):
        sonarproj.advise(tmp_path / "missing.toml")


def test_advise_reports_its_uncertainty_ties_and_front(tmp_path, root):
    result = sonarproj.advise(root / "data" / "example-advise.toml", tmp_path, backend="cpu-fast")
    columns, best = result["candidates"], json.loads((tmp_path / "best.json").read_text())
    ranked = result["ranked"]
    # Ties: the ranked candidates within two of the best's standard errors, as best.json counts.
    limit = result["best"]["score"] + 2 * result["best"]["score_se"]
    tied = columns["tied"][ranked]
    assert tied.dtype == bool
    np.testing.assert_array_equal(tied, columns["score"][ranked] <= limit)
    assert result["tied"] == best["tied"] == int(tied.sum())
    assert result["recommended"] == best["recommended"]
    assert columns["tied"][result["recommended_index"]]
    # The shared share's standard error is the binomial one over the points examined.
    p, n = columns["shared"], columns["examined"]
    np.testing.assert_allclose(columns["shared_se"], np.sqrt(p * (1 - p) / n), rtol=1e-12)
    # The Pareto front: no feasible candidate shares more with less ambiguity and sigma.
    front = result["pareto"]
    assert len(front) == best["pareto"] >= 1
    s, a, g = columns["shared"], columns["metric_mean"], columns["sigma_median"]
    for i in front:
        better = (s[ranked] >= s[i]) & (a[ranked] <= a[i]) & (g[ranked] <= g[i])
        strictly = (s[ranked] > s[i]) | (a[ranked] < a[i]) | (g[ranked] < g[i])
        assert not np.any(better & strictly), i
    move = result["next_move"]
    assert move["stay"] == (move["gain"] <= 2 * move["gain_se"])
    assert result["score_unit"] == "m²" and result["warnings"] == []


def test_advise_warns_when_the_objective_cannot_move(tmp_path):
    config = tmp_path / "origin.toml"
    config.write_text(
        'from = "paper-fls"\nto = "paper-fls"\nobjective = "recovery"\nmin_shared = 0.1\n'
        "[features]\ncount = 50\n[rig]\norigin = [0, 0, -0.5]\n"
        "[search]\nroll = [-10, 0, 10]\nrefine = 0\n"
    )
    with pytest.warns(sonarproj.AdviceWarning, match="baseline"):
        result = sonarproj.advise(config, backend="cpu-fast")
    assert len(result["warnings"]) == 1
