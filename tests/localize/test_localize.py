"""The localization classifier: training, checkpoints, planning from images, I2P, CLI."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
import torch
from conftest import image_for, make_trace

from vggc_cp.cli import main
from vggc_cp.errors import VggcError
from vggc_cp.evaluate.groundtruth import GroundTruth
from vggc_cp.evaluate.i2p import (
    evaluate_i2p,
    execute_plan,
    majority_states,
    plan_validates,
    sample_image_queries,
)
from vggc_cp.localize import (
    CheckpointError,
    ImageError,
    load_localizer,
    plan_images,
    quick_config,
    read_image,
    save_localizer,
    solution_graph,
    train_localizer,
    write_image,
)
from vggc_cp.localize.model import Augment
from vggc_cp.sim.novel import save_novel
from vggc_cp.solution import labels_solution, read_solution, write_solution
from vggc_cp.trace import save_trace

SIZE = 16
NOISE = 24
# two objects on three regions: pick states "xx-|-", place states "x--|x"
NAMES = ("pick_0", "pick_1", "pick_2", "place_0", "place_1", "place_2")


def _step(state: str, action: str) -> str | None:
    body, held = state.split("|")
    verb, r = action.split("_")
    r = int(r)
    if verb == "pick":
        if held != "-" or body[r] != "x":
            return None
        return body[:r] + "-" + body[r + 1:] + "|x"
    if held != "x" or body[r] != "-":
        return None
    return body[:r] + "x" + body[r + 1:] + "|-"


def _episodes(n_episodes: int, length: int, seed: int) -> list[list[str]]:
    rng = np.random.default_rng(seed)
    starts = ["xx-|-", "x-x|-", "-xx|-"]
    out = []
    for _ in range(n_episodes):
        s = starts[rng.integers(3)]
        ep = [s]
        for _ in range(length):
            valid = [a for a in NAMES if _step(s, a) is not None]
            a = valid[rng.integers(len(valid))]
            s = _step(s, a)
            ep += [a, s]
        out.append(ep)
    return out


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """A noisy hand-made trace, its ground-truth labelling, a trained localizer, files."""
    torch.set_num_threads(1)
    root = tmp_path_factory.mktemp("loc")
    trace = make_trace(_episodes(8, 8, 0), NAMES, size=SIZE, noise=NOISE, seed=1)
    _, labels = np.unique(trace.states, return_inverse=True)
    sol_dict = labels_solution(trace, labels.reshape(-1) + 10, solver="truth")
    write_solution(root / "sol.json", sol_dict)
    save_trace(trace, root / "trace.npz")
    solution = read_solution(root / "sol.json")
    config = quick_config(input_size=16, seed=0)
    localizer, report = train_localizer(trace, solution, config, trace_path=root / "trace.npz",
                                        solution_path=root / "sol.json")
    save_localizer(root / "model.pt", localizer)
    rng = np.random.default_rng(7)
    novel_states = np.array(sorted(set(trace.states.tolist())) * 5)
    novel = np.stack([image_for(s, SIZE, NOISE, rng) for s in novel_states])
    save_novel(root / "novel.npz", novel, novel_states)
    return {"root": root, "trace": trace, "solution": solution, "localizer": localizer,
            "report": report, "novel": novel, "novel_states": novel_states}


def test_training_generalises_to_held_out_noisy_renders(setup):
    loc, sol, trace = setup["localizer"], setup["solution"], setup["trace"]
    pred = loc.predict(setup["novel"])
    # ground-truth node of every state (labels were built from the states)
    node_of = {s: int(sol.labels[np.flatnonzero(trace.states == s)[0]])
               for s in set(trace.states.tolist())}
    truth = np.array([node_of[s] for s in setup["novel_states"]])
    assert np.mean(pred.nodes == truth) >= 0.95
    assert np.all((pred.confidence > 0) & (pred.confidence <= 1))
    np.testing.assert_allclose(pred.probabilities.sum(axis=1), 1.0, rtol=1e-5)
    assert setup["report"].train_accuracy >= 0.95
    assert setup["report"].cv  # the grid was cross-validated


def test_training_is_deterministic(setup):
    trace, sol = setup["trace"], setup["solution"]
    config = quick_config(input_size=16, seed=0, epoch_grid=(2,), folds=2)
    a, _ = train_localizer(trace, sol, config)
    b, _ = train_localizer(trace, sol, config)
    for (k, va), (_, vb) in zip(a.net.state_dict().items(), b.net.state_dict().items()):
        assert torch.equal(va, vb), k


def test_checkpoint_round_trip_weights_only(setup):
    root, loc = setup["root"], setup["localizer"]
    raw = torch.load(root / "model.pt", weights_only=True)
    assert raw["format"] == "vggc-localizer/1"
    meta = json.loads(raw["meta"])
    assert meta["node_ids"] == list(loc.node_ids)
    assert meta["image_shape"] == [SIZE, SIZE]
    assert meta["backbone"] == "cnn" and meta["backbone_config"]["input_size"] == 16
    assert meta["solution"]["digest"] and meta["solution"]["path"].endswith("sol.json")
    assert meta["trace"]["content_hash"] == setup["trace"].content_hash()
    assert "learning_rate" in meta["training"] and "cv" in meta["training"]
    back = load_localizer(root / "model.pt")
    a, b = loc.predict(setup["novel"]), back.predict(setup["novel"])
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_allclose(a.probabilities, b.probabilities, atol=1e-6)


class _Evil:
    def __reduce__(self):
        return (print, ("pwned",))


@pytest.mark.filterwarnings("ignore:Detected pickle protocol")
def test_pickle_and_garbage_checkpoints_are_refused(tmp_path):
    bad = tmp_path / "evil.pt"
    torch.save({"format": "vggc-localizer/1", "state_dict": {}, "meta": _Evil()}, bad)
    with pytest.raises(CheckpointError, match="refused"):
        load_localizer(bad)
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError, match="junk.pt"):
        load_localizer(junk)
    plain = tmp_path / "plain.pt"
    with open(plain, "wb") as fh:
        pickle.dump({"format": "other"}, fh)
    with pytest.raises(CheckpointError):
        load_localizer(plain)
    with pytest.raises(CheckpointError, match="no such file"):
        load_localizer(tmp_path / "missing.pt")


def test_plan_images_and_graph(setup):
    loc, sol, trace = setup["localizer"], setup["solution"], setup["trace"]
    rng = np.random.default_rng(3)
    start = image_for("xx-|-", SIZE, NOISE, rng)
    goal = image_for("-xx|-", SIZE, NOISE, rng)
    result = plan_images(loc, sol, start, goal)
    assert result.found and len(result.actions) == 2
    assert result.actions == ("pick_0", "place_2")
    # the graph from the solution file alone equals the trace-induced one
    g1, g2 = solution_graph(sol, trace.action_names), sol.graph(trace)
    assert set(g1.edges) == set(g2.edges)
    with pytest.raises(ImageError, match="expects 16x16"):
        plan_images(loc, sol, start[:8], goal)


def _plan(argv: list[str]) -> int:
    """Run ``vggc-cp plan ...`` through :func:`main` when the solver CLI registers ``plan``,
    else through the image-plan handler that ``plan`` dispatches to (same exit codes)."""
    from vggc_cp.cli import build_parser

    sub = next(a for a in build_parser()._actions if hasattr(a, "choices") and
               isinstance(a.choices, dict) and "evaluate" in a.choices)
    if "plan" in sub.choices:
        return main(["plan", *argv])
    import argparse
    import sys

    from vggc_cp.cli.options import add_image_plan_options
    from vggc_cp.cli.solve_cmds import cmd_image_plan

    parser = argparse.ArgumentParser()
    parser.add_argument("solution")
    add_image_plan_options(parser)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    try:
        return cmd_image_plan(args)
    except VggcError as exc:
        print(f"vggc-cp: error: {exc}", file=sys.stderr)
        return 2


def _png(path, img):
    write_image(path, img)
    return str(path)


def test_plan_cli_with_pngs(setup, tmp_path, capsys):
    root = setup["root"]
    rng = np.random.default_rng(5)
    a = _png(tmp_path / "a.png", image_for("x-x|-", SIZE, NOISE, rng))
    b = _png(tmp_path / "b.png", image_for("-x-|x", SIZE, NOISE, rng))
    np.testing.assert_array_equal(read_image(a).shape, (SIZE, SIZE, 3))
    rc = _plan([str(root / "sol.json"), "--model", str(root / "model.pt"),
               "--start", a, "--goal", b])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "confidence" in out and "pick_0" in out
    rc = _plan([str(root / "sol.json"), "--model", str(root / "model.pt"),
               "--start", a, "--goal", b, "--json"])
    data = json.loads(capsys.readouterr().out)
    assert data["found"] and len(data["actions"]) == 3  # x-x -> --x|x -> -xx -> -x-|x


def test_plan_cli_refuses_bad_images(setup, tmp_path, capsys):
    root = setup["root"]
    good = _png(tmp_path / "good.png", image_for("xx-|-", SIZE))
    big = _png(tmp_path / "big.png", np.zeros((SIZE * 2, SIZE * 2, 3), np.uint8))
    text = tmp_path / "notes.png"
    text.write_text("hello")
    base = [str(root / "sol.json"), "--model", str(root / "model.pt")]
    for start, name in ((big, "big.png"), (str(text), "notes.png"),
                        (str(tmp_path / "none.png"), "none.png")):
        rc = _plan(base + ["--start", start, "--goal", good])
        err = capsys.readouterr().err
        assert rc == 2
        assert name in err and len(err.strip().splitlines()) == 1
    rc = _plan(base + ["--start", good])
    assert rc == 2 and "--goal" in capsys.readouterr().err


def test_plan_refuses_model_of_another_solution(setup, tmp_path, capsys):
    root, trace = setup["root"], setup["trace"]
    other = np.arange(trace.n_obs)  # every observation its own node
    write_solution(tmp_path / "other.json", labels_solution(trace, other))
    good = _png(tmp_path / "g.png", image_for("xx-|-", SIZE))
    rc = _plan([str(tmp_path / "other.json"), "--model", str(root / "model.pt"),
               "--start", good, "--goal", good])
    assert rc == 2 and "trained on" in capsys.readouterr().err


def test_train_localizer_cli(setup, tmp_path, capsys):
    root = setup["root"]
    out = tmp_path / "m.pt"
    rc = main(["train-localizer", str(root / "trace.npz"), str(root / "sol.json"), "-o", str(out),
               "--input-size", "16", "--epochs", "2", "--lr", "3e-3", "--folds", "2",
               "--threads", "1", "--quiet"])
    assert rc == 0 and out.is_file()
    assert "train accuracy" in capsys.readouterr().out
    assert load_localizer(out).node_ids == setup["localizer"].node_ids
    rc = main(["train-localizer", str(root / "trace.npz"), str(root / "sol.json"), "-o", str(out),
               "--backbone", "resnet", "--quiet"])
    assert rc == 2 and "known: cnn, dinov2" in capsys.readouterr().err


def test_evaluate_cli_with_model_and_novel(setup, capsys):
    root = setup["root"]
    rc = main(["evaluate", str(root / "trace.npz"), str(root / "sol.json"), "--model",
               str(root / "model.pt"), "--novel", str(root / "novel.npz"), "--json", "-Q", "50"])
    assert rc == 0
    data = json.loads(capsys.readouterr().out)
    assert data["i2p"]["localization"] >= 0.95
    assert data["i2p"]["i2p"] >= 0.9 and data["i2p"]["exec_i2p"] >= 0.9
    assert data["i2p"]["queries"] == 150
    rc = main(["evaluate", str(root / "trace.npz"), str(root / "sol.json"), "--model",
               str(root / "model.pt"), "-Q", "5"])
    assert rc == 2 and "--novel" in capsys.readouterr().err


def test_i2p_metrics_by_hand():
    ep = ["A", "pick_0", "H", "place_1", "B", "pick_1", "H2", "place_0", "A"]
    trace = make_trace([ep], ("pick_0", "pick_1", "place_0", "place_1"))
    gt = GroundTruth.from_trace(trace)
    # merge H and H2 into node 5: A=1, B=2
    labels = np.array([1, 5, 2, 5, 1])
    graph = labels_solution(trace, labels)
    from vggc_cp.solution import Solution  # noqa: F401  (structure only)
    g = solution_graph(_read(graph), trace.action_names)
    cons = gt.consistent(labels)
    maj = majority_states(gt, labels)
    assert gt.state_names[maj[1]] == "A" and gt.state_names[maj[2]] == "B"
    plan = [(1, 0, 5), (5, 3, 2)]  # pick_0 then place_1: A -> H -> B
    assert plan_validates(plan, gt, cons)
    assert not plan_validates([(1, 0, 5), (5, 2, 1)], gt, cons)  # A -pick_0-> H -place_0-> ?
    a_id = gt.state_names.index("A")
    b_id = gt.state_names.index("B")
    assert execute_plan(plan, a_id, gt.observed_step) == b_id
    states = np.array(["A", "B", "H", "H2"])
    ids = np.array([gt.state_names.index(s) for s in states])
    q = sample_image_queries(gt, ids, 40, 0)
    assert q.shape == (40, 4) and np.all(q[:, 0] != q[:, 1])
    pred = np.array([1, 2, 5, 5])
    m = evaluate_i2p(g, labels, gt, pred, states, n_queries=40)
    # H and H2 share node 5 whose majority is H (tie -> smaller id): H2 images are wrong
    assert m.localization == pytest.approx(0.75)
    assert 0 < m.i2p < 1 and m.exec_i2p <= 1 and m.queries == 40


def _read(sol_dict):
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "s.json"
        write_solution(p, sol_dict)
        return read_solution(p)


def test_augment_is_seeded_and_bounded():
    x = torch.rand(4, 3, 16, 16)
    aug = Augment()
    a = aug(x, torch.Generator().manual_seed(1))
    b = aug(x, torch.Generator().manual_seed(1))
    assert torch.equal(a, b) and a.min() >= 0 and a.max() <= 1
    assert not torch.equal(a, x)


def test_unknown_backbone_and_bad_config():
    from vggc_cp.localize import TrainConfig

    with pytest.raises(VggcError, match="known"):
        from vggc_cp.localize.backbones import new_backbone
        new_backbone("vgg")
    with pytest.raises(VggcError):
        TrainConfig(folds=1)


def test_dinov2_backbone_with_a_tiny_random_checkpoint(setup, tmp_path):
    dinov2 = pytest.importorskip("vggc_cp.vision.dinov2")
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(0)
        vit = dinov2.DinoVisionTransformer(embed_dim=64, depth=2, num_heads=1, patch_size=14,
                                           pos_grid=2)
    weights = tmp_path / "tiny_dinov2.pth"
    torch.save(vit.state_dict(), weights)
    config = quick_config(backbone="dinov2", weights=str(weights), input_size=28,
                          epoch_grid=(2,), folds=2)  # one grid point: no cross-validation
    loc, report = train_localizer(setup["trace"], setup["solution"], config)
    net = loc.net
    # frozen except the last block and the final norm (and the head)
    trainable = {n for n, p in net.named_parameters() if p.requires_grad}
    assert trainable and all(n.startswith(("backbone.vit.blocks.1.", "backbone.vit.norm.",
                                           "head.")) for n in trainable)
    before = vit.state_dict()
    after = {k.removeprefix("backbone.vit."): v for k, v in net.state_dict().items()
             if k.startswith("backbone.vit.")}
    assert torch.equal(before["blocks.0.attn.qkv.weight"], after["blocks.0.attn.qkv.weight"])
    assert torch.equal(before["patch_embed.proj.weight"], after["patch_embed.proj.weight"])
    assert not torch.equal(before["blocks.1.mlp.fc1.weight"], after["blocks.1.mlp.fc1.weight"])
    assert loc.meta["training"]["weights_sha256"]
    path = tmp_path / "dino.pt"
    save_localizer(path, loc)
    back = load_localizer(path)  # no weights file needed to plan
    weights.unlink()
    a, b = loc.predict(setup["novel"]), back.predict(setup["novel"])
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_allclose(a.probabilities, b.probabilities, atol=1e-5)
    assert report.n_classes == len(loc.node_ids)


def test_shipped_model_localizes_the_shipped_novel_renders():
    from pathlib import Path

    from vggc_cp.evaluate.i2p import evaluate_localizer
    from vggc_cp.sim.novel import load_novel
    from vggc_cp.trace import load_trace

    root = Path(__file__).resolve().parents[2]
    model, sol = root / "models" / "fruit-2x3.pt", root / "models" / "fruit-2x3.solution.json"
    if not model.is_file() or not (root / "data" / "fruit-2x3.novel.npz").is_file():
        pytest.skip("shipped model or data absent")
    trace = load_trace(root / "data" / "fruit-2x3.npz")
    obs, states = load_novel(root / "data" / "fruit-2x3.novel.npz")
    m = evaluate_localizer(trace, read_solution(sol), load_localizer(model), obs, states,
                           n_queries=150, dynamics="trace")
    assert m.localization >= 0.95 and m.i2p >= 0.9 and m.exec_i2p >= 0.9


def test_choose_prefers_accuracy_then_fewer_epochs_then_larger_rate():
    from vggc_cp.localize.train import choose

    cv = ((1e-2, 10, 0.9), (1e-2, 20, 1.0), (3e-3, 20, 1.0), (3e-3, 40, 1.0))
    assert choose(cv) == (1e-2, 20)
    assert choose(((1e-2, 10, 0.5), (3e-3, 10, 0.7))) == (3e-3, 10)


def test_evaluate_reading_paper_takes_the_localizer_as_f(setup, capsys):
    root = setup["root"]
    args = ["evaluate", str(root / "trace.npz"), str(root / "sol.json"), "-Q", "200"]
    assert main(args + ["--reading", "paper", "--model", str(root / "model.pt"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    paper = out["paper_reading"]
    assert paper["assignment"] == "localizer" and "i2p" not in out
    # f agrees with the labels on every trace image except where the localizer errs
    pred = setup["localizer"].predict(setup["trace"].observations).nodes
    assert paper["agreement"] == pytest.approx(np.mean(pred == setup["solution"].labels))
    assert paper["agreement"] >= 0.95 and paper["any_path"] >= paper["opt_path"]
    # --model alone is still refused outside the paper reading (I2P needs --novel)
    assert main(args + ["--model", str(root / "model.pt")]) == 2
    assert "--novel" in capsys.readouterr().err


class _Counter:
    """Stands in for a tqdm bar: counts the epochs reported."""

    n = 0

    def update(self, k: int) -> None:
        self.n += k


@pytest.fixture
def scripted_training(monkeypatch):
    """Training that only reports its epochs, and a validation accuracy by learning rate."""
    from vggc_cp.localize import train

    accuracy = {}
    fitted = []

    def fake_fit(net, x, y, lr, epochs, config, seed, on_epoch=None):
        net.lr = lr
        fitted.append((lr, epochs))
        for epoch in range(1, epochs + 1):
            if on_epoch is not None and on_epoch(epoch):
                break

    monkeypatch.setattr(train, "_fit", fake_fit)
    monkeypatch.setattr(train, "_accuracy", lambda net, x, y: accuracy.get(net.lr, 0.5))
    return accuracy, fitted


def test_cross_validation_stops_once_a_setting_is_perfect(setup, scripted_training):
    from vggc_cp.localize.model import to_unit_tensor
    from vggc_cp.localize.train import cross_validate

    accuracy, fitted = scripted_training
    x = to_unit_tensor(setup["trace"].observations[:12], 16)
    y = torch.arange(12) % 3
    config = quick_config(input_size=16, learning_rates=(1e-2, 3e-3, 1e-3), epoch_grid=(6, 12))
    accuracy[3e-3] = 1.0  # the second rate validates perfectly on every fold
    bar = _Counter()
    cv = cross_validate(x, y, 3, config, bar)
    assert [(lr, e, acc) for lr, e, acc in cv] == [(1e-2, 6, 0.5), (1e-2, 12, 0.5),
                                                   (3e-3, 6, 1.0), (3e-3, 12, 1.0)]
    assert {lr for lr, _ in fitted} == {1e-2, 3e-3}  # 1e-3 never trained
    assert bar.n == 2 * 3 * 12  # the bar ends at its total: folds x rates x largest epochs
    # no setting perfect: every rate is tried, and the bar ends at the same total
    accuracy.clear()
    bar = _Counter()
    assert len(cross_validate(x, y, 3, config, bar)) == 6 and bar.n == 2 * 3 * 12


def test_train_localizer_cli_says_when_cross_validation_stopped_early(setup, scripted_training,
                                                                      tmp_path, capsys):
    accuracy, _ = scripted_training
    accuracy[3e-3] = 1.0
    root = setup["root"]
    rc = main(["train-localizer", str(root / "trace.npz"), str(root / "sol.json"), "-o",
               str(tmp_path / "m.pt"), "--input-size", "16", "--lr", "3e-3,1e-7", "--epochs",
               "6,12", "--folds", "2", "--threads", "1"])
    out = capsys.readouterr().out
    assert rc == 0 and "stopped early" in out and "not tried: lr 1e-07" in out
    assert "chosen         lr 0.003, 6 epochs" in out
    meta = json.loads(torch.load(tmp_path / "m.pt", weights_only=True)["meta"])
    assert meta["training"]["cv_untried"] == [1e-7]
