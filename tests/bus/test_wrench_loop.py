# SPDX-License-Identifier: Apache-2.0
"""The external wrench estimate in closed loop over vcan (issue 14): the
controller's CTRL_WRENCH against the plant's true wrench, in a short run:
engage, a short surge without load, a constant load of several kN and kN m
applied at home as a step and removed, park.

The estimate is judged ``WRENCH_SETTLE_TICKS`` (20 ms) after each change of
the true wrench (stewart.analysis.metrics.wrench_metrics). The bounds below
are what the estimate achieves today (docs/explanation/model.md, "The motion-error
correction of the wrench estimate") plus a margin for the spread between
runs; the issue's figures (150 N / 75 N m unloaded; 2 % of the load +
100 N / 50 N m loaded) are what the demo reports against.
"""

from __future__ import annotations

import pytest

from stewart import closedloop as cl
from stewart.analysis import read_log
from stewart.analysis.metrics import summarize, wrench_metrics
from stewart.analysis.truth import attach_truth, read_truth

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

SCENARIO = ("cmd ENGAGE\n"
            "wait ready 20\n"
            "delay 0.3\n"
            + cl.trig("x", 0.09, 0.5, 3.0, fade=0.5)
            + "delay 0.3\n"
            + cl.load_segment(hold=1.0, after=0.5)
            + "cmd PARK\n"
            "wait idle 20\n"
            "delay 0.1\n")

# Stated bounds: measured (hs_sim --inproc, the same scenario and log as
# over vcan) with 0.1 um lengths and the reported estimate's smoother
# (docs/explanation/model.md, "The motion-error correction") unloaded RUNNING 67 N /
# 46 N m, loaded 79 N / 38 N m, 0.58 of the bound (2 % + 100 N /
# 50 N m; for this 5.4 kN / 2.0 kN m load 160-180 N / 66-80 N m), plus
# about 35 % margin for the spread between machines; the figures
# (150 N / 75 N m unloaded, the bound loaded) hold with room.
UNLOADED_RUNNING_N = 90.0
UNLOADED_RUNNING_NM = 62.0
LOADED_N = 107.0
LOADED_NM = 52.0
LOADED_SHARE = 0.8


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("wrench_loop")
    r = cl.run([cl.RunSpec("wrench", SCENARIO)], out, progress=False, timeout=600)[0]
    assert r.plant_rc == 0, r.plant_out[-2000:]
    data = read_log(r.log)
    attach_truth(data, read_truth(r.truth))
    return data


def test_run_is_clean(run):
    s = summarize(run)
    assert s["bad_frames"] == 0 and s["faults_seen"] == [] and s["final_state"] == "IDLE"


def test_estimate_against_truth(run):
    w = wrench_metrics(run)
    assert w is not None
    for key in ("unloaded_running", "unloaded", "loaded"):
        v = w[key]
        print(f"{key}: max {v['force_N']:.0f} N, {v['moment_Nm']:.0f} N m, RMS "
              + " ".join(f"{x:.0f}" for x in v["rms"]) + f" over {v['n']} frames")
    assert w["unloaded_running"]["force_N"] <= UNLOADED_RUNNING_N
    assert w["unloaded_running"]["moment_Nm"] <= UNLOADED_RUNNING_NM
    assert w["loaded"]["force_N"] <= LOADED_N
    assert w["loaded"]["moment_Nm"] <= LOADED_NM
    assert w["loaded"]["worst_share_of_bound"] <= LOADED_SHARE
    assert w["loaded"]["n"] > 400


def test_estimate_follows_the_load(run):
    """Positive control: the estimate is not zero under load: its mean during
    the load is within 25 % of the true load on every axis."""
    import numpy as np

    truth = run.truth["wrench"]
    est = run.est_wrench
    loaded = np.all(truth == np.asarray(cl.DEMO_WRENCH), axis=1) & np.isfinite(est).all(axis=1)
    assert loaded.sum() > 400
    mean = est[loaded].mean(axis=0)
    print("mean estimate under load", np.round(mean), "true", cl.DEMO_WRENCH)
    for k, want in enumerate(cl.DEMO_WRENCH):
        assert abs(mean[k] - want) <= 0.25 * abs(want), k
