"""A DINOv2 vision transformer (facebookresearch architecture) and its CLS-to-patch attention.

The module mirrors ``dinov2/models/vision_transformer.py`` of facebookresearch/dinov2 closely
enough that an official checkpoint (``dinov2_vits14_pretrain.pth``, ``..._reg4_pretrain.pth``,
ViT-S/B/L with an MLP, ViT-g with SwiGLU) loads with its own key names:

``cls_token (1, 1, D)``, ``pos_embed (1, 1 + M^2, D)``, ``register_tokens (1, R, D)``
(optional), ``mask_token (1, D)``, ``patch_embed.proj.{weight,bias}`` (conv, kernel = stride =
patch size), ``blocks.{i}.{norm1, attn.qkv, attn.proj, ls1.gamma, norm2, mlp.fc1, mlp.fc2,
ls2.gamma}`` (``mlp.w12``, ``mlp.w3`` for SwiGLU), ``norm``.

Attention map (the paper's ``M(o)``): the last block's attention of the CLS query over the
patch keys, averaged over heads. Current releases use fused attention kernels that never
materialise the attention matrix, so it is recomputed from the last block's ``qkv``
projection as ``softmax(q k^T / sqrt(d_head))``.

Nothing is downloaded: weights come from a local file, read with
``torch.load(path, weights_only=True)``. A file holds either a bare state dict (the number of
heads is then ``D / 64``, as in every released model) or ``{"arch": {...}, "state_dict":
{...}}`` with explicit constructor arguments (what the tests write for a tiny random model).

References
----------
M. Oquab et al. *DINOv2: Learning Robust Visual Features without Supervision.* TMLR 2024.
T. Darcet et al. *Vision Transformers Need Registers.* ICLR 2024.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from vggc_cp.errors import VggcError

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)

#: Environment variable naming the weights file when ``--weights`` is not given.
WEIGHTS_ENV = "VGGC_CP_DINOV2_WEIGHTS"


class PatchEmbed(nn.Module):
    """``(B, 3, H, W) -> (B, (H/p)(W/p), D)`` by a stride-``p`` convolution."""

    def __init__(self, patch_size: int, embed_dim: int) -> None:
        super().__init__()
        self.patch_size = patch_size
        self.proj = nn.Conv2d(3, embed_dim, kernel_size=patch_size, stride=patch_size)
        self.norm = nn.Identity()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.norm(self.proj(x).flatten(2).transpose(1, 2))


class Attention(nn.Module):
    """Multi-head self-attention with a fused ``qkv`` projection."""

    def __init__(self, dim: int, num_heads: int, qkv_bias: bool = True) -> None:
        super().__init__()
        if dim % num_heads:
            raise ValueError(f"embed dim {dim} is not divisible by {num_heads} heads")
        self.num_heads = num_heads
        self.scale = (dim // num_heads) ** -0.5
        self.qkv = nn.Linear(dim, dim * 3, bias=qkv_bias)
        self.proj = nn.Linear(dim, dim)

    def qk(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``q, k, v``, each ``(B, heads, N, d_head)``."""
        b, n, c = x.shape
        qkv = self.qkv(x).reshape(b, n, 3, self.num_heads, c // self.num_heads)
        qkv = qkv.permute(2, 0, 3, 1, 4)
        return qkv[0], qkv[1], qkv[2]

    def attention_weights(self, x: torch.Tensor) -> torch.Tensor:
        """``softmax(q k^T / sqrt(d_head))``, ``(B, heads, N, N)``."""
        q, k, _ = self.qk(x)
        return torch.softmax((q * self.scale) @ k.transpose(-2, -1), dim=-1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, n, c = x.shape
        q, k, v = self.qk(x)
        out = F.scaled_dot_product_attention(q, k, v)
        return self.proj(out.transpose(1, 2).reshape(b, n, c))


class Mlp(nn.Module):
    def __init__(self, dim: int, hidden: int) -> None:
        super().__init__()
        self.fc1 = nn.Linear(dim, hidden)
        self.act = nn.GELU()
        self.fc2 = nn.Linear(hidden, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.fc2(self.act(self.fc1(x)))


class SwiGLUFFN(nn.Module):
    """The ViT-g feed-forward: ``w3(silu(x1) * x2)`` with ``x1, x2 = w12(x)``."""

    def __init__(self, dim: int, hidden: int) -> None:
        super().__init__()
        self.w12 = nn.Linear(dim, 2 * hidden)
        self.w3 = nn.Linear(hidden, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x1, x2 = self.w12(x).chunk(2, dim=-1)
        return self.w3(F.silu(x1) * x2)


class LayerScale(nn.Module):
    def __init__(self, dim: int, init_values: float = 1e-5) -> None:
        super().__init__()
        self.gamma = nn.Parameter(init_values * torch.ones(dim))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x * self.gamma


class Block(nn.Module):
    """Pre-norm transformer block with LayerScale: ``x + ls1(attn(norm1 x))``, then MLP."""

    def __init__(self, dim: int, num_heads: int, mlp_hidden: int, ffn_layer: str = "mlp",
                 init_values: float = 1e-5) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(dim, eps=1e-6)
        self.attn = Attention(dim, num_heads)
        self.ls1 = LayerScale(dim, init_values)
        self.norm2 = nn.LayerNorm(dim, eps=1e-6)
        self.mlp = SwiGLUFFN(dim, mlp_hidden) if ffn_layer == "swiglu" else Mlp(dim, mlp_hidden)
        self.ls2 = LayerScale(dim, init_values)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x + self.ls1(self.attn(self.norm1(x)))
        return x + self.ls2(self.mlp(self.norm2(x)))


class DinoVisionTransformer(nn.Module):
    """DINOv2 ViT (facebookresearch layout and parameter names).

    Parameters
    ----------
    embed_dim, depth, num_heads : int
    patch_size : int
        14 for every released model.
    pos_grid : int
        Side ``M`` of the positional-embedding grid (37 for the released 518-px models);
        other input sizes interpolate it bicubically.
    num_register_tokens : int
        0, or 4 for the ``_reg`` models.
    mlp_hidden : int or None
        Hidden width of the feed-forward (default ``4 D``).
    ffn_layer : {"mlp", "swiglu"}
    interpolate_offset : float
        The official 0.1 offset of the positional-embedding interpolation.
    """

    def __init__(self, embed_dim: int = 384, depth: int = 12, num_heads: int = 6,
                 patch_size: int = 14, pos_grid: int = 37, num_register_tokens: int = 0,
                 mlp_hidden: int | None = None, ffn_layer: str = "mlp",
                 interpolate_offset: float = 0.1) -> None:
        super().__init__()
        self.embed_dim = embed_dim
        self.patch_size = patch_size
        self.num_register_tokens = num_register_tokens
        self.interpolate_offset = interpolate_offset
        self.patch_embed = PatchEmbed(patch_size, embed_dim)
        self.cls_token = nn.Parameter(torch.zeros(1, 1, embed_dim))
        self.pos_embed = nn.Parameter(torch.zeros(1, 1 + pos_grid * pos_grid, embed_dim))
        self.register_tokens = (nn.Parameter(torch.zeros(1, num_register_tokens, embed_dim))
                                if num_register_tokens else None)
        self.mask_token = nn.Parameter(torch.zeros(1, embed_dim))
        hidden = mlp_hidden or 4 * embed_dim
        self.blocks = nn.ModuleList(Block(embed_dim, num_heads, hidden, ffn_layer)
                                    for _ in range(depth))
        self.norm = nn.LayerNorm(embed_dim, eps=1e-6)
        self.head = nn.Identity()

    def interpolate_pos_encoding(self, n_patches: int, h: int, w: int) -> torch.Tensor:
        """Positional embeddings for an ``h x w`` input, ``(1, 1 + n_patches, D)``."""
        pos = self.pos_embed.float()
        m = int(math.sqrt(pos.shape[1] - 1))
        h0, w0 = h // self.patch_size, w // self.patch_size
        if n_patches == m * m and h0 == w0 == m:
            return self.pos_embed
        patch_pos = pos[:, 1:].reshape(1, m, m, -1).permute(0, 3, 1, 2)
        scale = ((h0 + self.interpolate_offset) / m, (w0 + self.interpolate_offset) / m)
        patch_pos = F.interpolate(patch_pos, scale_factor=scale, mode="bicubic", antialias=False)
        if patch_pos.shape[-2:] != (h0, w0):
            patch_pos = F.interpolate(patch_pos, size=(h0, w0), mode="bicubic", antialias=False)
        patch_pos = patch_pos.permute(0, 2, 3, 1).reshape(1, h0 * w0, -1)
        return torch.cat([pos[:, :1], patch_pos], dim=1).to(self.pos_embed.dtype)

    def prepare_tokens(self, x: torch.Tensor) -> torch.Tensor:
        """``(B, 3, H, W) -> (B, 1 + R + N, D)``: CLS, registers, patches (with positions)."""
        b, _, h, w = x.shape
        t = self.patch_embed(x)
        t = torch.cat([self.cls_token.expand(b, -1, -1), t], dim=1)
        t = t + self.interpolate_pos_encoding(t.shape[1] - 1, h, w)
        if self.register_tokens is not None:
            t = torch.cat([t[:, :1], self.register_tokens.expand(b, -1, -1), t[:, 1:]], dim=1)
        return t

    def forward_features(self, x: torch.Tensor) -> dict:
        t = self.prepare_tokens(x)
        for blk in self.blocks:
            t = blk(t)
        tn = self.norm(t)
        r = self.num_register_tokens
        return {"x_norm_clstoken": tn[:, 0], "x_norm_regtokens": tn[:, 1:r + 1],
                "x_norm_patchtokens": tn[:, r + 1:], "x_prenorm": t, "masks": None}

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.forward_features(x)["x_norm_clstoken"])

    def cls_attention(self, x: torch.Tensor) -> torch.Tensor:
        """Last block's CLS-to-patch attention, averaged over heads.

        Parameters
        ----------
        x : tensor, shape (B, 3, H, W), normalised images, H and W multiples of the patch size

        Returns
        -------
        tensor, shape (B, H/p, W/p), non-negative; each map sums to the CLS query's attention
        mass on patches (registers and CLS itself excluded).
        """
        t = self.prepare_tokens(x)
        for blk in self.blocks[:-1]:
            t = blk(t)
        last = self.blocks[-1]
        att = last.attn.attention_weights(last.norm1(t))  # (B, heads, N, N)
        start = 1 + self.num_register_tokens
        cls = att[:, :, 0, start:].mean(dim=1)
        b, _, h, w = x.shape
        return cls.reshape(b, h // self.patch_size, w // self.patch_size)


def arch_from_state_dict(sd: dict) -> dict:
    """Constructor arguments of the ViT that ``sd`` (an official-layout state dict) belongs to."""
    try:
        embed_dim = int(sd["cls_token"].shape[-1])
        patch = int(sd["patch_embed.proj.weight"].shape[-1])
        n_pos = int(sd["pos_embed"].shape[1]) - 1
    except KeyError as exc:
        raise VggcError(f"DINOv2 weights: missing parameter {exc}; not a facebookresearch "
                        f"DINOv2 state dict") from None
    depth = 1 + max(int(k.split(".")[1]) for k in sd if k.startswith("blocks."))
    swiglu = "blocks.0.mlp.w12.weight" in sd
    hidden = (int(sd["blocks.0.mlp.w3.weight"].shape[1]) if swiglu
              else int(sd["blocks.0.mlp.fc1.weight"].shape[0]))
    if embed_dim % 64:
        raise VggcError(f"DINOv2 weights: embed dim {embed_dim} is not a multiple of 64, so the "
                        f"number of heads is unknown; save {{'arch': ..., 'state_dict': ...}}")
    return {"embed_dim": embed_dim, "depth": depth, "num_heads": embed_dim // 64,
            "patch_size": patch, "pos_grid": int(round(math.sqrt(n_pos))),
            "num_register_tokens": int(sd["register_tokens"].shape[1])
            if "register_tokens" in sd else 0,
            "mlp_hidden": hidden, "ffn_layer": "swiglu" if swiglu else "mlp"}


def resolve_weights(path: str | None) -> Path:
    """The weights file: ``path``, else ``$VGGC_CP_DINOV2_WEIGHTS``; a clear error if neither."""
    import os

    chosen = path or os.environ.get(WEIGHTS_ENV)
    if not chosen:
        raise VggcError("attention backend 'dinov2' needs local DINOv2 weights: pass --weights "
                        f"PATH or set {WEIGHTS_ENV} (e.g. the facebookresearch "
                        "dinov2_vits14_pretrain.pth); nothing is downloaded")
    from vggc_cp.safeio import check_input

    p = Path(chosen).expanduser()
    where = "--weights" if path else f"${WEIGHTS_ENV}"
    try:
        check_input(p, "DINOv2 weights file")
    except VggcError as exc:
        raise VggcError(f"{exc} ({where})") from None
    return p


def weights_sha256(path: str | Path) -> str:
    """SHA-256 of a weights file (part of the distance cache key)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def load_dinov2(path: str | Path) -> tuple[DinoVisionTransformer, dict]:
    """Load a ViT from a local weights file (``weights_only=True``); returns ``(model, arch)``.

    The model is in eval mode on the CPU. ``arch`` holds the constructor arguments.
    """
    path = resolve_weights(str(path))
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # unpickling errors of every kind
        raise VggcError(f"DINOv2 weights {str(path)!r} are unreadable with weights_only=True "
                        f"({type(exc).__name__}: {exc})") from None
    if isinstance(obj, dict) and "state_dict" in obj and "arch" in obj:
        sd, arch = obj["state_dict"], dict(obj["arch"])
    elif isinstance(obj, dict) and "model" in obj and isinstance(obj["model"], dict):
        sd = obj["model"]
        arch = arch_from_state_dict(sd)
    elif isinstance(obj, dict):
        sd = obj
        arch = arch_from_state_dict(sd)
    else:
        raise VggcError(f"DINOv2 weights {str(path)!r} hold a {type(obj).__name__}, "
                        f"not a state dict")
    sd = {k.removeprefix("module.").removeprefix("backbone."): v for k, v in sd.items()}
    model = DinoVisionTransformer(**arch)
    missing, unexpected = model.load_state_dict(sd, strict=False)
    missing = [k for k in missing if k != "mask_token"]
    if missing or unexpected:
        raise VggcError(f"DINOv2 weights {str(path)!r} do not match the architecture {arch}: "
                        f"missing {missing[:5]}, unexpected {unexpected[:5]}")
    return model.eval(), arch


def preprocess(images: np.ndarray, size: int) -> torch.Tensor:
    """uint8 ``(B, H, W, 3)`` -> normalised float ``(B, 3, size, size)`` (bilinear, antialiased)."""
    x = torch.from_numpy(np.ascontiguousarray(images)).permute(0, 3, 1, 2).float() / 255.0
    x = F.interpolate(x, size=(size, size), mode="bilinear", antialias=True, align_corners=False)
    mean = torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1)
    std = torch.tensor(IMAGENET_STD).view(1, 3, 1, 1)
    return (x - mean) / std
