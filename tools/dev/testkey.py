# SPDX-License-Identifier: Apache-2.0
"""A throw-away machine key for the test suites (docs/explanation/security.md): unless
STEWART_KEY already names one, a fresh key in a temporary directory, named
by STEWART_KEY for the run, so that sp_controller, hs_sim and `stewart op`
started by the tests share it. Never a key in the repository.

The pytest hooks of tests/python/conftest.py and tests/bus/conftest.py (one
copy for both suites)."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from stewart import auth

_made: list[str] = []


def pytest_configure(config):
    if os.environ.get(auth.KEY_ENV):
        return
    d = tempfile.mkdtemp(prefix="stewart-test-key-")
    _made.append(d)
    os.environ[auth.KEY_ENV] = str(auth.new_key_file(Path(d) / "machine.key"))


def pytest_unconfigure(config):
    for d in _made:
        shutil.rmtree(d, ignore_errors=True)
        if os.environ.get(auth.KEY_ENV, "").startswith(d):
            del os.environ[auth.KEY_ENV]
