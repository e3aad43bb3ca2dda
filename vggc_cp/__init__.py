"""vggc-cp: learn discrete pick/place task graphs from RGB traces and plan on them.

Pipeline (one module a stage, data flowing one way)::

    trace -> roles -> vision (attention maps, Sinkhorn distances) -> solvers (greedy | cpsat)
          -> selection -> graph (TaskGraph, planning) -> localize -> plan / evaluate

From Python (:mod:`vggc_cp.api`, loaded on first use: ``import vggc_cp`` imports nothing
heavy)::

    import vggc_cp as vg
    trace = vg.load_trace("data/fruit-2x3.npz")
    learned = vg.learn_graph(trace)          # vg.learn_graph(trace, evidence="keypoints")
    learned.to_networkx(); learned.save("s.json")
    vg.plan(learned, start_obs=0, goal_obs=13); vg.evaluate(trace, learned)
"""

import sys
import types

from vggc_cp.version import __version__

#: The names of :mod:`vggc_cp.api` the package re-exports.
FACE = ("LearnConfig", "Learned", "Solution", "Trace", "evaluate", "learn_graph",
        "load_solution", "load_trace", "plan")

__all__ = ["__version__", *FACE]


def _face(name: str):
    from vggc_cp import api

    return getattr(api, name)


def __getattr__(name: str):
    """The face's names, imported on first use (PEP 562)."""
    if name in FACE:
        return _face(name)
    raise AttributeError(f"module 'vggc_cp' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *FACE})


class _Package(types.ModuleType):
    """The package's module type: ``vggc_cp.evaluate`` is the face's function
    (:func:`vggc_cp.api.evaluate`) although a subpackage has that name too. Importing the
    subpackage does not rebind it; ``from vggc_cp.evaluate import ...`` and
    ``sys.modules["vggc_cp.evaluate"]`` still give the subpackage."""

    @property
    def evaluate(self):
        return _face("evaluate")

    @evaluate.setter
    def evaluate(self, _module) -> None:  # the import system binding the subpackage
        pass


sys.modules[__name__].__class__ = _Package
