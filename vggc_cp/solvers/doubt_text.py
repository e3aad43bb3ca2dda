"""Doubts in words: the table ``solve`` prints and the captions of ``vggc-cp doubts``
(:mod:`vggc_cp.solvers.doubts` finds them)."""

from __future__ import annotations

from vggc_cp.solvers.doubts import MERGE, SPLIT, Doubt  # noqa: F401  (SPLIT: doctests)
from vggc_cp.solvers.read_doubts import bound_decided


def broken_fact_note(d: Doubt) -> str:
    """One line for a broken fact (:func:`vggc_cp.solvers.broken_facts.broken_facts`); empty for another doubt.

    >>> d = Doubt(MERGE, (3, 5), ((7,), (10,)), {"undo": ["pick_a", "place_a"], "via": 4,
    ...                                          "transitions": [[7, 8], [9, 10]]})
    >>> broken_fact_note(d)
    'pick_a takes observation 7 (node 3) to observation 8 (node 4) and place_a, which undoes it, takes observation 9 (node 4) to observation 10 (node 5): one state on two nodes, or two states on node 4'
    """
    ev = d.evidence or {}
    if isinstance(ev.get("reset"), list):
        a, b = ev["reset"]
        return (f"observation {b} was recorded from the state of observation {a}, "
                f"but they lie on nodes {d.nodes[1]} and {d.nodes[0]}")
    steps = ev.get("transitions")
    if isinstance(ev.get("undo"), list) and len(ev["undo"]) == 2 and isinstance(steps, list) \
            and [len(x) if isinstance(x, list) else 0 for x in steps] == [2, 2]:
        (a, b), ((o, o2), (p, p2)) = ev["undo"], steps
        return (f"{a} takes observation {o} (node {d.nodes[0]}) to observation {o2} (node "
                f"{ev.get('via')}) and {b}, which undoes it, takes observation {p} (node "
                f"{ev.get('via')}) to observation {p2} (node {d.nodes[1]}): one state on two "
                f"nodes, or two states on node {ev.get('via')}")
    if isinstance(ev.get("site"), list) and len(ev["site"]) == 2 and \
            [len(x) for x in d.observations] == [1, 1]:
        (a, b), ((o,), (p,)) = ev["site"], d.observations
        return (f"node {d.nodes[0]} takes {a} (observation {o}) and {b} (observation {p}), "
                f"two actions of one kind at one site, which a state offers once: two "
                f"states on node {d.nodes[0]}")
    if "refused" in ev:
        return (f"{ev['refused']} was refused at observation {ev.get('observation')}, but "
                f"node {d.nodes[0]} takes it (observation {d.observations[1][0]})")
    return ""


def doubt_caption(k: int, d: Doubt) -> str:
    """The caption of doubt ``k`` on the contact sheet (``vggc-cp doubts``): what is in
    question, then the evidence each way.

    >>> d = Doubt(SPLIT, (4,), ((7,), (2,)), {"refused": "pick_a", "observation": 7})
    >>> doubt_caption(0, d)
    '#0 split? node 4: side P | side Q; the graph breaks what the recording states: pick_a was refused at observation 7, but node 4 takes it (observation 2)'
    """
    ev = d.evidence
    what = (f"#{k} merge? nodes {d.nodes[0]} | {d.nodes[1]}" if d.kind == MERGE
            else f"#{k} split? node {d.nodes[0]}: side P | side Q")
    dist, thr = ev.get("distance"), ev.get("threshold")
    parts = [what]
    if isinstance(dist, (int, float)) and isinstance(thr, (int, float)) and thr:
        parts.append(f"distance {dist:.3g} = {dist / thr:.2f} x threshold")
    if isinstance(ev.get("dl_change"), (int, float)):
        parts.append(f"flip {ev['dl_change']:+.4f} nats/transition")
    if "thresholds_apart" in ev:
        parts.append(f"apart at {ev['thresholds_apart']}, together at "
                     f"{ev.get('thresholds_together')} thresholds")
    if ev.get("forbidden"):
        parts.append("the hands' colours forbid the join" if ev["forbidden"] == "hand"
                     else "an action refused in one is taken in the other"
                     if ev["forbidden"] == "refused" else "Exactly-One forbids the join")
    if isinstance(ev.get("read_kappa"), (int, float)):
        parts.append(f"only the reading at {', '.join(ev.get('read_sites', []))} sets them "
                     f"apart (kappa {_kappa(ev)})")
    if broken_fact_note(d):
        parts.append("the graph breaks what the recording states: " + broken_fact_note(d))
    return "; ".join(parts)


#: Rows of the doubts table ``vggc-cp solve`` prints (a solution lists more, up to
#: :attr:`~vggc_cp.solvers.doubts.DoubtRule.listed`).
SHOWN_DOUBTS = 10


def format_doubts(doubts, limit: int = SHOWN_DOUBTS) -> list[str]:
    """A short table of doubts (at most ``limit`` rows), one line each::

        #  kind   nodes     observations       distance/t*  steps  dl nats/tr  apart/together
    """
    if not doubts:
        return []
    lines = [f"{'#':>3}  {'kind':<5}  {'nodes':<9}  {'observations (each side)':<24}  "
             f"{'dist/t*':>7}  {'steps':>6}  {'dl/tr':>7}  {'apart/tog':>9}  note"]
    for k, d in enumerate(doubts[:limit]):
        ev = d.evidence
        nodes = "+".join(str(u) for u in d.nodes)
        obs = " | ".join(",".join(str(o) for o in side) for side in d.observations)
        ratio = ev.get("distance", 0.0) / ev["threshold"] if ev.get("threshold") else 0.0
        steps = ev.get("steps")
        note = ("the graph breaks it: " + broken_fact_note(d) if broken_fact_note(d) else
                f"read apart, the cut {ev['read_cut_nats']:.2f} nats longer: "
                f"{', '.join(ev.get('read_sites', []))}"
                if isinstance(ev.get("read_cut_nats"), (int, float)) else
                f"colours {ev['never_together'][0]} and {ev['never_together'][1]} are never "
                f"seen together: one class, maybe"
                if isinstance(ev.get("never_together"), list) and ev["never_together"] else
                "the hands hold different colours" if ev.get("forbidden") == "hand" else
                "an action refused in one is taken in the other" if ev.get("forbidden") == "refused"
                else
                "Exactly-One forbids" if ev.get("forbidden") else
                f"{ev['contradicted']} held-out transition(s) dispute it"
                if ev.get("contradicted") else
                "the runner-up graph decides it the other way" if ev.get("runner_up") else
                f"episode {ev['lone_episode'][0]}-{ev['lone_episode'][-1]} visits only nodes "
                f"of its own; no walk fits, node {ev.get('moved_to')} is the nearest"
                if isinstance(ev.get("lone_episode"), list) and ev["lone_episode"]
                and ev.get("nearest") else
                f"episode {ev['lone_episode'][0]}-{ev['lone_episode'][-1]} visits only nodes "
                f"of its own; might be the path from node {ev.get('moved_to')}"
                if isinstance(ev.get("lone_episode"), list) and ev["lone_episode"] else
                f"episode start {ev['lone_start'][0]}-{ev['lone_start'][-1]} is on nodes of its "
                f"own; node {ev.get('moved_to')} is the nearest"
                if isinstance(ev.get("lone_start"), list) and ev["lone_start"] else
                f"episode {ev['episode'][0]}-{ev['episode'][-1]} might start at node "
                f"{ev.get('moved_to')}, kappa {_kappa(ev)}: "
                f"{', '.join(ev.get('read_sites', []))}"
                if isinstance(ev.get("episode"), list) and ev["episode"]
                and isinstance(ev.get("read_kappa"), (int, float)) else
                f"only read apart, kappa {_kappa(ev)}: {', '.join(ev.get('read_sites', []))}"
                if isinstance(ev.get("read_kappa"), (int, float)) else "")
        lines.append(f"{k:>3}  {d.kind:<5}  {nodes:<9}  {obs[:24]:<24}  {ratio:>7.2f}  "
                     f"{'-' if steps is None else f'{steps:+.2f}':>6}  "
                     f"{ev.get('dl_change', 0.0):>+7.4f}  "
                     f"{ev.get('thresholds_apart', 0):>4}/{ev.get('thresholds_together', 0):<4}  "
                     f"{note}".rstrip())
    return lines


def _kappa(ev: dict) -> str:
    """A read doubt's kappa, with its 95 % lower bound where the bound, not the kappa, made
    the doubt.

    >>> _kappa({"read_kappa": 0.3, "read_kappa_low": 0.1}), _kappa({"read_kappa": 0.65, "read_kappa_low": 0.33})
    ('0.30', '0.65, >= 0.33')
    """
    if bound_decided(ev):
        return f"{ev['read_kappa']:.2f}, >= {ev['read_kappa_low']:.2f}"
    return f"{ev['read_kappa']:.2f}"
