"""The viewer (`sonarproj view`) in a real browser: headless Chromium loads the page, moves
sliders and types values, and what the page shows is checked against the command line
(`sonarproj project --backend cpu`, an independent process) and against where the documented
picture convention puts each occupied bin: near range at the bottom, port on the left, beam 0
(starboard-most) on the right of the raw layout."""

import http.client
import io
import json
import math
import os
import shlex
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from conftest import Page, Server, chrome

RED = (214, 39, 40)  # the page's colour of occupied bins and pixels


@pytest.fixture()
def page(browser, viewer):
    return Page(browser, viewer.url)


def project(cli, tmp_path, pair, feature, rotation, place=None, translation=None, occupancy=False):
    """Returns `sonarproj project --backend cpu`'s JSON (and its occupancy as numpy)."""
    args = ["project", "--backend", "cpu", "--from", pair[0], "--to", pair[1],
            "--range", feature[0], "--azimuth", feature[1], "--elevation", feature[2],
            "--roll", rotation[0], "--pitch", rotation[1], "--yaw", rotation[2]]
    if place is not None:
        args += ["--place-range", place[0], "--place-azimuth", place[1], "--place-elevation", place[2]]
    else:
        args += ["--translation", ",".join(map(str, translation))]
    npy = tmp_path / "occupancy.npy"
    if occupancy:
        args += ["--occupancy", npy]
    out = json.loads(cli(*args).stdout)
    return out, (np.load(npy) if occupancy else None)


def set_scene(page, pair, feature, rotation, place=None, translation=None):
    """Sets every field of the page, moving the sliders where a person would drag them."""
    if page.d.execute_script("return document.getElementById('from').value") != pair[0]:
        page.select("from", pair[0])
    if page.d.execute_script("return document.getElementById('to').value") != pair[1]:
        page.select("to", pair[1])
    for key, v in zip(("feature.range", "feature.azimuth", "feature.elevation"), feature):
        page.type(key, v)
    for key, v in zip(("rotation.roll", "rotation.pitch", "rotation.yaw"), rotation):
        page.slide(key, v)
    if place is not None:
        page.mode("place")
        for key, v in zip(("place.range", "place.azimuth", "place.elevation"), place):
            page.type(key, v)
    else:
        page.mode("translation")
        for key, v in zip(("translation.x", "translation.y", "translation.z"), translation):
            page.type(key, v)


SCENES = [
    # (pair, feature (m, deg, deg), roll/pitch/yaw (deg), place or None, translation or None)
    (("paper-fls", "paper-sss"), (5, 10, 0), (0, 90, 0), (15, 0, 0), None),
    (("paper-sss", "paper-fls"), (5, 0, 0), (20, 30, 40), (5, 5, 0), None),
    (("paper-fls", "paper-fls"), (4, -12, 3), (5, 0, -15), None, (-1.0, 0.5, 0.2)),
    (("holoocean-sidescan", "holoocean-sidescan"), (12, 0, 0), (0, 0, 30), (14, -10, 0), None),
]


def test_the_page_loads_without_console_errors(page):
    assert page.severe_logs() == []
    assert page.error() is None
    assert page.metrics()["total"] > 0


@pytest.mark.parametrize("scene", SCENES, ids=lambda s: f"{s[0][0]}-{s[0][1]}")
def test_moving_sliders_shows_the_numbers_of_sonarproj_project(page, cli, tmp_path, scene):
    pair, feature, rotation, place, translation = scene
    set_scene(page, pair, feature, rotation, place, translation)
    shown = page.metrics()
    expected, _ = project(cli, tmp_path, pair, feature, rotation, place, translation)
    assert shown == expected["metrics"], "the page shows other numbers than the command line"
    assert shown["visible"] > 0, "a scene where sonar 2 sees something"
    # and the slider moved them: a yaw of 170° more shows another projection
    page.slide("rotation.yaw", rotation[2] - 170 if rotation[2] > 0 else rotation[2] + 170)
    assert page.metrics() != shown
    assert page.severe_logs() == []


def red_pixels(page, canvas_id="data-canvas"):
    """Returns the (x, y) canvas pixels painted in the occupied colour."""
    data = page.d.execute_script(
        "const c = document.getElementById(arguments[0]);"
        "return [c.width, c.height, Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data)];",
        canvas_id)
    w, h, rgba = data
    a = np.array(rgba, dtype=np.int32).reshape(h, w, 4)
    hit = (np.abs(a[..., 0] - RED[0]) <= 6) & (np.abs(a[..., 1] - RED[1]) <= 6) & (np.abs(a[..., 2] - RED[2]) <= 6)
    ys, xs = np.nonzero(hit)
    return xs, ys


def occupied_centres(occ, sonar):
    """Returns the (range m, azimuth rad) centres of the occupied pixels of an FLS occupancy."""
    i, j = np.nonzero(occ)
    dr = (sonar["range_max"] - sonar["range_min"]) / sonar["range_bins"]
    edges = np.radians(sonar["beam_edges"])
    r = sonar["range_min"] + (i + 0.5) * dr
    az = 0.5 * (edges[j] + edges[j + 1])
    return i, j, r, az


def test_the_fan_puts_port_on_the_left_and_near_range_at_the_bottom(page, cli, tmp_path):
    # a feature seen at +20° (port) and 3 m, near the fan's apex; rolled 90° so that the arc
    # spreads over beams
    scene = (("paper-fls", "paper-fls"), (5, 0, 0), (90, 0, 0), (3, 20, 0), None)
    set_scene(page, *scene)
    page.d.execute_script(
        "const s = document.getElementById('layout-view'); s.value = 'fan';"
        "s.dispatchEvent(new Event('change'));")
    _, occ = project(cli, tmp_path, *scene, occupancy=True)
    sonar = page.answer()["to"]
    _, _, r, az = occupied_centres(occ, sonar)
    drawn = page.d.execute_script("return window.sonarprojDrawn")
    assert drawn["view"] == "fan"
    xs, ys = red_pixels(page)
    assert len(xs) > 20, "the projected region is drawn"
    # where the documented convention puts the occupied pixels: forward up, +y (port) left
    x_expected = drawn["cx"] - np.mean(r * np.sin(az)) * drawn["scale"]
    y_expected = drawn["cy"] - np.mean(r * np.cos(az)) * drawn["scale"]
    assert abs(np.mean(xs) - x_expected) < 3 and abs(np.mean(ys) - y_expected) < 3, \
        (np.mean(xs), np.mean(ys), x_expected, y_expected)
    assert np.mean(xs) < drawn["cx"], "a port feature is left of the sonar"
    fan_height = sonar["range_max"] * drawn["scale"]
    assert drawn["cy"] - np.mean(ys) < fan_height / 2, "3 m of 10 m is in the lower half"


def test_the_raw_layout_puts_beam_0_on_the_right_and_row_0_at_the_bottom(page, cli, tmp_path):
    scene = (("paper-fls", "paper-fls"), (5, 0, 0), (90, 0, 0), (8, -20, 0), None)  # starboard, far
    set_scene(page, *scene)
    page.d.execute_script(
        "const s = document.getElementById('layout-view'); s.value = 'raw';"
        "s.dispatchEvent(new Event('change'));")
    try:
        _, occ = project(cli, tmp_path, *scene, occupancy=True)
        sonar = page.answer()["to"]
        i, j, _, _ = occupied_centres(occ, sonar)
        drawn = page.d.execute_script("return window.sonarprojDrawn")
        assert drawn["view"] == "raw"
        xs, ys = red_pixels(page)
        assert len(xs) > 0
        cw = drawn["width"] / sonar["beams"]
        rh = drawn["height"] / sonar["range_bins"]
        x_expected = drawn["left"] + (sonar["beams"] - 1 - np.mean(j) + 0.5) * cw
        y_expected = drawn["top"] + drawn["height"] - (np.mean(i) + 0.5) * rh
        assert abs(np.mean(xs) - x_expected) < 2 and abs(np.mean(ys) - y_expected) < 2
        assert np.mean(xs) > drawn["left"] + drawn["width"] / 2, "starboard is on the right"
        assert np.mean(ys) < drawn["top"] + drawn["height"] / 2, "8 m of 10 m is in the upper half"
    finally:
        page.d.execute_script(
            "const s = document.getElementById('layout-view'); s.value = 'fan';"
            "s.dispatchEvent(new Event('change'));")


def test_the_sidescan_strip_puts_near_range_at_the_bottom(page, cli, tmp_path):
    scene = (("paper-fls", "paper-sss"), (5, 10, 0), (0, 90, 0), (6, 0, 0), None)
    set_scene(page, *scene)
    _, occ = project(cli, tmp_path, *scene, occupancy=True)
    sonar = page.answer()["to"]
    bins = np.nonzero(occ)[0]
    drawn = page.d.execute_script("return window.sonarprojDrawn")
    assert drawn["view"] == "strip"
    xs, ys = red_pixels(page)
    assert len(xs) > 0
    rh = drawn["height"] / sonar["range_bins"]
    y_expected = drawn["top"] + drawn["height"] - (np.mean(bins) + 0.5) * rh
    assert abs(np.mean(ys) - y_expected) < 2
    assert np.mean(ys) > drawn["top"] + drawn["height"] * 0.7, "6 m of 30 m is near the bottom"


def test_a_two_sided_sidescan_is_drawn_as_a_port_strip_left_of_a_starboard_strip(page, cli, tmp_path):
    # holoocean-sidescan's data is one row: port far to near, then starboard near to far.
    for azimuth, port in ((-20, False), (20, True)):
        scene = (("paper-fls", "holoocean-sidescan"), (5, 10, 0), (0, 90, 0), (8, azimuth, 0), None)
        set_scene(page, *scene)
        _, occ = project(cli, tmp_path, *scene, occupancy=True)
        sonar = page.answer()["to"]
        n = sonar["range_bins"]
        assert occ.shape == (2 * n,) and sonar["beams"] == 2
        row = np.nonzero(occ)[0]
        assert len(row) > 0 and ((row < n).all() if port else (row >= n).all()), row
        bins = n - 1 - row if port else row - n
        drawn = page.d.execute_script("return window.sonarprojDrawn")
        assert drawn["view"] == "strip" and drawn["sides"] == 2
        xs, ys = red_pixels(page)
        assert len(xs) > 0
        middle = drawn["left"] + drawn["width"] / 2
        assert (np.mean(xs) < middle) == port, ("port strip on the left", np.mean(xs), middle)
        rh = drawn["height"] / n
        y_expected = drawn["top"] + drawn["height"] - (np.mean(bins) + 0.5) * rh
        assert abs(np.mean(ys) - y_expected) < 2


def test_the_screenshots_are_not_blank_and_the_3d_view_shows_the_seen_samples(page):
    set_scene(page, ("paper-fls", "paper-sss"), (5, 0, 0), (0, 90, 0), (15, 0, 0))
    for element_id in ("data-canvas", "three-canvas"):
        png = page.d.find_element("id", element_id).screenshot_as_png
        image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
        distinct = len(np.unique(image.reshape(-1, 3), axis=0))
        assert distinct > 20, f"{element_id} is blank ({distinct} colours)"
        red = np.sum((np.abs(image - np.array(RED)) <= 20).all(axis=2))
        assert red > 10, f"{element_id} shows no seen samples / occupied bins"


def assert_framed(page, what):
    """Every drawn vertex is on the 3-D canvas, and the scene fills most of it."""
    e = page.d.execute_script("return window.sonarprojFraming()")
    assert e is not None and e["points"] > 100, (what, e)
    assert -1 <= e["left"] and e["right"] <= 1 and -1 <= e["bottom"] and e["top"] <= 1, (what, "off the canvas", e)
    fill = max(e["right"] - e["left"], e["top"] - e["bottom"]) / 2
    assert fill > 0.8, (what, "the scene is small on the canvas", e)


def assert_feature_framed(page, what):
    """The sampled arc or surface and the true point are on the 3-D canvas, the arc across at
    least 40 % of it (and at most 90 %: there is room around it)."""
    e = page.d.execute_script("return window.sonarprojFraming('samples')")
    assert e is not None and e["points"] > 50, (what, e)
    assert -1 <= e["left"] and e["right"] <= 1 and -1 <= e["bottom"] and e["top"] <= 1, (what, "off the canvas", e)
    fill = max(e["right"] - e["left"], e["top"] - e["bottom"]) / 2
    assert 0.4 <= fill <= 0.9, (what, "the arc's share of the canvas", e)
    t = page.d.execute_script("return window.sonarprojFraming('truth')")
    assert t["points"] == 1 and abs(t["left"]) <= 1 and abs(t["bottom"]) <= 1, (what, "the true point", t)


def click(page, element_id):
    page.d.execute_script("document.getElementById(arguments[0]).click()", element_id)


@pytest.mark.parametrize("pair", [("oculus-m750d", "holoocean-sidescan"), ("holoocean-sidescan", "oculus-m750d")])
def test_the_3d_view_opens_on_the_feature_and_whole_scene_frames_everything(pair):
    # Long ranges (120 m and 35 m fields of view around a feature at 5 m) on a page that was
    # never touched: the feature is framed, not the fields of view; "whole scene" frames them.
    server = Server("--backend", "cpu-fast", "--from", pair[0], "--to", pair[1])
    driver = chrome()
    try:
        page = Page(driver, server.url)
        assert_feature_framed(page, pair)
        e = page.d.execute_script("return window.sonarprojFraming()")
        assert max(e["right"] - e["left"], e["top"] - e["bottom"]) / 2 > 2, ("the fields of view reach past it", e)
        click(page, "fit-all")
        assert_framed(page, (pair, "whole scene"))
    finally:
        driver.quit()
        server.stop()


def test_the_fit_buttons_frame_the_feature_and_the_scene_again(page):
    set_scene(page, ("paper-sss", "paper-fls"), (5, 0, 0), (20, 30, 40), (5, 5, 0))
    assert_feature_framed(page, "a new pair")
    # Moving sonar 2 100 m up keeps the camera (a person is looking); "whole scene" frames it
    # all, and "frame the feature" the feature again.
    page.mode("translation")
    for key in ("rotation.roll", "rotation.pitch", "rotation.yaw"):
        page.slide(key, 0)
    page.type("translation.z", -100)
    assert page.error() is None, page.error()
    e = page.d.execute_script("return window.sonarprojFraming()")
    assert e["left"] < -1 or e["right"] > 1 or e["bottom"] < -1 or e["top"] > 1, ("still framed?", e)
    click(page, "fit-all")
    assert_framed(page, "after whole scene")
    click(page, "fit")
    assert_feature_framed(page, "after frame the feature")


def test_a_bad_value_shows_the_engines_message_and_nothing_breaks(page, cli):
    set_scene(page, ("paper-fls", "paper-sss"), (5, 0, 0), (0, 90, 0), (15, 0, 0))
    good = page.metrics()
    page.type("feature.range", "50")
    done = cli("project", "--from", "paper-fls", "--to", "paper-sss", "--range", "50",
               "--pitch", "90", "--place-range", "15", check=False)
    assert done.returncode == 2
    message = done.stderr.strip().removeprefix("error: ")
    stale = "document.body.classList.contains('stale')"
    # The engine's message, then what the greyed views are.
    assert page.error() == message + " — the views and metrics below are greyed: they show the last good scene."
    assert page.d.execute_script("return " + stale)
    page.type("feature.range", "5")
    page.type("place.range", "-3")  # a second bad value: the page keeps answering
    assert page.error().startswith("place range = -3 is invalid: must be >= 0 m — ")
    page.type("place.range", "15")
    page.type("feature.range", "5")
    assert page.error() is None
    assert not page.d.execute_script("return " + stale)
    assert page.metrics() == good
    # the browser logs each refused scene (HTTP 400) as a failed load; nothing else
    assert [e for e in page.severe_logs() if "status of 400" not in e["message"]] == []


def test_letters_in_a_number_field_say_what_is_allowed_and_keep_the_last_value(page):
    set_scene(page, ("paper-fls", "paper-sss"), (5, 0, 0), (0, 90, 0), (15, 0, 0))
    good, updates = page.metrics(), page.updates()
    field = "f-feature-range"
    # A number field holding letters reads as empty: what a browser does with "abc".
    page.type("feature.range", "abc")
    message = page.error()
    assert message.startswith("range (feature): not a number; type a number from 0.1 to 10 m"), message
    assert "the last value, 5, is kept" in message
    assert page.updates() == updates, "nothing was sent"
    assert page.metrics() == good
    # Leaving the field puts the last value back and the page answers again.
    page._changed(
        "const s = document.getElementById(arguments[0]); s.dispatchEvent(new Event('change', {bubbles: true}));",
        field)
    assert page.d.find_element("id", field).get_attribute("value") == "5"
    assert page.error() is None and page.metrics() == good


def test_a_sidescan_target_has_one_data_view(page):
    view = "return document.getElementById('layout-view').disabled"
    set_scene(page, ("paper-fls", "paper-sss"), (5, 0, 0), (0, 90, 0), (15, 0, 0))
    assert page.d.execute_script(view), "a sidescan's strip is its only view"
    set_scene(page, ("paper-sss", "paper-fls"), (5, 0, 0), (20, 30, 40), (5, 5, 0))
    assert not page.d.execute_script(view), "an imaging sonar has the fan and the raw layout"


def test_the_exact_box_shows_the_numbers_of_project_step_exact(page, cli, tmp_path):
    pair, feature, rotation, place = ("paper-fls", "paper-sss"), (5, 0, 0), (0, 0, 0), (15, 0, 0)
    set_scene(page, pair, feature, rotation, place)
    page.check("exact", True)
    try:
        shown = page.metrics()
        args = ["project", "--backend", "cpu", "--from", pair[0], "--to", pair[1], "--range", 5, "--azimuth", 0,
                "--elevation", 0, "--roll", 0, "--pitch", 0, "--yaw", 0, "--place-range", 15, "--place-azimuth", 0,
                "--place-elevation", 0, "--step", "exact"]
        expected = json.loads(cli(*args).stdout)["metrics"]
        assert shown == expected, "the page shows other numbers than `project --step exact`"
        assert shown["total"] == 0 and 0.07 < shown["visible_fraction"] < 0.08
        assert "--step exact" in page.answer()["copy"]["command"]
    finally:
        page.check("exact", False)
    assert page.metrics()["total"] > 0
    assert page.severe_logs() == []


def test_noise_draws_a_widened_mask_holding_the_exact_occupancy(page):
    set_scene(page, ("paper-fls", "paper-fls"), (5, 0, 0), (0, 0, 10), (6, 5, 0))
    page.check("noise-on", True)
    try:
        a = page.answer()
        assert a["mask"] is not None
        mask = {k for s, n in a["mask"]["runs"] for k in range(s, s + n)}
        exact = {k for s, n in a["occupancy"]["runs"] for k in range(s, s + n)}
        assert exact and exact <= mask and len(mask) > len(exact)
    finally:
        page.check("noise-on", False)


def test_recovery_finds_the_true_point(page):
    set_scene(page, ("paper-fls", "paper-fls"), (5, 8, 2), (0, 10, 20), (6, -4, 1))
    page.check("second-on", True)
    try:
        page._changed("document.getElementById('second-truth').click()")
        best = page.answer()["recovery"]["candidates"][0]
        feature = np.radians([8, 2])
        truth = 5 * np.array([math.cos(feature[1]) * math.cos(feature[0]),
                              math.cos(feature[1]) * math.sin(feature[0]), math.sin(feature[1])])
        assert np.allclose(best["point_first"], truth, atol=1e-6)
    finally:
        page.check("second-on", False)


def metric_lines(text):
    out = {}
    for line in text.splitlines():
        name, value = line.split(" ", 1)
        out[name] = float(value)
    return out


def test_copy_as_reproduces_the_view(page, cli, tmp_path):
    scene = (("paper-sss", "paper-fls"), (5, 0, 0), (20, 30, 40), (5, 5, 0), None)
    set_scene(page, *scene)
    shown = page.metrics()
    copy = page.answer()["copy"]
    # the command line, computed on the same backend as the viewer: the same numbers
    first = shlex.split(copy["command"].splitlines()[0])
    assert first[:2] == ["sonarproj", "project"]
    args = [a if a != "occupancy.npy" else str(tmp_path / "o.npy") for a in first[1:]]
    assert json.loads(cli(*args, "--backend", "cpu").stdout)["metrics"] == shown
    # the sweep file: one row with the same numbers
    (tmp_path / "one.toml").write_text(copy["toml"])
    cli("sweep", "--config", tmp_path / "one.toml", "--out", tmp_path / "sweep", "--backend", "cpu")
    rows = (tmp_path / "sweep" / "sweep.csv").read_text().splitlines()
    header, row = rows[0].split(","), rows[1].split(",")
    assert len(rows) == 2
    for name in ("visible", "total", "occupied"):
        assert int(row[header.index(name)]) == shown[name]
    for name in ("range_min", "range_max", "span", "occupied_measure"):
        assert float(row[header.index(name)]) == shown[name]
    # Python: the package's default backend (the fast CPU path here) agrees with the reference
    # to rounding (1e-9 m), counts exactly
    done = subprocess.run([sys.executable, "-c", copy["python"]], capture_output=True, text=True,
                          env=dict(os.environ, NODEVICE_SELECT="1"))
    assert done.returncode == 0, done.stderr
    got = metric_lines(done.stdout)
    for name in ("visible", "total", "occupied"):
        assert got[name] == shown[name]
    for name in ("range_min", "range_max", "span", "occupied_measure"):
        assert abs(got[name] - shown[name]) <= 1e-9


def test_without_webgl_the_2d_view_and_metrics_still_work(viewer):
    driver = chrome("--disable-3d-apis", "--disable-webgl")
    try:
        page = Page(driver, viewer.url)
        assert driver.execute_script("return !document.getElementById('no-webgl').hidden")
        # the note shows: nothing (such as the blank canvas) lies over it
        assert driver.execute_script(
            "const p = document.getElementById('no-webgl'), r = p.getBoundingClientRect();"
            "return r.height > 0 && p.contains(document.elementFromPoint((r.left + r.right) / 2, (r.top + r.bottom) / 2))")
        page.slide("rotation.pitch", 90)
        assert page.metrics()["visible"] > 0
        assert len(red_pixels(page)[0]) > 0
        assert page.severe_logs() == []
    finally:
        driver.quit()


def request(viewer, method, path, body=None, headers=None):
    conn = http.client.HTTPConnection("127.0.0.1", viewer.port, timeout=10)
    conn.request(method, path, body=body, headers=headers or {})
    res = conn.getresponse()
    data = res.read()
    conn.close()
    return res.status, data


def test_the_server_refuses_other_hosts_origins_files_and_oversized_requests(viewer):
    scene = json.dumps({"from": "paper-fls", "to": "paper-sss", "feature": {"range": 5},
                        "place": {"range": 15}})
    assert request(viewer, "POST", "/api/scene", scene)[0] == 200
    # DNS rebinding: a page on another name that resolves to 127.0.0.1
    status, body = request(viewer, "GET", "/", headers={"Host": f"attacker.example:{viewer.port}"})
    assert status == 403 and b"not this viewer" in body
    status, _ = request(viewer, "POST", "/api/scene", scene, {"Origin": "http://attacker.example"})
    assert status == 403
    # a sonar is a label the server offers, never a path it would read
    status, body = request(viewer, "POST", "/api/scene", scene.replace('"paper-fls"', '"/etc/passwd"'))
    assert status == 400 and b"one of paper-fls" in body
    for path in ("/../Cargo.toml", "/etc/passwd", "/vendor/three/../../Cargo.toml"):
        assert request(viewer, "GET", path)[0] == 404
    status, body = request(viewer, "POST", "/api/scene", " " * (70 * 1024))
    assert status == 413 and b"at most 65536 bytes" in body
    status, body = request(viewer, "POST", "/api/scene", "{not json")
    assert status == 400 and b"request" in body
    # the engine's size limits: a sampling step that would need too many samples
    fine = json.dumps({"from": "paper-sss", "to": "paper-fls", "feature": {"range": 5},
                       "place": {"range": 5}, "step": 1e-6})
    status, body = request(viewer, "POST", "/api/scene", fine)
    assert status == 400 and b"samples per pose" in body


def raw(port, data, timeout=20):
    """Sends `data` on a new connection and returns everything the server answers until it
    closes the connection (or b"" when it resets it)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    out = b""
    try:
        try:
            s.sendall(data)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the server answered and closed before the rest was sent
        while True:
            try:
                chunk = s.recv(65536)
            except ConnectionResetError:
                break
            if not chunk:
                break
            out += chunk
    finally:
        s.close()
    return out


def status_of(reply):
    return int(reply.split(b" ", 2)[1]) if reply.startswith(b"HTTP/1.1 ") else None


def peak_memory_kib(pid):
    for line in open(f"/proc/{pid}/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    raise AssertionError("no VmHWM")


def test_a_slow_client_stalls_nobody_else(viewer):
    host = f"Host: 127.0.0.1:{viewer.port}\r\n"
    slow = socket.create_connection(("127.0.0.1", viewer.port))
    try:
        # Announces 60 000 bytes and sends one: its connection waits, nobody else does.
        slow.sendall(f"POST /api/scene HTTP/1.1\r\n{host}Content-Length: 60000\r\n\r\n{{".encode())
        for _ in range(3):
            status, body = request(viewer, "GET", "/api/init")
            assert status == 200 and b"sonars" in body
    finally:
        slow.close()


def test_request_heads_are_bounded_and_doubled_headers_refused(viewer):
    port = viewer.port
    host = f"Host: 127.0.0.1:{port}\r\n"
    close = "Connection: close\r\n"
    before = peak_memory_kib(viewer.process.pid)
    # A head that never ends (8 MiB of one header line after another) and 20 000 headers: 431.
    flood = f"GET / HTTP/1.1\r\n{host}".encode() + (b"X-A: " + b"a" * 65536 + b"\r\n") * 128
    assert status_of(raw(port, flood)) == 431
    many = f"GET / HTTP/1.1\r\n{host}" + "".join(f"X-{i}: 1\r\n" for i in range(20000)) + close + "\r\n"
    assert status_of(raw(port, many.encode())) == 431
    assert peak_memory_kib(viewer.process.pid) - before < 64 * 1024, "the flood was held in memory"
    # Two Host headers (ours first) and two different Content-Length headers: 400 (RFC 9112).
    two_hosts = raw(port, f"GET /api/init HTTP/1.1\r\n{host}Host: evil.example:{port}\r\n{close}\r\n".encode())
    assert status_of(two_hosts) == 400 and b"more than one Host header" in two_hosts
    two_lengths = raw(port, f"POST /api/scene HTTP/1.1\r\n{host}Content-Length: 5\r\nContent-Length: 6\r\n{close}\r\n{{}}xxxx".encode())
    assert status_of(two_lengths) == 400
    # Error replies are short: a 50 kB path is quoted by its first 80 characters.
    long_path = raw(port, f"GET /{'a' * 50000} HTTP/1.1\r\n{host}{close}\r\n".encode())
    assert status_of(long_path) == 404 and len(long_path) < 1024 and b"(50001 bytes)" in long_path
    # And the server goes on.
    assert request(viewer, "GET", "/api/init")[0] == 200


HEAVY = json.dumps({"from": "holoocean-sidescan", "to": "oculus-m750d", "feature": {"range": 20},
                    "place": {"range": 20}, "step": 0.0008})  # 66.5 M samples, seconds of work
LIGHT = json.dumps({"from": "paper-fls", "to": "paper-sss", "feature": {"range": 5}, "place": {"range": 15}})


@pytest.fixture()
def fast_viewer():
    server = Server("--backend", "cpu-fast")
    yield server
    server.stop()


def cpu_seconds(pid):
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def test_a_heavy_scene_blocks_no_one_and_stops_when_its_client_leaves(fast_viewer):
    port = fast_viewer.port
    heavy = socket.create_connection(("127.0.0.1", port))
    heavy.sendall(f"POST /api/scene HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: {len(HEAVY)}\r\n\r\n{HEAVY}".encode())
    heavy.setblocking(False)
    # A light scene is answered while the heavy one is still being computed.
    status, body = request(fast_viewer, "POST", "/api/scene", LIGHT)
    assert status == 200 and json.loads(body)["metrics"]["visible"] > 0
    with pytest.raises(BlockingIOError):
        heavy.recv(1)  # no answer yet: it is still computing
    # The heavy scene's client leaves: its work stops at the next tile of samples, where it
    # would have gone on for several CPU-seconds more.
    heavy.close()
    time.sleep(0.5)
    used = cpu_seconds(fast_viewer.process.pid)
    time.sleep(2)
    assert cpu_seconds(fast_viewer.process.pid) - used < 0.5
    assert peak_memory_kib(fast_viewer.process.pid) < 512 * 1024
