#!/usr/bin/env bash
# Create .venv and install judgeopt with everything it needs, in the one order that works:
# torch (CPU wheel) first, then the build tools, then l4casadi built against that torch
# (see shared/notes/dependencies.md), then the package itself, every package at the version CI
# tests (scripts/constraints.txt, torch and l4casadi included; pyproject.toml has the ranges), and
# Debian's chromium for the docs test.
# torch comes from pip's own configuration (CI's machines hold the CPU wheel); on a machine whose pip
# would take PyPI's far larger CUDA build, set TORCH_INDEX_URL=https://download.pytorch.org/whl/cpu.
# Idempotent: a second run only checks for chromium and a stamp, and returns.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${JUDGEOPT_VENV:-.venv}
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3
# headless Chromium for the docs test (tests/test_docs.py opens the built site); Debian's package
if ! command -v chromium >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1; then
  SUDO=; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends chromium >/dev/null
fi
stamp="$VENV/.judgeopt-setup-$(cat pyproject.toml scripts/setup.sh scripts/constraints.txt | sha1sum | cut -c1-12)"
if [ -f "$stamp" ]; then exit 0; fi
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
pip() { "$VENV/bin/python" -m pip "$@"; }
pip install -q --upgrade pip
TORCH_INDEX_URL=${TORCH_INDEX_URL:-}
pip install -q -c scripts/constraints.txt ${TORCH_INDEX_URL:+--index-url "$TORCH_INDEX_URL"} torch
pip install -q -c scripts/constraints.txt casadi scikit-build cmake ninja setuptools wheel
if ! "$VENV/bin/python" -c "import l4casadi" 2>/dev/null; then
  CMAKE_POLICY_VERSION_MINIMUM=3.5 pip install -q --no-build-isolation -c scripts/constraints.txt l4casadi
fi
pip install -q --no-build-isolation -c scripts/constraints.txt -e ".[test,docs,serve]"
rm -f "$VENV"/.judgeopt-setup-*
touch "$stamp"
