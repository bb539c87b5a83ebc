"""The viewer's page as a person sees it: at common window sizes the views, the metrics and
"copy as" share the window without scrolling; the 3-D view opens on the feature with a scale
bar that measures it; the sidescan strip names port and starboard only where both are drawn;
and choosing another sonar keeps the pose and the values that still apply."""

import io
import re
import time

import numpy as np
import pytest
from PIL import Image

from conftest import Page
from test_viewer import RED, set_scene

SIZES = [(1400, 900), (1920, 1080)]


@pytest.fixture()
def page(browser, viewer):
    return Page(browser, viewer.url)


def rect(page, element_id):
    return page.d.execute_script(
        "const r = document.getElementById(arguments[0]).getBoundingClientRect();"
        "return {left: r.left, top: r.top, right: r.right, bottom: r.bottom};", element_id)


def wait_for_canvases(page):
    """Waits until both canvases' drawing buffers have the size the layout gives them."""
    sized = ("return ['data-canvas', 'three-canvas'].every((id) => {"
             "const c = document.getElementById(id), d = window.devicePixelRatio || 1;"
             "return c.clientWidth > 0 && Math.abs(c.width - Math.round(c.clientWidth * (id === 'data-canvas' ? 1 : d))) <= 1"
             " && Math.abs(c.height - Math.round(c.clientHeight * (id === 'data-canvas' ? 1 : d))) <= 1; })")
    page.wait(lambda: page.d.execute_script(sized), "the canvases sized to the layout")
    time.sleep(0.1)


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_the_views_metrics_and_copy_share_the_window_without_scrolling(browser, viewer, size):
    browser.set_window_size(*size)
    try:
        page = Page(browser, viewer.url)
        wait_for_canvases(page)
        width, height = page.d.execute_script("return [window.innerWidth, window.innerHeight]")
        # the page itself does not scroll (the controls scroll in their own column)
        assert page.d.execute_script("return document.documentElement.scrollHeight") <= height
        assert page.d.execute_script("return document.documentElement.scrollWidth") <= width
        metrics = rect(page, "metrics")
        assert 0 <= metrics["top"] and metrics["bottom"] <= height and metrics["right"] <= width, (metrics, height)
        # every row of the table shows, none cut off by the panel
        last = page.d.execute_script(
            "const r = document.getElementById('m-time').getBoundingClientRect(); return r.bottom")
        assert last <= metrics["bottom"], (last, metrics)
        copy = rect(page, "copy")
        assert copy["bottom"] <= height and copy["right"] <= width and copy["right"] - copy["left"] > 300, copy
        # the two views side by side over the whole width: no blank column on the right
        v3, v2 = rect(page, "view3d"), rect(page, "view2d")
        assert abs(v3["top"] - v2["top"]) < 2 and v3["right"] < v2["left"], (v3, v2)
        assert v2["right"] > width - 40, (v2, width)
        for r in (v3, v2):
            assert r["bottom"] - r["top"] > 300 and r["right"] - r["left"] > 450, r
        assert page.severe_logs() == []
    finally:
        browser.set_window_size(1600, 1100)


def canvas_image(page, element_id):
    png = page.d.find_element("id", element_id).screenshot_as_png
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def test_the_opening_3d_view_frames_the_arc_and_shows_the_seen_samples(page):
    # The page as it opens: an FLS feature at 5 m whose 1 m arc sonar 2 (a sidescan, 30 m
    # fields of view) sees 8 % of, around the true point.
    assert page.metrics()["visible"] > 0
    wait_for_canvases(page)
    height = page.d.execute_script("return document.getElementById('three-canvas').clientHeight")
    arc = page.d.execute_script("return window.sonarprojFraming('samples')")
    assert -1 <= arc["left"] and arc["right"] <= 1 and -1 <= arc["bottom"] and arc["top"] <= 1, arc
    assert max(arc["right"] - arc["left"], arc["top"] - arc["bottom"]) / 2 >= 0.4, ("the arc is small", arc)
    # the seen samples show in red on the canvas, beside the true point's mark
    red = np.sum((np.abs(canvas_image(page, "three-canvas") - np.array(RED)) <= 40).all(axis=2))
    assert red >= 20, f"{red} red pixels"
    seen = page.answer()["metrics"]["visible"]
    assert seen == 17, seen  # 0.078 of the 217 samples: the scene the numbers above are about
    # the scale bar measures what is drawn: its pixels per metre are the arc's, whose chord is
    # 2 × 5 m × sin 6° (the arc is seen almost square, within 16°: cos 16° = 0.96)
    label = page.d.find_element("id", "scale-label").text
    found = re.fullmatch(r"([\d.]+) (m|cm)", label)
    assert found, label
    metres = float(found.group(1)) * (0.01 if found.group(2) == "cm" else 1)
    bar = page.d.execute_script(
        "return document.querySelector('#scale-bar .bar').getBoundingClientRect().width")
    assert 40 <= bar <= 150, bar
    arc_pixels = (arc["top"] - arc["bottom"]) / 2 * height
    chord = 2 * 5 * np.sin(np.radians(6))
    ratio = (bar / metres) / (arc_pixels / chord)
    assert 0.93 <= ratio <= 1.1, (ratio, bar, metres, arc_pixels)
    # sonar 2, 15 m away, is off the view: its label points to it from the edge
    label2 = page.d.find_element("id", "origin-2")
    assert label2.get_attribute("data-where") == "edge" and "15 m away" in label2.text, label2.text


def dark_pixels(page, x0, x1, y0, y1):
    """Returns how many pixels of the 2-D canvas's region are dark (text)."""
    data = page.d.execute_script(
        "const c = document.getElementById('data-canvas'); const w = c.width, h = c.height;"
        "return [w, h, Array.from(c.getContext('2d').getImageData(0, 0, w, h).data)];")
    w, h, rgba = data
    a = np.array(rgba, dtype=np.int32).reshape(h, w, 4)
    x0, x1 = (x if x >= 0 else w + x for x in (x0, x1))
    y0, y1 = (y if y >= 0 else h + y for y in (y0, y1))
    region = a[y0:y1, x0:x1]
    return int(np.sum((region[..., 3] > 0) & (region[..., :3] < 140).all(axis=2)))


def test_the_port_starboard_legend_is_drawn_only_where_both_sides_are(page):
    # paper-sss is one channel: no "◀ port … starboard ▶" in the strip's bottom corners
    set_scene(page, ("paper-fls", "paper-sss"), (5, 0, 0), (0, 90, 0), (8, 0, 0))
    assert page.d.execute_script("return window.sonarprojDrawn.sides") == 1
    corners = dark_pixels(page, 0, 90, -26, -1), dark_pixels(page, -110, -1, -26, -1)
    assert corners == (0, 0), corners
    # holoocean-sidescan draws both sides: the legend names them
    set_scene(page, ("paper-fls", "holoocean-sidescan"), (5, 10, 0), (0, 90, 0), (8, 20, 0))
    assert page.d.execute_script("return window.sonarprojDrawn.sides") == 2
    corners = dark_pixels(page, 0, 90, -26, -1), dark_pixels(page, -110, -1, -26, -1)
    assert min(corners) > 30, corners


def field(page, key):
    return float(page.d.find_element("id", "f-" + key.replace(".", "-")).get_attribute("value"))


def test_choosing_another_sonar_keeps_the_pose_and_the_values_that_still_apply(page):
    set_scene(page, ("paper-fls", "paper-sss"), (4, 20, 3), (20, 30, 40), (8, 10, 0))
    # sonar 2 becomes an FLS (0.1–10 m, ±30°): 8 m at 10° still applies
    page.select("to", "paper-fls")
    assert [field(page, "rotation." + k) for k in ("roll", "pitch", "yaw")] == [20, 30, 40]
    assert [field(page, "feature." + k) for k in ("range", "azimuth", "elevation")] == [4, 20, 3]
    assert [field(page, "place." + k) for k in ("range", "azimuth")] == [8, 10]
    command = page.answer()["copy"]["command"]
    for part in ("--roll 20 ", "--pitch 30 ", "--yaw 40 ", "--place-range 8 ", "--place-azimuth 10 ", "--range 4 "):
        assert part in command, (part, command)
    # back to the sidescan (0.1–30 m, ±65°), 25 m there; then the FLS again: 25 m is past its
    # 10 m, and the placement becomes 9 m (the round value a tenth of the span inside), not the
    # middle and not an odd number
    page.select("to", "paper-sss")
    page.type("place.range", 25)
    page.select("to", "paper-fls")
    assert field(page, "place.range") == 9
    assert [field(page, "rotation." + k) for k in ("roll", "pitch", "yaw")] == [20, 30, 40]
    # sonar 1 becomes a sidescan (elevation ±0.15°): 3° no longer applies and is 0; the
    # azimuth* (±65°) and the range stay
    page.select("from", "paper-sss")
    assert [field(page, "feature." + k) for k in ("range", "azimuth", "elevation")] == [4, 20, 0]
    assert [field(page, "rotation." + k) for k in ("roll", "pitch", "yaw")] == [20, 30, 40]
    assert page.error() is None, page.error()
    assert "--elevation 0 " in page.answer()["copy"]["command"]
