"""Backbones of the localization classifier: a registry ``name -> class``.

Every backbone is a :class:`torch.nn.Module` that maps a batch of normalised images
``[B, 3, S, S]`` (``S = input_size``) to embeddings ``[B, embed_dim]``. It carries a plain
``config`` dict (JSON-able) from which :func:`build_backbone` rebuilds the same architecture,
so a checkpoint needs only the name, the config and the state dict.

* ``cnn`` (default): a small convolutional network trained from scratch on the trace; no
  pretrained weights. The spatial feature map is flattened (not pooled), so *where* an
  object lies on the table stays in the embedding.
* ``dinov2``: the DINOv2 ViT of :mod:`vggc_cp.vision.dinov2` (imported when built), loaded from a local
  weights file and frozen except its last block and final norm; the embedding is the
  normalised CLS token.
"""

from __future__ import annotations

from pathlib import Path

import torch
from torch import nn

from vggc_cp.errors import VggcError, lookup

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


class CnnBackbone(nn.Module):
    """A small CNN: a strided 5x5 stem, then conv-BN-ReLU-maxpool stages down to a 4x4 map,
    flattened (not pooled, so positions survive) into a linear embedding.

    Parameters
    ----------
    input_size : int
        Side S of the (square) input; must be a multiple of 16.
    width : int
        Channels of the stem (then 2w, 4w, 4w).
    embed_dim : int
        Size of the embedding.
    dropout : float
        Dropout before the final linear layer.
    """

    name = "cnn"

    def __init__(self, input_size: int = 64, width: int = 16, embed_dim: int = 96,
                 dropout: float = 0.1) -> None:
        super().__init__()
        if input_size % 16 or input_size < 16:
            raise VggcError(f"cnn backbone: input_size must be a multiple of 16, got {input_size}")
        self.config = {"input_size": int(input_size), "width": int(width),
                       "embed_dim": int(embed_dim), "dropout": float(dropout)}
        self.input_size = int(input_size)
        self.embed_dim = int(embed_dim)
        self.mean = IMAGENET_MEAN
        self.std = IMAGENET_STD
        chans = [width, 2 * width, 4 * width, 4 * width]
        layers: list[nn.Module] = [nn.Conv2d(3, width, 5, stride=2, padding=2, bias=False),
                                   nn.BatchNorm2d(width), nn.ReLU(inplace=True)]
        side = input_size // 2
        for c_in, c_out in zip(chans[:-1], chans[1:]):
            layers += [nn.Conv2d(c_in, c_out, 3, padding=1, bias=False), nn.BatchNorm2d(c_out),
                       nn.ReLU(inplace=True), nn.MaxPool2d(2)]
            side //= 2
        self.features = nn.Sequential(*layers)
        self.project = nn.Sequential(nn.Flatten(), nn.Dropout(dropout),
                                     nn.Linear(chans[-1] * side * side, embed_dim))

    @classmethod
    def from_config(cls, config: dict) -> CnnBackbone:
        return cls(**config)

    def trainable_parameters(self) -> list[nn.Parameter]:
        return list(self.parameters())

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Embeddings ``[B, embed_dim]`` of normalised images ``[B, 3, S, S]``."""
        return self.project(self.features(x))


class Dinov2Backbone(nn.Module):
    """The vision package's DINOv2 ViT, frozen except the last block (and the final norm).

    Parameters
    ----------
    input_size : int
        Side S of the input; a multiple of the patch size (14).
    arch : dict
        Keyword arguments of the ViT constructor (embed dim, depth, heads, registers, ...),
        as :func:`vggc_cp.vision.dinov2` reports them for a weights file.
    weights : str or None
        Local weights file, read once when training starts (a checkpoint of the localizer
        holds the whole state dict, so planning never needs it). With neither ``weights`` nor
        ``arch``, the file named by ``$VGGC_CP_DINOV2_WEIGHTS``.
    """

    name = "dinov2"

    def __init__(self, input_size: int = 112, arch: dict | None = None,
                 weights: str | None = None) -> None:
        super().__init__()
        from vggc_cp.vision import dinov2 as vision

        if weights is None and arch is None:  # training: the weights file of the environment
            weights = str(vision.resolve_weights(None))
        if weights is not None:
            vit, arch = vision.load_dinov2(weights)
        else:
            vit = vision.DinoVisionTransformer(**arch)
        patch = int(arch.get("patch_size", 14))
        if input_size % patch:
            raise VggcError(f"dinov2 backbone: input_size {input_size} is not a multiple of "
                            f"the patch size {patch}")
        self.config = {"input_size": int(input_size), "arch": dict(arch)}
        self.input_size = int(input_size)
        self.vit = vit
        self.embed_dim = int(arch["embed_dim"])
        self.mean = IMAGENET_MEAN
        self.std = IMAGENET_STD
        for p in self.vit.parameters():
            p.requires_grad_(False)
        for p in self.trainable_parameters():
            p.requires_grad_(True)

    @classmethod
    def from_config(cls, config: dict) -> Dinov2Backbone:
        return cls(input_size=config["input_size"], arch=config["arch"])

    def trainable_parameters(self) -> list[nn.Parameter]:
        params = list(self.vit.blocks[-1].parameters())
        params += list(self.vit.norm.parameters())
        return params

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """CLS embeddings ``[B, embed_dim]`` after the final norm."""
        return self.vit.forward_features(x)["x_norm_clstoken"]


BACKBONES: dict[str, type[nn.Module]] = {"cnn": CnnBackbone, "dinov2": Dinov2Backbone}
DEFAULT_BACKBONE = "cnn"


def backbone_names() -> tuple[str, ...]:
    return tuple(sorted(BACKBONES))


def new_backbone(name: str, *, weights: str | Path | None = None, **options) -> nn.Module:
    """A freshly initialised (``cnn``) or pretrained (``dinov2``, from ``weights``) backbone."""
    cls = lookup(BACKBONES, name, "localizer backbone")
    if name == "dinov2":
        return cls(weights=None if weights is None else str(weights), **options)
    if weights is not None:
        raise VggcError(f"backbone {name!r} takes no weights file")
    return cls(**options)


def build_backbone(name: str, config: dict) -> nn.Module:
    """Rebuild a backbone's architecture from its ``config`` (weights come from a state dict)."""
    return lookup(BACKBONES, name, "localizer backbone").from_config(config)
