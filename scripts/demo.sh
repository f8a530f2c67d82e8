#!/usr/bin/env bash
# The main job: the closed-loop demo (firmware + simulated hexapod over vcan).
# Until the controller and the plant exist (issues 5 and 6), it builds
# everything and says what it will run.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
scripts/setup.sh
scripts/build.sh host-release
echo "demo: the closed-loop run (engage, surge 90 mm 0.5 Hz, yaw 90 mm 0.5 Hz, park over vcan)"
echo "demo: is not built yet; the fixed-point figures so far:"
scripts/bench.sh
