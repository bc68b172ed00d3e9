#!/usr/bin/env bash
# One command from a fresh clone: set up the environment, then run the headless demo.
set -euo pipefail
cd "$(dirname "$0")"
bash scripts/setup_env.sh
exec .venv/bin/python -m lapig_addon demo --out out/demo "$@"
