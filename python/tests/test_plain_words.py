"""What a person reads: the CPU-fallback notice is one short line that says how to silence it and
stays a filterable warning; values print as the call that made them, or a summary when that call
would be hundreds of numbers; the example plots use the library's frame (y positive to port);
and the Rust example that opens a GPU prints no Mesa noise on a headless machine."""

import importlib.util
import os
import subprocess
import sys
import warnings

import matplotlib
import numpy as np
import pytest

import sonarproj
from sonarproj import Pose, Sonar

matplotlib.use("Agg")

# A process whose `auto` backend finds no GPU whatever the machine (no wgpu backend to look
# on), so the notice is always there to check.
NO_GPU = (
    "import warnings, sonarproj\n"
    "sonarproj.configure_gpu(backends=[])\n"
    "{before}\n"
    "sonarproj.project('paper-fls', 'paper-sss', sonarproj.Pose(pitch=90), (5.0, 0.0){backend})\n"
)


def run_python(code):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)


def test_the_cpu_notice_is_one_short_line_saying_how_to_silence_it():
    done = run_python(NO_GPU.format(before="", backend=""))
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    line = lines[0]
    assert line.startswith("sonarproj: note: running on the CPU"), line
    assert line.endswith('backend="cpu-fast" skips this note'), line
    assert len(line) <= 120, line
    # Not the warning's usual form: no file, line number or source line of the call.
    assert "<string>" not in line and "BackendNotice" not in line and "project(" not in line
    # Choosing the CPU says nothing.
    done = run_python(NO_GPU.format(before="", backend=", backend='cpu-fast'"))
    assert done.returncode == 0 and done.stderr == "", done.stderr


def test_the_cpu_notice_remains_a_filterable_warning():
    ignored = run_python(NO_GPU.format(
        before="warnings.filterwarnings('ignore', category=sonarproj.BackendNotice)", backend=""))
    assert ignored.returncode == 0 and ignored.stderr == "", ignored.stderr
    raised = run_python(NO_GPU.format(before="warnings.simplefilter('error', sonarproj.BackendNotice)", backend=""))
    assert raised.returncode != 0 and "BackendNotice" in raised.stderr, raised.stderr


def test_only_the_notice_is_formatted_as_one_line():
    assert warnings.formatwarning("why", sonarproj.BackendNotice, "f.py", 3) == "sonarproj: note: why\n"
    other = warnings.formatwarning("why", UserWarning, "f.py", 3, line="call()")
    assert "f.py:3" in other and "UserWarning: why" in other


@pytest.mark.parametrize("pose, text", [
    (Pose(0, 90, 0, t=(1, 2, 3)), "Pose(pitch=90.0, t=[1.0, 2.0, 3.0])"),
    (Pose(), "Pose()"),
    (Pose(10.5, 0, -3), "Pose(roll=10.5, yaw=-3.0)"),
    (Pose.from_quat_xyzw((0, 0, 0, 1), t=(1, 0, 0)), "Pose.from_quat_xyzw([0.0, 0.0, 0.0, 1.0], t=[1.0, 0.0, 0.0])"),
    (Pose.placement((5, 10, 0), (15, 0, 0), pitch=90),
     "Pose.placement(feature=[5.0, 10.0, 0.0], place=[15.0, 0.0, 0.0], pitch=90.0)"),
    (Pose.placement((5, 0, 0), (15, 0, 0), matrix=np.eye(3)),
     "Pose.placement(feature=[5.0, 0.0, 0.0], place=[15.0, 0.0, 0.0], "
     "matrix=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])"),
])
def test_a_pose_prints_as_the_call_that_made_it(pose, text):
    import pickle

    assert repr(pose) == text
    assert eval(repr(pose), {"Pose": Pose}) == pose  # noqa: S307 - the repr is the call
    assert repr(pickle.loads(pickle.dumps(pose))) == text


def test_a_pose_made_otherwise_prints_its_matrix():
    a, b = sonarproj.Mount((0, 0, 0)), sonarproj.Mount((1, 0, 0), rpy=(0, 0, 90))
    pose = Pose.from_mounts(a, b)
    assert repr(pose).startswith("Pose.from_matrix([[")
    assert eval(repr(pose), {"Pose": Pose}) == pose  # noqa: S307


def test_a_sonar_of_many_measured_beams_is_summarised():
    edges = list(np.round(np.linspace(-30.21, 30.21, 257) + 1e-12, 6))
    s = Sonar("fls", 0.0, 1.96, 60.42, 12, 700, beam_edges=edges, name="ping")
    text = repr(s)
    assert text == ("<Sonar 'ping': fls, 0–1.96 m in 700 range bins, 256 beams, edges -30.21° to 30.21°, "
                    "elevation aperture 12°>"), text
    # A few edges still print as the call.
    few = Sonar("fls", 0.5, 20, 90, 20, 390, beam_edges=[-45, -10, 0, 12.5, 45], name="few")
    assert repr(few).startswith("Sonar(") and eval(repr(few), {"Sonar": Sonar}) == few  # noqa: S307


def load_example(name):
    path = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "python", f"{name}.py")
    spec = importlib.util.spec_from_file_location(f"example_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_oculus_example_draws_y_positive_to_port(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    example = load_example("oculus_masks")
    monkeypatch.setattr(sys, "argv", ["oculus_masks.py", "--out", str(tmp_path), "--backend", "cpu"])
    example.main()
    ax = plt.gcf().axes[0]
    assert "+ port" in ax.get_xlabel() and ax.xaxis_inverted()
    # The detections' masks lie mostly to port (their azimuths -1.6°..20°): their cells' mean
    # horizontal coordinate is y, positive.
    meshes = [m for m in ax.collections if np.ma.count(m.get_array()) and np.ma.count(m.get_array()) < 10_000]
    assert meshes
    for mesh in meshes:
        corners = mesh.get_coordinates()
        centres = 0.25 * (corners[:-1, :-1] + corners[1:, :-1] + corners[:-1, 1:] + corners[1:, 1:])
        filled = ~np.ma.getmaskarray(mesh.get_array()).reshape(centres.shape[:2])
        assert centres[..., 0][filled].mean() > 0
    plt.close("all")


def test_the_ss2fl_example_draws_y_positive_to_port(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    example = load_example("example_ss2fl")
    monkeypatch.setattr(sys, "argv", ["example_ss2fl.py", "--out", str(tmp_path), "--backend", "cpu-fast"])
    example.main()
    ax = plt.gcf().axes[0]
    assert "+ port" in ax.get_xlabel() and ax.xaxis_inverted()
    # Each point is (y, x) = (r sin az, r cos az) of an occupied pixel: the farthest point's
    # azimuth is that of the library's farthest occupied pixel, sign included.
    points = next(c for c in ax.collections if len(c.get_offsets()) > 10).get_offsets()
    far = np.argmax(np.hypot(points[:, 0], points[:, 1]))
    plotted = np.degrees(np.arctan2(points[far, 0], points[far, 1]))
    fls = Sonar("fls", 0.1, 10, 60, 10, 990, beams=512)
    m = sonarproj.project(Sonar("sss", 0.1, 30, 130, 0.3, 2990), fls,
                          Pose.placement((15, 0, 0), (5, 0, 0), roll=45, yaw=45), 15, step=0.1,
                          occupancy=True, backend="cpu-fast")
    rows, cols = np.nonzero(m["occupancy"])
    edges = np.asarray(fls.beam_edges)
    k = np.argmax(rows)
    expected = 0.5 * (edges[cols[k]] + edges[cols[k] + 1])
    assert abs(expected) > 1, expected
    assert plotted == pytest.approx(expected, abs=0.2)
    plt.close("all")


def test_the_fl2ss_example_says_it_is_the_authors_configuration(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    example = load_example("example_fl2ss")
    monkeypatch.setattr(sys, "argv", ["example_fl2ss.py", "--out", str(tmp_path), "--backend", "cpu-fast"])
    example.main()
    title = plt.gcf().axes[0].get_title()
    assert "authors' example_fl2ss configuration" in title and "10°" in title, title
    plt.close("all")
