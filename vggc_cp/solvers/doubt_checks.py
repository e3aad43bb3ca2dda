"""Checks that flag a graph from its doubts (:mod:`vggc_cp.solvers.doubts`), beside the chance
of change of :mod:`vggc_cp.solvers.confidence`:

* :func:`corroborate` -- a doubt on nodes the re-runs changed whose flip the actions favour by
  more than 3 nats (the chance of change corroborated);
* :func:`doubt_forbidden` -- the images (within the chosen threshold) and the actions (by more
  than 3 nats) both favour joining two nodes that Exactly-One forbids (then another decision
  conflicts with them), or that the hands' colours forbid where one node is one render or two
  (a misread action colour makes such a node);
* :func:`doubt_readings` -- nodes that only an untrustworthy reading of the images sets apart
  (:func:`vggc_cp.solvers.read_doubts.read_doubts`).
"""

from __future__ import annotations

import math

import numpy as np

from vggc_cp.solvers.confidence import Confidence


def doubt_readings(conf: Confidence, doubts) -> Confidence:
    """``conf`` flagged when a doubt rests on an untrustworthy reading
    (:func:`vggc_cp.solvers.read_doubts.read_doubts`: its evidence has ``read_kappa``): two nodes
    that nothing the actions state sets apart, told apart only by what the images read at
    sites whose reading agrees with the stated frames less than substantially beyond
    chance. Re-runs and the description length cannot see it: both take the reading as
    given. The reason names the nodes, the sites and what to record.
    """
    read = [d for d in doubts if "read_kappa" in d.evidence]
    if not read:
        return conf
    d = read[0]
    ev = d.evidence
    more = f" (and {len(read) - 1} more such pair(s))" if len(read) > 1 else ""
    reason = (f"nodes {d.nodes[0]} and {d.nodes[1]} might be one state{more}: only the images' "
              f"reading at {', '.join(ev.get('read_sites', [])) or 'some site'} tells them "
              f"apart, and it agrees with the frames whose actions state it only "
              f"{ev['read_kappa']:.2f} beyond chance (kappa; 0.6 is substantial); record "
              f"episodes that act there from both nodes (`vggc-cp suggest SOLUTION TRACE -o "
              f"next.json`)")
    return conf.flagged(reason)


#: A node of at most this many observations is one render or two: what keeps it apart from
#: another node weighs more than the node's own evidence.
FEW_RENDERS = 2


def doubt_forbidden(conf: Confidence, doubts, labels: np.ndarray, max_nats: float = 3.0
                    ) -> Confidence:
    """``conf`` flagged when a constraint forbids a join that the images and the actions both
    favour: a merge doubt whose ``steps`` is at most 0 (the images put the two nodes within
    the chosen threshold) and whose flip shortens the description length by more than
    ``max_nats`` (``dl_nats``; odds of 20 to 1 for 3), while

    * Exactly-One forbids it (``forbidden == "exactly_one"``): the join would put two labels
      between one ordered pair of nodes, so some *other* decision of the graph conflicts with
      what the images and the actions say here; or
    * the hands' colours forbid it (``"hand"``) and one of the two nodes has at most
      :data:`FEW_RENDERS` observations: the hand's colour is itself read from the images
      (the colour of the objects an action moves), and one misread action colour can make
      such a node. (Two well-rendered nodes whose hands hold different colours are usually
      two states that look alike: not flagged.)

    The reason names the nodes and what to record.

    >>> from vggc_cp.solvers.doubts import Doubt
    >>> c = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    >>> d = Doubt("merge", (0, 1), ((0, 2), (3,)), {"forbidden": "hand", "steps": -0.5,
    ...                                             "dl_nats": -15.0})
    >>> doubt_forbidden(c, [d], np.array([0, 2, 0, 1])).suspect
    True
    >>> doubt_forbidden(c, [d], np.array([0, 0, 0, 1, 1, 1])).suspect   # three renders each
    False
    """
    labels = np.asarray(labels)
    for d in doubts:
        ev = d.evidence
        steps, nats, why = ev.get("steps"), ev.get("dl_nats"), ev.get("forbidden")
        if d.kind != "merge" or why not in ("exactly_one", "hand") or \
                not isinstance(steps, (int, float)) or steps > 0 or \
                not isinstance(nats, (int, float)) or nats >= -max_nats:
            continue
        a, b = d.nodes
        if why == "exactly_one":
            reason = (f"nodes {a} and {b} look alike (within the threshold) and the actions "
                      f"favour one node by {-nats:.1f} nats, but Exactly-One forbids the join: "
                      f"another decision of the graph conflicts with them")
        else:
            sizes = [int(np.sum(labels == u)) for u in d.nodes]
            if min(sizes) > FEW_RENDERS:
                continue
            small, other = (a, b) if sizes[0] <= sizes[1] else (b, a)
            reason = (f"node {small} ({min(sizes)} observation(s)) is kept apart from node "
                      f"{other} only by the colour its hand is read to hold: the images put "
                      f"them within the threshold and the actions favour one node by "
                      f"{-nats:.1f} nats; an action's colour may be misread")
        reason += ("; `vggc-cp doubts SOLUTION TRACE -o doubts.png` shows it and `vggc-cp "
                   "suggest SOLUTION TRACE -o next.json` the episodes to record next")
        return conf.flagged(reason)
    return conf


def corroborate(conf: Confidence, doubts, max_nats: float = 3.0) -> Confidence:
    """``conf`` flagged also when a decision that the re-runs changed is one the trace's
    actions reject: a doubt (:mod:`vggc_cp.solvers.doubts`) on unstable nodes whose flip
    shortens the description length by more than ``max_nats`` (a Bayes factor above
    ``exp(max_nats)``, 20 for 3 nats: "strong" evidence, Kass and Raftery 1995).

    The two readings are independent: the re-runs test the images and the constraints on
    less of the recording, the description length the actions of all of it. Either alone
    is common on right graphs of few episodes; both on one decision is not.
    """
    unstable = set(conf.unstable)
    if not unstable:
        return conf
    for d in doubts:
        nats = d.evidence.get("dl_nats")
        if not isinstance(nats, (int, float)) or nats >= -max_nats:
            continue
        if not unstable.intersection(int(u) for u in d.nodes):
            continue
        what = ("nodes {} and {} might be one state".format(*d.nodes) if d.kind == "merge"
                else f"node {d.nodes[0]} might be two states")
        reason = (f"{what}: re-runs change {'them' if d.kind == 'merge' else 'it'} and the "
                  f"actions favour that by {-nats:.1f} nats (odds {math.exp(min(-nats, 50)):.0f} "
                  f"to 1); `vggc-cp doubts SOLUTION TRACE -o doubts.png` shows it and "
                  f"`vggc-cp suggest SOLUTION TRACE -o next.json` the episodes to record next")
        return conf.flagged(reason)
    return conf
