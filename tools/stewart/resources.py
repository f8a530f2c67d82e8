# SPDX-License-Identifier: Apache-2.0
"""Where the tools find the files they work with; the one module that knows.

Shipped with the package: the protocol's DBC, the default platform config,
the firmware headers whose constants the tools share, and the firmware
core built as a shared library. An installed package (``pip install
./tools``) carries its own copies, which its build made from the checkout:
``stewart/data/`` and ``stewart/lib/libsp_core.so``. The editable install
of a checkout (scripts/setup.sh) carries none: there each comes from the
checkout itself (``protocol/``, ``config/``, ``firmware/`` and the
host-release build tree), so the tools follow the developer's edits and
builds. ``STEWART_CORE_LIB`` names another build of the core library.

Files that only a source tree has (the build trees with the controller
and the plant, the docs, ``out/``) are looked for in the checkout the
package runs from, else relative to the working directory.
"""

from __future__ import annotations

import os
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_DATA = _PACKAGE / "data"
_LIB = _PACKAGE / "lib"

DBC = "stewart.dbc"
DEFAULT_PLATFORM = "platform_default.json"
CORE_LIBRARY = "libsp_core.so"


def checkout() -> Path | None:
    """The source checkout the package runs from (an editable install), or None."""
    root = _PACKAGE.parents[1]
    if (root / "tools" / "pyproject.toml").is_file() and (root / "protocol" / DBC).is_file():
        return root
    return None


def source_path(*parts: str) -> Path:
    """A path in the source tree: in the checkout the package runs from,
    else relative to the working directory."""
    root = checkout()
    return root.joinpath(*parts) if root else Path(*parts)


def host_build() -> Path:
    """The host-release build tree (sp_controller, hs_sim, the core library)."""
    return source_path("build", "host-release")


def _shipped(name: str, *checkout_parts: str) -> Path:
    packaged = _DATA / name
    if packaged.is_file():
        return packaged
    root = checkout()
    if root is not None:
        return root.joinpath(*checkout_parts, name)
    raise FileNotFoundError(f"{name} is neither in the package ({_DATA}) nor in a checkout: "
                            "reinstall the package (pip install ./tools)")


def dbc_path() -> Path:
    """The CAN protocol's DBC (protocol/stewart.dbc)."""
    return _shipped(DBC, "protocol")


def default_platform() -> Path:
    """The default platform config (config/platform_default.json)."""
    return _shipped(DEFAULT_PLATFORM, "config")


def firmware_header(name: str) -> Path:
    """A header of the firmware core's ``sp/`` include directory."""
    packaged = _DATA / name
    if packaged.is_file():
        return packaged
    root = checkout()
    found = sorted((root / "firmware").glob(f"**/include/sp/**/{name}")) if root else []
    if not found:
        raise FileNotFoundError(f"firmware header sp/{name} is neither in the package ({_DATA}) "
                                "nor in a checkout")
    return found[0]


def core_library() -> Path:
    """The firmware core's shared library: $STEWART_CORE_LIB, else the
    package's own, else the checkout's host-release build."""
    env = os.environ.get("STEWART_CORE_LIB")
    if env:
        return Path(env)
    packaged = _LIB / CORE_LIBRARY
    if packaged.is_file():
        return packaged
    return host_build() / "firmware" / CORE_LIBRARY
