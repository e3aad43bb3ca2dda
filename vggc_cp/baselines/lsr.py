"""Latent Space Roadmap (LSR): the paper's second baseline, after Lippi et al.

A small convolutional VAE is trained on the trace's observations (resized to ``image_size``
pixels) with

.. math::  L = \\underbrace{\\|x - \\hat x\\|^2}_{\\text{reconstruction}}
           + \\beta_t\\,\\mathrm{KL}(q(z|x)\\,\\|\\,\\mathcal N(0, I))
           + \\gamma\\,[(1-a)\\,d + a\\,\\max(0, d_m - d)],
   \\qquad d = \\|\\mu(x) - \\mu(x')\\|_1,

summed over pixels and latent dimensions and averaged over the batch; ``beta_t`` rises linearly
from 0 to ``beta`` over the first half of training (annealing). The action term pulls
*no-action* pairs (``a = 0``) together and pushes *action* pairs (``a = 1``) at least ``d_m``
apart in L1 latent distance.

* **Action pairs** are the observed transitions ``(o_t, o_{t+1})`` and, with ``two_step``
  (default), the pairs ``(o_t, o_{t+2})`` of two consecutive transitions. A single pick/place
  transition always joins a pick observation to a place one, so those pairs alone teach the
  latent space only the role; the two-step pairs are LSR's own unit of action (a whole
  pick-and-place moves an object) and separate states within a role. (A place back into the
  region just left makes such a pair show one state twice; the hinge then errs on that pair.)
* **No-action pairs** must show one situation twice, and the trace never says which
  observations do (that would be ground truth). They are made from one observation by two
  independent random augmentations: an integer shift of up to ``shift`` pixels (edge padding),
  a per-channel gain in ``[1 - jitter, 1 + jitter]``, and Gaussian pixel noise of std ``noise``
  — nuisances a re-render of the same state also shows, smaller than a moved object.

Clustering follows LSR, pre-split by role (pick and place observations are clustered apart):

* ``"epsilon"`` (LSR v1) — epsilon-connected components: two observations of one role are
  joined when the L1 distance of their latent means is below
  ``epsilon = mean + 1 std`` of the no-action distances (fresh augmentation pairs of every
  observation, measured after training); the clusters are the connected components;
* ``"average"`` (LSR v2) — average-linkage agglomerative clustering on L1 latent distances,
  one cut height shared by both roles, chosen among ``cut_candidates`` quantiles of the merge
  heights to maximize the number of edges supported by at least ``min_edge_support``
  transitions (ties: the higher cut, fewer nodes).

Each cluster is a node and the edges are those the transitions induce. The training grid
(``d_m`` x ``gamma``) times the clustering methods is swept and the graph chosen by
:func:`vggc_cp.baselines.base.select`. Training is seeded and single-threaded by default, so
it is deterministic on CPU.

References
----------
M. Lippi, P. Poklukar, M. C. Welle, A. Varava, H. Yin, A. Marino, D. Kragic. *Latent Space
Roadmap for Visual Action Planning of Deformable and Rigid Object Manipulation*, IROS 2020;
*Enabling Visual Action Planning for Object Manipulation through Latent Space Roadmap*, T-RO 2022.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from itertools import product

import numpy as np

from vggc_cp.baselines.base import (
    Baseline,
    Candidate,
    graph_stats,
    induced_graph,
    labels_from_roles,
    register_baseline,
    within_role_score,
)
from vggc_cp.errors import VggcError
from vggc_cp.trace import PICK, PLACE, Trace

CLUSTERINGS = ("epsilon", "average")


@dataclass(frozen=True)
class LsrConfig:
    """Training, augmentation, clustering and sweep options of :class:`LatentSpaceRoadmap`.

    Attributes
    ----------
    image_size : int
        Side the observations are resized to (a power of two, 8 to 128).
    latent_dim : int
    beta : float
        Final KL weight (annealed linearly from 0 over the first half of the steps).
    gamma : tuple of float
        Action-term weights swept.
    d_m : tuple of float
        Minimum L1 latent distance of action pairs, swept.
    steps : int
        Optimizer steps (Adam) per training run.
    batch : int
        Transitions per step (each gives two views of its source and its target: 4 images).
    lr : float
    shift : int
        Largest augmentation shift in pixels (at ``image_size``).
    jitter : float
        Largest relative per-channel gain change of an augmentation.
    noise : float
        Std of the Gaussian pixel noise of an augmentation (pixels in [0, 1]).
    two_step : bool
        Also push apart ``(o_t, o_{t+2})`` (module doc).
    clusterings : tuple of str
        Subset of ``("epsilon", "average")``.
    cut_candidates : int
        Cut heights tried by ``"average"``.
    min_edge_support : int
        Transitions an edge needs to count for the ``"average"`` cut.
    seed : int
    threads : int
        ``torch.set_num_threads`` during training.
    """

    image_size: int = 32
    latent_dim: int = 12
    beta: float = 1.0
    gamma: tuple[float, ...] = (10.0,)
    d_m: tuple[float, ...] = (4.0, 12.0)
    steps: int = 500
    batch: int = 32
    lr: float = 3e-3
    shift: int = 1
    jitter: float = 0.05
    noise: float = 0.02
    two_step: bool = True
    clusterings: tuple[str, ...] = ("epsilon", "average")
    cut_candidates: int = 40
    min_edge_support: int = 2
    seed: int = 0
    threads: int = 1

    def __post_init__(self) -> None:
        if self.image_size < 8 or self.image_size > 128 or self.image_size & (self.image_size - 1):
            raise VggcError(f"image_size must be a power of two in [8, 128], got {self.image_size}")
        bad = [c for c in self.clusterings if c not in CLUSTERINGS]
        if bad or not self.clusterings:
            raise VggcError(f"unknown LSR clustering {bad[0] if bad else '(none)'!r}; known: "
                            f"{', '.join(CLUSTERINGS)}")
        if self.steps < 1 or self.batch < 1 or self.latent_dim < 1:
            raise VggcError("steps, batch and latent_dim must be positive")
        if not self.gamma or not self.d_m:
            raise VggcError("gamma and d_m need at least one value each")


# ---------------------------------------------------------------- model and training


def _build_vae(image_size: int, latent_dim: int):
    """Encoder/decoder: stride-2 4x4 convolutions down to 4x4 pixels, and back."""
    import torch
    from torch import nn

    levels = int(math.log2(image_size // 4))
    widths = [3] + [min(16 * 2 ** i, 64) for i in range(levels)]
    enc: list[nn.Module] = []
    for i in range(levels):
        enc += [nn.Conv2d(widths[i], widths[i + 1], 4, 2, 1), nn.ReLU()]
    flat = widths[-1] * 16
    dec: list[nn.Module] = []
    for i in reversed(range(levels)):
        dec += [nn.ConvTranspose2d(widths[i + 1], widths[i], 4, 2, 1),
                nn.ReLU() if i > 0 else nn.Sigmoid()]

    class Vae(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.encoder = nn.Sequential(*enc, nn.Flatten())
            self.head = nn.Linear(flat, 2 * latent_dim)
            self.expand = nn.Linear(latent_dim, flat)
            self.decoder = nn.Sequential(*dec)

        def encode(self, x):
            mu, logvar = self.head(self.encoder(x)).chunk(2, dim=1)
            return mu, logvar.clamp(-10.0, 10.0)

        def decode(self, z):
            h = torch.relu(self.expand(z)).view(len(z), widths[-1], 4, 4)
            return self.decoder(h)

    return Vae()


def _to_tensor(observations: np.ndarray, image_size: int):
    """uint8 (N, H, W, 3) -> float32 tensor (N, 3, S, S) in [0, 1] (area resampling)."""
    import torch
    import torch.nn.functional as F

    x = torch.from_numpy(np.ascontiguousarray(observations)).permute(0, 3, 1, 2).float() / 255.0
    if x.shape[-2:] != (image_size, image_size):
        x = F.interpolate(x, size=(image_size, image_size), mode="area")
    return x.contiguous()


def augment(x, cfg: LsrConfig, gen):
    """One random augmentation of every image of ``x`` (tensor (B, 3, S, S)), see module doc."""
    import torch
    import torch.nn.functional as F

    b, _, s, _ = x.shape
    out = x
    if cfg.shift > 0:
        p = cfg.shift
        padded = F.pad(x, (p, p, p, p), mode="replicate")
        dx = torch.randint(0, 2 * p + 1, (b,), generator=gen)
        dy = torch.randint(0, 2 * p + 1, (b,), generator=gen)
        rows = (dy[:, None] + torch.arange(s)[None, :])  # (B, S)
        cols = (dx[:, None] + torch.arange(s)[None, :])
        bi = torch.arange(b)[:, None, None]
        out = padded.permute(0, 2, 3, 1)[bi, rows[:, :, None], cols[:, None, :]].permute(0, 3, 1, 2)
    if cfg.jitter > 0:
        gain = 1.0 + (torch.rand((b, 3, 1, 1), generator=gen) * 2 - 1) * cfg.jitter
        out = out * gain
    if cfg.noise > 0:
        out = out + torch.randn(out.shape, generator=gen) * cfg.noise
    return out.clamp(0.0, 1.0)


@dataclass(frozen=True)
class TrainedLsr:
    """What one training run leaves: latent means and the no-action distance statistics.

    Attributes
    ----------
    mu : ndarray of float64, shape (N, latent_dim)
        Latent mean of every (unaugmented) observation.
    no_action : ndarray of float64, shape (N,)
        L1 latent distance of a fresh pair of augmentations of every observation.
    final_loss : float
    seconds : float
    """

    mu: np.ndarray
    no_action: np.ndarray
    final_loss: float
    seconds: float


def action_pairs(trace: Trace, two_step: bool) -> tuple[np.ndarray, np.ndarray]:
    """Observation index pairs ``(i, j)`` (arrays of shape (P,)) the action term pushes apart:
    every transition ``(t, t+1)`` and, if ``two_step``, every ``(t, t+2)`` with both
    transitions observed (a pick followed by a place, or a place by a pick)."""
    src, _act, dst = trace.transitions()
    if not two_step:
        return src, dst
    valid = trace.actions >= 0
    t = np.flatnonzero(valid[:-1] & valid[1:])
    return np.concatenate([src, t]), np.concatenate([dst, t + 2])


def train_lsr(trace: Trace, cfg: LsrConfig, gamma: float, d_m: float,
              on_step: Callable[[int], object] | None = None) -> TrainedLsr:
    """Train the VAE with the action term on ``trace`` (module doc); deterministic on CPU.

    ``on_step(1)`` is called after every optimizer step (progress bars).
    """
    import torch

    t0 = time.perf_counter()
    old_threads = torch.get_num_threads()
    torch.set_num_threads(max(1, cfg.threads))
    try:
        torch.manual_seed(cfg.seed)
        gen = torch.Generator().manual_seed(cfg.seed)
        x = _to_tensor(trace.observations, cfg.image_size)
        src, dst = action_pairs(trace, cfg.two_step)
        src_t, dst_t = torch.from_numpy(src), torch.from_numpy(dst)
        model = _build_vae(cfg.image_size, cfg.latent_dim)
        opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
        n_tr = len(src)
        loss_value = float("nan")
        for step in range(cfg.steps):
            beta = cfg.beta * min(1.0, step / max(1.0, cfg.steps / 2))
            pick = torch.randint(0, n_tr, (min(cfg.batch, n_tr),), generator=gen)
            a, b = x[src_t[pick]], x[dst_t[pick]]
            views = torch.cat([augment(a, cfg, gen), augment(a, cfg, gen),
                               augment(b, cfg, gen), augment(b, cfg, gen)])
            mu, logvar = model.encode(views)
            z = mu + torch.randn(mu.shape, generator=gen) * (0.5 * logvar).exp()
            recon = ((model.decode(z) - views) ** 2).sum(dim=(1, 2, 3)).mean()
            kl = (-0.5 * (1 + logvar - mu ** 2 - logvar.exp()).sum(1)).mean()
            a1, a2, b1, b2 = mu.chunk(4)
            same = torch.cat([(a1 - a2).abs().sum(1), (b1 - b2).abs().sum(1)])
            moved = torch.cat([(a1 - b1).abs().sum(1), (a2 - b2).abs().sum(1)])
            action = same.mean() + torch.clamp(d_m - moved, min=0).mean()
            loss = recon + beta * kl + gamma * action
            opt.zero_grad()
            loss.backward()
            opt.step()
            loss_value = float(loss.detach())
            if on_step is not None:
                on_step(1)
        model.eval()
        with torch.no_grad():
            mus, dists = [], []
            for lo in range(0, len(x), 256):
                chunk = x[lo:lo + 256]
                mus.append(model.encode(chunk)[0])
                m1 = model.encode(augment(chunk, cfg, gen))[0]
                m2 = model.encode(augment(chunk, cfg, gen))[0]
                dists.append((m1 - m2).abs().sum(1))
            mu_all = torch.cat(mus).double().numpy()
            no_action = torch.cat(dists).double().numpy()
    finally:
        torch.set_num_threads(old_threads)
    return TrainedLsr(mu_all, no_action, loss_value, time.perf_counter() - t0)


# ---------------------------------------------------------------- clustering


def epsilon_components(z: np.ndarray, epsilon: float) -> np.ndarray:
    """Connected components of the graph joining rows of ``z`` (shape (n, F)) closer than
    ``epsilon`` in L1. Returns the component of every row, shape (n,)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(z)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    pairs = cKDTree(z).query_pairs(epsilon, p=1, output_type="ndarray")
    adj = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(adj, directed=False)[1].astype(np.int64)


def _supported_edges(labels: np.ndarray, src: np.ndarray, act: np.ndarray, dst: np.ndarray,
                     min_support: int) -> int:
    if len(src) == 0:
        return 0
    _, counts = np.unique(np.stack([labels[src], act, labels[dst]], 1), axis=0,
                          return_counts=True)
    return int(np.count_nonzero(counts >= min_support))


def average_linkage_labels(trace: Trace, z: np.ndarray, n_cuts: int,
                           min_support: int) -> tuple[np.ndarray, float]:
    """LSR v2: average-linkage per role, one shared cut maximizing supported edges.

    Returns the labels (shape (N,)) and the chosen cut height.
    """
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import pdist

    roles = trace.roles()
    src, act, dst = trace.transitions()
    idx = [np.flatnonzero(roles == PICK), np.flatnonzero(roles == PLACE)]
    trees = [linkage(pdist(z[i], "cityblock"), "average") if len(i) > 1 else None for i in idx]
    heights = np.concatenate([t[:, 2] for t in trees if t is not None] or [np.zeros(1)])
    cuts = np.unique(np.quantile(heights, np.linspace(0, 1, max(2, n_cuts))))
    best: tuple[int, float, np.ndarray] | None = None
    for cut in cuts[::-1]:  # high cut first: ties keep fewer nodes
        parts = [fcluster(t, cut, "distance") if t is not None else np.zeros(len(i), int)
                 for t, i in zip(trees, idx)]
        labels = labels_from_roles(roles, parts[0], parts[1])
        score = _supported_edges(labels, src, act, dst, min_support)
        if best is None or score > best[0]:
            best = (score, float(cut), labels)
    return best[2], best[1]


def epsilon_labels(trace: Trace, z: np.ndarray, epsilon: float) -> np.ndarray:
    """LSR v1 labels: :func:`epsilon_components` per role."""
    roles = trace.roles()
    pick, place = np.flatnonzero(roles == PICK), np.flatnonzero(roles == PLACE)
    return labels_from_roles(roles, epsilon_components(z[pick], epsilon),
                             epsilon_components(z[place], epsilon))


@register_baseline
class LatentSpaceRoadmap(Baseline):
    """VAE with the LSR action term, LSR clustering per role, edges from transitions."""

    name = "lsr"

    config_class = LsrConfig

    def __init__(self, config: LsrConfig | None = None, **options) -> None:
        self.config = config or LsrConfig(**options)

    def _work(self) -> tuple[int, str]:
        cfg = self.config
        return len(cfg.gamma) * len(cfg.d_m) * cfg.steps, "step"

    def _sweep(self, trace: Trace, advance: Callable[[int], object]) -> list[Candidate]:
        cfg = self.config
        roles = trace.roles()
        out: list[Candidate] = []
        for gamma, d_m in product(cfg.gamma, cfg.d_m):
            trained = train_lsr(trace, cfg, float(gamma), float(d_m), advance)
            z = trained.mu
            epsilon = float(trained.no_action.mean() + trained.no_action.std())
            base = {"gamma": float(gamma), "d_m": float(d_m), "latent_dim": cfg.latent_dim,
                    "image_size": cfg.image_size, "steps": cfg.steps,
                    "final_loss": round(trained.final_loss, 4)}
            for j, method in enumerate(cfg.clusterings):
                t1 = time.perf_counter()
                if method == "epsilon":
                    labels = epsilon_labels(trace, z, epsilon)
                    params = base | {"clustering": method, "epsilon": round(epsilon, 5)}
                else:
                    labels, cut = average_linkage_labels(trace, z, cfg.cut_candidates,
                                                         cfg.min_edge_support)
                    params = base | {"clustering": method, "cut": round(cut, 5)}
                stats = graph_stats(induced_graph(trace, labels))
                J = within_role_score(roles, labels, z, p=1)
                seconds = time.perf_counter() - t1 + (trained.seconds if j == 0 else 0.0)
                out.append(Candidate(params, labels, stats, J, seconds))
        return out
