"""The paper's seven benchmarks: specs, discrete dynamics, PyBullet scenes, exploration.

``get_benchmark(name)`` returns the dynamics (``.spec``, ``.step``, ``.apply``,
``.all_states``, ``.action_names``); rendering (:mod:`vggc_cp.sim.render`) imports PyBullet
only when used.
"""

from vggc_cp.sim.dynamics import Benchmark, get_benchmark
from vggc_cp.sim.specs import SPECS, BenchmarkSpec, benchmark_names, get_spec

__all__ = ["SPECS", "Benchmark", "BenchmarkSpec", "benchmark_names", "get_benchmark", "get_spec"]
