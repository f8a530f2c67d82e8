"""The plant's drives as CiA 408 nodes over SocketCAN vcan (issue 18).

``hs_sim --canopen`` (host-release build) runs the hydraulic plant in real
time with its six drives as CiA 408 nodes (ids 1-3 on vcan1 = axis_a, 4-6
on vcan2 = axis_b). The PC tools on the ``canopen`` library talk to it as
to real drives: ``stewart drives scan`` finds the three nodes of a bus with
the EDS's identity and device type, and ``stewart drives config`` writes
the controller's configuration into one and reads it back, all equal.

Meant to run inside ``stewart vcan --fd``; skipped elsewhere.
"""

from __future__ import annotations

import json
import re
import subprocess
import time

import pytest

from stewart import REPO_ROOT, closedloop as cl

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

STEWART = REPO_ROOT / ".venv" / "bin" / "stewart"
DEFAULT = REPO_ROOT / "config" / "platform_default.json"


@pytest.fixture
def plant():
    bins = cl.Binaries.find()
    if not bins.plant.exists():
        pytest.skip(f"{bins.plant} not built")
    p = subprocess.Popen([str(bins.plant), "--canopen", "--ops", "vcan0", "--axis-a", "vcan1", "--axis-b", "vcan2"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.5)  # the boot-ups
    assert p.poll() is None, p.communicate()
    yield p
    p.terminate()
    out, err = p.communicate(timeout=10)
    print(out, err)


def _stewart(*args, timeout=60):
    return subprocess.run([str(STEWART), *args], capture_output=True, text=True, timeout=timeout)


def test_scan_finds_the_plant_nodes(plant):
    r = _stewart("drives", "scan", "--interface", "socketcan", "--channel", "vcan1", "--wait", "1.0")
    assert r.returncode == 0, r.stderr
    rows = [line for line in r.stdout.splitlines() if re.match(r"\| [0-9]+ \|", line)]
    assert [int(row.split("|")[1]) for row in rows] == [1, 2, 3], r.stdout
    for row in rows:
        assert "CiA 408 fluid power (0x00000198)" in row and "0x00005348" in row, row


def test_config_writes_a_plant_node_and_reads_it_back(plant, tmp_path):
    d = json.loads(DEFAULT.read_text())
    legs = [{"protocol": "cia408", "bus": "can_a" if i < 3 else "can_b", "node_id": 1 + i,
             "scaling": {"position_per_count": 1e-6, "length_at_zero": 1.85}} for i in range(6)]
    d["drives"] = {"buses": {"can_a": {"bitrate": 1000000}, "can_b": {"bitrate": 1000000}},
                   "sync_divider": 3, "legs": legs}
    cfg = tmp_path / "platform_cia408.json"
    cfg.write_text(json.dumps(d))
    r = _stewart("drives", "config", "--config", str(cfg), "--bus", "can_b", "--node", "5",
                 "--interface", "socketcan", "--channel", "vcan2")
    assert r.returncode == 0, r.stdout + r.stderr
    assert re.search(r"wrote (\d+) objects, read back (\d+): all equal", r.stdout), r.stdout
