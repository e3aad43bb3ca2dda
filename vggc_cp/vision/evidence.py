"""Visual evidences: the one registry of the distances that the default pipeline merges on.

An *evidence* turns a trace into within-role distances, ``(dist_pick, dist_place)``, rows in
the order of ``flatnonzero(roles == PICK)`` and ``flatnonzero(roles == PLACE)``. Every
evidence is registered under a name with two functions:

* ``distances(trace, options, progress) -> (dist_pick, dist_place)``, ``options`` the
  :class:`~vggc_cp.learned.LearnConfig` of the run (each evidence reads its own settings
  from it);
* ``settings(options) -> dataclass``: the settings it ran under, recorded in the solution
  file's ``distances`` field.

Built in: ``footprints`` (:mod:`.footprints`, no weights) and one evidence per attention
backend of :data:`~vggc_cp.vision.attention.ATTENTION_BACKENDS` (``saliency``, ``keypoints``,
``dinov2``: the Sinkhorn distances of :mod:`.distances` with that backend). An evidence that
cannot read a trace raises :class:`~vggc_cp.errors.EvidenceNotApplicable` (the only error
``evidence="auto"`` passes over).

Adding one is a registration (``vggc_cp.pipeline.learn_graph``, ``LearnConfig`` and
``vggc-cp solve --evidence`` read this registry)::

    @register_evidence("mine", settings=lambda options: options.distance)
    def my_distances(trace, options, progress=False):
        ...
        return dist_pick, dist_place
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from vggc_cp.errors import EvidenceNotApplicable, lookup
from vggc_cp.vision.attention import ATTENTION_BACKENDS

if TYPE_CHECKING:
    from vggc_cp.trace import Trace

#: ``distances(trace, options, progress) -> (dist_pick, dist_place)``.
DistanceFn = Callable[..., "tuple[np.ndarray, np.ndarray]"]


@dataclass(frozen=True)
class Evidence:
    """One registered evidence.

    Attributes
    ----------
    name : str
    distances : callable
        ``(trace, options, progress=False) -> (dist_pick, dist_place)``, float64 arrays of
        shapes ``(n_pick, n_pick)`` and ``(n_place, n_place)``.
    settings : callable
        ``options -> settings object`` (a dataclass: recorded in the solution file).
    """

    name: str
    distances: DistanceFn
    settings: Callable[[object], object]


#: name -> :class:`Evidence`, in registration order (footprints first).
EVIDENCE_REGISTRY: dict[str, Evidence] = {}


def register_evidence(name: str, *, settings: Callable[[object], object]
                      ) -> Callable[[DistanceFn], DistanceFn]:
    """Decorator: register ``fn(trace, options, progress=False)`` as the evidence ``name``."""
    def deco(fn: DistanceFn) -> DistanceFn:
        EVIDENCE_REGISTRY[name] = Evidence(name, fn, settings)
        return fn
    return deco


def get_evidence(name: str) -> Evidence:
    """The evidence called ``name`` (unknown names list the registered ones)."""
    return lookup(EVIDENCE_REGISTRY, name, "evidence")


def evidence_names() -> tuple[str, ...]:
    """The registered evidence names, in registration order."""
    return tuple(EVIDENCE_REGISTRY)


# ----------------------------------------------------------------------- built-in evidences


@register_evidence("footprints", settings=lambda options: options.footprint)
def footprint_evidence(trace: Trace, options, progress: bool = False
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Action-footprint distances (:func:`vggc_cp.vision.footprints.footprint_distances`)."""
    from vggc_cp.vision.footprints import footprint_distances

    return footprint_distances(trace, options.footprint)


def _attention_evidence(backend: str) -> DistanceFn:
    def distances(trace: Trace, options, progress: bool = False
                  ) -> tuple[np.ndarray, np.ndarray]:
        from vggc_cp.vision.distances import compute_distances

        cfg = replace(options.distance, backend=backend)
        h, w = trace.image_shape
        if min(h, w) < cfg.grid:
            raise EvidenceNotApplicable(
                f"{trace.source or 'the trace'}: field 'observations' holds {h}x{w} images, "
                f"smaller than the {cfg.grid}x{cfg.grid} attention grid (--grid)")
        return compute_distances(trace, cfg, progress=progress)

    distances.__name__ = f"{backend}_evidence"
    distances.__doc__ = (f"Sinkhorn divergences between {backend!r} attention maps "
                         f"(:func:`vggc_cp.vision.distances.compute_distances`).")
    return distances


for _backend in ATTENTION_BACKENDS:
    register_evidence(_backend, settings=lambda options, b=_backend:
                      replace(options.distance, backend=b))(_attention_evidence(_backend))
