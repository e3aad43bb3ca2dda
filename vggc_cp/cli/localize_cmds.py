"""``vggc-cp train-localizer``, ``vggc-cp demo``, and the image options that ``vggc-cp plan``
(:mod:`vggc_cp.cli.solve_cmds`) and ``vggc-cp evaluate`` (:mod:`vggc_cp.cli.trace_cmds`) add
through :func:`add_image_plan_options` / :func:`add_i2p_options`. Parses, calls
:mod:`vggc_cp.localize`, prints."""

from __future__ import annotations

import json
import sys

from vggc_cp.errors import VggcError


def _floats(text: str) -> tuple[float, ...]:
    try:
        out = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise VggcError(f"expected comma-separated numbers, got {text!r}") from None
    if not out:
        raise VggcError(f"expected comma-separated numbers, got {text!r}")
    return out


def _ints(text: str) -> tuple[int, ...]:
    try:
        out = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise VggcError(f"expected comma-separated integers, got {text!r}") from None
    if not out:
        raise VggcError(f"expected comma-separated integers, got {text!r}")
    return out


def _threads(n: int) -> None:
    import torch

    if n < 1:
        raise VggcError(f"--threads must be positive, got {n}")
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
    p.add_argument("--folds", type=int, default=3, help="k of the k-fold cross-validation")
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
                         folds=args.folds, seed=args.seed)
    trace = load_trace(args.trace)
    solution = read_solution(args.solution)
    verify_solution(solution, trace, args.solution, args.trace)
    localizer, report = train_localizer(trace, solution, config, progress=not args.quiet,
                                        trace_path=args.trace, solution_path=args.solution)
    save_localizer(args.output, localizer)
    if not args.quiet:
        for lr, epochs, acc in report.cv:
            print(f"cv  lr {lr:<8g} epochs {epochs:<4d} validation accuracy {100 * acc:6.2f} %")
    print(f"localizer      {args.output} ({config.backbone}, {report.n_classes} nodes, "
          f"{report.n_images} images)")
    print(f"chosen         lr {report.learning_rate:g}, {report.epochs} epochs "
          f"({config.folds}-fold cross-validation)")
    print(f"train accuracy {100 * report.train_accuracy:6.2f} %")
    print(f"seconds        {report.seconds:.1f}")
    return 0


# ------------------------------------------------------------------ plan --start/--goal


def add_image_plan_options(p) -> None:
    """Add ``--model``, ``--start`` and ``--goal`` to a ``plan`` parser."""
    p.add_argument("--model", default=None, help="localizer checkpoint (.pt) for --start/--goal")
    p.add_argument("--start", default=None, help="start image (PNG/JPEG), with --model")
    p.add_argument("--goal", default=None, help="goal image (PNG/JPEG), with --model")


def wants_image_plan(args) -> bool:
    """True when ``plan`` was called with any of the image options."""
    return any(getattr(args, k, None) is not None for k in ("model", "start", "goal"))


def cmd_image_plan(args) -> int:
    """``vggc-cp plan solution.json --model m.pt --start a.png --goal b.png``."""
    from vggc_cp.localize import load_localizer, plan_images, read_image
    from vggc_cp.solution import read_solution, verify_standalone

    missing = [f"--{k}" for k in ("model", "start", "goal") if getattr(args, k, None) is None]
    if missing:
        raise VggcError(f"planning from images needs --model, --start and --goal "
                        f"(missing {', '.join(missing)})")
    solution = read_solution(args.solution)
    verify_standalone(solution, args.solution)
    localizer = load_localizer(args.model)
    start, goal = read_image(args.start), read_image(args.goal)
    result = plan_images(localizer, solution, start, goal, start_source=args.start,
                         goal_source=args.goal, solution_source=args.solution)
    if getattr(args, "json", False):
        print(json.dumps({"start": result.start, "start_confidence": result.start_confidence,
                          "goal": result.goal, "goal_confidence": result.goal_confidence,
                          "found": result.found, "length": len(result.actions) if result.found
                          else None, "actions": list(result.actions),
                          "steps": list(result.steps)}, indent=2))
        return 0 if result.found else 1
    print(f"start          node {result.start} (confidence {result.start_confidence:.3f}) "
          f"<- {args.start}")
    print(f"goal           node {result.goal} (confidence {result.goal_confidence:.3f}) "
          f"<- {args.goal}")
    if not result.found:
        print(f"plan           none: node {result.goal} is unreachable from node {result.start}")
        return 1
    print(f"plan           {len(result.actions)} actions")
    for i, step in enumerate(result.steps, 1):
        print(f"  {i:>3}. {step}")
    return 0


# ------------------------------------------------------------------ evaluate --model/--novel


def add_i2p_options(p) -> None:
    """Add ``--model`` and ``--novel`` to the ``evaluate`` parser."""
    p.add_argument("--model", default=None,
                   help="localizer checkpoint: add localization accuracy, I2P and Exec-I2P "
                        "(with --novel); under --reading paper, the assignment map f")
    p.add_argument("--novel", default=None, help="novel renders .npz for --model")
    p.add_argument("--i2p-queries", type=int, default=150,
                   help="start/goal image pairs for I2P (the paper's Q is 150)")


def i2p_results(args, trace, solution) -> dict | None:
    """I2P figures for ``evaluate`` when ``--model`` was given (None otherwise)."""
    if getattr(args, "model", None) is None and getattr(args, "novel", None) is None:
        return None
    if args.model is None or args.novel is None:
        if args.novel is None and getattr(args, "reading", "exact") == "paper":
            return None  # --model alone: the paper reading's assignment map, no I2P
        raise VggcError("I2P evaluation needs both --model and --novel")
    if args.i2p_queries < 1:
        raise VggcError(f"--i2p-queries must be positive, got {args.i2p_queries}")
    from vggc_cp.evaluate.i2p import evaluate_localizer
    from vggc_cp.localize import check_model_matches, load_localizer
    from vggc_cp.sim.novel import load_novel

    localizer = load_localizer(args.model)
    check_model_matches(localizer, solution, args.model)
    obs, states = load_novel(args.novel)
    if trace.states is not None and not set(states.tolist()) & set(trace.states.tolist()):
        raise VggcError(f"{args.novel}: none of its {len(states)} images shows a state that "
                        f"the trace {args.trace} visited (another benchmark or seed?)")
    m = evaluate_localizer(trace, solution, localizer, obs, states, n_queries=args.i2p_queries,
                           seed=args.seed, dynamics=args.dynamics)
    return m.as_dict()


def print_i2p(d: dict) -> None:
    print(f"novel images   {d['images']}; I2P queries Q = {d['queries']}, Exec-I2P on "
          f"{d['dynamics']} dynamics")
    print(f"{'Localization':<14} {100 * d['localization']:6.2f} %")
    print(f"{'I2P':<14} {100 * d['i2p']:6.2f} %")
    print(f"{'Exec-I2P':<14} {100 * d['exec_i2p']:6.2f} %")


# ------------------------------------------------------------------ demo


def cmd_demo(args) -> int:
    from vggc_cp.localize.demo import run_demo

    _threads(args.threads)
    say = (lambda _msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    result = run_demo(args.output, seed=args.seed, workdir=args.workdir, log=say)
    print(f"start          node {result.plan.start} (confidence "
          f"{result.plan.start_confidence:.3f}), true state {result.start_state}")
    print(f"goal           node {result.plan.goal} (confidence "
          f"{result.plan.goal_confidence:.3f}), true state {result.goal_state}")
    print(f"plan           {' -> '.join(result.plan.actions) or '(empty)'}")
    print(f"executed       {' -> '.join(result.visited)}")
    print(f"reached goal   {'yes' if result.success else 'no'}")
    print(f"strip          {args.output}")
    return 0 if result.success else 1
