#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The main job: the firmware's controller (host build) commands the simulated
# hydraulic hexapod over three CAN FD buses (vcan; user-mode Linux where the
# kernel has no CAN) in deterministic lockstep: engage, the paper's surge and
# yaw (90 mm / 0.09 rad, 0.5 Hz), park; force control; then the work at the
# tool: a rotation about a tool tip and a 2 kN hold on a tilted surface with
# a slide along it (stewart.framesdemo). Writes the CAN log, a CSV of decoded
# signals, plots and a summary of the figures into out/demo/.
# Extra arguments go to `stewart demo` (e.g. --quick, --out DIR).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
scripts/setup.sh
scripts/build.sh host-release
exec .venv/bin/stewart demo "$@"
