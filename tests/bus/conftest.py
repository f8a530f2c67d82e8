# SPDX-License-Identifier: Apache-2.0
"""The suite's throw-away machine key: testkey's hooks. The developer tools
(testkey, the build's generators) live in tools/dev, outside the package."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools" / "dev"))
from testkey import pytest_configure, pytest_unconfigure  # noqa: E402, F401
