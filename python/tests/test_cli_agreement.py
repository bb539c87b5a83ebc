"""The Python API against the command line on the same inputs: the same engine and the same
applications behind both, so the numbers must agree bit for bit on the CPU backends and the
files byte for byte."""

import csv
import json
import math
import pathlib

import numpy as np
import pytest

import sonarproj

PAIRS = [("paper-fls", "paper-sss"), ("paper-sss", "paper-fls"), ("holoocean-imaging", "oculus-m1200d-hf")]


def random_columns(first, second, n, rng, placement=True):
    s1, s2 = sonarproj.Sonar.preset(first), sonarproj.Sonar.preset(second)
    cols = {
        "range": rng.uniform(s1.range_min + 0.5, s1.range_max * 0.9, n),
        "azimuth": rng.uniform(-s1.azimuth_aperture / 2, s1.azimuth_aperture / 2, n) * 0.9,
        "elevation": rng.uniform(-s1.elevation_aperture / 2, s1.elevation_aperture / 2, n) * 0.9,
        "roll": rng.uniform(-180, 180, n),
        "pitch": rng.uniform(-90, 90, n),
        "yaw": rng.uniform(-180, 180, n),
    }
    if placement:
        # A fifth of the features placed beyond sonar 2's range: rows where nothing is seen.
        cols["place_range"] = rng.uniform(s2.range_min, s2.range_max * 1.25, n)
        cols["place_azimuth"] = rng.uniform(-s2.azimuth_aperture / 2, s2.azimuth_aperture / 2, n)
        cols["place_elevation"] = rng.uniform(-s2.elevation_aperture / 2, s2.elevation_aperture / 2, n)
    else:
        for k in ("tx", "ty", "tz"):
            cols[k] = rng.uniform(-3, 3, n)
    return cols


def write_csv(path, cols):
    names = list(cols)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for row in zip(*(cols[n] for n in names)):
            w.writerow([repr(float(v)) for v in row])


def read_metric_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = {}
    for name in sonarproj.METRIC_COLUMNS:
        out[name] = [math.nan if r[name] == "" else float(r[name]) for r in rows]
    return out


def same(a, b):
    """Bit-for-bit equality of floats, NaN equal to NaN."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


@pytest.mark.parametrize("first,second", PAIRS)
@pytest.mark.parametrize("backend", ["cpu", "cpu-fast"])
@pytest.mark.parametrize("placement", [True, False])
def test_batch_equals_the_command_line(tmp_path, cli, first, second, backend, placement):
    rng = np.random.default_rng(7)
    cols = random_columns(first, second, 150, rng, placement)
    write_csv(tmp_path / "in.csv", cols)
    cli("batch", "--from", first, "--to", second, "--step", "0.1", "--backend", backend,
        "--input", tmp_path / "in.csv", "--output", tmp_path / "out.csv")
    expected = read_metric_csv(tmp_path / "out.csv")
    got = sonarproj.batch(first, second, cols, step=0.1, backend=backend)
    assert list(got) == sonarproj.METRIC_COLUMNS
    for name in sonarproj.METRIC_COLUMNS:
        assert same(got[name], expected[name]), name
    assert got["visible"].dtype == np.int64 and got["span"].dtype == np.float64
    # Something is seen, and something is not: both kinds of cells are compared.
    assert (got["visible"] > 0).any() and (got["visible"] == 0).any()


def test_batch_with_auto_sampling_equals_the_command_line(tmp_path, cli):
    rng = np.random.default_rng(3)
    cols = random_columns("paper-sss", "paper-fls", 40, rng)
    write_csv(tmp_path / "in.csv", cols)
    cli("batch", "--from", "paper-sss", "--to", "paper-fls", "--backend", "cpu-fast",
        "--input", tmp_path / "in.csv", "--output", tmp_path / "out.csv")
    expected = read_metric_csv(tmp_path / "out.csv")
    got = sonarproj.batch("paper-sss", "paper-fls", cols, backend="cpu-fast")
    for name in sonarproj.METRIC_COLUMNS:
        assert same(got[name], expected[name]), name


def test_a_dataframe_like_mapping_and_integer_columns_are_taken(cli):
    class Frame:
        """The part of a pandas DataFrame batch() uses: keys() and column lookup."""

        def __init__(self, d):
            self.d = d

        def keys(self):
            return self.d.keys()

        def __getitem__(self, k):
            return self.d[k]

    cols = {"range": [5], "azimuth": [0], "elevation": [0], "roll": [0], "pitch": [90], "yaw": [0],
            "place_range": [15], "place_azimuth": [0], "place_elevation": [0]}
    a = sonarproj.batch("paper-fls", "paper-sss", Frame(cols), step=0.1, backend="cpu")
    b = sonarproj.batch("paper-fls", "paper-sss", {k: np.array(v, dtype=np.float64) for k, v in cols.items()},
                        step=0.1, backend="cpu")
    for name in sonarproj.METRIC_COLUMNS:
        assert same(a[name], b[name])
    assert a["visible"][0] == a["total"][0] == 121


@pytest.mark.parametrize("first,second,feature,pose_args", [
    ("paper-fls", "paper-sss", (5.0, 10.0), ["--pitch", "90", "--place-range", "15"]),
    ("paper-sss", "paper-fls", (8.0,), ["--roll", "20", "--yaw", "-5", "--translation", "0.5,-1,0.25"]),
    ("holoocean-imaging", "oculus-m750d", (4.0, -20.0), ["--quaternion", "0.9659258262890683,0,0.25881904510252074,0", "--translation", "1,0,0"]),
])
def test_project_equals_the_command_line(tmp_path, cli, first, second, feature, pose_args):
    args = ["project", "--from", first, "--to", second, "--step", "0.1", "--backend", "cpu",
            "--range", feature[0], "--occupancy", tmp_path / "occ.npy", *pose_args]
    if len(feature) == 2:
        args += ["--azimuth", feature[1]]
    out = json.loads(cli(*args).stdout)
    if "--place-range" in pose_args:
        pose = sonarproj.Pose.placement(feature=(feature[0], feature[1] if len(feature) == 2 else 0, 0),
                                        place=(15, 0, 0), pitch=90)
    elif "--quaternion" in pose_args:
        w, x, y, z = (float(v) for v in pose_args[1].split(","))
        pose = sonarproj.Pose.from_quat_xyzw((x, y, z, w), t=(1, 0, 0))
    else:
        pose = sonarproj.Pose(roll=20, yaw=-5, t=(0.5, -1, 0.25))
    np.testing.assert_array_equal(pose.rotation, np.array(out["pose"]["rotation"]))
    np.testing.assert_array_equal(pose.translation, np.array(out["pose"]["translation"]))
    # The command line's placement knows the true point (elevation 0); a translation does not.
    elevation = 0 if "--place-range" in pose_args else None
    got = sonarproj.project(first, second, pose, feature if len(feature) == 2 else feature[0],
                            elevation=elevation, step=0.1, occupancy=True, backend="cpu")
    for name in sonarproj.METRIC_COLUMNS:
        expected = out["metrics"][name]
        assert same([got[name]], [math.nan if expected is None else expected]), name
    occ = np.load(tmp_path / "occ.npy")
    assert got["occupancy"].dtype == np.uint8 and got["occupancy"].shape == occ.shape
    np.testing.assert_array_equal(got["occupancy"], occ)
    assert got["occupancy"].shape == sonarproj.Sonar.preset(second).shape


def test_masks_equal_the_command_line(tmp_path, cli):
    done = cli("mask", "--from", "holoocean-sidescan", "--to", "holoocean-imaging", "--backend", "cpu",
               "--pitch", "5", "--yaw", "10", "--translation", "0.3,0.2,-0.1", "--feature", "4",
               "--feature", "7.5", "--sigma-rotation", "0.5", "--sigma-range", "0.05",
               "--npy", tmp_path / "m.npy", "--json")
    report = json.loads(done.stdout)
    expected = np.load(tmp_path / "m.npy")
    pose = sonarproj.Pose(pitch=5, yaw=10, t=(0.3, 0.2, -0.1))
    got = sonarproj.masks("holoocean-sidescan", "holoocean-imaging", pose, [4, 7.5],
                          sigma={"roll": 0.5, "pitch": 0.5, "yaw": 0.5, "range": 0.05}, backend="cpu")
    assert got.masks.shape == expected.shape == (2, 512, 512)
    np.testing.assert_array_equal(got.masks, expected)
    for k, f in enumerate(report["features"]):
        assert got.boxes[k] == f["bounding_box"]
        assert got.radius[k] == f["radius"] and got.noise_radius[k] == f["noise_radius"]
    np.testing.assert_array_equal(got.union, got.masks.max(axis=0))


def test_mask_summaries_are_the_masks_and_the_command_lines(cli):
    # `mask` printing JSON only reduces the masks (MaskEngine::summary); so does Python's
    # MaskEngine.summary. Both must say what the masks themselves say, an empty mask included
    # (35 m is past the imaging sonar's range).
    done = cli("mask", "--from", "holoocean-sidescan", "--to", "holoocean-imaging", "--backend", "cpu",
               "--pitch", "5", "--yaw", "10", "--translation", "0.3,0.2,-0.1", "--feature", "4",
               "--feature", "7.5", "--feature", "35", "--sigma-rotation", "0.5")
    report = json.loads(done.stdout)
    pose = sonarproj.Pose(pitch=5, yaw=10, t=(0.3, 0.2, -0.1))
    engine = sonarproj.MaskEngine("holoocean-sidescan", "holoocean-imaging", backend="cpu")
    sigma = {"roll": 0.5, "pitch": 0.5, "yaw": 0.5}
    summary = engine.summary(pose, [4, 7.5, 35], sigma=sigma)
    masks = engine.masks(pose, [4, 7.5, 35], sigma=sigma)
    assert summary.occupied.dtype == np.uint64
    assert list(summary.occupied) == [int(m.sum()) for m in masks.masks] == [
        f["occupied"] for f in report["features"]]
    assert summary.occupied[0] > 100 and summary.occupied[2] == 0
    assert summary.boxes == masks.boxes == [f["bounding_box"] for f in report["features"]]
    assert summary.boxes[2] is None
    np.testing.assert_array_equal(summary.union, masks.union)
    assert int(summary.union.sum()) == report["union_occupied"]
    assert summary.radius == masks.radius and summary.noise_radius == masks.noise_radius
    assert summary.cells == [f["cells"] for f in report["features"]]
    assert "3 features (2 seen by sonar 2)" in repr(summary)
    # Many pings at once (two in flight on a GPU): each ping's own summary, an empty one too.
    poses = [pose, sonarproj.Pose(yaw=3), pose]
    features = [[4, 7.5, 35], [], [6.0]]
    many = engine.summaries_of_pings(poses, features, sigma=sigma)
    for s, p, f in zip(many, poses, features):
        one = engine.summary(p, f, sigma=sigma)
        assert list(s.occupied) == list(one.occupied) and s.boxes == one.boxes
        np.testing.assert_array_equal(s.union, one.union)
    assert list(many[0].occupied) == list(summary.occupied) and len(many[1].occupied) == 0
    with pytest.raises(sonarproj.InputError, match="2 pings of features for 3 poses"):
        engine.summaries_of_pings(poses, features[:2])
    # A bad feature is named with its ping, counted from 1 (the second here).
    with pytest.raises(sonarproj.InputError, match=r"ping 2 \(counted from 1\)"):
        engine.summaries_of_pings(poses, [[4.0], [400.0], [5.0]])


@pytest.mark.parametrize("first,second,feature,place,rpy,sigmas", [
    ("paper-fls", "paper-sss", (5.0, 10.0, 3.0), (15.0, 20.0, 0.0), (0, 90, 0), None),
    ("holoocean-imaging", "holoocean-imaging", (5.0, 10.0, 4.0), (5.5, 12.0, -2.0), (5, 3, 20), (0.02, 0.2)),
    ("paper-sss", "paper-fls", (8.0, 40.0, 0.1), (6.0, -10.0, 2.0), (10, -30, 45), None),
    ("paper-sss", "paper-sss", (8.0, 30.0, 0.1), (8.3, 35.0, 0.0), (0, 0, 3), None),
])
def test_recover_equals_the_command_line(cli, first, second, feature, place, rpy, sigmas):
    """A true point seen by both sonars (placed there), recovered from its two measurements."""
    pose = sonarproj.Pose.placement(feature=feature, place=place, roll=rpy[0], pitch=rpy[1], yaw=rpy[2])
    obs1 = feature[:2] if sonarproj.Sonar.preset(first).kind == "fls" else feature[0]
    obs2 = place[:2] if sonarproj.Sonar.preset(second).kind == "fls" else place[0]
    text = lambda v: ",".join(repr(float(x)) for x in np.ravel(v))
    args = ["recover", "--from", first, "--to", second, "--matrix", text(pose.rotation),
            "--translation", text(pose.translation), "--first", text(obs1), "--second", text(obs2)]
    kwargs = {}
    if sigmas:
        args += ["--sigma-range", sigmas[0], "--sigma-azimuth", sigmas[1]]
        kwargs = {"sigma_range": sigmas[0], "sigma_azimuth": sigmas[1]}
    out = json.loads(cli(*args).stdout)
    got = sonarproj.recover(first, second, pose, obs1, obs2, **kwargs)
    assert got["candidates"] == out["candidates"]
    assert got["flags"] == out["flags"]
    assert got["curve"] == out.get("curve")
    assert got["candidates"], "the case recovers something"
    if got["curve"] is None:
        # The true point is among the candidates.
        best = min(got["candidates"], key=lambda c: abs(c["first"][2] - feature[2]))
        assert abs(best["first"][2] - feature[2]) < 1e-6


def test_recover_many_equals_one_by_one():
    rng = np.random.default_rng(11)
    pose = sonarproj.Pose(roll=3, pitch=80, yaw=2, t=(0.2, 0.1, 0.5))
    n = 50
    fr = rng.uniform(2, 9, n)
    fa = rng.uniform(-25, 25, n)
    # The second range of the true point at elevation 0 and elevation 3, so most rows recover.
    el = rng.uniform(-5, 5, n)
    pts = np.stack([fr * np.cos(np.radians(el)) * np.cos(np.radians(fa)),
                    fr * np.cos(np.radians(el)) * np.sin(np.radians(fa)),
                    fr * np.sin(np.radians(el))], axis=1)
    sr = np.linalg.norm(pts @ pose.rotation.T + pose.translation, axis=1)
    many = sonarproj.recover_many("paper-fls", "paper-sss", pose,
                                  {"first_range": fr, "first_azimuth": fa, "second_range": sr})
    assert (many["candidates"] > 0).sum() > n // 2
    for k in range(n):
        one = sonarproj.recover("paper-fls", "paper-sss", pose, (fr[k], fa[k]), sr[k])
        assert many["candidates"][k] == len(one["candidates"])
        assert many["flags"][k] == ";".join(one["flags"])
        if one["candidates"]:
            best = one["candidates"][0]
            assert many["elevation_first"][k] == best["first"][2]
            assert many["x_second"][k] == best["point_second"][0]
            assert bool(many["in_view"][k]) == best["in_view"]
        else:
            assert math.isnan(many["elevation_first"][k])


def test_sweep_writes_what_the_command_line_writes(tmp_path, cli, root):
    config = tmp_path / "sweep.toml"
    config.write_text(
        'from = "paper-fls"\nto = "paper-sss"\nstep = 0.5\nmetric = "span"\n'
        "[feature]\nrange = 5\n[place]\nrange = [5, 15]\n[rotation]\npitch = { start = 0, stop = 90, step = 15 }\n"
    )
    cli("sweep", "--config", config, "--out", tmp_path / "cli", "--backend", "cpu-fast", "--chunk-poses", "5")
    calls = []
    got = sonarproj.sweep(config, tmp_path / "py", backend="cpu-fast", chunk_poses=5,
                          progress=lambda done, total: calls.append((done, total)))
    assert got["poses"] == 14 and got["computed"] == 14 and got["resumed"] == 0
    assert (tmp_path / "cli" / "sweep.csv").read_bytes() == (tmp_path / "py" / "sweep.csv").read_bytes()
    assert calls[-1] == (14, 14) and len(calls) == 3
    assert got["figure"] is not None and str(got["figure"]).endswith(".png")
    # A second call resumes: nothing computed again.
    again = sonarproj.sweep(config, tmp_path / "py", backend="cpu-fast", chunk_poses=5)
    assert again["computed"] == 0 and again["resumed"] == 14
    # Parquet: the command line's bytes, and the CSV's values read by pyarrow (typed columns,
    # nulls where the CSV is empty).
    cli("sweep", "--config", config, "--out", tmp_path / "cli-pq", "--backend", "cpu-fast", "--format", "parquet")
    got = sonarproj.sweep(config, tmp_path / "py-pq", backend="cpu-fast", format="parquet")
    assert str(got["file"]).endswith("sweep.parquet")
    assert (tmp_path / "cli-pq" / "sweep.parquet").read_bytes() == (tmp_path / "py-pq" / "sweep.parquet").read_bytes()
    import pyarrow.parquet as pq  # installed by the test command
    table = pq.read_table(tmp_path / "py-pq" / "sweep.parquet")
    with open(tmp_path / "cli" / "sweep.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert table.column_names == list(rows[0].keys()) and table.num_rows == len(rows)
    assert str(table.schema.field("index").type) == "int64" and str(table.schema.field("visible").type) == "int64"
    assert str(table.schema.field("span").type) == "double" and not table.schema.field("span").nullable
    assert table.schema.field("range_min").nullable
    nulls = 0
    for name in table.column_names:
        for k, value in enumerate(table.column(name).to_pylist()):
            text = rows[k][name]
            if text == "":
                assert value is None, (name, k)
                nulls += 1
            else:
                assert value == float(text), (name, k, value, text)
    assert nulls > 0, "the sweep should have empty cells for nulls to be tested"
    with pytest.raises(sonarproj.InputError, match="format"):
        sonarproj.sweep(config, tmp_path / "bad", format="feather")


def test_a_sweep_in_memory_returns_the_tables_columns(tmp_path, cli):
    config = tmp_path / "sweep.toml"
    config.write_text(
        'from = "paper-sss"\nto = "paper-fls"\nstep = 1\n'
        "[feature]\nrange = 5\n[place]\nrange = [5, 8]\n[rotation]\nroll = [0, 90]\nyaw = { start = 0, stop = 180, step = 30 }\n"
        '[summary]\ntop = 2\nmarginals = ["yaw"]\n'
    )
    cli("sweep", "--config", config, "--out", tmp_path / "cli", "--backend", "cpu-fast")
    calls = []
    got = sonarproj.sweep(config, backend="cpu-fast", chunk_poses=5, progress=lambda d, t: calls.append((d, t)))
    assert not any(tmp_path.glob("*/summary.json")) or (tmp_path / "cli" / "summary.json").exists()
    assert got["poses"] == 28 and calls[-1] == (28, 28) and len(calls) == 6
    with open(tmp_path / "cli" / "sweep.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    columns = got["columns"]
    assert list(columns) == list(rows[0].keys())
    assert columns["index"].dtype == np.int64 and columns["visible"].dtype == np.int64
    assert columns["projection_area"].dtype == np.float64
    nan = 0
    for name, array in columns.items():
        assert len(array) == len(rows)
        for k, row in enumerate(rows):
            if row[name] == "":
                assert math.isnan(array[k]), (name, k)
                nan += 1
            else:
                assert array[k] == float(row[name]), (name, k)
    assert nan > 0, "the sweep should have empty cells for NaN to be tested"
    assert got["summary"] == json.loads((tmp_path / "cli" / "summary.json").read_text())
    # Part of it, and the refusals of what needs a directory.
    half = sonarproj.sweep(config, shard="2/2", backend="cpu-fast")
    np.testing.assert_array_equal(half["columns"]["index"], np.arange(14, 28))
    with pytest.raises(sonarproj.InputError, match="max_chunks"):
        sonarproj.sweep(config, max_chunks=1)
    with pytest.raises(sonarproj.InputError, match="format"):
        sonarproj.sweep(config, format="parquet")
    # A sweep file's `columns`: those result columns alone, in the table's order, the same values.
    kept = tmp_path / "kept.toml"
    kept.write_text('columns = ["sigma_elevation", "occupied"]\n' + config.read_text())
    some = sonarproj.sweep(kept, backend="cpu-fast", chunk_poses=5)["columns"]
    poses = [name for name in columns if name not in sonarproj.METRIC_COLUMNS]
    assert list(some) == poses + ["occupied", "sigma_elevation"]
    for name, array in some.items():
        np.testing.assert_array_equal(array, columns[name])
    with pytest.raises(sonarproj.InputError, match=r"columns\[1\]"):
        kept.write_text('columns = ["span", "spam"]\n' + config.read_text())
        sonarproj.sweep(kept)


def test_sweep_summaries_come_back_as_a_dict(tmp_path, cli):
    config = tmp_path / "sweep.toml"
    config.write_text(
        'from = "paper-fls"\nto = "paper-sss"\nstep = 0.5\n'
        "[feature]\nrange = 5\n[place]\nrange = [5, 15]\n[rotation]\npitch = { start = 0, stop = 90, step = 15 }\n"
        '[summary]\ntop = 3\nmarginals = ["pitch"]\nrows = false\n'
    )
    cli("sweep", "--config", config, "--out", tmp_path / "cli", "--backend", "cpu-fast")
    got = sonarproj.sweep(config, tmp_path / "py", backend="cpu-fast", chunk_poses=4)
    assert got["file"] is None and str(got["summary_file"]).endswith("summary.json")
    assert (tmp_path / "cli" / "summary.json").read_bytes() == (tmp_path / "py" / "summary.json").read_bytes()
    summary = got["summary"]
    assert summary == json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert summary["poses"] == 14 and summary["metric"] == "span"
    assert len(summary["smallest"]) == 3 and summary["min"] == summary["smallest"][0]
    pitch = summary["marginals"][0]
    assert pitch["axes"] == ["pitch"] and pitch["values"] == [[0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]]
    assert sum(pitch["count"]) == summary["with_value"]


@pytest.mark.parametrize("step", [0.5, "auto"])
def test_paper_writes_what_the_command_line_writes(tmp_path, cli, step):
    cli("paper", "--out", tmp_path / "cli", "--angle-step", "45", "--step", str(step), "--backend", "cpu-fast")
    got = sonarproj.paper(tmp_path / "py", angle_step=45, step=step, backend="cpu-fast")
    for name in ("fls-to-sss.csv", "sss-to-fls.csv", "findings.md"):
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes(), name
    assert len(got["findings"]) == 4 and all("claim" in f and "holds" in f for f in got["findings"])
    assert got["poses"] > 0


def _quaternion_of_rpy(roll, pitch, yaw):
    """(w, x, y, z) of R = (Rz Ry Rx)ᵀ = Rx(−roll) Ry(−pitch) Rz(−yaw), from half angles."""
    def q(axis, a):
        h = np.radians(-a) / 2
        out = np.zeros((len(a), 4))
        out[:, 0] = np.cos(h)
        out[:, axis] = np.sin(h)
        return out

    def mul(a, b):
        w1, x1, y1, z1 = a.T
        w2, x2, y2, z2 = b.T
        return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                         w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                         w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)

    return mul(mul(q(1, roll), q(2, pitch)), q(3, yaw))


def test_batch_takes_quaternion_and_matrix_columns_and_equals_the_command_line(tmp_path, cli):
    rng = np.random.default_rng(3)
    cols = random_columns("paper-fls", "paper-fls", 80, rng, placement=True)
    by_rpy = sonarproj.batch("paper-fls", "paper-fls", cols, step=0.1, backend="cpu")
    quat = _quaternion_of_rpy(cols["roll"], cols["pitch"], cols["yaw"])
    q_cols = {k: v for k, v in cols.items() if k not in ("roll", "pitch", "yaw")}
    q_cols.update(qw=quat[:, 0], qx=quat[:, 1], qy=quat[:, 2], qz=quat[:, 3])
    by_quat = sonarproj.batch("paper-fls", "paper-fls", q_cols, step=0.1, backend="cpu")
    matrices = np.stack([sonarproj.Pose(roll=r, pitch=p, yaw=y).rotation
                         for r, p, y in zip(cols["roll"], cols["pitch"], cols["yaw"])])
    m_cols = {k: v for k, v in cols.items() if k not in ("roll", "pitch", "yaw")}
    for i in range(3):
        for j in range(3):
            m_cols[f"r{i + 1}{j + 1}"] = matrices[:, i, j]
    by_matrix = sonarproj.batch("paper-fls", "paper-fls", m_cols, step=0.1, backend="cpu")
    assert (by_rpy["visible"] > 0).sum() > 20
    for got in (by_quat, by_matrix):
        np.testing.assert_array_equal(got["visible"], by_rpy["visible"])
        np.testing.assert_allclose(got["span"], by_rpy["span"], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(got["sigma_elevation"], by_rpy["sigma_elevation"], rtol=1e-6)
    # The command line reads the same columns to the same bits.
    write_csv(tmp_path / "q.csv", q_cols)
    cli("batch", "--from", "paper-fls", "--to", "paper-fls", "--step", "0.1", "--backend", "cpu",
        "--input", tmp_path / "q.csv", "--output", tmp_path / "q-out.csv")
    expected = read_metric_csv(tmp_path / "q-out.csv")
    for name in sonarproj.METRIC_COLUMNS:
        assert same(by_quat[name], expected[name]), name
    # A quaternion off unit norm names the row.
    bad = dict(q_cols)
    bad["qw"] = bad["qw"].copy()
    bad["qw"][5] += 0.01
    with pytest.raises(sonarproj.InputError, match="row 5.*quaternion"):
        sonarproj.batch("paper-fls", "paper-fls", bad, step=0.1, backend="cpu")
    with pytest.raises(sonarproj.InputError, match="give one rotation"):
        sonarproj.batch("paper-fls", "paper-fls", {**q_cols, "roll": cols["roll"], "pitch": cols["pitch"],
                                                   "yaw": cols["yaw"]}, step=0.1)


def test_projection_area_and_local_precision_reach_python():
    pose = sonarproj.Pose.placement((15, 0, 0), (5, 0, 0), roll=45, pitch=0, yaw=45)
    m = sonarproj.project("paper-sss", "paper-fls", pose, 15, elevation=0, step=0.1, backend="cpu")
    assert m["projection_area"] == pytest.approx(44 * 0.0064, abs=1e-12)
    assert m["sigma_elevation"] == pytest.approx(
        0.01 / math.sqrt(12) / abs(m["range_per_elevation"]), rel=1e-12)
    coarse = sonarproj.project("paper-sss", "paper-fls", pose, 15, step=0.1, area_grid=0.5, backend="cpu")
    assert coarse["projection_area"] % 0.25 == pytest.approx(0, abs=1e-12)
    assert math.isnan(coarse["sigma_elevation"])  # no elevation given: no true point
    with pytest.raises(sonarproj.InputError, match="area_grid"):
        sonarproj.project("paper-sss", "paper-fls", pose, 15, area_grid=0, backend="cpu")
    with pytest.raises(sonarproj.InputError, match="sigma_range"):
        sonarproj.project("paper-sss", "paper-fls", pose, 15, elevation=0, sigma_range=-1, backend="cpu")


def test_recover_many_takes_one_pose_per_row():
    poses = [sonarproj.Pose(roll=0, pitch=80 + k, yaw=0, t=(0.2, 0.1, 0.5)) for k in range(4)]
    fr, fa = np.array([5.0, 6.0, 7.0, 8.0]), np.zeros(4)
    sr = np.array([np.linalg.norm(p.apply([r, 0.0, 0.0])) for p, r in zip(poses, fr)])
    many = sonarproj.recover_many("paper-fls", "paper-sss", poses,
                                  {"first_range": fr, "first_azimuth": fa, "second_range": sr})
    for k, p in enumerate(poses):
        one = sonarproj.recover("paper-fls", "paper-sss", p, (fr[k], fa[k]), sr[k])
        assert many["elevation_first"][k] == one["candidates"][0]["first"][2]
    with pytest.raises(sonarproj.InputError, match="pose"):
        sonarproj.recover_many("paper-fls", "paper-sss", poses[:3],
                               {"first_range": fr, "first_azimuth": fa, "second_range": sr})


def test_merge_refuses_shards_of_different_backends(tmp_path):
    config = tmp_path / "sweep.toml"
    config.write_text('from = "paper-fls"\nto = "paper-sss"\nstep = 0.5\n'
                      "[feature]\nrange = 5\n[place]\nrange = [5, 15]\n[rotation]\npitch = [0, 45, 90]\n")
    out = tmp_path / "out"
    sonarproj.sweep(config, out, shard="1/2", backend="cpu")
    sonarproj.sweep(config, out, shard="2/2", backend="cpu-fast")
    with pytest.raises(sonarproj.InputError, match="backend"):
        sonarproj.merge(out)
    assert not (out / "sweep.csv").exists()
    (out / "shard-2-of-2.csv").unlink()
    sonarproj.sweep(config, out, shard="2/2", backend="cpu")
    merged = sonarproj.merge(out)
    one = sonarproj.sweep(config, tmp_path / "one", backend="cpu")
    assert pathlib.Path(merged["file"]).read_bytes() == pathlib.Path(one["file"]).read_bytes()
