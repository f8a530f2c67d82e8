# SPDX-License-Identifier: Apache-2.0
"""The suite's throw-away machine key: stewart.testkey's hooks."""

from stewart.testkey import pytest_configure, pytest_unconfigure  # noqa: F401
