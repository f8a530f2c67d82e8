#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs what the project needs on a fresh Debian bookworm machine:
# Debian packages (compilers, cmocka, the Cortex-M4 toolchain, QEMU,
# user-mode Linux and can-utils for the vcan bus), the Python venv in .venv
# with the stewart tools, and a user-mode Linux kernel that boots on this CPU
# (.cache/uml where Debian's panics). Idempotent: does nothing when all is there.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

apt_packages=(
  cmake ninja-build gcc make pkg-config libcmocka-dev
  gcc-arm-none-eabi libnewlib-arm-none-eabi libnewlib-dev qemu-system-arm
  user-mode-linux kmod can-utils iproute2 patchelf
  clang libclang-rt-14-dev clang-format
  cppcheck clang-tidy frama-c-base why3 z3
  chromium chromium-driver
)
# Node.js and npm build the console's page (web/console). A machine with a
# node of its own (from another repository) keeps it: Debian's npm would
# conflict with it; Debian's nodejs and npm only where there is no node.
if ! command -v npm >/dev/null 2>&1 && ! command -v node >/dev/null 2>&1; then
  apt_packages+=(nodejs npm)
fi
missing=()
for p in "${apt_packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
fi

# The venv is rebuilt when the pinned dependencies change (stamp = hash of
# tools/pyproject.toml).
venv="$root/.venv"
stamp="$venv/.stewart-stamp"
want=$(sha256sum "$root/tools/pyproject.toml" | cut -d' ' -f1)
if [ ! -x "$venv/bin/python" ] || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "setup: creating the Python venv in .venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check -e "$root/tools[test]"
  echo "$want" > "$stamp"
fi

# The console's page (docs/guides/console.md): the npm packages of
# web/console/package-lock.json, bundled by esbuild into
# tools/stewart/console/static/dist; nothing is fetched at run time. Redone
# only when the lock file or a source changed (stamp = their hash).
web="$root/web/console"
dist="$root/tools/stewart/console/static/dist"
if command -v npm >/dev/null 2>&1; then
  wstamp=$(cat "$web/package-lock.json" "$web"/src/*.js | sha256sum | cut -d' ' -f1)
  if [ ! -f "$dist/app.js" ] || [ "$(cat "$dist/.stamp" 2>/dev/null)" != "$wstamp" ]; then
    echo "setup: building the console's page (npm ci, esbuild)"
    (cd "$web" && npm ci --no-audit --no-fund --loglevel=error >/dev/null && npm run --silent build >/dev/null)
    echo "$wstamp" > "$dist/.stamp"
  fi
else
  echo "setup: no npm: the console's page is not built (stewart console serves a notice instead)"
fi

# A vcan back end that works on this host (docs/vcan.md): the host kernel's
# vcan, else Debian's user-mode Linux where it boots on this CPU, else (CPUs
# with AMX) a newer one fetched from Debian's registry into .cache/uml. The
# probe's verdict is cached per host, so this is quick after the first time.
"$venv/bin/stewart" vcan --setup | sed 's/^/setup: /'
