"""The trained localizer (image -> node) and its checkpoint file.

Checkpoint (``torch.save`` of plain containers, loads with ``weights_only=True``)::

    {"format": "vggc-localizer/1",
     "state_dict": {name: tensor, ...},     # the whole network (backbone + cosine head)
     "meta": "<JSON object>"}               # see below

``meta`` holds ``node_ids`` (class index -> solution node), ``node_roles``, ``image_shape``
``[H, W]`` of the trace images the model accepts, ``backbone`` and ``backbone_config``,
``gamma``, ``solution`` (path and :func:`solution_digest`), ``trace`` (path and content
hash) and ``training`` (seed, chosen learning rate and epochs, the cross-validation table,
augmentations, seconds).
"""

from __future__ import annotations

import hashlib
import json
import pickle
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from vggc_cp.atomic import atomic_path
from vggc_cp.errors import VggcError
from vggc_cp.localize.backbones import build_backbone
from vggc_cp.localize.model import LocalizerNet, to_unit_tensor
from vggc_cp.solution import Solution

FORMAT = "vggc-localizer/1"


class CheckpointError(VggcError):
    """A localizer checkpoint is missing, unreadable, unsafe or inconsistent."""


class ImageError(VggcError):
    """An image file is unreadable or does not match the localizer's image size."""


def solution_digest(solution: Solution) -> str:
    """SHA-256 of what a localizer learned from a solution: its labels, roles and edges."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(solution.labels, dtype=np.int64).tobytes())
    h.update(np.ascontiguousarray(solution.roles, dtype=np.int8).tobytes())
    h.update(json.dumps(sorted([int(u), a, int(v)] for u, a, v in solution.edges)).encode())
    return h.hexdigest()


@dataclass(frozen=True)
class Prediction:
    """Localization of a batch of images.

    Attributes
    ----------
    nodes : ndarray of int64, shape (M,)
        The most probable node of every image.
    confidence : ndarray of float64, shape (M,)
        Its softmax probability.
    probabilities : ndarray of float32, shape (M, K)
        Softmax over the K nodes (columns in ``Localizer.node_ids`` order).
    """

    nodes: np.ndarray
    confidence: np.ndarray
    probabilities: np.ndarray


@dataclass(frozen=True, eq=False)
class Localizer:
    """A trained image -> node classifier.

    Attributes
    ----------
    net : LocalizerNet
        In eval mode.
    node_ids : tuple of int
        Solution node of every class index.
    image_shape : tuple of int
        ``(H, W)`` of the images it accepts (those of its training trace).
    meta : dict
        Everything else of the checkpoint's metadata.
    """

    net: LocalizerNet
    node_ids: tuple[int, ...]
    image_shape: tuple[int, int]
    meta: dict = field(default_factory=dict)

    @property
    def input_size(self) -> int:
        return int(self.net.backbone.input_size)

    def check_image(self, image: np.ndarray, source: str = "<image>") -> None:
        """Raise :class:`ImageError` unless ``image`` is uint8 ``[H, W, 3]`` of the right size."""
        if not isinstance(image, np.ndarray) or image.ndim != 3 or image.shape[2] != 3:
            shape = getattr(image, "shape", None)
            raise ImageError(f"{source}: expected an RGB image, got shape {shape}")
        if tuple(image.shape[:2]) != self.image_shape:
            h, w = self.image_shape
            raise ImageError(f"{source}: image is {image.shape[1]}x{image.shape[0]} pixels, "
                             f"the localizer expects {w}x{h} (the training trace's size)")

    def predict(self, images: np.ndarray, batch_size: int = 256) -> Prediction:
        """Localize uint8 images ``[M, H, W, 3]`` of the training size."""
        images = np.asarray(images)
        if images.ndim != 4 or images.shape[0] == 0:
            raise ImageError(f"expected a batch of images [M, H, W, 3], got {images.shape}")
        self.check_image(images[0])
        probs = predict_probabilities(self.net, to_unit_tensor(images, self.input_size),
                                      batch_size)
        idx = probs.argmax(axis=1)
        nodes = np.asarray(self.node_ids, dtype=np.int64)[idx]
        conf = probs[np.arange(len(idx)), idx].astype(np.float64)
        return Prediction(nodes, conf, probs)


def predict_probabilities(net: LocalizerNet, x: torch.Tensor, batch_size: int = 256) -> np.ndarray:
    """Softmax probabilities ``[M, K]`` (float32) of unit images ``x`` ``[M, 3, S, S]``."""
    was_training = net.training
    net.eval()
    out = []
    with torch.no_grad():
        for i in range(0, x.shape[0], batch_size):
            out.append(torch.softmax(net(x[i:i + batch_size]), dim=1))
    net.train(was_training)
    return torch.cat(out).numpy()


def save_localizer(path: str | Path, localizer: Localizer) -> None:
    """Write a checkpoint atomically (plain tensors and strings only)."""
    meta = dict(localizer.meta)
    meta["node_ids"] = [int(u) for u in localizer.node_ids]
    meta["image_shape"] = [int(s) for s in localizer.image_shape]
    meta["backbone"] = localizer.net.backbone.name
    meta["backbone_config"] = localizer.net.backbone.config
    meta["gamma"] = localizer.net.head.gamma
    state = {k: v.detach().cpu().clone().contiguous()
             for k, v in localizer.net.state_dict().items()}
    payload = {"format": FORMAT, "state_dict": state, "meta": json.dumps(meta, sort_keys=True)}
    with atomic_path(path, suffix=".pt") as tmp:
        torch.save(payload, tmp)


def load_localizer(path: str | Path) -> Localizer:
    """Read a checkpoint with ``torch.load(weights_only=True)``; never unpickles objects.

    Raises
    ------
    CheckpointError
        Naming the file: missing, not a checkpoint, refused (it needs arbitrary unpickling),
        or inconsistent with its architecture.
    """
    from vggc_cp.safeio import cap, check_input, loads_json

    p = Path(path)
    src = str(p)
    try:
        size = check_input(p, "checkpoint").st_size
    except VggcError as exc:
        raise CheckpointError(str(exc)) from None
    if size > cap("max_bytes"):
        raise CheckpointError(f"{src}: {size:,} bytes exceed the cap of {cap('max_bytes'):,} "
                              f"(VGGC_CP_MAX_BYTES)")
    try:
        payload = torch.load(p, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as exc:
        first = str(exc).strip().splitlines()
        why = next((ln.strip() for ln in first if "Unsupported" in ln or "global" in ln), "")
        raise CheckpointError(f"{src}: refused: the file needs arbitrary unpickling, which "
                              f"weights_only loading forbids ({why or 'unsafe pickle'})") from None
    except (RuntimeError, EOFError, OSError, zipfile.BadZipFile, ValueError) as exc:
        raise CheckpointError(f"{src}: not a localizer checkpoint ({type(exc).__name__})") from None
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise CheckpointError(f"{src}: not a localizer checkpoint (format is not {FORMAT!r})")
    try:
        if not isinstance(payload.get("meta"), str):
            raise TypeError("field 'meta' is not a JSON string")
        meta = loads_json(payload["meta"], "field 'meta'")
        if not isinstance(meta, dict):
            raise TypeError("field 'meta' is not a JSON object")
        node_ids = tuple(int(u) for u in meta["node_ids"])
        shape = tuple(int(s) for s in meta["image_shape"])
        if len(shape) < 2:
            raise ValueError("image_shape has fewer than two sides")
        _check_declared_size(meta, len(node_ids), payload.get("state_dict"), src)
        backbone = build_backbone(meta["backbone"], meta["backbone_config"])
        net = LocalizerNet(backbone, len(node_ids), float(meta["gamma"]))
        net.load_state_dict(payload["state_dict"], strict=True)
    except VggcError as exc:
        msg = str(exc)
        raise CheckpointError(msg if msg.startswith(f"{src}:") else f"{src}: {msg}") from None
    except (KeyError, TypeError, ValueError, RuntimeError, json.JSONDecodeError) as exc:
        raise CheckpointError(f"{src}: inconsistent checkpoint ({type(exc).__name__}: "
                              f"{str(exc).splitlines()[0]})") from None
    for name, tensor in payload["state_dict"].items():
        if tensor.is_floating_point() and not bool(torch.isfinite(tensor).all()):
            raise CheckpointError(f"{src}: weight {name!r} holds NaN or infinite values")
    net.eval()
    rest = {k: v for k, v in meta.items()
            if k not in ("node_ids", "image_shape", "backbone", "backbone_config", "gamma")}
    return Localizer(net, node_ids, (shape[0], shape[1]), rest)


def _check_declared_size(meta: dict, n_classes: int, state: dict, src: str) -> None:
    """Build the declared network on the ``meta`` device (no memory) and refuse it when its
    weights exceed ``max_bytes`` or differ in number from the file's, before allocating."""
    from vggc_cp.safeio import cap

    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise TypeError("field 'state_dict' is not a dict of tensors")
    config = meta["backbone_config"]
    if isinstance(config, dict):
        side = config.get("input_size")
        if isinstance(side, (int, float)) and side * side > cap("max_pixels"):
            raise CheckpointError(f"{src}: backbone input_size {side} exceeds the pixel cap "
                                  f"(VGGC_CP_MAX_PIXELS)")
    try:
        with torch.device("meta"):
            probe = LocalizerNet(build_backbone(meta["backbone"], config), n_classes,
                                 float(meta["gamma"]))
    except VggcError as exc:
        raise CheckpointError(f"{src}: {exc}") from None
    except MemoryError:
        raise CheckpointError(f"{src}: the declared network does not fit in memory") from None
    sizes = {k: v.numel() * v.element_size() for k, v in probe.state_dict().items()}
    total = sum(sizes.values())
    if total > cap("max_bytes"):
        raise CheckpointError(f"{src}: the declared network needs {total:,} bytes of weights, "
                              f"over the cap of {cap('max_bytes'):,} (VGGC_CP_MAX_BYTES)")
    if set(sizes) != set(state) or any(tuple(probe.state_dict()[k].shape) != tuple(state[k].shape)
                                       for k in sizes):
        raise CheckpointError(f"{src}: inconsistent checkpoint (the weights do not match the "
                              f"declared architecture)")


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file as uint8 ``[H, W, 3]`` RGB (alpha dropped, grey expanded).

    Raises :class:`ImageError` naming the file when it is missing or not an image.
    """
    from PIL import Image, UnidentifiedImageError

    from vggc_cp.safeio import check_image_size, check_input

    p = Path(path)
    try:
        check_input(p, "image")
    except VggcError as exc:
        raise ImageError(str(exc)) from None
    bomb_limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None  # our cap (VGGC_CP_MAX_PIXELS) is checked instead
    try:
        with Image.open(p) as im:
            Image.MAX_IMAGE_PIXELS = bomb_limit
            w, h = im.size  # from the header (PNG: IHDR), before decoding
            try:
                check_image_size(h, w, str(p))
            except VggcError as exc:
                raise ImageError(str(exc)) from None
            im.load()
            rgb = im.convert("RGB")
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, EOFError,
            Image.DecompressionBombError) as exc:
        raise ImageError(f"{p}: not a readable image ({type(exc).__name__})") from None
    finally:
        Image.MAX_IMAGE_PIXELS = bomb_limit
    return np.asarray(rgb, dtype=np.uint8).copy()


def write_image(path: str | Path, image: np.ndarray) -> None:
    """Write uint8 ``[H, W, 3]`` as PNG, atomically."""
    from PIL import Image

    with atomic_path(path, suffix=".png") as tmp:
        Image.fromarray(np.ascontiguousarray(image, dtype=np.uint8)).save(tmp, format="PNG")
