#!/usr/bin/env bash
# Render the 12 synthetic pretraining setups with our own capture code, then pretrain CompenNeSt,
# PCNet and CompenNeSt reversed on them. The weights land in lapig_core/photometric/weights/ (about 25-40 min of
# rendering and 30-60 min of training on 2 CPU cores; set OMP_NUM_THREADS=1 to share the machine).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/python -m lapig_addon dataset --setups pretrain --out out/pretrain_data --train 125 --test 20 --skip-existing
.venv/bin/python -m lapig_addon pretrain --data out/pretrain_data --out lapig_core/photometric/weights --iterations 1500 --crop 96
