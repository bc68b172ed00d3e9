"""A helper process that embeds texts with the offline MiniLM model (run as a script, no package imports).

Why a process: importing sentence-transformers and building the model hold Python's GIL for up to
a quarter of a second at a time, which freezes Blender's UI even from a worker thread. In a process
of its own, the load costs the UI nothing. Protocol: one JSON list of strings per stdin line, one
JSON list of unit-length vectors per stdout line.
"""
import json
import os
import sys


def main(model_dir: str) -> int:
    os.environ["HF_HUB_OFFLINE"] = "1"  # the model is local: never reach for the network
    os.environ["TRANSFORMERS_OFFLINE"] = "1"
    from sentence_transformers import SentenceTransformer

    model = SentenceTransformer(model_dir, device="cpu", local_files_only=True)
    out = sys.stdout
    out.write(json.dumps({"ready": True}) + "\n")
    out.flush()
    for line in sys.stdin:
        texts = json.loads(line)
        vectors = model.encode(texts, normalize_embeddings=True, show_progress_bar=False)
        out.write(json.dumps([[float(v) for v in row] for row in vectors]) + "\n")
        out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
