"""The fixed-point firmware core (the C code, through ctypes) against the
independent float64 model, on 10,000 random poses and motions around home.

Bounds (from the issue): leg lengths within 1 um, cylinder forces within
0.05 N, forward kinematics within 1 um and 5 urad of the true pose and at
most 3 Newton steps when warm-started from the previous 1 kHz tick.
"""

import pytest

from stewart import REPO_ROOT, accuracy
from stewart import config as cfg


@pytest.fixture(scope="module")
def platform():
    return cfg.load(REPO_ROOT / "config" / "platform_default.json")


def test_core_matches_float64_model_on_10000_random_motions(platform):
    rep = accuracy.measure(platform, n=10000, seed=1)
    print("\n".join(rep.lines()))
    assert rep.failures == 0
    assert rep.length <= accuracy.BOUND_LENGTH
    assert rep.stretch <= accuracy.BOUND_LENGTH
    assert rep.force <= accuracy.BOUND_FORCE
    assert rep.fk_pos <= accuracy.BOUND_FK_POS
    assert rep.fk_rot <= accuracy.BOUND_FK_ROT
    assert rep.fk_iter_max <= accuracy.BOUND_FK_ITER
