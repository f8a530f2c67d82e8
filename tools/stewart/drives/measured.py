# SPDX-License-Identifier: Apache-2.0
"""The load the CANopen frames of a closed-loop run's CAN log put on each
drive bus, as if the bus were classic CAN at ``bitrate`` (vcan has no bit
rate): every CiA 301 frame (``analysis.decode.is_canopen_id``) of the
interface, at its worst-case length (``classic_frame_bits``), summed over
the window from the first RPDO1 to the log's end. SDO and NMT frames (the
start-up) are counted apart; the simulation's lockstep clock (the DBC's
SYNC) and the force sensor's frames are not CANopen and not counted.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..canframe import classic_frame_bits


def canopen_load(log: str | Path, ifaces: dict[str, str], bitrate: int = 1_000_000) -> dict[str, dict]:
    """Per bus name ({iface: bus}): cyclic load (%), frames per ms, and the
    start-up's SDO/NMT frames."""
    from ..analysis.decode import is_canopen_id
    from ..analysis.logfile import read_frames

    fr = read_frames(Path(log))
    out: dict[str, dict] = {}
    bits = np.array([classic_frame_bits(min(int(n), 8)) for n in range(65)])
    for iface, bus in ifaces.items():
        if iface not in fr.ifaces:
            continue
        on = (fr.iface == fr.ifaces.index(iface)) & ~fr.fd & is_canopen_id(fr.frame_id)
        fid = fr.frame_id
        startup = on & ((fid == 0x000) | ((fid >= 0x581) & (fid <= 0x67F)))
        cyclic = on & ~startup
        rpdo = np.flatnonzero(cyclic & (fid >= 0x201) & (fid <= 0x27F))
        if len(rpdo) == 0:
            continue
        t0, t1 = float(fr.time[rpdo[0]]), float(fr.time[-1])
        win = cyclic & (fr.time >= t0)
        span = max(t1 - t0, 1e-3)
        busy = float(bits[fr.dlc[win]].sum()) / bitrate
        out[bus] = {"load_percent": 100.0 * busy / span, "frames_per_ms": int(win.sum()) / (span * 1e3),
                    "window_s": span, "startup_frames": int(startup.sum())}
    return out
