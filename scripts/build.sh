#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Configures and builds every CMake preset (or those named as arguments).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
presets=("$@")
((${#presets[@]})) || presets=(host-debug host-release m4-core stm32g4 stm32g4-cia408)
for p in "${presets[@]}"; do
  echo "== build: $p"
  cmake --preset "$p" >/dev/null
  cmake --build --preset "$p"
done
