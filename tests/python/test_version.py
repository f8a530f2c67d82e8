# SPDX-License-Identifier: Apache-2.0
"""The project's one version (tools/pyproject.toml, semantic versioning,
CHANGELOG.md): the firmware's sp/math/version.h is generated from it at
build time and the tools report the same."""

import re
from pathlib import Path
import tomllib

from stewart import __version__

REPO_ROOT = Path(__file__).resolve().parents[2]

PYPROJECT = REPO_ROOT / "tools" / "pyproject.toml"
HEADER = REPO_ROOT / "build" / "host-release" / "firmware" / "generated" / "include" / "sp" / "math" / "version.h"


def _version():
    return tomllib.loads(PYPROJECT.read_text())["project"]["version"]


def test_the_version_is_semantic_and_in_the_changelog():
    v = _version()
    assert re.fullmatch(r"(0|[1-9]\d*)\.(0|[1-9]\d*)\.(0|[1-9]\d*)", v)
    assert f"## [{v}]" in (REPO_ROOT / "CHANGELOG.md").read_text()


def test_firmware_and_tools_say_the_same_version():
    assert HEADER.is_file(), f"{HEADER} not found: build it with `scripts/build.sh host-release`"
    text = HEADER.read_text()
    macros = dict(re.findall(r"#define SP_VERSION_(MAJOR|MINOR|PATCH) (\d+)", text))
    v = _version()
    assert f"{macros['MAJOR']}.{macros['MINOR']}.{macros['PATCH']}" == v
    assert f'#define SP_VERSION_STRING "{v}"' in text
    assert __version__ == v
