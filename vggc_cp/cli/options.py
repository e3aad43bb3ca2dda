"""Options that several ``vggc-cp`` commands share, and the settings they stand for.

The one module that command modules (``*_cmds``) import from each other's territory: argument
definitions and their translation into library values; no command lives here.
"""

from __future__ import annotations

import argparse
import contextlib

from vggc_cp.errors import VggcError
from vggc_cp.parallel import BACKENDS, LOCAL, SCHEDULER_ENV, Backend
from vggc_cp.vision.attention import ATTENTION_BACKENDS
from vggc_cp.vision.distances import COLOUR_MODES, DistanceConfig
from vggc_cp.vision.sinkhorn import DEVICES


def add_distance_arguments(parser: argparse.ArgumentParser) -> tuple[str, ...]:
    """Add the distance options (``--attention``, ``--weights``, ``--eps``, ``--grid``, ...);
    returns their ``dest`` names."""
    d = DistanceConfig()
    g = parser.add_argument_group("visual distances")
    g.add_argument("--attention", default=d.backend, metavar="NAME",
                   help=f"attention backend: {', '.join(sorted(ATTENTION_BACKENDS))} "
                        f"(default {d.backend})")
    g.add_argument("--weights", default=None, metavar="PATH",
                   help="DINOv2 weights file (default $VGGC_CP_DINOV2_WEIGHTS)")
    g.add_argument("--eps", type=float, default=d.eps,
                   help=f"Sinkhorn entropic regularisation, costs in the unit square "
                        f"(default {d.eps})")
    g.add_argument("--grid", type=int, default=d.grid,
                   help=f"attention patch grid side (default {d.grid})")
    g.add_argument("--floor", type=float, default=d.floor,
                   help=f"uniform mass added to every map (default {d.floor})")
    g.add_argument("--sinkhorn-tol", type=float, default=d.tol,
                   help=f"L1 marginal error at which Sinkhorn stops (default {d.tol:g})")
    g.add_argument("--sinkhorn-dtype", choices=("float32", "float64"), default=d.dtype,
                   help=f"Sinkhorn matrix-product precision (default {d.dtype})")
    g.add_argument("--sinkhorn-device", choices=DEVICES, default=d.device,
                   help="Sinkhorn device: torch (CUDA when present, else CPU), torch-cpu, "
                        f"cuda, numpy (default {d.device})")
    g.add_argument("--sinkhorn-threads", type=int, default=d.threads,
                   help=f"CPU threads of the Sinkhorn stage (default {d.threads})")
    g.add_argument("--colour", choices=COLOUR_MODES, default=d.colour,
                   help="add colour-channel divergences when the trace shows two or more "
                        f"object colours (auto) or never (off) (default {d.colour})")
    g.add_argument("--distance-rows", type=int, default=None, metavar="R",
                   help="split each role's Sinkhorn pairs into blocks of R rows, one task each "
                        "(spread over --backend dask/ray); the same R gives the same numbers "
                        "on every backend (default: one block per role)")
    g.add_argument("--cache-dir", default=None,
                   help="distance cache directory (default $VGGC_CP_CACHE/distances or "
                        "./.cache/vggc-cp/distances)")
    g.add_argument("--no-cache", action="store_true", help="neither read nor write the cache")
    return tuple(a.dest for a in g._group_actions)


def config_from_args(args: argparse.Namespace) -> DistanceConfig:
    """The :class:`DistanceConfig` of options added by :func:`add_distance_arguments`."""
    d = DistanceConfig()
    return DistanceConfig(
        backend=getattr(args, "attention", d.backend),
        grid=getattr(args, "grid", d.grid),
        eps=getattr(args, "eps", d.eps),
        floor=getattr(args, "floor", d.floor),
        weights=getattr(args, "weights", None),
        tol=getattr(args, "sinkhorn_tol", d.tol),
        dtype=getattr(args, "sinkhorn_dtype", d.dtype),
        colour=getattr(args, "colour", d.colour),
        device=getattr(args, "sinkhorn_device", d.device),
        threads=getattr(args, "sinkhorn_threads", d.threads),
        rows=getattr(args, "distance_rows", None),
        cache_dir=getattr(args, "cache_dir", None),
        use_cache=not getattr(args, "no_cache", False),
    )


def add_backend_arguments(p, what: str = "independent tasks") -> None:
    """Add ``--backend`` and ``--scheduler`` (:mod:`vggc_cp.parallel`); ``what`` says what runs
    there."""
    g = p.add_argument_group("where the work runs")
    g.add_argument("--backend", choices=BACKENDS, default=LOCAL,
                   help=f"where {what} run: local (this machine, --jobs processes), dask or "
                        f"ray (a cluster; extras) (default {LOCAL})")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help=f"dask scheduler (tcp://host:8786) or ray address of an existing "
                        f"cluster (default ${SCHEDULER_ENV}; unset: a fresh local dask cluster "
                        f"of --jobs workers, or one per core)")


def backend_from_args(args: argparse.Namespace) -> Backend:
    """The :class:`~vggc_cp.parallel.Backend` of ``--backend``, ``--scheduler`` and ``--jobs``."""
    return Backend(getattr(args, "backend", LOCAL), getattr(args, "scheduler", None),
                   getattr(args, "jobs", None))


@contextlib.contextmanager
def cluster_from_args(args: argparse.Namespace):
    """The executor of ``--backend dask|ray`` held open for the ``with`` block, or None for
    ``--backend local`` (the command's own ``--jobs`` handling: today's behaviour)."""
    from vggc_cp.parallel import check_backend, open_executor

    backend = backend_from_args(args)
    check_backend(backend)
    if backend.name == LOCAL:
        yield None
        return
    with open_executor(backend) as executor:
        yield executor


def add_cpsat_arguments(p) -> None:
    """The CP-SAT options of ``compare`` and ``solve``."""
    p.add_argument("--cpsat-params", default="", metavar="S",
                   help='OR-Tools CP-SAT parameters, "field:value,..." (default '
                        '"max_time_in_seconds:10,num_workers:2", per solved cell)')
    p.add_argument("--deterministic", action="store_true",
                   help="CP-SAT: one node and one action lead to one node")
    p.add_argument("--max-actions", type=int, default=None, metavar="K",
                   help="CP-SAT: at most K distinct actions leave a node")
    p.add_argument("--codeterministic", action="store_true",
                   help="CP-SAT: one action into a node comes from one node")
    p.add_argument("--cannot-link", type=float, default=None, metavar="D",
                   help="CP-SAT: observations farther apart than visual distance D never "
                        "share a node")
    p.add_argument("--objective", choices=("J", "none"), default="J",
                   help="CP-SAT: minimize the quantized visual score J or decide "
                        "feasibility only")
    p.add_argument("--hint", default=None, metavar="SOLUTION",
                   help="CP-SAT: a solution JSON of this trace (e.g. of a larger cell) offered "
                        "to every cell: a hint where valid, else merged into the cell's colours "
                        "and repaired by CP-SAT (a start, never a proof)")
    p.add_argument("--optimize", choices=("minimal", "all"), default="minimal",
                   help="CP-SAT cells whose J is minimized: those of the fewest feasible nodes "
                        "or every feasible cell")


def cpsat_solver_from_args(args: argparse.Namespace, tau: float | None = None,
                           n_obs: int | None = None):
    """The CP-SAT solver of the options added by :func:`add_cpsat_arguments`
    (:func:`vggc_cp.pipeline.cpsat_solver`; errors: exit 2)."""
    from vggc_cp.pipeline import cpsat_solver

    return cpsat_solver(params=args.cpsat_params, objective=args.objective,
                        deterministic=args.deterministic, max_actions=args.max_actions,
                        codeterministic=args.codeterministic, cannot_link=args.cannot_link,
                        tau=tau, hint=getattr(args, "hint", None), n_obs=n_obs)


def add_image_plan_options(p) -> None:
    """Add ``--model``, ``--start`` and ``--goal`` to a ``plan`` parser."""
    p.add_argument("--model", default=None, help="localizer checkpoint (.pt) for --start/--goal")
    p.add_argument("--start", default=None, help="start image (PNG/JPEG), with --model")
    p.add_argument("--goal", default=None, help="goal image (PNG/JPEG), with --model")


def wants_image_plan(args) -> bool:
    """True when ``plan`` was called with any of the image options."""
    return any(getattr(args, k, None) is not None for k in ("model", "start", "goal"))


def add_i2p_options(p) -> None:
    """Add ``--model`` and ``--novel`` to the ``evaluate`` parser."""
    p.add_argument("--model", default=None,
                   help="localizer checkpoint: add localization accuracy, I2P and Exec-I2P "
                        "(with --novel); under --reading paper, the assignment map f")
    p.add_argument("--novel", default=None, help="novel renders .npz for --model")
    p.add_argument("--i2p-queries", type=int, default=150,
                   help="start/goal image pairs for I2P (the paper's Q is 150)")


#: most seeds one study takes (every seed is a trace per benchmark and look)
MAX_SEEDS = 10_000
#: largest seed (numpy's seeds are 32-bit here)
MAX_SEED = 2**32 - 1


def parse_seeds(text: str, option: str = "--seeds") -> tuple[int, ...]:
    """``"0:4"`` (inclusive) or ``"0,1,2"`` -> a tuple of seeds, at most :data:`MAX_SEEDS`,
    each in ``0..MAX_SEED``."""
    if len(text) > 20 * MAX_SEEDS:
        raise VggcError(f"{option}: {len(text):,} characters; at most {MAX_SEEDS:,} seeds "
                        f"(options.MAX_SEEDS)")
    try:
        if ":" in text:
            a, b = (int(x) for x in text.split(":"))
            if b < a:
                raise ValueError
            if b - a + 1 > MAX_SEEDS:
                raise VggcError(f"{option} {text!r}: {b - a + 1:,} seeds, above the cap of "
                                f"{MAX_SEEDS:,} (options.MAX_SEEDS)")
            seeds = tuple(range(a, b + 1))
        else:
            seeds = tuple(int(s) for s in text.split(",") if s.strip())
    except ValueError:
        raise VggcError(f"{option} {text!r}: expected an inclusive range A:B (A <= B) or "
                        "comma-separated integers") from None
    if not seeds:
        raise VggcError(f"{option} {text!r}: no seed")
    if len(seeds) > MAX_SEEDS:
        raise VggcError(f"{option}: {len(seeds):,} seeds, above the cap of {MAX_SEEDS:,} "
                        f"(options.MAX_SEEDS)")
    if any(not 0 <= s <= MAX_SEED for s in seeds):
        raise VggcError(f"{option} {text[:60]!r}: seeds are integers from 0 to {MAX_SEED:,}")
    return seeds
