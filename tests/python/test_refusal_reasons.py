# SPDX-License-Identifier: Apache-2.0
"""The one list of refusal reasons: the firmware's SP_REFUSE_* values
(firmware/core/include/sp/control/controller.h) are the value tables of
CTRL_REFUSAL Reason and CTRL_FRAMES LastRefusal in the DBC, and CTRL_FRAMES
counts every reason but NONE and LINK (docs/reference/commands.md)."""

from __future__ import annotations

import re
from pathlib import Path

from stewart import protocol as pr
from stewart.operator import node

ROOT = Path(__file__).resolve().parents[2]


def _header_reasons() -> dict[int, str]:
    text = (ROOT / "firmware/core/include/sp/control/controller.h").read_text()
    found = re.findall(r"#define SP_REFUSE_([A-Z_]+)\s*(?:\\\s*)?(\d+)u", text)
    return {int(v): n for n, v in found if n != "COUNT"}


def test_header_is_the_dbc_table():
    header = _header_reasons()
    count = int(re.search(r"#define SP_REFUSE_COUNT (\d+)u",
                          (ROOT / "firmware/core/include/sp/control/controller.h").read_text()).group(1))
    assert sorted(header) == list(range(count)) and count == 10
    for message, signal in (("CTRL_REFUSAL", "Reason"), ("CTRL_FRAMES", "LastRefusal")):
        names = pr.value_names(message, signal)
        assert {i: n for i, n in enumerate(names)} == header, (message, signal)
        assert pr.Protocol().message(message).get_signal_by_name(signal).maximum == count - 1


def test_frames_counts_every_reason_but_link():
    header = _header_reasons()
    camel = {"".join(w.capitalize() for w in n.split("_")): n for n in header.values()}
    sent = [camel[n] for n in node.FRAME_REFUSALS]
    assert sorted(sent) == sorted(set(header.values()) - {"NONE", "LINK"})
    signals = {s.name for s in pr.Protocol().message("CTRL_FRAMES").signals}
    assert {f"Refused{n}" for n in node.FRAME_REFUSALS} == {s for s in signals if s.startswith("Refused")}
    # node.c sends them in this order (m.refused[k] = refusals[sent[k]])
    text = (ROOT / "firmware/core/src/link/node.c").read_text()
    order = re.search(r"sent\[SP_PROTO_FRAMES_REFUSED\] = \{([^}]*)\}", text).group(1)
    assert [n.strip().removeprefix("SP_REFUSE_") for n in order.split(",")] == sent
