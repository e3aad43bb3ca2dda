"""The ground-truth graph G* of a trace. The only module that reads a trace's ``states``.

G* has one node per distinct ground-truth state and one edge ``(s, a, s')`` per distinct
observed transition. A learned node ``u`` is *consistent* with a state ``s`` when some
observation labelled ``u`` has state ``s``; ``C(u)`` denotes that set (the paper's notion).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.trace import Trace

# step(state_id, action) -> next state id, or None when the action is invalid there
StepFn = Callable[[int, int], "int | None"]


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """G* of a trace, with states numbered ``0..S-1``.

    Attributes
    ----------
    state_names : tuple of str, length S
    obs_state : ndarray of int64, shape (N,)
        State id of every observation.
    edges : frozenset of (s, a, s')
        Observed ground-truth transitions.
    succ : dict[(s, a), frozenset of s']
        ``edges`` indexed by source state and action.
    adjacency : dict[s, frozenset of s']
        Successor states of every state, any action.
    """

    state_names: tuple[str, ...]
    obs_state: np.ndarray
    edges: frozenset
    succ: dict
    adjacency: dict

    @classmethod
    def from_trace(cls, trace: Trace) -> GroundTruth:
        if trace.states is None:
            raise VggcError("the trace has no ground-truth 'states'; evaluation needs them")
        names, obs_state = np.unique(trace.states, return_inverse=True)
        obs_state = obs_state.astype(np.int64).reshape(-1)
        src, act, dst = trace.transitions()
        triples = {(int(obs_state[s]), int(a), int(obs_state[d])) for s, a, d in zip(src, act, dst)}
        succ: dict[tuple[int, int], set[int]] = {}
        adjacency: dict[int, set[int]] = {}
        for s, a, d in triples:
            succ.setdefault((s, a), set()).add(d)
            adjacency.setdefault(s, set()).add(d)
        return cls(tuple(str(x) for x in names), obs_state, frozenset(triples),
                   {k: frozenset(v) for k, v in succ.items()},
                   {k: frozenset(v) for k, v in adjacency.items()})

    @property
    def n_states(self) -> int:
        return len(self.state_names)

    @property
    def n_edges(self) -> int:
        return len(self.edges)

    def observations_of(self) -> list[np.ndarray]:
        """Observation indices of every state (list indexed by state id)."""
        order = np.argsort(self.obs_state, kind="stable")
        bounds = np.searchsorted(self.obs_state[order], np.arange(self.n_states + 1))
        return [order[bounds[s]:bounds[s + 1]] for s in range(self.n_states)]

    def consistent(self, labels: np.ndarray) -> dict[int, frozenset]:
        """``C(u)``: the states consistent with every node of a labelling."""
        out: dict[int, set[int]] = {}
        for u, s in zip(np.asarray(labels).tolist(), self.obs_state.tolist()):
            out.setdefault(u, set()).add(s)
        return {u: frozenset(v) for u, v in out.items()}

    def reachable_from(self, state: int) -> set[int]:
        """States reachable from ``state`` in G* (``state`` included)."""
        seen = {state}
        stack = [state]
        while stack:
            s = stack.pop()
            for d in self.adjacency.get(s, ()):
                if d not in seen:
                    seen.add(d)
                    stack.append(d)
        return seen

    def observed_step(self, state: int, action: int) -> int | None:
        """The true transition as observed in the trace (None when never observed)."""
        nxt = self.succ.get((state, action))
        if not nxt:
            return None
        return min(nxt)  # ground truth is deterministic; min() only guards corrupt data

    def step_from_names(self, step: Callable[[str, str], str | None],
                        action_names: tuple[str, ...]) -> StepFn:
        """Wrap a simulator's ``step(state_key, action_name)`` as a :data:`StepFn` on ids.

        States the simulator reaches that the trace never visited get fresh ids ``>= S``.
        """
        index = {name: i for i, name in enumerate(self.state_names)}
        names = list(self.state_names)

        def step_ids(state: int, action: int) -> int | None:
            nxt = step(names[state], action_names[action])
            if nxt is None:
                return None
            if nxt not in index:
                index[nxt] = len(names)
                names.append(nxt)
            return index[nxt]

        return step_ids
