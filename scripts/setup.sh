#!/usr/bin/env bash
# Set up navlog on a fresh Debian/Ubuntu machine with Python 3.11: system libraries the wheels need
# (open3d wants libusb-1.0-0 and libgl1), a virtual environment in .venv, and navlog installed in it
# (editable) with its test tools: pytest, ruff, mypy, import-linter and the setuptools that builds
# the wheel the tests install. Safe to run again: it only does what is missing, and reinstalls
# when pyproject.toml changed.
set -euo pipefail
cd "$(dirname "$0")/.."

PY="${PYTHON:-}"
if [ -z "$PY" ]; then
  for cand in python3.11 python3; do
    if command -v "$cand" >/dev/null 2>&1; then PY="$cand"; break; fi
  done
fi
if [ -z "$PY" ]; then
  echo "setup: no python3.11 or python3 on PATH (set PYTHON=/path/to/python3.11)" >&2
  exit 1
fi
"$PY" -c 'import sys; assert sys.version_info >= (3, 11), "navlog needs Python 3.11 or newer"'

need_pkgs=()
if command -v dpkg >/dev/null 2>&1; then
  for pkg in libusb-1.0-0 libgl1 libgomp1; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need_pkgs+=("$pkg")
  done
fi
# Debian's Pythons make virtual environments only with their pythonX.Y-venv package.
if [ ! -x .venv/bin/python ] && ! "$PY" -c 'import ensurepip' >/dev/null 2>&1; then
  need_pkgs+=("python$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')-venv")
fi
if [ ${#need_pkgs[@]} -gt 0 ] && command -v apt-get >/dev/null 2>&1; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  echo "setup: installing system packages: ${need_pkgs[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_pkgs[@]}" >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv with $("$PY" --version)"
  "$PY" -m venv .venv
fi
stamp=.venv/.navlog-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  echo "setup: installing navlog and its dependencies into .venv"
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -e ".[test]"
  touch "$stamp"
fi
