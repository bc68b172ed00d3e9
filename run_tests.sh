#!/usr/bin/env bash
# One command from a fresh clone: set up the environment, then run every test.
# Then the newest Blender release's torch-free tier in a venv of its own (scripts/test_blender_versions.sh
# --newest): LAPIG_MATRIX=all runs all eight releases instead, =none none (see docs/development.md, "Blender releases").
# With arguments, they go to pytest in .venv only (e.g. bash run_tests.sh tests/core -k gray).
set -euo pipefail
cd "$(dirname "$0")"
bash scripts/setup_env.sh
set +e
.venv/bin/python -m pytest -q "$@"
status=$?
set -e
if [ "$status" -eq 5 ]; then  # pytest: no tests collected
  echo "no tests were collected"
  status=0
fi
if [ $# -eq 0 ]; then
  case "${LAPIG_MATRIX:-newest}" in
    all) bash scripts/test_blender_versions.sh || status=1 ;;
    newest) bash scripts/test_blender_versions.sh --newest || status=1 ;;
    *) ;;
  esac
fi
exit "$status"
