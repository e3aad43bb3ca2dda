"""vggc-cp: learn discrete pick/place task graphs from RGB traces and plan on them.

Pipeline (one module a stage, data flowing one way)::

    trace -> roles -> vision (attention maps, Sinkhorn distances) -> solvers (greedy | cpsat)
          -> selection -> graph (TaskGraph, planning) -> localize -> plan / evaluate
"""

__version__ = "0.1.0"
