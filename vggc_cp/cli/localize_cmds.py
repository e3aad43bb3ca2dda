"""``vggc-cp train-localizer`` and ``vggc-cp demo``. Parses, calls :mod:`vggc_cp.localize` and
:mod:`vggc_cp.experiments.demo`, prints."""

from __future__ import annotations

import sys

from vggc_cp.errors import VggcError

#: most torch threads
MAX_THREADS = 1024
#: most values of a --lr or --epochs grid (each is a cross-validation run)
MAX_GRID = 100


def _grid(out: tuple, text: str, option: str) -> tuple:
    if len(out) > MAX_GRID:
        raise VggcError(f"{option}: {len(out):,} values, above the cap of {MAX_GRID} "
                        f"(localize_cmds.MAX_GRID)")
    return out


def _floats(text: str, option: str = "--lr") -> tuple[float, ...]:
    if len(text) > 40 * MAX_GRID:
        raise VggcError(f"{option}: {len(text):,} characters; at most {MAX_GRID} values")
    try:
        out = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise VggcError(f"expected comma-separated numbers, got {text!r}") from None
    if not out:
        raise VggcError(f"expected comma-separated numbers, got {text!r}")
    return _grid(out, text, option)


def _ints(text: str, option: str = "--epochs") -> tuple[int, ...]:
    if len(text) > 40 * MAX_GRID:
        raise VggcError(f"{option}: {len(text):,} characters; at most {MAX_GRID} values")
    try:
        out = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise VggcError(f"expected comma-separated integers, got {text!r}") from None
    if not out:
        raise VggcError(f"expected comma-separated integers, got {text!r}")
    return _grid(out, text, option)


def _threads(n: int) -> None:
    import torch

    if not 1 <= n <= MAX_THREADS:
        raise VggcError(f"--threads {n}: expected 1 to {MAX_THREADS}")
    torch.set_num_threads(n)


def register(sub) -> None:
    # the backbone names are spelled out here, not imported: importing the localizer pulls in
    # torch, which would make every vggc-cp command start slowly (unknown names still fail
    # with the registry's list when training starts)
    p = sub.add_parser("train-localizer",
                       help="train the image -> node classifier on a trace and its solution")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("solution", help="solution .json (its labels supervise the classifier)")
    p.add_argument("-o", "--output", required=True, help="checkpoint to write (.pt)")
    p.add_argument("--backbone", default="cnn",
                   help="backbone: cnn (a small CNN trained from scratch) or dinov2 "
                        "(local weights, frozen except the last block)")
    p.add_argument("--weights", default=None,
                   help="local weights file of a pretrained backbone (dinov2)")
    p.add_argument("--input-size", type=int, default=None,
                   help="network input side in pixels (default: the backbone's, 64 for cnn)")
    p.add_argument("--gamma", type=float, default=16.0, help="cosine-head temperature")
    p.add_argument("--lr", default="1e-2,3e-3", help="learning-rate grid (comma-separated)")
    p.add_argument("--epochs", default="10,20,40", help="epoch grid (comma-separated)")
    p.add_argument("--folds", type=int, default=None,
                   help="k of the k-fold cross-validation, at most half the images (default 3; "
                        "no cross-validation on fewer than 2k images)")
    p.add_argument("--seed", type=int, default=0, help="seed of initialisation, folds, batches")
    p.add_argument("--threads", type=int, default=2, help="torch CPU threads")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_train)

    d = sub.add_parser(
        "demo", help="generate fruit-2x3, learn its graph as `vggc-cp solve` does by default, "
                     "train the localizer, plan between two novel images, execute, draw a strip",
        description="The whole chain on fruit-2x3, from pixels to an executed plan: generate a "
                    "trace, learn its task graph with the default of `vggc-cp solve` (the "
                    "pipeline vggc_cp.pipeline.learn_graph: action-footprint evidence, "
                    "congruence-closure merging over distance thresholds, the threshold of "
                    "least description length, a confidence with a warning), train the "
                    "image -> node localizer on its labels, localize two novel renders, plan "
                    "between them, execute the plan in the simulator and draw the strip.")
    d.add_argument("-o", "--output", default="demo.png", help="picture strip (PNG)")
    d.add_argument("--seed", type=int, default=0, help="seed of every stage")
    d.add_argument("--workdir", default=None,
                   help="keep the intermediate files here (default: a temporary folder)")
    d.add_argument("--threads", type=int, default=2, help="torch CPU threads")
    d.add_argument("--quiet", action="store_true", help="no progress output")
    d.set_defaults(func=cmd_demo)


def cmd_train(args) -> int:
    from vggc_cp.localize import TrainConfig, save_localizer, train_localizer
    from vggc_cp.solution import read_solution, verify_solution
    from vggc_cp.trace import load_trace

    _threads(args.threads)
    config = TrainConfig(backbone=args.backbone, input_size=args.input_size,
                         weights=args.weights, gamma=args.gamma,
                         learning_rates=_floats(args.lr), epoch_grid=_ints(args.epochs),
                         folds=TrainConfig().folds if args.folds is None else args.folds,
                         seed=args.seed)
    trace = load_trace(args.trace)
    if args.folds is not None and trace.n_obs < 2 * args.folds:
        raise VggcError(f"--folds {args.folds}: {args.trace} holds {trace.n_obs} images; "
                        f"k-fold cross-validation needs at least 2k (at most "
                        f"{trace.n_obs // 2} folds here)")
    solution = read_solution(args.solution)
    verify_solution(solution, trace, args.solution, args.trace)
    localizer, report = train_localizer(trace, solution, config, progress=not args.quiet,
                                        trace_path=args.trace, solution_path=args.solution)
    save_localizer(args.output, localizer)
    if not args.quiet:
        for lr, epochs, acc in report.cv:
            print(f"cv  lr {lr:<8g} epochs {epochs:<4d} validation accuracy {100 * acc:6.2f} %")
        if report.untried:
            print(f"cv  stopped early: a setting validated 100 % on every fold; not tried: lr "
                  f"{', '.join(f'{lr:g}' for lr in report.untried)}")
    print(f"localizer      {args.output} ({config.backbone}, {report.n_classes} nodes, "
          f"{report.n_images} images)")
    print(f"chosen         lr {report.learning_rate:g}, {report.epochs} epochs "
          f"({config.folds}-fold cross-validation)")
    print(f"train accuracy {100 * report.train_accuracy:6.2f} %")
    print(f"seconds        {report.seconds:.1f}")
    return 0


# ------------------------------------------------------------------ demo


def cmd_demo(args) -> int:
    from vggc_cp.experiments.demo import run_demo
    from vggc_cp.plots import plot_image_strip

    _threads(args.threads)
    say = (lambda _msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    result = run_demo(seed=args.seed, workdir=args.workdir, log=say)
    strip = result.strip
    plot_image_strip(list(strip.images), list(strip.titles), args.output,
                     outlines=list(strip.outlines), suptitle=strip.suptitle)
    print(f"start          node {result.plan.start} (confidence "
          f"{result.plan.start_confidence:.3f}), true state {result.start_state}")
    print(f"goal           node {result.plan.goal} (confidence "
          f"{result.plan.goal_confidence:.3f}), true state {result.goal_state}")
    print(f"plan           {' -> '.join(result.plan.actions) or '(empty)'}")
    print(f"executed       {' -> '.join(result.visited)}")
    print(f"reached goal   {'yes' if result.success else 'no'}")
    print(f"strip          {args.output}")
    return 0 if result.success else 1
