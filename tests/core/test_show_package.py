# SPDX-License-Identifier: GPL-3.0-or-later
"""The show package's names: the model and schedule without torch, the producer on first use."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_model_loads_without_torch_and_the_api_names_resolve():
    code = ("import importlib.util, sys\n"
            f"spec = importlib.util.spec_from_file_location('lapig', {str(ROOT / '__init__.py')!r}, "
            f"submodule_search_locations=[{str(ROOT)!r}])\n"
            "m = importlib.util.module_from_spec(spec); sys.modules['lapig'] = m; spec.loader.exec_module(m)\n"
            "import lapig.lapig_core.show as show\n"
            "s = show.Show([show.Look('/r/a', hold_s=1.0)], [], fps=4)\n"
            "assert show.schedule_of(s).total_frames == 4\n"
            "assert 'torch' not in sys.modules, 'the model imported torch'\n"
            "if importlib.util.find_spec('torch'):  # the producer's names, where torch is (not the torch-free tier)\n"
            "    assert callable(show.show_frames) and show.ShowSetup and show.FrameSettings and show.KeyedLook\n"
            "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
