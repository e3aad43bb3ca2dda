"""The paper's seven benchmarks and the task family beyond them: specs, discrete dynamics,
PyBullet scenes, exploration.

``get_benchmark(name)`` returns the dynamics (``.spec``, ``.step``, ``.apply``,
``.all_states``, ``.action_names``) of a benchmark, of ``random-S`` (a task drawn from seed
``S``) or of a spec string ``task:...`` (:mod:`vggc_cp.sim.tasks`); rendering
(:mod:`vggc_cp.sim.render`) imports PyBullet only when used.
"""

from vggc_cp.sim.dynamics import Benchmark
from vggc_cp.sim.specs import SPECS, BenchmarkSpec, benchmark_names
from vggc_cp.sim.tasks import draw_task, get_benchmark, get_spec, is_task_name

__all__ = ["SPECS", "Benchmark", "BenchmarkSpec", "benchmark_names", "draw_task",
           "get_benchmark", "get_spec", "is_task_name"]
