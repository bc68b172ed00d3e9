"""bench machine: this machine's reference figures alone (machine_speed.py's torch_step_s and numpy_matmul_s,
the CPU's topology), which every other benchmark also prints beside its timings.

It was a test once; a measurement of the machine is a benchmark's work, not a check of the code (it took
from seconds to minutes by the machine's load). cmd_bench adds the figures to this empty summary.
"""


def run(args) -> dict:
    return {"benchmark": "machine"}
