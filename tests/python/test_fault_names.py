# SPDX-License-Identifier: Apache-2.0
"""The controller's fault names in Python follow the firmware's SP_FAULT_* bits."""

import re
from pathlib import Path

from stewart import protocol as pr

REPO_ROOT = Path(__file__).resolve().parents[2]


def test_controller_fault_names_match_the_header():
    header = (REPO_ROOT / "firmware/core/include/sp/control/controller.h").read_text()
    bits = {}
    for name, value in re.findall(r"#define SP_FAULT_(\w+) (0x[0-9A-Fa-f]+)u", header):
        v = int(value, 16)
        assert v & (v - 1) == 0, f"SP_FAULT_{name} is not one bit"
        bits[v.bit_length() - 1] = name.lower()
    assert len(bits) >= 12
    assert tuple(bits[k] for k in range(len(bits))) == pr.CONTROLLER_FAULTS
