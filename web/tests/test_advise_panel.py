"""The viewer's advise panel in a real browser: it scores the grid around the pose now, draws an
arrow to the best small move, and "apply" moves the sliders there; its numbers are those of
`sonarproj advise` (the command line, another process) on the same rig and features."""

import json

import pytest

from conftest import Page
from test_viewer import set_scene


@pytest.fixture()
def page(browser, viewer):
    return Page(browser, viewer.url)


def run_panel(page, span=10):
    page.d.execute_script(
        "document.getElementById('advise-span').value = arguments[0];"
        "window.sonarprojAdvice = null; document.getElementById('advise-run').click();", str(span))
    page.wait(lambda: page.d.execute_script("return window.sonarprojAdvice !== null"), "the advice", timeout=60)
    return page.d.execute_script("return window.sonarprojAdvice")


def test_the_panel_scores_around_the_pose_and_applies_the_move(page, cli, tmp_path):
    pair, rotation, t = ("paper-fls", "paper-fls"), (20, -5, 0), (0.0, 0.0, -0.5)
    set_scene(page, pair, (4, 0, 0), rotation, translation=t)
    a = run_panel(page)
    assert a["axes"] == ["roll", "pitch"]
    assert len(a["scores"]) == 81 and len(a["values"][0]) == 9
    assert a["values"][0][4] == rotation[0] and a["values"][1][4] == rotation[1]
    move = a["move"]
    assert move["now"]["rotation"] == list(rotation)
    assert move["best"] is not None and move["gain"] > 2 * move["gain_se"] and not move["stay"]
    drawn = page.d.execute_script("return window.sonarprojAdviceDrawn")
    assert drawn["to"] is not None and drawn["to"] != drawn["from"]
    text = page.d.find_element("id", "advise-text").text
    # The numbers with their units and errors, the ties, the move in words.
    assert a["score_unit"] == "m²" and a["tied"] >= 1
    assert "Best move" in text and move["words"] in text and "gain" in text and "m²" in text and "±" in text, text
    assert f"{a['tied']} pose" in text and "tied with the best" in text, text

    # The command line on the same rig, features and grid.
    config = tmp_path / "advise.toml"
    config.write_text(
        f'from = "{pair[0]}"\nto = "{pair[1]}"\nstep = "auto"\nobjective = "correspondence"\n'
        "[features]\ncount = 200\nseed = 1\n"
        f"[rig]\ntranslation = {list(t)}\n"
        f"[search]\nroll = {a['values'][0]}\npitch = {a['values'][1]}\nyaw = 0\nrefine = 0\n"
        f"[from_pose]\nroll = {rotation[0]}\npitch = {rotation[1]}\nyaw = 0\nstep = 2.5\n"
    )
    cli("advise", "--config", config, "--out", tmp_path / "out", "--backend", "cpu")
    best = json.loads((tmp_path / "out" / "best.json").read_text())
    assert best["next_move"]["best"]["rotation"] == move["best"]["rotation"]
    assert best["next_move"]["gain"] == move["gain"]
    assert best["next_move"]["gain_se"] == move["gain_se"] and best["tied"] == a["tied"]

    # Apply: the sliders move there and the scene is computed again.
    before = page.updates()
    page.d.execute_script("document.getElementById('advise-apply').click()")
    page.wait(lambda: page.updates() > before, "the scene at the moved pose")
    for key, v in zip(("rotation.roll", "rotation.pitch", "rotation.yaw"), move["best"]["rotation"]):
        shown = float(page.d.execute_script(f"return document.getElementById('f-{key.replace('.', '-')}').value"))
        assert shown == v, key
    assert page.answer()["metrics"]["total"] > 0
    page.d.find_element("id", "advise").screenshot(str(tmp_path / "advise-panel.png"))


def test_bad_panel_input_says_what_is_allowed(page):
    page.d.execute_script(
        "document.getElementById('advise-span').value = '200';"
        "document.getElementById('advise-run').click();")
    text = lambda: page.d.find_element("id", "advise-text").text  # noqa: E731
    page.wait(lambda: text() not in ("scoring…", "") and not text().startswith("200 features"), "the answer")
    assert "span = 200" in text() and "(0, 90]" in text(), text()
    assert page.d.execute_script("return document.getElementById('advise-apply').disabled")
    # The browser logs the refused request (400) as an error: that one, and nothing else (read
    # here, so the browser's log is clean for the tests after this one).
    logs = page.severe_logs()
    assert logs and all("/api/advise" in e["message"] and "400" in e["message"] for e in logs), logs
