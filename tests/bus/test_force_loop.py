# SPDX-License-Identifier: Apache-2.0
"""Force control in closed loop over vcan (issue 15), one short lockstep
run with the force/torque sensor as the wrench source (the default
config's): engage, tare, a 1e6 N/m plane 2 mm above the tool, FORCE on z
with 2 kN (OP_FORCE + OP_COMMAND, as an operator sends them), a bad force
command while holding (a target beyond the controller's 8 kN, then an
empty mask: both refused, the hold goes on), then the surface removed.

Asserted with the issue's figures: the true force within 1 % RMS of 2 kN
from 0.5 s after contact, overshoot <= 10 %, peak-to-peak <= 2 % in the
last second; the removal detected within 10 ticks (CONTACT_LOST latched),
the platform at rest within 5 mm of where it was; the refusals counted
and reported (CTRL_STATUS CmdRejected, the controller's summary).

A second, shorter run holds 2 kN on the same surface with the cylinders'
estimate as the source (no sensor), two more on a soft and a stiff surface
(1e5 N/m: 20 mm of compression; 1e7 N/m): within 2 % RMS from 0.5 s after
the true contact (the true force at 100 N), overshoot <= 10 %,
peak-to-peak <= 2 %, and the removal detected within 10 ticks.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from stewart import closedloop as cl
from stewart import forcecontrol as fc
from stewart.analysis.truth import read_truth

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

SCENARIO = ("cmd ENGAGE\n"
            "wait ready 20\n"
            "delay 0.3\n"
            + fc.tare()
            + fc.approach_and_hold(1e6, 2000.0, hold=2.0)
            + fc.bad_force_command()
            + fc.remove_surface(1.0)
            + "end\n")


def scenario_cylinders(stiffness: float) -> str:
    return ("cmd ENGAGE\n"
            "wait ready 20\n"
            "delay 0.3\n"
            + fc.tare()
            + fc.approach_and_hold(stiffness, 2000.0, hold=2.0)
            + fc.remove_surface(0.5)
            + "end\n")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("force_loop")
    rs = cl.run([cl.RunSpec("force", SCENARIO, wrench_source="sensor"),
                 cl.RunSpec("force_cylinders", scenario_cylinders(1e6), wrench_source="cylinders"),
                 cl.RunSpec("force_cylinders_1e5", scenario_cylinders(1e5), wrench_source="cylinders"),
                 cl.RunSpec("force_cylinders_1e7", scenario_cylinders(1e7), wrench_source="cylinders")],
                out, progress=False, timeout=900)
    for r in rs:
        assert r.plant_rc == 0, r.plant_out[-2000:]
    return [(r, read_truth(r.truth), fc.read_status(r.log), fc.marks(r.plant_out)) for r in rs]


@pytest.fixture(scope="module")
def run(runs):
    return runs[0]


def test_hold_2kN_on_1e6(run):
    r, truth, status, m = run
    h = fc.hold_figures(truth, m["begin hold"], m["end hold"], 2000.0)
    print("hold", h)
    assert h["contact_tick"] is not None and h["n"] >= 1500
    assert h["rms_pct"] <= fc.HOLD_RMS_SENSOR_PCT
    assert h["overshoot_pct"] <= fc.HOLD_OVERSHOOT_PCT
    assert h["pp_pct"] <= fc.HOLD_PP_PCT
    # in contact and in FORCE throughout the hold, as CTRL_STATUS says
    sel = (status.tick >= h["contact_tick"] + 50) & (status.tick < m["end hold"])
    assert np.all(status.force_mode[sel] == fc.MODES.index("FORCE")) and np.all(status.contact[sel] == 1)


def test_bad_force_command_refused_and_hold_goes_on(run):
    r, truth, status, m = run
    assert fc.refusals(status, m["end hold"], m["end hold"] + 5) == 1       # beyond 8 kN
    assert fc.refusals(status, m["end hold"] + 200, m["end hold"] + 205) == 1  # empty mask
    assert fc.refusals(status, 0, m["end hold"]) == 0
    assert re.search(r"sp_controller commands: refused 2,", r.controller_out), r.controller_out
    # safe: still FORCE on the same 2 kN, no fault
    sel = (status.tick >= m["end hold"]) & (status.tick < m["remove"])
    assert np.all(status.force_mode[sel] == fc.MODES.index("FORCE")) and np.all(status.faults[sel] == 0)
    after = fc.hold_figures(truth, m["end hold"], m["remove"], 2000.0, settle=0)
    print("after the bad commands", after)
    assert after["rms_pct"] <= fc.HOLD_RMS_SENSOR_PCT


def test_contact_loss_stops_and_latches(run):
    r, truth, status, m = run
    loss = fc.loss_figures(truth, status, m["remove"])
    print("loss", loss)
    assert loss["detected_ticks"] is not None and loss["detected_ticks"] <= fc.LOSS_TICKS
    assert loss["travel_max_mm"] <= fc.LOSS_REST_MM
    assert loss["final_speed_mm_s"] <= 0.1
    assert loss["fault_latched"] and loss["state"] == "FAULT"


@pytest.mark.parametrize("which", [1, 2, 3], ids=["1e6", "1e5", "1e7"])
def test_hold_2kN_with_the_cylinders_estimate(runs, which):
    r, truth, status, m = runs[which]
    h = fc.hold_figures(truth, m["begin hold"], m["end hold"], 2000.0)
    print("hold (cylinders)", h)
    assert h["contact_tick"] is not None and h["n"] >= 1500
    assert h["rms_pct"] <= fc.HOLD_RMS_CYLINDERS_PCT
    assert h["overshoot_pct"] <= fc.HOLD_OVERSHOOT_PCT
    assert h["pp_pct"] <= fc.HOLD_PP_PCT
    sel = (status.tick >= m["begin hold"]) & (status.tick < m["remove"])
    assert np.all((status.faults[sel] & fc.FAULT_CONTACT_LOST) == 0)
    loss = fc.loss_figures(truth, status, m["remove"])
    print("loss (cylinders)", loss)
    assert loss["detected_ticks"] is not None and loss["detected_ticks"] <= fc.LOSS_TICKS
    assert loss["travel_max_mm"] <= fc.LOSS_REST_MM
    assert loss["fault_latched"] and loss["state"] == "FAULT"
