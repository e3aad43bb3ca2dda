"""The localization network: a backbone, then a cosine-similarity head with temperature gamma.

``logits = gamma * <z / |z|, w_c / |w_c|>`` for every node ``c``: the normalised embedding
against normalised class weights, trained with cross-entropy (a few-shot classifier in the
style of cosine-softmax / normalised-softmax heads). Images enter as float ``[B, 3, S, S]`` in
``[0, 1]`` (see :func:`to_unit_tensor`); the network normalises them itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn


class CosineHead(nn.Module):
    """Cosine-similarity classifier: ``gamma * normalize(z) @ normalize(W).T``.

    Parameters
    ----------
    embed_dim : int
    n_classes : int
    gamma : float
        Temperature (scale) of the cosine logits.
    """

    def __init__(self, embed_dim: int, n_classes: int, gamma: float = 16.0) -> None:
        super().__init__()
        self.gamma = float(gamma)
        self.weight = nn.Parameter(torch.randn(n_classes, embed_dim) / embed_dim ** 0.5)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        """Logits ``[B, n_classes]`` of embeddings ``[B, embed_dim]``."""
        return self.gamma * F.normalize(z, dim=1) @ F.normalize(self.weight, dim=1).T


class LocalizerNet(nn.Module):
    """Backbone + cosine head; input float images in ``[0, 1]``, ``[B, 3, S, S]``."""

    def __init__(self, backbone: nn.Module, n_classes: int, gamma: float = 16.0) -> None:
        super().__init__()
        self.backbone = backbone
        self.head = CosineHead(backbone.embed_dim, n_classes, gamma)
        self.register_buffer("mean", torch.tensor(backbone.mean).view(1, 3, 1, 1),
                             persistent=False)
        self.register_buffer("std", torch.tensor(backbone.std).view(1, 3, 1, 1),
                             persistent=False)

    def trainable_parameters(self) -> list[nn.Parameter]:
        return self.backbone.trainable_parameters() + list(self.head.parameters())

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.backbone((x - self.mean) / self.std))


def to_unit_tensor(images: np.ndarray, size: int) -> torch.Tensor:
    """uint8 ``[M, H, W, 3]`` -> float32 ``[M, 3, size, size]`` in ``[0, 1]`` (area/bilinear
    resampling with antialiasing when the size differs)."""
    x = torch.from_numpy(np.ascontiguousarray(images)).permute(0, 3, 1, 2).float().div_(255.0)
    if x.shape[-2:] != (size, size):
        x = F.interpolate(x, size=(size, size), mode="bilinear", antialias=True,
                          align_corners=False)
    return x.clamp_(0.0, 1.0)


@dataclass(frozen=True)
class Augment:
    """Light photometric and geometric augmentations, on ``[0, 1]`` images, seeded.

    Attributes
    ----------
    brightness : float
        Global gain drawn from ``1 +- brightness``.
    channel_gain : float
        Per-channel gain (tint) drawn from ``1 +- channel_gain``.
    contrast : float
        Contrast around the image mean drawn from ``1 +- contrast``.
    shift : int
        Largest translation in pixels (each axis, integer, border-replicated).
    noise : float
        Standard deviation of additive Gaussian pixel noise.
    """

    brightness: float = 0.15
    channel_gain: float = 0.08
    contrast: float = 0.1
    shift: int = 2
    noise: float = 0.02

    def as_dict(self) -> dict:
        return {"brightness": self.brightness, "channel_gain": self.channel_gain,
                "contrast": self.contrast, "shift": self.shift, "noise": self.noise}

    def __call__(self, x: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
        """Augmented copy of ``x`` (float ``[B, 3, S, S]`` in ``[0, 1]``)."""
        b = x.shape[0]

        def unif(*shape):
            return torch.rand(*shape, generator=gen) * 2.0 - 1.0

        if self.shift > 0:
            s = self.shift
            h, w = x.shape[-2:]
            pad = F.pad(x, (s, s, s, s), mode="replicate")
            dy = torch.randint(0, 2 * s + 1, (b, 1, 1), generator=gen)
            dx = torch.randint(0, 2 * s + 1, (b, 1, 1), generator=gen)
            rows = (torch.arange(h).view(1, h, 1) + dy).expand(b, h, w)
            cols = (torch.arange(w).view(1, 1, w) + dx).expand(b, h, w)
            flat = rows * (w + 2 * s) + cols  # index into each padded plane
            x = pad.flatten(2).gather(2, flat.reshape(b, 1, h * w).expand(b, 3, h * w))
            x = x.view(b, 3, h, w)
        mean = x.mean(dim=(1, 2, 3), keepdim=True)
        x = (x - mean) * (1.0 + self.contrast * unif(b, 1, 1, 1)) + mean
        x = x * (1.0 + self.brightness * unif(b, 1, 1, 1))
        x = x * (1.0 + self.channel_gain * unif(b, 3, 1, 1))
        if self.noise > 0:
            x = x + self.noise * torch.randn(x.shape, generator=gen)
        return x.clamp(0.0, 1.0)
