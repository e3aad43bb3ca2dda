"""Training the localizer with a solution's labels as supervision.

Learning rate and number of epochs are chosen by k-fold cross-validation on the trace's own
observations (a small grid: every learning rate is trained once per fold with a constant rate,
and validated after each epoch count of the grid, so epochs cost nothing extra); then the
network is fitted on all observations with the chosen pair.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from vggc_cp.errors import VggcError
from vggc_cp.localize.backbones import DEFAULT_BACKBONE, new_backbone
from vggc_cp.localize.localizer import Localizer, predict_probabilities, solution_digest
from vggc_cp.localize.model import Augment, LocalizerNet, to_unit_tensor
from vggc_cp.solution import Solution
from vggc_cp.trace import ROLE_NAMES, Trace

#: caps of the training settings (a NaN or absurd value is refused, not trained)
MAX_LR = 10.0
MAX_GAMMA = 1e4
MAX_EPOCHS = 10_000
MAX_FOLDS = 100


@dataclass(frozen=True)
class TrainConfig:
    """Everything that shapes a training run.

    Attributes
    ----------
    backbone : str
        Registry name (``cnn``, ``dinov2``).
    input_size : int or None
        Side of the network's input (images are resampled); None: the backbone's default.
    weights : str or None
        Local weights file of a pretrained backbone (``dinov2``).
    gamma : float
        Temperature of the cosine head.
    learning_rates : tuple of float
        Grid of (constant) AdamW learning rates.
    epoch_grid : tuple of int
        Epoch counts validated; the largest is what each cross-validation run trains.
    folds : int
        k of the k-fold cross-validation (no cross-validation below ``2 * folds`` images).
    batch_size : int
    weight_decay : float
    augment : Augment
    seed : int
    """

    backbone: str = DEFAULT_BACKBONE
    input_size: int | None = None
    weights: str | None = None
    gamma: float = 16.0
    learning_rates: tuple[float, ...] = (1e-2, 3e-3)
    epoch_grid: tuple[int, ...] = (10, 20, 40)
    folds: int = 3
    batch_size: int = 32
    weight_decay: float = 1e-4
    augment: Augment = field(default_factory=Augment)
    seed: int = 0

    def __post_init__(self) -> None:
        import math

        from vggc_cp.safeio import CAPS, cap

        if not self.learning_rates or any(not (math.isfinite(lr) and 0 < lr <= MAX_LR)
                                          for lr in self.learning_rates):
            raise VggcError(f"--lr {','.join(f'{x:g}' for x in self.learning_rates)}: learning "
                            f"rates must be finite, positive and at most {MAX_LR:g}")
        if not (math.isfinite(self.gamma) and 0 < self.gamma <= MAX_GAMMA):
            raise VggcError(f"--gamma {self.gamma:g}: the cosine-head temperature must be "
                            f"finite, positive and at most {MAX_GAMMA:g}")
        if not self.epoch_grid or any(not 1 <= e <= MAX_EPOCHS for e in self.epoch_grid):
            raise VggcError(f"--epochs {','.join(map(str, self.epoch_grid))}: epoch counts must "
                            f"be from 1 to {MAX_EPOCHS:,}")
        if not 2 <= self.folds <= MAX_FOLDS:
            raise VggcError(f"--folds {self.folds}: cross-validation needs 2 to {MAX_FOLDS} "
                            f"folds")
        if self.input_size is not None:
            lo = cap("min_side")
            if self.input_size < lo or self.input_size ** 2 > cap("max_pixels"):
                raise VggcError(f"--input-size {self.input_size}: the network input side must "
                                f"be from {lo} ({CAPS['min_side'][1]}) to "
                                f"{math.isqrt(cap('max_pixels'))} "
                                f"({CAPS['max_pixels'][1]} = {cap('max_pixels'):,} pixels)")
        if not (math.isfinite(self.weight_decay) and self.weight_decay >= 0):
            raise VggcError(f"weight decay must be finite and non-negative, got "
                            f"{self.weight_decay}")
        if self.batch_size < 1:
            raise VggcError(f"batch size must be positive, got {self.batch_size}")

    def as_dict(self) -> dict:
        return {"backbone": self.backbone, "input_size": self.input_size, "gamma": self.gamma,
                "learning_rates": list(self.learning_rates), "epoch_grid": list(self.epoch_grid),
                "folds": self.folds, "batch_size": self.batch_size,
                "weight_decay": self.weight_decay, "augment": self.augment.as_dict(),
                "seed": self.seed}


@dataclass(frozen=True)
class TrainReport:
    """What training chose and measured.

    Attributes
    ----------
    learning_rate, epochs : float, int
        The cross-validated choice used for the final fit.
    cv : tuple of (lr, epochs, mean validation accuracy)
        The settings cross-validated (empty when too few images for cross-validation).
    train_accuracy : float
        Accuracy of the final network on the (unaugmented) training images.
    n_images, n_classes : int
    seconds : float
    untried : tuple of float
        Learning rates of the grid that cross-validation did not try because an earlier
        setting validated perfectly on every fold (empty when it tried them all).
    """

    learning_rate: float
    epochs: int
    cv: tuple[tuple[float, int, float], ...]
    train_accuracy: float
    n_images: int
    n_classes: int
    seconds: float
    untried: tuple[float, ...] = ()

    def as_dict(self) -> dict:
        return {"learning_rate": self.learning_rate, "epochs": self.epochs,
                "cv": [list(row) for row in self.cv], "train_accuracy": self.train_accuracy,
                "n_images": self.n_images, "n_classes": self.n_classes, "seconds": self.seconds,
                "cv_untried": list(self.untried)}


def _new_net(config: TrainConfig, n_classes: int, seed: int) -> LocalizerNet:
    options = {} if config.input_size is None else {"input_size": config.input_size}
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        backbone = new_backbone(config.backbone, weights=config.weights, **options)
        return LocalizerNet(backbone, n_classes, config.gamma)


def _child_seed(seed: int, *path: int) -> int:
    return int(np.random.SeedSequence([seed, *path]).generate_state(1)[0])


def _fit(net: LocalizerNet, x: torch.Tensor, y: torch.Tensor, lr: float, epochs: int,
         config: TrainConfig, seed: int, on_epoch=None) -> None:
    """Train ``net`` in place for ``epochs`` (AdamW at a constant rate, shuffled batches,
    fresh augmentations every epoch); ``on_epoch(epoch)`` is called after each epoch and
    stops the run by returning True.

    Dropout draws from torch's global generator, so the run is seeded inside a forked RNG
    state (the caller's global state is left as it was).
    """
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        _fit_seeded(net, x, y, lr, epochs, config, seed, on_epoch)


def _fit_seeded(net, x, y, lr, epochs, config, seed, on_epoch) -> None:
    gen = torch.Generator().manual_seed(seed)
    opt = torch.optim.AdamW(net.trainable_parameters(), lr=lr, weight_decay=config.weight_decay)
    n = x.shape[0]
    bs = min(config.batch_size, n)
    for epoch in range(1, epochs + 1):
        net.train()
        order = torch.randperm(n, generator=gen)
        for i in range(0, n, bs):
            idx = order[i:i + bs]
            if len(idx) < 2 and n >= 2:  # BatchNorm needs two samples
                idx = order[max(0, i - 1):i + bs]
            xb = config.augment(x[idx], gen)
            loss = F.cross_entropy(net(xb), y[idx])
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
        if on_epoch is not None and on_epoch(epoch):
            break


def _accuracy(net: LocalizerNet, x: torch.Tensor, y: torch.Tensor) -> float:
    if x.shape[0] == 0:
        return float("nan")
    probs = predict_probabilities(net, x)
    return float(np.mean(probs.argmax(axis=1) == y.numpy()))


def cross_validate(x: torch.Tensor, y: torch.Tensor, n_classes: int, config: TrainConfig,
                   progress=None) -> tuple[tuple[float, int, float], ...]:
    """Mean k-fold validation accuracy of (learning rate, epochs) settings of the grid.

    Learning rates are tried in the order given, each on every fold. Early stopping: a run
    stops at a grid point where it validates perfectly or no better than at the previous grid
    point; its later grid points keep that score (so the choice, which prefers fewer epochs on
    ties, picks the earlier point). Once a learning rate has a setting that validates
    perfectly on every fold, the later learning rates are not tried: none could score higher.

    Parameters
    ----------
    x : Tensor, float, shape (N, 3, S, S)
        Unit images.
    y : Tensor, int64, shape (N,)
        Class indices.
    progress : tqdm or None
        Advanced by one per trained epoch (and by the epochs an early stop skips).

    Returns
    -------
    tuple of (lr, epochs, mean validation accuracy)
        The settings tried, learning rate by learning rate; fewer than the whole grid when
        cross-validation stopped early.
    """
    n = x.shape[0]
    folds = np.array_split(np.random.default_rng(config.seed).permutation(n), config.folds)
    grid = sorted(set(config.epoch_grid))
    scores: dict[tuple[float, int], list[float]] = {}
    for j, lr in enumerate(config.learning_rates):
        for e in grid:
            scores.setdefault((lr, e), [])
        for f, val in enumerate(folds):
            mask = np.ones(n, dtype=bool)
            mask[val] = False
            tr = torch.from_numpy(np.flatnonzero(mask))
            va = torch.from_numpy(np.sort(val))
            net = _new_net(config, n_classes, _child_seed(config.seed, 1, f, j))

            def on_epoch(epoch, net=net, lr=lr, va=va) -> bool:
                if progress is not None:
                    progress.update(1)
                if (lr, epoch) not in scores:
                    return False
                acc = _accuracy(net, x[va], y[va])
                scores[(lr, epoch)].append(acc)
                k = grid.index(epoch)
                plateau = k > 0 and acc <= scores[(lr, grid[k - 1])][-1]
                if epoch == grid[-1] or not (acc >= 1.0 or plateau):
                    return False
                # perfect, or no better than at the previous grid point: stop this run early;
                # its later grid points keep this score
                for e in grid[k + 1:]:
                    scores[(lr, e)].append(acc)
                if progress is not None:
                    progress.update(grid[-1] - epoch)
                return True

            _fit(net, x[tr], y[tr], lr, grid[-1], config, _child_seed(config.seed, 2, f, j),
                 on_epoch)
        if any(min(scores[(lr, e)]) >= 1.0 for e in grid):
            if progress is not None:
                progress.update((len(config.learning_rates) - j - 1) * len(folds) * grid[-1])
            break
    return tuple((lr, e, float(np.mean(s))) for (lr, e), s in scores.items())


def choose(cv: tuple[tuple[float, int, float], ...]) -> tuple[float, int]:
    """Best mean validation accuracy; ties go to fewer epochs, then to the larger rate."""
    lr, e, _ = min(cv, key=lambda row: (-round(row[2], 9), row[1], -row[0]))
    return lr, e


def train_on_images(images: np.ndarray, classes: np.ndarray, n_classes: int,
                    config: TrainConfig, progress: bool = False,
                    description: str = "train-localizer") -> tuple[LocalizerNet, TrainReport]:
    """Cross-validate, then fit on everything.

    Parameters
    ----------
    images : ndarray, uint8, shape (N, H, W, 3)
    classes : ndarray of int, shape (N,)
        Class index in ``[0, n_classes)`` of every image.
    config : TrainConfig
    progress : bool
        Show a tqdm bar (counts epochs).
    """
    from tqdm.auto import tqdm

    t0 = time.perf_counter()
    y = torch.as_tensor(np.asarray(classes, dtype=np.int64))
    probe = _new_net(config, n_classes, config.seed)
    x = to_unit_tensor(images, probe.backbone.input_size)
    n = x.shape[0]
    do_cv = n >= 2 * config.folds and (len(config.learning_rates) > 1 or len(config.epoch_grid) > 1)
    grid_max = max(config.epoch_grid)
    cv_epochs = config.folds * len(config.learning_rates) * grid_max if do_cv else 0
    bar = tqdm(total=cv_epochs + grid_max, desc=description, unit="epoch", disable=not progress,
               leave=False)
    with bar:
        if do_cv:
            bar.set_postfix_str("cross-validation")
            cv = cross_validate(x, y, n_classes, config, bar)
            lr, epochs = choose(cv)
        else:
            cv = ()
            lr, epochs = config.learning_rates[0], grid_max
        bar.update(grid_max - epochs)  # the final fit trains `epochs` of the grid_max counted
        bar.set_postfix_str(f"final fit lr={lr:g} epochs={epochs}")
        net = probe

        def tick(_epoch: int) -> bool:
            bar.update(1)
            return False

        _fit(net, x, y, lr, epochs, config, _child_seed(config.seed, 3), tick)
    net.eval()
    tried = {row[0] for row in cv}
    untried = tuple(r for r in config.learning_rates if cv and r not in tried)
    report = TrainReport(lr, epochs, cv, _accuracy(net, x, y), n, n_classes,
                         time.perf_counter() - t0, untried)
    return net, report


def train_localizer(trace: Trace, solution: Solution, config: TrainConfig | None = None, *,
                    progress: bool = False, trace_path: str | Path | None = None,
                    solution_path: str | Path | None = None) -> tuple[Localizer, TrainReport]:
    """Train an image -> node classifier on ``trace``'s observations with ``solution.labels``.

    Reads observations and labels only (never the trace's ground-truth ``states``).
    """
    config = config or TrainConfig()
    labels = np.asarray(solution.labels, dtype=np.int64)
    if len(labels) != trace.n_obs:
        raise VggcError(f"the solution has {len(labels)} labels, the trace {trace.n_obs} "
                        f"observations")
    node_ids, classes = np.unique(labels, return_inverse=True)
    roles = {int(u): ROLE_NAMES[int(solution.roles[np.flatnonzero(labels == u)[0]])]
             for u in node_ids}
    net, report = train_on_images(trace.without_states().observations, classes.reshape(-1),
                                  len(node_ids), config, progress)
    meta = {
        "node_roles": [roles[int(u)] for u in node_ids],
        "solution": {"path": None if solution_path is None else str(solution_path),
                     "digest": solution_digest(solution), "solver": solution.solver,
                     "k_pick": solution.k_pick, "k_place": solution.k_place},
        "trace": {"path": None if trace_path is None else str(trace_path),
                  "content_hash": trace.content_hash(),
                  "benchmark": trace.meta.get("benchmark") if trace.meta else None},
        "training": config.as_dict() | {"weights": config.weights,
                                        "weights_sha256": _weights_digest(config)}
                    | report.as_dict(),
        "action_names": list(trace.action_names),
    }
    return Localizer(net, tuple(int(u) for u in node_ids), trace.image_shape, meta), report


def _weights_digest(config: TrainConfig) -> str | None:
    """SHA-256 of the pretrained weights file a run started from (None for ``cnn``)."""
    if config.backbone != "dinov2":
        return None
    from vggc_cp.vision.dinov2 import resolve_weights, weights_sha256

    return weights_sha256(resolve_weights(config.weights))


def quick_config(**changes) -> TrainConfig:
    """A cheaper configuration (for tests and the demo): two folds, a shorter grid."""
    base = TrainConfig(learning_rates=(3e-3,), epoch_grid=(6, 12), folds=2)
    return replace(base, **changes)
