# SPDX-License-Identifier: Apache-2.0
"""Host tools of the Stewart platform controller."""

from importlib.metadata import PackageNotFoundError, version


def _version() -> str:
    """tools/pyproject.toml's version (the one source), from the installed
    metadata, or from the file when a build's generator runs the source tree."""
    try:
        return version("stewart")
    except PackageNotFoundError:
        import tomllib
        from pathlib import Path

        with open(Path(__file__).resolve().parents[1] / "pyproject.toml", "rb") as f:
            return tomllib.load(f)["project"]["version"]


__version__ = _version()
