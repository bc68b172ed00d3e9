"""Contact sheets for people to judge the LGST styles and prompt mapping (PNG, no bpy)."""
from __future__ import annotations

import numpy as np
import torch


def test_scene(size: int = 256) -> np.ndarray:
    """A photo-like RGB float image in [0,1]: sky gradient, sun, hills, a house and a tree.

    Why: flat textures hide what a style does to edges, gradients and small details.
    """
    import cv2

    s = size / 256.0
    y = np.linspace(0, 1, size, dtype=np.float32)[:, None, None]
    img = (1 - y) * np.array([0.35, 0.6, 0.95], np.float32) + y * np.array([0.95, 0.85, 0.7], np.float32)
    img = np.ascontiguousarray(np.broadcast_to(img, (size, size, 3)))
    sc = lambda *v: tuple(int(round(c * s)) for c in v)  # noqa: E731 - tiny local helper
    cv2.circle(img, sc(200, 50), int(28 * s), (1.0, 0.85, 0.2), -1, cv2.LINE_AA)
    cv2.ellipse(img, sc(70, 260), sc(200, 90), 0, 180, 360, (0.25, 0.55, 0.2), -1, cv2.LINE_AA)
    cv2.ellipse(img, sc(230, 270), sc(160, 80), 0, 180, 360, (0.2, 0.45, 0.15), -1, cv2.LINE_AA)
    cv2.rectangle(img, sc(110, 140), sc(180, 215), (0.85, 0.8, 0.7), -1)
    tri = np.array([sc(100, 142), sc(145, 100), sc(190, 142)], np.int32)
    cv2.fillPoly(img, [tri], (0.7, 0.15, 0.1), cv2.LINE_AA)
    cv2.rectangle(img, sc(135, 180), sc(155, 215), (0.35, 0.2, 0.1), -1)
    cv2.rectangle(img, sc(118, 155), sc(132, 170), (0.3, 0.5, 0.8), -1)
    cv2.rectangle(img, sc(30, 150), sc(40, 215), (0.4, 0.25, 0.1), -1)
    cv2.circle(img, sc(35, 135), int(26 * s), (0.1, 0.4, 0.12), -1, cv2.LINE_AA)
    cv2.putText(img, "LAPIG", sc(150, 245), cv2.FONT_HERSHEY_SIMPLEX, 0.8 * s, (0.05, 0.05, 0.3), 2,
                cv2.LINE_AA)
    return np.clip(img, 0, 1)


def to_tensor(img: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(img.transpose(2, 0, 1)))[None].float()


def to_image(t: torch.Tensor) -> np.ndarray:
    return t.detach()[0].clamp(0, 1).permute(1, 2, 0).cpu().numpy()


def save_png(path, img: np.ndarray) -> None:
    import cv2
    from pathlib import Path

    Path(path).parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), cv2.cvtColor((np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8), cv2.COLOR_RGB2BGR))


def styles_sheet(image: np.ndarray, internal_size: int = 512, blend: float = 0.0,
                 labels: dict | None = None) -> np.ndarray:
    """All 26 styles, one-hot, on `image` (pure style: no effects)."""
    from ..common.sheets import labelled_grid
    from .style_net import NUM_STYLES
    from .styletransfer_backend import stylize_mix

    x = to_tensor(image)
    tiles, names = [image], ["input"]
    for k in range(NUM_STYLES):
        mix = torch.zeros(NUM_STYLES)
        mix[k] = 1.0
        with torch.no_grad():
            tiles.append(to_image(stylize_mix(x, mix, internal_size=internal_size, blend=blend)))
        names.append(f"{k} {labels[k]}" if labels else str(k))
    return labelled_grid(tiles, names, columns=7, cell=image.shape[0],
                         title=f"multistyle26, one-hot, run at {internal_size}px, blend {blend}")


PAPER_PROMPTS = (
    "Make it a stained glass artwork", "Make it a Claymation", "Make it a Miro painting",
    "Turn into an oil pastel drawing", "Make it a Modigliani painting",
    "Transform it into a 1980s retro pixel art graphic",
    "Render it as a whimsical children's book illustration",
    "Render it in the style of a Van Gogh oil painting",
    "Imagine it as a traditional Indian miniature painting",
)


def prompts_sheet(image: np.ndarray, prompts=PAPER_PROMPTS, backend: str = "styletransfer",
                  seed: int = 0, cell: int = 320, **backend_kwargs) -> tuple[np.ndarray, list[dict]]:
    """`image` stylized once per prompt; tiles labelled with the chosen styles. Returns (sheet, describes)."""
    from ..common.sheets import labelled_grid
    from . import get_backend
    from .style_catalog import BY_NAME

    lgst = get_backend(backend, **backend_kwargs)
    x = to_tensor(image)
    tiles, labels, infos = [image], ["input"], []
    for p in prompts:
        tiles.append(to_image(lgst.stylize(x, p, seed=seed)))
        info = lgst.describe()
        infos.append(info)
        mix = " ".join(f"#{BY_NAME[n].index}:{w:.2f}" for n, w in info["styles"] if w >= 0.1)
        fx = " +pixel" if info["effects"] else ""
        labels.append(f"{_short(p)}: {mix}{fx}")
    return labelled_grid(tiles, labels, columns=5, cell=cell,
                         title="LGST 'styletransfer' backend on the paper's prompts; "
                               "#style:weight (names in style_catalog.py)"), infos


def _short(prompt: str) -> str:
    from .prompt_mapping import core_phrase

    words = [w for w in core_phrase(prompt).split() if w.lower() not in
             ("painting", "artwork", "drawing", "graphic", "illustration", "a", "an", "the", "of", "style")]
    return " ".join(words)[:16]
