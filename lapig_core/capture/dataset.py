# SPDX-License-Identifier: GPL-3.0-or-later
"""On-disk layout of projector-camera capture sets.

The layout follows the public projector compensation datasets (CompenNet
family) so data captured here can be used by their tools and vice versa::

    <root>/prj/{ref,train,test}/img_%04d.png        projector inputs shared by all
                                                     setups, 8-bit, the working frame
                                                     (public sets: 256x256)
    <root>/setups/<setup>/setup.json                 metadata (a JSON object)
    <root>/setups/<setup>/cam/raw/{ref,sl,train,test,cmp}/img_%04d.png
                                                     raw camera captures, any size
    <root>/setups/<setup>/cam/warp/{ref,train,test,cmp}/img_%04d.png
                                                     captures registered into
                                                     projector space (working frame)
    <root>/setups/<setup>/prj/{sl,cmp}/img_%04d.png  setup-specific projector images
                                                     (structured light at native
                                                     resolution; compensation images)

Numbering is 1-based and gap-free: img_0001.png, img_0002.png, ...

Reference order, in prj/ref and cam/*/ref:
    img_0001  black projection (I-, the surface under ambient light only)
    img_0002  white projection (I+, full projector output)
    img_0003  uniform gray projection (s); its level is setup.json "gray_level"

The working frame covers the whole projector frame, so its aspect ratio is the projector's
(setup.json "working_frame": [width, height]); the public sets' 256x256 square is one aspect among
others, and a set whose aspect is not the projector's is refused where it meets one
(optics.working_frame.check_aspect). registration.npz, where a setup has one, says which working
pixels the projector frame lands on (CaptureSet.projector_valid).

A setup captured here records a digest of the shared prj/{ref,train,test} images in setup.json
("projector_images_sha256"); the loader refuses the setup when prj/ no longer holds them.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ..common.atomic import atomic_write_bytes
from ..common.imageio import ImageReadError, read_image, write_png
from ..common.jsonable import json_default
from .registration import Registration

PRJ_KINDS = ("ref", "train", "test")
CAM_RAW_KINDS = ("ref", "sl", "train", "test", "cmp")
CAM_WARP_KINDS = ("ref", "train", "test", "cmp")
PRJ_SETUP_KINDS = ("sl", "cmp")
STAGES = ("raw", "warp")
REF_BLACK, REF_WHITE, REF_GRAY = 1, 2, 3  # 1-based indices in the ref folders
SETUP_JSON = "setup.json"
REGISTRATION_FILE = "registration.npz"
PRJ_DIGEST_KEY = "projector_images_sha256"

_IMAGE_NAME = re.compile(r"^img_(\d{4,})\.png$")


class DatasetError(ValueError):
    """A capture set on disk is missing, incomplete or inconsistent."""


def _check_kind(kind: str, allowed: tuple[str, ...], where: str) -> str:
    if kind not in allowed:
        raise DatasetError(f"unknown {where} kind {kind!r}; expected one of {', '.join(allowed)}")
    return kind


@dataclass(frozen=True)
class DatasetLayout:
    """Paths of one setup inside a dataset root."""

    root: Path
    setup: str

    def __post_init__(self):
        object.__setattr__(self, "root", Path(self.root))
        name = str(self.setup)
        if not name or name in (".", "..") or "/" in name or "\\" in name:
            raise DatasetError(f"invalid setup name {self.setup!r}: it must be a plain folder name")

    @classmethod
    def of_setup_dir(cls, setup_dir) -> "DatasetLayout":
        """The layout of a setup folder, <root>/setups/<name>."""
        setup_dir = Path(setup_dir)
        return cls(setup_dir.parent.parent, setup_dir.name)

    @property
    def setup_dir(self) -> Path:
        return self.root / "setups" / self.setup

    @property
    def setup_json(self) -> Path:
        return self.setup_dir / SETUP_JSON

    def prj_dir(self, kind: str) -> Path:
        """Shared projector inputs: ref, train or test."""
        return self.root / "prj" / _check_kind(kind, PRJ_KINDS, "projector")

    def cam_raw_dir(self, kind: str) -> Path:
        return self.setup_dir / "cam" / "raw" / _check_kind(kind, CAM_RAW_KINDS, "raw capture")

    def cam_warp_dir(self, kind: str) -> Path:
        return self.setup_dir / "cam" / "warp" / _check_kind(kind, CAM_WARP_KINDS, "warped capture")

    def prj_setup_dir(self, kind: str) -> Path:
        """Setup-specific projector images: sl or cmp."""
        return self.setup_dir / "prj" / _check_kind(kind, PRJ_SETUP_KINDS, "setup projector")

    @staticmethod
    def image_path(folder, index: int) -> Path:
        """``folder``/img_%04d.png for a 1-based ``index``."""
        if index < 1:
            raise DatasetError(f"image indices start at 1, got {index}")
        return Path(folder) / f"img_{index:04d}.png"


def setup_dir_of(capture) -> Path:
    """The folder of a setup's own files (setup.json, registration.npz, models/) for a CaptureSet or a
    DatasetLayout: <root>/setups/<setup>, or the root itself where it has no setups/ (a set made in
    memory, e.g. by the tests)."""
    root = Path(capture.root)
    return root / "setups" / capture.setup if (root / "setups").is_dir() else root


# --------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------


def _remove_numbered_images(folder: Path, keep: int) -> None:
    """Delete img_NNNN.png with N > keep so a shorter rewrite leaves no stale tail."""
    if not folder.is_dir():
        return
    for path in folder.iterdir():
        match = _IMAGE_NAME.match(path.name)
        if match and int(match.group(1)) > keep:
            path.unlink()


def write_projector_images(layout: DatasetLayout, kind: str, images) -> list[Path]:
    """Write projector images as 8-bit img_0001.png, img_0002.png, ...

    ``kind`` ref/train/test goes to the shared <root>/prj, sl/cmp to the
    setup's own prj folder. Numbered images beyond the new count are removed.
    """
    folder = layout.prj_setup_dir(kind) if kind in PRJ_SETUP_KINDS else layout.prj_dir(kind)
    paths = [write_png(layout.image_path(folder, i), img, 8) for i, img in enumerate(images, start=1)]
    _remove_numbered_images(folder, len(paths))
    return paths


def write_capture(layout: DatasetLayout, stage: str, kind: str, index: int, image, bit_depth: int = 8) -> Path:
    """Write one camera capture to cam/raw/<kind> or cam/warp/<kind>."""
    _check_kind(stage, STAGES, "capture stage")
    folder = layout.cam_raw_dir(kind) if stage == "raw" else layout.cam_warp_dir(kind)
    return write_png(layout.image_path(folder, index), image, bit_depth)


def write_setup_json(layout: DatasetLayout, meta: dict) -> Path:
    """Atomically write the setup metadata (numpy scalars/arrays are converted)."""
    if not isinstance(meta, dict):
        raise DatasetError(f"setup metadata must be a dict, got {type(meta).__name__}")
    text = json.dumps(meta, indent=2, default=json_default, allow_nan=False)
    return atomic_write_bytes(layout.setup_json, (text + "\n").encode("utf-8"))


def read_setup_json(path) -> dict:
    """Read setup.json; a missing file gives an empty dict."""
    path = Path(path)
    if not path.exists():
        return {}
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DatasetError(f"cannot read setup metadata {path}: {exc}") from exc
    if not isinstance(meta, dict):
        raise DatasetError(f"setup metadata {path} must hold a JSON object, found {type(meta).__name__}")
    return meta


# --------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------


def list_images(folder) -> list[Path]:
    """img_%04d.png files in ``folder`` in index order; other files are ignored.

    Raises DatasetError if the folder is missing or the numbering is not
    exactly 1..N (naming the first missing file).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise DatasetError(f"folder not found: {folder}")
    numbered = {}
    for path in folder.iterdir():
        match = _IMAGE_NAME.match(path.name)
        if match:
            numbered[int(match.group(1))] = path
    for expected, index in enumerate(sorted(numbered), start=1):
        if index != expected:
            missing = DatasetLayout.image_path(folder, expected)
            raise DatasetError(
                f"gap in image numbering: {missing} is missing but {numbered[index].name} exists; "
                "images must be numbered img_0001.png, img_0002.png, ... without gaps"
            )
    return [numbered[i] for i in sorted(numbered)]


def projector_images_digest(root) -> str:
    """SHA-256 over the names and bytes of <root>/prj/{ref,train,test}/img_*.png; a missing
    folder counts as empty."""
    digest = hashlib.sha256()
    for kind in PRJ_KINDS:
        folder = Path(root) / "prj" / kind
        for path in list_images(folder) if folder.is_dir() else []:
            digest.update(f"{kind}/{path.name}\0".encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _check_fingerprint(meta: dict, layout: DatasetLayout) -> None:
    """The rig fingerprint is text (or absent, for a set captured elsewhere): models and scenes store it."""
    value = meta.get("fingerprint")
    if value is not None and not isinstance(value, str):
        raise DatasetError(f"{layout.setup_json}: \"fingerprint\" must be text, got {value!r}; capture this "
                           "setup again, or remove the entry for a set captured elsewhere")


def _check_projector_images(meta: dict, layout: DatasetLayout) -> None:
    expected = meta.get(PRJ_DIGEST_KEY)
    if expected is not None and expected != projector_images_digest(layout.root):
        raise DatasetError(
            f"the projector images in {layout.root / 'prj'} are not the ones setup '{layout.setup}' "
            "was captured with (another capture replaced them, or one was interrupted while it was "
            "being saved): capture this setup again"
        )


@dataclass
class CaptureSet:
    """Projector inputs and registered camera captures of one setup, float32 RGB in [0, 1]."""

    prj_train: np.ndarray  # (N, H, W, 3)
    cam_train: np.ndarray  # (N, H, W, 3)
    prj_test: np.ndarray  # (M, H, W, 3), M may be 0
    cam_test: np.ndarray  # (M', H, W, 3); 0 when the test set is not captured yet
    cam_black: np.ndarray  # (H, W, 3) I-: surface under a black projection
    cam_white: np.ndarray  # (H, W, 3) I+: surface under a white projection
    cam_gray: np.ndarray  # (H, W, 3) s: surface under the uniform gray projection
    gray_level: float
    projector_valid: np.ndarray | None = None  # (H, W) bool: registered pixels; None: unknown (public sets)
    meta: dict = field(default_factory=dict)
    root: Path = Path(".")
    setup: str = ""

    @property
    def image_size(self) -> tuple[int, int]:
        """(height, width) of every image."""
        return tuple(self.cam_black.shape[:2])

    @property
    def frame_size(self) -> tuple[int, int]:
        """(width, height) of the working frame."""
        return self.image_size[1], self.image_size[0]

    @property
    def has_test(self) -> bool:
        """True when test inputs and their captures are both present."""
        return len(self.cam_test) > 0 and len(self.cam_test) == len(self.prj_test)


def resolve_setup(path) -> DatasetLayout:
    """The setup of a dataset root holding exactly one, or of a setup folder."""
    path = Path(path)
    if not path.is_dir():
        raise DatasetError(f"capture set folder not found: {path}")
    if (path / "setups").is_dir():
        setups = sorted(p.name for p in (path / "setups").iterdir() if p.is_dir() and not p.name.startswith("."))
        if len(setups) == 1:
            return DatasetLayout(path, setups[0])
        if not setups:
            raise DatasetError(f"dataset {path} has no setups: {path / 'setups'} is empty")
        raise DatasetError(
            f"dataset {path} has {len(setups)} setups ({', '.join(setups)}); "
            f"choose one by passing its folder, e.g. {path / 'setups' / setups[0]}"
        )
    if path.parent.name == "setups":
        return DatasetLayout.of_setup_dir(path)
    raise DatasetError(
        f"{path} is neither a dataset root (with setups/ and prj/ inside) "
        "nor a setup folder (<root>/setups/<name>)"
    )


def _read_folder_images(paths: list[Path], frame: tuple[int, int] | None, shape: list) -> np.ndarray:
    """Read images into one array; ``shape`` ([H, W] or empty) is shared so sizes stay consistent."""
    if not paths:
        return np.zeros((0, *(shape or (frame[::-1] if frame else [0, 0])), 3), np.float32)
    out = None
    for i, path in enumerate(paths):
        try:
            img = read_image(path)
        except ImageReadError as exc:
            raise DatasetError(str(exc)) from exc  # the message already names the file
        if frame is not None:
            if img.shape[:2] != frame[::-1]:
                img = cv2.resize(img, frame, interpolation=cv2.INTER_AREA)
        elif not shape:
            shape.extend(img.shape[:2])
        elif list(img.shape[:2]) != shape:
            raise DatasetError(
                f"image size mismatch: {path} is {img.shape[1]}x{img.shape[0]} "
                f"but earlier images are {shape[1]}x{shape[0]}; all projector images and "
                "warped captures must have the same size (or load with frame=...)"
            )
        if out is None:
            out = np.empty((len(paths), *img.shape), np.float32)
        out[i] = img
    return out


def _require_dir(folder: Path, what: str) -> Path:
    if not folder.is_dir():
        raise DatasetError(f"missing {what}: folder {folder} does not exist")
    return folder


def _gray_level(meta: dict, layout: DatasetLayout) -> float:
    """setup.json "gray_level", else the mean of the gray projector reference image."""
    if "gray_level" in meta:
        try:
            level = float(meta["gray_level"])
        except (TypeError, ValueError):
            raise DatasetError(f"{layout.setup_json}: gray_level must be a number, got {meta['gray_level']!r}") from None
        if not 0.0 <= level <= 1.0:
            raise DatasetError(f"{layout.setup_json}: gray_level must be in [0, 1], got {level}")
        return level
    gray_image = layout.image_path(layout.prj_dir("ref"), REF_GRAY)
    if gray_image.is_file():
        try:
            return float(read_image(gray_image).mean())
        except ImageReadError as exc:
            raise DatasetError(str(exc)) from exc
    raise DatasetError(
        f"gray level unknown: add \"gray_level\" (0..1) to {layout.setup_json} or provide {gray_image}"
    )


def frame_size_of(path) -> tuple[int, int]:
    """(width, height) of a setup's working frame, without loading it: setup.json's "working_frame",
    else the size of its first registered reference (public sets)."""
    layout = resolve_setup(path)
    frame = read_setup_json(layout.setup_json).get("working_frame")
    if frame:
        return int(frame[0]), int(frame[1])
    try:
        h, w = read_image(layout.image_path(layout.cam_warp_dir("ref"), REF_BLACK)).shape[:2]
    except ImageReadError as exc:
        raise DatasetError(str(exc)) from exc
    return w, h


def _projector_valid(layout: DatasetLayout, shape) -> np.ndarray | None:
    """The registration's frame_valid at the images' (H, W); None without a usable registration."""
    path = layout.setup_dir / REGISTRATION_FILE
    if not path.is_file():
        return None
    try:
        valid = Registration.load(path).frame_valid
    except (OSError, ValueError):
        return None  # an older or damaged file: the images still load, nothing is masked
    if valid.shape != tuple(shape):
        valid = cv2.resize(valid.astype(np.uint8), tuple(shape)[::-1], interpolation=cv2.INTER_NEAREST) > 0
    return valid


def load_capture_set(path, frame: tuple[int, int] | None = None, pairs: bool = True) -> CaptureSet:
    """Load and validate the training/test data of one setup.

    ``path`` is a dataset root with exactly one setup, or <root>/setups/<name>.
    With ``frame`` (width, height) every image is resized to it; without it all
    images must already share one size. pairs=False: the references, the valid map and the
    metadata only (what Generate needs once the models are trained), the training and test
    pairs left empty (0, H, W, 3) and unread. Any problem raises DatasetError.
    """
    layout = resolve_setup(path)
    _require_dir(layout.setup_dir, "setup")
    meta = read_setup_json(layout.setup_json)
    _check_fingerprint(meta, layout)
    if pairs:  # the hash of the shared projector images guards the pairs only
        _check_projector_images(meta, layout)

    prj_train_dir = _require_dir(layout.prj_dir("train"), "projector training images")
    cam_train_dir = _require_dir(layout.cam_warp_dir("train"), "warped training captures")
    cam_ref_dir = _require_dir(layout.cam_warp_dir("ref"), "warped reference captures (black, white, gray)")
    prj_train_files, cam_train_files = list_images(prj_train_dir), list_images(cam_train_dir)
    if not prj_train_files:
        raise DatasetError(f"no training images: {prj_train_dir} holds no img_%04d.png files")
    if len(prj_train_files) != len(cam_train_files):
        raise DatasetError(
            f"training count mismatch: {len(prj_train_files)} projector images in {prj_train_dir} "
            f"but {len(cam_train_files)} captures in {cam_train_dir}; capture the training set again"
        )
    ref_files = list_images(cam_ref_dir)
    if len(ref_files) < REF_GRAY:
        raise DatasetError(
            f"{cam_ref_dir} holds {len(ref_files)} images but needs 3 "
            "(img_0001 black, img_0002 white, img_0003 gray); capture the references again"
        )

    prj_test_dir, cam_test_dir = layout.prj_dir("test"), layout.cam_warp_dir("test")
    prj_test_files = list_images(prj_test_dir) if prj_test_dir.is_dir() else []
    cam_test_files = list_images(cam_test_dir) if cam_test_dir.is_dir() else []
    if cam_test_files and len(cam_test_files) != len(prj_test_files):
        raise DatasetError(
            f"test count mismatch: {len(prj_test_files)} projector images in {prj_test_dir} "
            f"but {len(cam_test_files)} captures in {cam_test_dir}"
        )

    shape: list = []  # filled by the first image read, checked against all others
    if not pairs:
        prj_train_files = cam_train_files = prj_test_files = cam_test_files = []
    prj_train = _read_folder_images(prj_train_files, frame, shape)
    cam_train = _read_folder_images(cam_train_files, frame, shape)
    refs = _read_folder_images(ref_files[:REF_GRAY], frame, shape)
    prj_test = _read_folder_images(prj_test_files, frame, shape)
    cam_test = _read_folder_images(cam_test_files, frame, shape)
    if not pairs:  # empty, but of the frame's size, as a set without test pairs has them
        prj_train = cam_train = prj_test = cam_test = np.zeros((0, *refs.shape[1:]), np.float32)
    return CaptureSet(
        prj_train=prj_train,
        cam_train=cam_train,
        prj_test=prj_test,
        cam_test=cam_test,
        cam_black=refs[REF_BLACK - 1],
        cam_white=refs[REF_WHITE - 1],
        cam_gray=refs[REF_GRAY - 1],
        gray_level=_gray_level(meta, layout),
        projector_valid=_projector_valid(layout, refs.shape[1:3]),
        meta=meta,
        root=layout.root,
        setup=layout.setup,
    )


def summarize(capture_set: CaptureSet) -> str:
    """One human-readable paragraph describing a capture set."""
    cs = capture_set
    h, w = cs.image_size
    if cs.has_test:
        test = f"{len(cs.prj_test)} test pairs"
    elif len(cs.prj_test):
        test = f"{len(cs.prj_test)} test images not yet captured"
    else:
        test = "no test set"
    black, white, gray = (float(img.mean()) for img in (cs.cam_black, cs.cam_white, cs.cam_gray))
    contrast = white / black if black > 1e-6 else float("inf")
    return (
        f"Setup '{cs.setup}' in {cs.root}: {len(cs.prj_train)} training pairs and {test} at {w}x{h} pixels "
        f"(aspect {w / h:.3f}; the projector's must match). "
        f"Camera means under black/white/gray ({cs.gray_level:.2f}) projection: "
        f"{black:.3f}/{white:.3f}/{gray:.3f} (white-to-black ratio {contrast:.1f}:1)."
    )
