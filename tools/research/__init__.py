# SPDX-License-Identifier: GPL-3.0-or-later
"""Research code: baselines and comparisons the benchmarks and tests measure the product against,
never reached by the add-on, the command line's user commands or lapig_core.

- psa_resample: the public code's PSA (re-sample the look with new seeds until the loss halves) and
  the paper's loss ablation table (ABLATIONS); reached by tools/bench/bench_psa.py and
  tests/core/test_psa.py, test_ip2p.py.
- projector_space_choice: the compensator choice by recovered projector images on held-back pairs
  (`choose`), which the benchmarks record beside the rendered and PCNet choices; reached by
  tools/bench/bench_transport.py and tests/core/test_compensator_choice.py.
"""
