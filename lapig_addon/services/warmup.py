"""Load the text and style models in the background as soon as the add-on is used, so that the first Generate of
a session finds them loaded (BENCHMARKS: about 9.5 s cold against 2 s warm).

The warm-up runs once per session on a worker thread, never on Blender's main thread: it imports torch and the
look library, builds the default backend's look for a small image (which loads the prompt model, in the helper
process where Blender has a UI, the lexicon's embeddings and the style network) and runs one small forward and
backward pass through a network and one optimiser step, so torch's CPU kernels are chosen before the first job.
Generate waits for a warm-up under way (on its own worker thread) rather than loading the same models beside it. A warm-up that fails says why in warmup_state() and changes nothing: the first
Generate then loads what it needs, as before.
"""
from __future__ import annotations

import importlib.util
import threading
import time

from .float_mode import flush_denormals_here
from .jobs import THREAD_PREFIX

_lock = threading.Lock()
_state = {"thread": None, "started": None, "seconds": None, "error": None}


def start_warmup(backend: str | None = None) -> bool:
    """Start the session's warm-up (once); True when this call started it."""
    with _lock:
        if _state["thread"] is not None:
            return False
        thread = threading.Thread(target=_run, args=(backend,), name=f"{THREAD_PREFIX}warm-up", daemon=True)
        _state.update(thread=thread, started=time.perf_counter(), seconds=None, error=None)
        thread.start()
        return True


def warmup_state() -> dict:
    """{'running': bool, 'seconds': float | None (when done), 'error': str | None}."""
    thread = _state["thread"]
    return {"running": thread is not None and thread.is_alive(), "seconds": _state["seconds"],
            "error": _state["error"]}


def wait_for_warmup(timeout: float | None = None) -> bool:
    """On a worker thread: wait for a warm-up under way (True when none is running any more)."""
    thread = _state["thread"]
    if thread is None or thread is threading.current_thread():
        return True
    thread.join(timeout)
    return not thread.is_alive()


def _run(backend):
    try:
        if importlib.util.find_spec("torch") is not None:
            import torch  # noqa: F401  (warm() loads it anyway: first, so that the mode reaches torch's threads)
        flush_denormals_here()
        warm(backend)
    except Exception as exc:  # a missing model or package: the first Generate reports it with its reason
        _state["error"] = f"{type(exc).__name__}: {exc}"
    finally:
        _state["seconds"] = round(time.perf_counter() - _state["started"], 2)


def warm(backend: str | None = None, size: int = 64) -> None:
    """What the first job would otherwise load: the backend's models and torch's kernels, at a small size."""
    import torch

    from ...lapig_core.common.adam import Adam
    from ...lapig_core.lgst import DEFAULT_BACKEND, get_backend
    from ...lapig_core.photometric import checkpoints

    surface = torch.full((1, 3, size, size), 0.5)
    look = get_backend(backend or DEFAULT_BACKEND)
    look.prepare(surface, "an oil painting")
    with torch.no_grad():
        look.forward()
    net, _ = checkpoints.load_pretrained("CompenNeSt", "compensation")
    x = torch.rand(1, 3, size, size, requires_grad=True)
    net(x, surface).mean().backward()
    Adam([x], lr=1e-3).step()  # the optimiser PSA and Train use (ours: torch.optim's first import froze the UI)


def _reset_for_tests():
    with _lock:
        _state.update(thread=None, started=None, seconds=None, error=None)
