"""Shared fixtures: the command-line binary the API is compared with, and the repository root."""

import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _binary() -> pathlib.Path:
    given = os.environ.get("SONARPROJ_BIN")
    if given:
        return pathlib.Path(given)
    built = ROOT / "target" / "release" / "sonarproj"
    if built.exists():
        return built
    found = shutil.which("sonarproj")
    if found:
        return pathlib.Path(found)
    return built


@pytest.fixture(scope="session")
def cli():
    """Returns a function running the sonarproj binary with arguments; the result is
    subprocess's CompletedProcess (text). The comparison tests need the binary: under CI=true a
    missing one fails them instead of skipping."""
    binary = _binary()
    if not binary.exists():
        message = f"the sonarproj binary is needed ({binary}); build it with cargo build --release or set SONARPROJ_BIN"
        if os.environ.get("CI") == "true":
            pytest.fail(message)
        pytest.skip(message)

    def run(*args, check=True, **kwargs):
        env = dict(os.environ)
        env.setdefault("NODEVICE_SELECT", "1")
        done = subprocess.run(
            [str(binary), *map(str, args)], capture_output=True, text=True, env=env, **kwargs
        )
        if check and done.returncode != 0:
            raise AssertionError(f"sonarproj {' '.join(map(str, args))} exited {done.returncode}: {done.stderr}")
        return done

    return run


@pytest.fixture(scope="session")
def root():
    return ROOT
