"""The verdict on a chosen graph: its doubtful decisions, and the checks they raise.

``(problem, path, labels, confidence) -> (confidence, doubts)``, one stage of the pipeline
(:func:`vggc_cp.pipeline.learn_graph` calls :func:`verdict` once, after the evidence is
chosen):

1. the decisions near the chosen threshold that neither the images nor the actions settle
   (:func:`~vggc_cp.solvers.doubts.find_doubts`); the graph is flagged where re-runs change
   one the actions reject (:func:`~vggc_cp.solvers.doubt_checks.corroborate`) or a
   constraint forbids a join the images and the actions both favour
   (:func:`~vggc_cp.solvers.doubt_checks.doubt_forbidden`);
2. node pairs only an untrustworthy reading of the images sets apart, and episodes only such
   a reading puts on their path (:mod:`vggc_cp.solvers.read_doubts`): flagged or noted
   (:func:`~vggc_cp.solvers.doubt_checks.doubt_readings`), listed before the others, pairs
   and episodes in turn;
3. nodes the readings read apart that a cut would keep deterministic but whose cut makes
   the code longer by less than ln 20 nats (:func:`~vggc_cp.solvers.read_splits.near_cuts`):
   flagged (:func:`~vggc_cp.solvers.doubt_checks.doubt_near_cuts`), each a split doubt
   (:func:`~vggc_cp.solvers.read_doubts.near_cut_doubts`), listed first;
4. episodes none of whose nodes another episode visits, beyond chance
   (:mod:`vggc_cp.solvers.lone_episodes`): flagged, each with the walk its actions take on
   the rest of the graph, listed first;
5. what the recording states (resets, refusals) and the graph breaks
   (:mod:`vggc_cp.solvers.broken_facts`): certain errors, flagged, listed first of all;
6. a graph warned or noted with no doubt yet: the decisions on the way to the runner-up
   graph (:func:`runner_up`), else the nodes held-out transitions dispute, else the nodes
   the runner-up splits or joins -- so that a warning always says what is doubtful.

Nothing here reads ground-truth states.
"""

from __future__ import annotations

import math
from dataclasses import replace
from itertools import zip_longest

import numpy as np

from vggc_cp.recorded import recorded_facts
from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.broken_facts import broken_facts, facts_check
from vggc_cp.solvers.coded import CodedProblem
from vggc_cp.solvers.confidence import Confidence
from vggc_cp.solvers.doubt_checks import (
    corroborate,
    doubt_forbidden,
    doubt_lone,
    doubt_lone_starts,
    doubt_near_cuts,
    doubt_readings,
)
from vggc_cp.solvers.doubts import (
    Doubt,
    DoubtRule,
    disputed_doubts,
    find_doubts,
    runner_up_doubts,
)
from vggc_cp.solvers.episodes import lone_episodes, lone_starts
from vggc_cp.solvers.lone_episodes import lone_doubts, lone_start_doubts
from vggc_cp.solvers.merge import ThresholdPath
from vggc_cp.solvers.read_doubts import (
    dense_problem,
    episode_doubts,
    near_cut_doubts,
    read_doubts,
)
from vggc_cp.solvers.read_splits import near_cuts
from vggc_cp.solvers.together import doubt_never_together, never_together, together_doubts
from vggc_cp.trace import Trace

#: Largest trace (observations) whose doubts are looked for on a problem of descriptor codes:
#: they read the within-role distance matrices, which such a problem builds for them.
DOUBTS_MAX_OBS = 8000


def _too_large(problem) -> bool:
    """A problem of descriptor codes too large to densify for its doubts
    (:data:`DOUBTS_MAX_OBS`)."""
    return isinstance(problem, CodedProblem) and problem.n_obs > DOUBTS_MAX_OBS


def _listed_first(found, doubts, listed: int) -> tuple:
    """``found`` ahead of the ``doubts`` about other node pairs, at most ``listed``."""
    named = {f.nodes for f in found}
    return (*found, *(d for d in doubts if d.nodes not in named))[:listed]


def runner_up(path: ThresholdPath, dls) -> int | None:
    """The graph the description-length margin of the selected one is measured to: the least
    description length (``dls``, one per graph of ``path``) among graphs of another size,
    the nearest on the path of equal ones; None when there is none.

    The runner-up is chosen in the code of the actions and stated facts; the margin to it
    also counts the readings that are surely right
    (:func:`~vggc_cp.solvers.mdl.sure_reading_gap`), not every trusted reading that chose
    among a tie (:func:`~vggc_cp.solvers.mdl.choice_lengths`): those break a tie but do not
    settle it (a run of frames read wrong at a well-read site is common under a robot's
    arm), so a graph they alone chose keeps the warning that the actions leave another size
    at least 1/20 as probable."""
    k = path.selected
    if k is None:
        return None
    size = path.results[k].n_nodes
    others = [j for j, r in enumerate(path.results) if r.n_nodes != size]
    return min(others, key=lambda j: (dls[j], abs(j - k))) if others else None


def graph_doubts(problem: Problem | CodedProblem, path: ThresholdPath, labels: np.ndarray,
                 dls=(), heldout=None, toward_runner_up: bool = False, disputed: bool = False,
                 differences: bool = False, read: bool = False, resets=(),
                 rule: DoubtRule | None = None) -> tuple[Doubt, ...]:
    """The doubts of the graph ``labels`` chosen on ``path``
    (:func:`~vggc_cp.solvers.doubts.find_doubts`); for a problem of descriptor codes, on its
    dense matrices up to :data:`DOUBTS_MAX_OBS` observations (none beyond: the matrices
    would cost what the codes save).

    With ``toward_runner_up``, the decisions between the chosen threshold and that of the
    runner-up graph (:func:`runner_up` on the description lengths ``dls``, the graph the
    margin is measured to): the window reaches it and the description length does not
    settle a decision (what questions the graph is that the two are nearly as probable).
    With ``disputed``, the node pairs that contradicted held-out transitions name
    (``heldout``, the confidence's :class:`~vggc_cp.solvers.heldout.HeldOut`;
    :func:`~vggc_cp.solvers.doubts.disputed_doubts`); with ``toward_runner_up`` and
    ``differences``, the nodes the runner-up graph splits or joins
    (:func:`~vggc_cp.solvers.doubts.runner_up_doubts`); with ``read``, the node pairs only an
    untrustworthy reading of the images sets apart
    (:func:`~vggc_cp.solvers.read_doubts.read_doubts`), then the episodes only such a reading
    puts on their path (:func:`~vggc_cp.solvers.read_doubts.episode_doubts`; ``resets``, the
    recording's, keep what they join together)."""
    if _too_large(problem):
        return ()
    if read:                    # a problem of codes: densified only if a doubt is found
        pairs = read_doubts(problem, path, labels, rule=rule)
        return (*pairs, *episode_doubts(problem, path, labels, rule=rule, resets=resets))
    problem = dense_problem(problem)
    if disputed:
        return () if heldout is None else disputed_doubts(problem, path, labels,
                                                          heldout.disputed)
    rule = None
    if toward_runner_up:
        if len(dls) != len(path.results):
            raise ValueError(f"graph_doubts: toward_runner_up needs dls, one description "
                             f"length per graph of the path ({len(path.results)}), got "
                             f"{len(dls)}")
        other = runner_up(path, dls)
        if other is None:
            return ()
        if differences:
            other_labels = path.results[other].labels
            return (() if other_labels is None else
                    runner_up_doubts(problem, path, labels, other_labels))
        rule = DoubtRule(window=max(DoubtRule().window, abs(other - path.selected)),
                         max_nats=math.inf)
    return find_doubts(problem, path, labels, rule=rule)


def verdict(problem: Problem | CodedProblem, path: ThresholdPath, labels: np.ndarray,
            confidence: Confidence, dls, trace: Trace | None = None
            ) -> tuple[Confidence, tuple[Doubt, ...]]:
    """The confidence of the graph ``labels`` chosen on ``path`` with the checks its doubts
    raise, and its doubts, most pressing first (module docstring, steps 1-6).

    Parameters
    ----------
    problem : Problem or CodedProblem
    path : ThresholdPath
        The merge path the graph was chosen on.
    labels : ndarray of int, shape (N,)
        The chosen graph's node of every observation.
    confidence : Confidence
        As the selection assessed it (:func:`vggc_cp.pipeline.assess_path`).
    dls : sequence of float
        Description length of every graph of ``path``.
    trace : Trace, optional
        The recording, for the facts it states (:func:`~vggc_cp.recorded.recorded_facts`).

    Returns
    -------
    confidence : Confidence
    doubts : tuple of Doubt
    """
    rule = DoubtRule()
    doubts = graph_doubts(problem, path, labels)
    conf = corroborate(confidence, doubts, rule.max_nats)
    conf = doubt_forbidden(conf, doubts, labels, rule.max_nats, problem)
    facts = recorded_facts(trace) if trace is not None else None
    # listed up to rule.listed (what suggest can propose episodes for); judged on the first
    # rule.limit pairs, on every episode for where the other episodes start, and on the first
    # rule.limit of the others for the plans they risk
    read = graph_doubts(problem, path, labels, read=True,
                        resets=facts.resets if facts else (),
                        rule=replace(rule, limit=rule.listed))
    if read:
        kinds = ([d for d in read if "episode" not in d.evidence],
                 [d for d in read if "episode" in d.evidence])
        # nodes (episodes) only an untrustworthy reading of the images sets apart (puts on
        # their path): flagged, or noted where the episodes would misplace few plans; first
        conf = doubt_readings(conf, (*kinds[0][:rule.limit], *kinds[1]), labels, problem,
                              rule.limit)
        pairs = {d.nodes for d in read}
        # the pairs and the episodes in turn, so that the list keeps some of each
        read = tuple(d for two in zip_longest(*kinds) for d in two if d is not None)
        doubts = (*read, *(d for d in doubts if d.nodes not in pairs))[:rule.listed]
    # nodes the readings read apart that keep together by less than ln 20 nats of code: the
    # recording does not settle them; flagged, listed first
    near = near_cuts(problem, labels)
    if near:
        conf = doubt_near_cuts(conf, near)
        if not _too_large(problem):
            found = near_cut_doubts(problem, path, labels, near, rule)
            doubts = _listed_first(found, doubts, rule.listed)
    # episodes that share no node with any other, beyond chance: their images may have been
    # read wrong throughout, which no bound on the readings sees; flagged, listed first
    lone = lone_episodes(problem, labels)
    if lone.doubtful:
        conf = doubt_lone(conf, lone)
        if not _too_large(problem):
            found = lone_doubts(problem, path, labels, lone)
            doubts = _listed_first(found, doubts, rule.listed)
    # episodes that start on nodes of their own and then join the graph, beyond chance:
    # their first images may have been read wrong (the arm where the last episode left it)
    starts = lone_starts(problem, labels)
    if starts.surprising:
        conf = doubt_lone_starts(conf, starts)
        if not _too_large(problem):
            found = lone_start_doubts(problem, path, labels, starts, rule)
            doubts = _listed_first(found, doubts, rule.listed)
    # two colours no observation shows together: one class seen two ways, maybe (objects are
    # conserved); flagged, the doubts as for any warning below
    apart = never_together(problem)
    if apart:
        conf = doubt_never_together(conf, apart)
        if not _too_large(problem):
            found = together_doubts(problem, path, labels, apart, rule)
            doubts = _listed_first(found, doubts, rule.listed)
    # what the recording states (resets, refusals) and the graph breaks: certain errors,
    # flagged and listed first
    if facts:
        broken = broken_facts(facts, trace.actions, trace.action_names, labels)
        if broken:
            conf = facts_check(conf, broken)
            doubts = (*broken, *doubts)[:max(rule.listed, len(broken))]
    # warned or noted (the re-runs change nodes) with no close call near t*: the decisions
    # on the way to the runner-up graph, so the verdict says what is doubtful
    asked = conf.suspect or bool(conf.notes)
    if asked and not doubts:
        # e.g. a graph of another size nearly as probable
        doubts = graph_doubts(problem, path, labels, dls, toward_runner_up=True)
    if asked and not doubts:
        # nor on the way to it: the nodes that held-out transitions dispute, else the nodes
        # the runner-up graph splits or joins
        doubts = (graph_doubts(problem, path, labels, heldout=conf.heldout, disputed=True)
                  or graph_doubts(problem, path, labels, dls, toward_runner_up=True,
                                  differences=True))
    return conf, tuple(doubts)


__all__ = ["DOUBTS_MAX_OBS", "graph_doubts", "runner_up", "verdict"]
