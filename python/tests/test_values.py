"""The package behaves like Python: immutable values compare, hash, copy, pickle and print as
the call that makes them; only the public API is visible; a bad argument raises an InputError
whose message starts with the argument's name (an InputTypeError, also a TypeError, for a wrong
type); and importing and probing the GPU prints nothing on a headless machine."""

import copy
import os
import pickle
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import sonarproj
from sonarproj import InputError, InputTypeError, Mount, Pose, Sonar

VALUES = [
    lambda: Pose(1, 2, 3),
    lambda: Pose(10.5, -20.25, 33.125, t=(0.1, -0.2, 3.0)),
    lambda: Pose.from_quat_xyzw((0.1, 0.2, 0.3, 0.9273618495495703), t=(1, 2, 3)),
    lambda: Pose.placement((5, 10, 1), (15, -3, 0.2), roll=45, yaw=45),
    lambda: Mount((0.5, -0.1, 0.2), rpy=(10, 20, 30)),
    lambda: Mount((0, 0, 0), quat_xyzw=(0.0, 0.0, 0.3826834323650898, 0.9238795325112867)),
    lambda: Sonar.preset("paper-fls"),
    lambda: Sonar.preset("holoocean-sidescan"),
    lambda: Sonar("fls", 0.5, 20, 90, 20, 390, beam_edges=[-45, -10, 0, 12.5, 45], name="it's"),
    lambda: Sonar("sss", 0.1, 30, 130, 0.3, 2990),
]
NAMES = {"Pose": Pose, "Mount": Mount, "Sonar": Sonar}


@pytest.mark.parametrize("make", VALUES)
def test_values_compare_hash_copy_pickle_and_print_as_their_call(make):
    a, b = make(), make()
    assert a is not b and a == b and hash(a) == hash(b)
    assert a != object() and a != "x"
    assert copy.copy(a) == a and copy.deepcopy(a) == a
    back = pickle.loads(pickle.dumps(a))
    assert back == a and hash(back) == hash(a) and type(back) is type(a)
    again = eval(repr(a), dict(NAMES))  # noqa: S307 - the repr is the call that makes it
    assert again == a, repr(a)
    assert len({a, b, back, again}) == 1


def test_different_values_differ():
    assert Pose(1, 2, 3) != Pose(1, 2, 4)
    assert Pose(t=(0, 0, 1)) != Pose()
    assert Mount((0, 0, 0)) != Mount((0, 0, 1e-9))
    assert Sonar.preset("paper-fls") != Sonar.preset("paper-sss")
    # -0.0 and 0.0 are equal numbers: equal poses hash alike.
    assert Pose(t=(0.0, 0, 0)) == Pose(t=(-0.0, 0, 0))
    assert hash(Pose(t=(0.0, 0, 0))) == hash(Pose(t=(-0.0, 0, 0)))


def test_mask_sets_and_engines_say_what_they_are():
    engine = sonarproj.MaskEngine("paper-fls", "paper-sss", backend="cpu")
    assert eval(repr(engine), {"MaskEngine": sonarproj.MaskEngine}).first == engine.first  # noqa: S307
    assert repr(engine) == "MaskEngine('paper-fls', 'paper-sss', backend='cpu')"
    custom = Sonar("sss", 0.1, 30, 130, 0.3, 100)
    assert repr(custom) in repr(sonarproj.MaskEngine("paper-fls", custom, backend="cpu", counts=True))
    m = engine.masks(Pose(pitch=90), [[5.0, 0.0], [6.0, 10.0]])
    text = repr(m)
    assert text.startswith("<MaskSet: 2 features") and "(2, 2990)" in text and "CPU" in text


def test_only_the_public_api_is_visible():
    assert sorted(dir(sonarproj)) == sorted(sonarproj.__all__)
    for private in ("np", "os", "json", "warnings", "Any", "Optional", "SIGMA_KEYS", "REQUIRED_COLUMNS"):
        assert private not in dir(sonarproj)
    # The imports used at run time are underscored (the typing names stay, hidden from dir(),
    # for the annotations that tools resolve).
    for private in ("np", "os", "json", "warnings", "SIGMA_KEYS", "REQUIRED_COLUMNS"):
        assert not hasattr(sonarproj, private), private
    for name in sonarproj.__all__:
        assert hasattr(sonarproj, name), name


POSES = {"range": [5.0], "azimuth": [0.0], "roll": [0.0], "pitch": [90.0], "yaw": [0.0],
         "tx": [0.0], "ty": [0.0], "tz": [0.0]}

WRONG_TYPES = [
    (lambda: Pose(roll=True), "roll"),
    (lambda: Pose(yaw="10"), "yaw"),
    (lambda: Pose(pitch=1j), "pitch"),
    (lambda: Pose(t=(0, 0, True)), "t"),
    (lambda: Pose(t="abc"), "t"),
    (lambda: Pose.from_quat_xyzw((0, 0, 0, True)), "quat_xyzw"),
    (lambda: Pose.placement((5, 0, 0), (15, 0, 0), roll=np.bool_(True)), "roll"),
    (lambda: Mount((0, 0, "1")), "position"),
    (lambda: Sonar("sss", 0.1, 30, 130, 0.3, 100, sides=True), "sides"),
    (lambda: Sonar("fls", 0.1, 10, 60, 12, 100, beams=True), "beams"),
    (lambda: Sonar("fls", 0.1, 10, 60, 12, 100.0, beams=8), "range_bins"),
    (lambda: Sonar("fls", False, 10, 60, 12, 100, beams=8), "range_min"),
    (lambda: Sonar("fls", 0.1, 10, 60, 12, 100, beam_edges="abc"), "beam_edges"),
    (lambda: Pose().apply(np.array([1j, 0, 0])), "p"),
    (lambda: Pose().apply(["a", "b", "c"]), "p"),
    (lambda: Pose().apply([True, False, True]), "p"),
    (lambda: sonarproj.project("paper-fls", "paper-sss", Pose(), (5.0, 0.0), occupancy="no"), "occupancy"),
    (lambda: sonarproj.masks("paper-fls", "paper-sss", Pose(), [[5.0, 0.0]], counts=1), "counts"),
    (lambda: sonarproj.MaskEngine("paper-fls", "paper-sss", counts="yes"), "counts"),
    (lambda: sonarproj.project("paper-fls", "paper-sss", Pose(), (5.0, 0.0), step=True), "step"),
    (lambda: Sonar(1, 0.1, 10, 60, 12, 100, beams=8), "kind"),
    (lambda: Sonar("fls", 0.1, 10, 60, 12, 100, beams=8, name=5), "name"),
    (lambda: Pose.from_mounts(1, 2), "first"),
    (lambda: Pose.from_mounts(Mount((0, 0, 0)), "m"), "second"),
    (lambda: Sonar.from_projected_sonar_image([[0, 0, 1]], [1.0, 2.0], "12"), "elevation_aperture"),
    (lambda: sonarproj.batch("paper-fls", "paper-sss", {**POSES, "range": np.array([True])}), "poses['range']"),
    (lambda: sonarproj.batch("paper-fls", "paper-sss", {**POSES, "range": np.array([5 + 0j])}), "poses['range']"),
    (lambda: sonarproj.batch("paper-fls", "paper-sss", {**POSES, 3: [0.0]}), "poses"),
    (lambda: sonarproj.batch("paper-fls", "paper-sss", POSES, backend=3), "backend"),
]


@pytest.mark.parametrize("call, name", WRONG_TYPES)
def test_a_wrong_type_is_a_type_error_naming_the_argument(call, name):
    with pytest.raises(TypeError) as e:
        call()
    assert isinstance(e.value, InputTypeError) and isinstance(e.value, InputError)
    assert str(e.value).startswith(f"{name}: "), str(e.value)


BAD_VALUES = [
    (lambda: Sonar("fls", 0.1, 10, 60, 12, 100, beams=2**70), "beams", "1180591620717411303424"),
    (lambda: Sonar("fls", 0.1, 10, 60, 12, -3, beams=8), "range_bins", "-3"),
    (lambda: Sonar("sss", 0.1, 30, 130, 0.3, 100, sides=3), "sides", "3"),
    (lambda: Pose.from_matrix(np.eye(4)), "matrix", "(4, 4)"),
    (lambda: Pose(t=(1, 2)), "t", "(2,)"),
    (lambda: Pose.from_quat_xyzw((0, 0, 1)), "quat_xyzw", "(3,)"),
    (lambda: Mount((0, 0, 0), rpy=(1, 2, 3, 4)), "rpy", "(4,)"),
    (lambda: Pose().apply(np.zeros((2, 4))), "p", "(2, 4)"),
    (lambda: sonarproj.paper("/tmp/x", angle_step=1000), "angle_step", "1000"),
    # A ping's features, as the command line's limit (2^16), though the calls are chunked.
    (lambda: sonarproj.masks("paper-fls", "paper-sss", Pose(), np.tile([5.0, 0.0], (65537, 1)), dense=False),
     "features", "at most 65536"),
]


@pytest.mark.parametrize("call, name, value", BAD_VALUES)
def test_a_bad_value_is_an_input_error_starting_with_the_argument(call, name, value):
    with pytest.raises(InputError) as e:
        call()
    message = str(e.value)
    assert re.match(rf"{name}\b", message), message
    assert value in message and "--" not in message, message


def test_a_sonar_file_that_is_not_one_is_refused_without_reading_it(tmp_path):
    with pytest.raises(InputError, match="not a regular file"):
        Sonar.from_toml("/dev/zero")
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * (5 << 20))
    with pytest.raises(InputError, match="longer than"):
        Sonar.from_toml(big)
    # A FIFO with no writer: refused at once (in a process of its own; the limit only guards
    # against the wait it used to be).
    fifo = tmp_path / "sonar.fifo"
    os.mkfifo(fifo)
    script = f"import sonarproj\ntry:\n    sonarproj.Sonar.from_toml({str(fifo)!r})\nexcept sonarproj.InputError as e:\n    print(e)"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=30)
    assert "not a regular file" in done.stdout, done.stdout + done.stderr


def test_preset_beam_edges_are_the_documented_numbers():
    s = Sonar.preset("paper-fls")
    assert s.beam_edges[0] == -30.0 and s.beam_edges[-1] == 30.0
    assert np.allclose(np.diff(s.beam_edges), 60 / 512, rtol=1e-12)


def test_a_covariance_in_degrees_squared_is_warned_about():
    pose = Pose(pitch=90)
    cov_deg2 = np.diag([1e-4, 1e-4, 1e-4, 1.0, 1.0, 1.0])  # 1° sigmas written in deg²
    with pytest.warns(UserWarning, match="deg²"):
        sonarproj.masks("paper-fls", "paper-sss", pose, [[5.0, 0.0]], covariance=cov_deg2, backend="cpu")
    cov_rad2 = np.diag([1e-4, 1e-4, 1e-4, *[np.radians(1.0) ** 2] * 3])
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        sonarproj.masks("paper-fls", "paper-sss", pose, [[5.0, 0.0]], covariance=cov_rad2, backend="cpu")


def test_probing_the_gpu_prints_nothing_on_a_headless_machine():
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_RUNTIME_DIR", "NODEVICE_SELECT")}
    code = (
        "import warnings, sonarproj\n"
        "warnings.simplefilter('ignore')\n"
        "sonarproj.MaskEngine('holoocean-sidescan', 'holoocean-imaging')\n"
        "sonarproj.project('paper-fls', 'paper-sss', sonarproj.Pose(pitch=90), (5.0, 0.0))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stderr == "", done.stderr


def test_a_holoocean_sensor_entry_reads_as_the_frame_it_returns():
    """A scenario's sensor entries, as HoloOcean's JSON scenarios write them."""
    imaging = {"sensor_type": "ImagingSonar", "socket": "SonarSocket", "Hz": 2,
               "configuration": {"Azimuth": 130, "Elevation": 20, "RangeMin": 1, "RangeMax": 40,
                                 "RangeRes": 0.05, "AzimuthBins": 512, "AddSigma": 0.15,
                                 "MultiPath": True, "ViewOctree": -10}}
    s = Sonar.from_holoocean(imaging)
    assert (s.kind, s.range_min, s.range_max, s.range_bins, s.beams) == ("fls", 1.0, 40.0, 780, 512)
    assert s.name == "holoocean-ImagingSonar"
    # Its configuration block alone, with the type given apart.
    assert Sonar.from_holoocean(imaging["configuration"], sensor_type="ImagingSonar", name="x").range_bins == 780
    # The defaults are the preset; the sidescan of the example scenarios is the sidescan preset.
    assert Sonar.from_holoocean({"sensor_type": "ImagingSonar"}).beams == Sonar.preset("holoocean-imaging").beams
    side = Sonar.from_holoocean({"sensor_type": "SidescanSonar", "configuration": {"RangeBins": 2000}})
    assert side.sides == 2 and side.range_bins == 1000
    preset = Sonar.preset("holoocean-sidescan")
    assert (side.range_min, side.range_max, side.azimuth_aperture) == (preset.range_min, preset.range_max, preset.azimuth_aperture)
    # numpy numbers read as numbers (a configuration built with numpy).
    s = Sonar.from_holoocean({"sensor_type": "ImagingSonar", "configuration": {"RangeMax": np.float32(40.0), "AzimuthBins": np.int64(256)}})
    assert (s.range_max, s.beams) == (40.0, 256)


@pytest.mark.parametrize("call, words", [
    (lambda: Sonar.from_holoocean({"sensor_type": "ImagingSonar", "configuration": {"RangeMAx": 5}}), ["sensor", "RangeMAx", "not a key"]),
    (lambda: Sonar.from_holoocean({"sensor_type": "ImagingSonar", "configuration": {"RangeMax": True}}), ["RangeMax", "not a bool"]),
    (lambda: Sonar.from_holoocean({"sensor_type": "SidescanSonar", "configuration": {"RangeBins": 999}}), ["RangeBins = 999", "odd"]),
    (lambda: Sonar.from_holoocean({"sensor_type": "RGBCamera"}), ["sensor_type", "RGBCamera"]),
    (lambda: Sonar.from_holoocean({"RangeMax": 5}), ["sensor_type", "missing"]),
    (lambda: Sonar.from_holoocean({"sensor_type": "ImagingSonar", "configuration": {"MultiPath": np.bool_(True), "RangeMax": np.True_}}), ["RangeMax", "not a bool"]),
    (lambda: Sonar.from_holoocean({"sensor_type": "ImagingSonar", "configuration": {"RangeMax": 10**400}}), ["RangeMax"]),
])
def test_a_bad_holoocean_sensor_is_refused_naming_the_key(call, words):
    with pytest.raises(InputError) as e:
        call()
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_a_projected_sonar_image_beam_table_reads_as_a_sonar_and_its_columns():
    """ROS ProjectedSonarImage: X up, Y starboard, Z forward. Beams listed port to starboard
    (as a driver may) come back starboard-first, with the columns that put them there."""
    az = np.radians([30.0, 10.0, 0.0, -12.0, -30.0])  # port to starboard
    directions = np.column_stack([np.zeros(5), -np.sin(az), np.cos(az)])
    ranges = (np.arange(40) + 0.5) * 0.25
    s, columns = Sonar.from_projected_sonar_image(directions, ranges, 20.0, name="ros")
    assert list(columns) == [4, 3, 2, 1, 0]
    assert (s.kind, s.range_min, s.range_max, s.range_bins, s.beams, s.elevation_aperture) == ("fls", 0.0, 10.0, 40, 5, 20.0)
    edges = s.beam_edges
    for k, j in enumerate(columns):
        assert edges[k] < np.degrees(az[j]) < edges[k + 1]
    with pytest.raises(InputError, match=r"beam_directions\[1\]"):
        Sonar.from_projected_sonar_image([[0, 0, 1], [0.5, 0, 1], [0, 0.2, 1]], ranges, 20.0)
    with pytest.raises(InputTypeError, match="ranges"):
        Sonar.from_projected_sonar_image(directions, "abc", 20.0)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: sonarproj.project(5, "paper-sss", sonarproj.Pose(0, 0, 0), (5, 10)), "first"),
        (lambda: sonarproj.project("paper-fls", "paper-sss", {"roll": 0}, (5, 10)), "pose"),
        (lambda: sonarproj.MaskEngine("paper-fls", 5), "second"),
        (lambda: sonarproj.sweep("x.toml", "out", chunk_poses="10"), "chunk_poses"),
        (lambda: sonarproj.sweep("x.toml", "out", progress="yes"), "progress"),
        (lambda: sonarproj.configure_gpu(adapter=5), "adapter"),
        (lambda: sonarproj.configure_gpu(workgroup="64"), "workgroup"),
        (lambda: sonarproj.configure_gpu(cull="yes"), "cull"),
        (lambda: sonarproj.configure_gpu(precision=64), "precision"),
        (lambda: sonarproj.configure_gpu(backends=[1]), "backends"),
        (lambda: sonarproj.Sonar.preset(5), "name"),
        (lambda: sonarproj.Sonar.from_toml(5), "path"),
    ],
)
def test_a_value_of_the_wrong_type_is_an_input_type_error_naming_its_parameter(call, name):
    with pytest.raises(sonarproj.InputTypeError, match=f"^{name}"):
        call()


def test_a_covariance_past_the_sigmas_bounds_is_refused_naming_it():
    pose = sonarproj.Pose(0, 5, 10, t=[0.3, 0.2, -0.1])
    for cov in (np.eye(6) * 1e308, np.diag([1e9, 1e9, 1e9, 0.01, 0.01, 0.01])):
        with pytest.raises(sonarproj.InputError, match="^covariance: its .* block's largest standard deviation"):
            sonarproj.masks("holoocean-sidescan", "holoocean-imaging", pose, [4], covariance=cov, backend="cpu-fast")
