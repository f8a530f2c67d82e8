# SPDX-License-Identifier: Apache-2.0
"""``stewart busload``: frame bit counts and the per-bus load of the shipped DBC."""

import subprocess
from pathlib import Path

import pytest

from stewart import cli
from stewart.commands import busload_cmd as bl

REPO_ROOT = Path(__file__).resolve().parents[2]


def test_classic_formula_matches_notes():
    assert bl.classic_frame_bits(8) == 135  # 11-bit ID, 8 bytes, worst-case stuffing
    assert bl.classic_frame_bits(0) == 47 + 8  # 47 + floor(33 / 4)


# Hand-computed worst case, CAN FD base frame with BRS:
# nominal 17 + 4 stuff + 13 = 34; data ESI + DLC + 8n, + floor((5 + 8n) / 4) dynamic stuff,
# + 4 stuff count, + CRC 17 (n <= 16) or 21, + 6 or 7 fixed stuff bits.
#   n = 8:  69 + 17 + 4 + 17 + 6 = 113
#   n = 12: 101 + 25 + 4 + 17 + 6 = 153
#   n = 32: 261 + 65 + 4 + 21 + 7 = 358
#   n = 64: 517 + 129 + 4 + 21 + 7 = 678
@pytest.mark.parametrize("n, data_bits", [(8, 113), (12, 153), (32, 358), (64, 678)])
def test_fd_bits_hand_computed(n, data_bits):
    assert bl.fd_frame_bits(n) == (34, data_bits)


def test_fd_time_at_1m_5m():
    assert bl.frame_time_us(8, True, 1e6, 5e6) == pytest.approx(34 + 113 / 5)
    assert bl.frame_time_us(64, True, 1e6, 5e6) == pytest.approx(34 + 678 / 5)
    assert bl.frame_time_us(8, False, 1e6, 5e6) == pytest.approx(135)


def test_fd_lengths_round_up_to_a_dlc():
    assert bl.fd_payload_length(9) == 12
    assert bl.fd_frame_bits(9) == bl.fd_frame_bits(12)
    assert bl.fd_payload_length(33) == 48
    with pytest.raises(ValueError):
        bl.fd_payload_length(65)


def _table():
    import cantools

    db = cantools.database.load_file(str(REPO_ROOT / "protocol" / "stewart.dbc"), strict=True)
    return bl.load_table(db, 1e6, 5e6)


def test_shipped_dbc_within_50_percent_per_bus():
    table = _table()
    assert set(table) == {"ops", "axis_a", "axis_b"}
    loads = {bus: bl.bus_load_percent(rows) for bus, rows in table.items()}
    # SYNC 8 + setpoints 32 + 3 x feedback 16 bytes (12 before the 0.1 um lengths, issue 14);
    # pose 32 + status 32 + monitor 64 every 1 ms, + CTRL_WRENCH 24 bytes every 2 ms,
    # + OP_HEARTBEAT 4 bytes every 20 ms, + OP_FORCE 32, OP_COMMAND 20, CTRL_AUTH 16 and
    # OP_FORCE_PARAMS 24 bytes budgeted every 10 ms (the authenticated frames: docs/explanation/security.md);
    # CTRL_IDENTITY 12 bytes, one per OP_COMMAND IDENTIFY, budgeted as OP_COMMAND;
    # CTRL_REFUSAL 8 bytes, at most every 10 ms;
    # axis_b also carries FT_SENSOR, 20 bytes every 1 ms
    assert loads["axis_a"] == pytest.approx((5 * 34 + (113 + 358 + 3 * 193) / 5) / 10, abs=1e-9)
    assert loads["axis_b"] == pytest.approx((6 * 34 + (113 + 358 + 3 * 193 + 238) / 5) / 10, abs=1e-9)
    assert loads["ops"] == pytest.approx((3 * 34 + (358 + 358 + 678) / 5 + (34 + 278 / 5) / 2 + (34 + 73 / 5) / 20
                                          + (34 + 358 / 5) / 10 + (34 + 238 / 5) / 10 + (34 + 193 / 5) / 10
                                          + (34 + 278 / 5) / 10 + (34 + 153 / 5) / 10 + (34 + 113 / 5) / 10
                                          # OP_FRAME 32 and CTRL_FRAMES 24 bytes every 100 ms, OP_REACH 24 and
                                          # CTRL_REACH 32 bytes every 20 ms (issue 31)
                                          + (34 + 358 / 5) / 100 + (34 + 278 / 5) / 100
                                          + (34 + 278 / 5) / 20 + (34 + 358 / 5) / 20) / 10, abs=1e-9)
    assert loads["ops"] < 50.0
    assert loads["ops"] == pytest.approx(48.68, abs=0.005)
    assert loads["axis_b"] == pytest.approx(46.16, abs=0.005)
    assert all(v <= 50.0 for v in loads.values()), loads
    single, drives = bl.single_bus_rows(table)
    assert bl.bus_load_percent(single) > 100.0  # why there are three buses
    assert bl.bus_load_percent(drives) > 50.0


def test_cli_passes_and_fails_on_a_tight_limit(capsys):
    assert cli.main(["busload"]) == 0
    out = capsys.readouterr().out
    assert "38.0 %" in out and "46.2 %" in out and "48.7 %" in out
    assert cli.main(["busload", "--limit", "46.2"]) == 1  # ops at 48.7 % is above
    assert cli.main(["busload", "--limit", "30"]) == 1


def test_cli_exit_status_of_the_installed_command():
    exe = REPO_ROOT / ".venv" / "bin" / "stewart"
    ok = subprocess.run([str(exe), "busload"], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    tight = subprocess.run([str(exe), "busload", "--limit", "10"], capture_output=True, text=True)
    assert tight.returncode == 1 and "above" in tight.stderr


def test_slower_bit_rate_overloads(tmp_path):
    # classic-like data rate: the same frames at 1 Mbit/s data phase exceed 50 %
    assert cli.main(["busload", "--data", "1e6"]) == 1
    assert cli.main(["busload", "--dbc", str(tmp_path / "missing.dbc")]) == 2


def test_wrench_at_1khz_would_overload_the_ops_bus(tmp_path):
    # CTRL_WRENCH is budgeted at 2 ms; at 1 ms the ops bus would be at 52.0 % (51.4 % before
    # CTRL_REFUSAL), and with
    # OP_COMMAND budgeted at 1 ms as before the authentication codes, at 58.8 %
    text = (REPO_ROOT / "protocol" / "stewart.dbc").read_text()
    assert 'BA_ "GenMsgCycleTime" BO_ 258 2;' in text
    fast = tmp_path / "fast.dbc"
    fast.write_text(text.replace('BA_ "GenMsgCycleTime" BO_ 258 2;', 'BA_ "GenMsgCycleTime" BO_ 258 1;'))
    import cantools

    table = bl.load_table(cantools.database.load_file(str(fast), strict=True), 1e6, 5e6)
    assert bl.bus_load_percent(table["ops"]) == pytest.approx(53.16, abs=0.05)
    assert cli.main(["busload", "--dbc", str(fast)]) == 1
    faster = tmp_path / "faster.dbc"
    faster.write_text(fast.read_text().replace('BA_ "GenMsgCycleTime" BO_ 64 10;', 'BA_ "GenMsgCycleTime" BO_ 64 1;'))
    table = bl.load_table(cantools.database.load_file(str(faster), strict=True), 1e6, 5e6)
    assert bl.bus_load_percent(table["ops"]) == pytest.approx(60.50, abs=0.05)
    assert cli.main(["busload", "--dbc", str(faster)]) == 1
    assert cli.main(["busload"]) == 0


@pytest.mark.parametrize("args, over, pct", [
    (["cia408"], True, "104.0 %"),                           # SYNC every tick with pressures: over
    (["cia408", "--force-ff"], True, "110.0 %"),
    (["cia408", "--sync-divider", "3"], False, "35.4 %"),    # the demo's layout
    (["cia402"], True, "75.5 %"),                            # no pressure TPDO, still over
    (["cia402", "--sync-divider", "2"], False, "38.3 %"),
])
def test_builtin_canopen_layout(capsys, args, over, pct):
    """sp_controller --canopen without a drives section runs a layout no
    config check sees: busload --builtin computes it, and an overloaded one
    fails with the SYNC divider that fits."""
    rc = cli.main(["busload", "--builtin", *args])
    out = capsys.readouterr().out
    assert rc == (1 if over else 0)
    assert out.count(pct) == 2  # axis_a and axis_b, three drives each
    assert ("Ways out for axis_a" in out) == over
    if over:
        assert "drives.sync_divider = " in out


def test_builtin_only_options_need_builtin(capsys):
    assert cli.main(["busload", "--sync-divider", "3"]) == 2
    assert "go with --builtin" in capsys.readouterr().err
