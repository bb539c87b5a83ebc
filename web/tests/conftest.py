"""Fixtures of the viewer's browser tests: the sonarproj binary, a running `sonarproj view`, and
headless Chromium driven through chromedriver (Debian packages `chromium`, `chromium-driver`).
Under CI=true a missing binary, browser or driver fails the tests instead of skipping them."""

import json
import os
import pathlib
import re
import shutil
import subprocess
import time

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _missing(message):
    if os.environ.get("CI") == "true":
        pytest.fail(message)
    pytest.skip(message)


def binary_path():
    given = os.environ.get("SONARPROJ_BIN")
    return pathlib.Path(given) if given else ROOT / "target" / "release" / "sonarproj"


@pytest.fixture(scope="session")
def cli():
    """Returns a function running the sonarproj binary; the result is a CompletedProcess (text)."""
    binary = binary_path()
    if not binary.exists():
        _missing(f"the sonarproj binary is needed ({binary}); build it with cargo build --release or set SONARPROJ_BIN")

    def run(*args, check=True):
        env = dict(os.environ, NODEVICE_SELECT="1")
        done = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True, env=env)
        if check and done.returncode != 0:
            raise AssertionError(f"sonarproj {' '.join(map(str, args))} exited {done.returncode}: {done.stderr}")
        return done

    return run


class Server:
    """A running `sonarproj view --port 0`; `url` is where it listens."""

    def __init__(self, *args):
        env = dict(os.environ, NODEVICE_SELECT="1")
        self.process = subprocess.Popen(
            [str(binary_path()), "view", "--port", "0", *args],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        )
        line = self.process.stdout.readline()
        found = re.search(r"(http://127\.0\.0\.1:\d+/)", line)
        if not found:
            self.process.kill()
            raise AssertionError(f"sonarproj view printed {line!r}; stderr: {self.process.stderr.read()}")
        self.url = found.group(1)
        self.port = int(self.url.rsplit(":", 1)[1].strip("/"))

    def stop(self):
        self.process.terminate()
        self.process.wait(timeout=10)


@pytest.fixture(scope="session")
def viewer(cli):
    """A viewer computing on the CPU reference, so that its numbers are the ones
    `sonarproj project --backend cpu` prints, bit for bit."""
    server = Server("--backend", "cpu")
    yield server
    server.stop()


def chrome(*extra):
    """Returns a headless Chromium (selenium) with the browser's console log kept."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver") or "/usr/lib/chromium/chromedriver"
    if not browser or not pathlib.Path(driver).exists():
        _missing("the browser tests need Chromium and chromedriver (apt-get install chromium chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        _missing("the browser tests need selenium (pip install selenium)")
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for flag in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                 "--enable-unsafe-swiftshader", "--window-size=1600,1100",
                 "--disable-background-networking", "--disable-extensions",
                 "--disable-component-update", "--no-first-run", *extra):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=options)


@pytest.fixture(scope="session")
def browser(viewer):
    driver = chrome()
    yield driver
    driver.quit()


class Page:
    """The viewer's page in a browser: set fields, wait for the engine's answer, read back."""

    METRICS = ["visible", "total", "visible_fraction", "range_min", "range_max", "span", "azimuth_min", "azimuth_max",
               "occupied", "occupied_measure", "projection_area", "range_per_elevation", "sigma_elevation"]

    def __init__(self, driver, url):
        self.d = driver
        self.d.get(url)
        self.wait(lambda: self.updates() >= 1, "the first scene")

    def wait(self, condition, what, timeout=20):
        end = time.time() + timeout
        while time.time() < end:
            if condition():
                return
            time.sleep(0.02)
        raise AssertionError(f"timed out waiting for {what}; page error: {self.error()!r}")

    def updates(self):
        return int(self.d.execute_script("return document.body.dataset.updates || '0'"))

    def errors(self):
        return int(self.d.execute_script("return document.body.dataset.errors || '0'"))

    def error(self):
        return self.d.execute_script(
            "const e = document.getElementById('error'); return e.hidden ? null : e.textContent")

    def _changed(self, action, *args):
        before, errors = self.updates(), self.errors()
        self.d.execute_script(action, *args)
        self.wait(lambda: self.updates() > before or self.errors() > errors, "the engine's answer")

    def slide(self, key, value):
        """Moves the slider of `key` (e.g. "rotation.pitch") to `value`, as a drag does."""
        slider = "f-" + key.replace(".", "-") + "-slider"
        self._changed(
            "const s = document.getElementById(arguments[0]); s.value = arguments[1];"
            "s.dispatchEvent(new Event('input', {bubbles: true}));", slider, str(value))

    def type(self, key, value):
        """Types `value` into the number field of `key`."""
        self._changed(
            "const s = document.getElementById(arguments[0]); s.value = arguments[1];"
            "s.dispatchEvent(new Event('input', {bubbles: true}));", "f-" + key.replace(".", "-"), str(value))

    def select(self, element_id, value):
        self._changed(
            "const s = document.getElementById(arguments[0]); s.value = arguments[1];"
            "s.dispatchEvent(new Event('change', {bubbles: true}));", element_id, value)

    def check(self, element_id, on):
        self._changed(
            "const s = document.getElementById(arguments[0]); s.checked = arguments[1];"
            "s.dispatchEvent(new Event('change', {bubbles: true}));", element_id, on)

    def mode(self, value):
        self._changed(
            "const s = document.querySelector(`input[name=mode][value=${arguments[0]}]`); s.checked = true;"
            "s.dispatchEvent(new Event('change', {bubbles: true}));", value)

    def metrics(self):
        """Returns the shown metrics as numbers (None where the page shows none)."""
        out = {}
        for name in self.METRICS:
            raw = self.d.find_element("id", "m-" + name).get_attribute("data-value")
            out[name] = None if raw == "" else json.loads(raw)
        return out

    def answer(self):
        """Returns the engine's last answer, as the page received it."""
        return self.d.execute_script("return window.sonarprojLast")

    def severe_logs(self):
        return [e for e in self.d.get_log("browser") if e["level"] == "SEVERE"]
