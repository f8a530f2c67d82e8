# SPDX-License-Identifier: Apache-2.0
"""Every source file the project ships carries its SPDX licence line, and
the licence and notice files are there (the project is Apache-2.0)."""

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TAG = "SPDX-License-Identifier: Apache-2.0"
SOURCE_SUFFIXES = (".c", ".h", ".py", ".sh", ".cmake", ".ld", ".s", ".S", ".awk", ".toml")
SOURCE_NAMES = ("CMakeLists.txt",)


def is_source(path: str) -> bool:
    name = Path(path).name
    return name.endswith(SOURCE_SUFFIXES) or name in SOURCE_NAMES or path == ".ci/run"


def missing_tag(paths, read) -> list[str]:
    """The paths among ``paths`` that are sources without the SPDX line in
    their first three lines."""
    bad = []
    for p in paths:
        if is_source(p):
            head = read(p).splitlines()[:3]
            if not any(TAG in line for line in head):
                bad.append(p)
    return bad


def tracked_files() -> list[str]:
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [p for p in out.splitlines() if (ROOT / p).is_file()]


def test_every_source_file_has_the_spdx_line():
    files = tracked_files()
    assert sum(is_source(p) for p in files) > 300
    bad = missing_tag(files, lambda p: (ROOT / p).read_text(errors="replace"))
    assert bad == [], f"no '{TAG}' line near the top of: {bad}"


def test_the_check_finds_a_file_without_it():
    texts = {"a.c": f"/* {TAG} */\nint x;\n", "b.py": "import os\n",
             "c.sh": f"#!/bin/sh\n# {TAG}\n", "d.md": "text\n"}
    assert missing_tag(texts, texts.__getitem__) == ["b.py"]


def test_licence_and_notice():
    licence = (ROOT / "LICENSE").read_text()
    assert "Apache License" in licence and "Version 2.0, January 2004" in licence
    assert "END OF TERMS AND CONDITIONS" in licence
    assert "Apache License, Version 2.0" in (ROOT / "NOTICE").read_text()
