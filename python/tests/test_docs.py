"""The Python and TOML code blocks of the README and the guide (docs/*.md), run and parsed.

Every ```python block is executed, in the order of its file, in a fresh namespace with a
temporary working directory that holds the repository's data/ (as the README's commands expect).
Every ```toml block must be TOML; a ```toml cargo block is a Cargo.toml fragment that must name
this repository's root package. (Shell blocks, and sonar and sweep files through their parsers,
are run by crates/sonarproj-cli/tests/docs.rs; Rust blocks are the engine's doctests.)
"""

from __future__ import annotations

import os
import pathlib
import re
import sys
import warnings

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^(\s*)```(\S*)(.*)$")


def blocks(path: pathlib.Path):
    """Yields (language, attributes, first line number, code) for each fenced block of `path`."""
    lines = path.read_text().splitlines()
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, lang, attrs = m.group(1), m.group(2), m.group(3).split()
        start = i + 1
        body = []
        i += 1
        while i < len(lines) and lines[i].strip() != "```":
            body.append(lines[i][len(indent):] if lines[i].startswith(indent) else lines[i])
            i += 1
        assert i < len(lines), f"{path.name}:{start}: unclosed code block"
        i += 1
        yield lang, attrs, start, "\n".join(body) + "\n"


def of(lang: str):
    return [
        pytest.param(path, attrs, code, id=f"{path.relative_to(ROOT)}:{line}")
        for path in DOCS
        for (l, attrs, line, code) in blocks(path)
        if l == lang
    ]


PYTHON = of("python")
TOML = of("toml")


def test_the_docs_have_python_and_toml_blocks():
    # The parametrised tests below would pass vacuously if the blocks were not found.
    assert len(PYTHON) >= 2 and len(TOML) >= 4


@pytest.mark.parametrize("path, attrs, code", PYTHON)
def test_python_block_runs(path, attrs, code, tmp_path, monkeypatch):
    assert attrs == [], f"no attributes are known for python blocks: {attrs}"
    (tmp_path / "data").symlink_to(ROOT / "data")
    monkeypatch.chdir(tmp_path)
    with warnings.catch_warnings():
        # The CPU-fallback notice (a BackendNotice warning) is part of normal output here.
        warnings.simplefilter("ignore")
        exec(compile(code, str(path), "exec"), {"__name__": "__doc_block__"})


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib is Python 3.11's")
@pytest.mark.parametrize("path, attrs, code", TOML)
def test_toml_block_parses(path, attrs, code):
    import tomllib

    data = tomllib.loads(code)
    if attrs == ["cargo"]:
        root = tomllib.loads((ROOT / "Cargo.toml").read_text())
        name = root["package"]["name"]
        assert "path" in data["dependencies"][name], data
    else:
        assert attrs in (["sonar"], ["sweep"]), f"unknown toml block attributes {attrs}"
