#!/usr/bin/env bash
# Render the 18 synthetic pretraining setups with our own capture code (12 direct-light, 6 with realistic
# transport: bounce light, defocus, gloss, subsurface), then pretrain CompenNeSt, PCNet and CompenNeSt
# reversed on them. The weights land in lapig_core/photometric/weights/ (about 30-50 min of rendering, the
# subsurface marble statue alone 15 min, and 30-60 min of training on 2 CPU cores; OMP_NUM_THREADS=1 shares
# the machine).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/python -m lapig_addon dataset --setups pretrain --out out/pretrain_data --train 125 --test 20 --skip-existing
.venv/bin/python -m lapig_addon pretrain --data out/pretrain_data --out lapig_core/photometric/weights --iterations 1500 --crop 96
