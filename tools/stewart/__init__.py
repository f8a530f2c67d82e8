# SPDX-License-Identifier: Apache-2.0
"""Host tools of the Stewart platform controller."""

from pathlib import Path

__version__ = "0.3.0"

#: Repository root (tools/stewart/__init__.py -> ../..).
REPO_ROOT = Path(__file__).resolve().parents[2]
