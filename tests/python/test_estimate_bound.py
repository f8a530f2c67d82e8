# SPDX-License-Identifier: Apache-2.0
"""The firmware's single-step pose estimate stays within its bound
(tools/dev/estimate_bound.py; sp/estimation/estimate.h, SP_ESTIMATE_STEP_MAX)."""

import numpy as np
import pytest
from pathlib import Path

import estimate_bound
from stewart import config as cfg

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def platform():
    return cfg.load(REPO_ROOT / "config" / "platform_default.json")


def test_step_error_is_second_order(platform):
    """Halving the tracking error quarters the step's error."""
    rng = np.random.default_rng(5)
    ref = estimate_bound.sample_references(platform, rng, 200)
    jac = estimate_bound.jacobians(platform, ref)
    direction = rng.normal(size=(200, 6))
    _, ep1, er1 = estimate_bound.step_errors(platform, ref, jac, direction, np.full(200, 1e-3))
    _, ep2, er2 = estimate_bound.step_errors(platform, ref, jac, direction, np.full(200, 0.5e-3))
    err1 = np.maximum(ep1, er1)
    err2 = np.maximum(ep2, er2)
    assert np.all(err1 > 0)
    assert np.allclose(err2 / err1, 0.25, atol=0.03)


def test_firmware_limit_within_the_bound(platform):
    """SP_ESTIMATE_STEP_MAX is below the 1 um / 1 urad bound (a quick search:
    the script's default run finds 0.62 mm), and at that limit the step's
    second-order error leaves at least 0.4 um for the fixed point."""
    fw = estimate_bound.firmware_limit()
    b, _ = estimate_bound.bound(platform, samples=2000, seed=3, refine=16, rounds=10)
    assert fw <= 0.8 * b
    _, ep, er = estimate_bound.check(platform, fw, samples=2000, seed=4)
    assert ep < 0.6e-6 and er < 0.6e-6


def test_aged_factorisation(platform):
    """The step through a kept factorisation (docs/explanation/model.md's table,
    `--aged`): age 0 is the fresh step of `check` exactly, and the added
    error grows with the age about linearly (first order in age x speed)."""
    fw = estimate_bound.firmware_limit()
    _, ep0, er0 = estimate_bound.check(platform, fw, samples=500, seed=7)
    assert estimate_bound.aged_check(platform, fw, 0, 0.5, 0.5, samples=500, seed=7) == (ep0, er0)
    e = [max(estimate_bound.aged_check(platform, fw, age, 0.5, 0.5, samples=500, seed=7)) for age in (2, 4, 8)]
    assert e[0] < e[1] < e[2]
    assert (e[2] - e[1]) == pytest.approx(2 * (e[1] - e[0]), rel=0.2)  # ages 2, 4, 8
