"""What the footprints tell the solver each site holds (beyond the paper).

:func:`~vggc_cp.vision.footprints.action_footprints` settles, for every taken action's site
and every observation, a presence and a colour, and says where the trace's actions state
them (``Footprints.stated``) and how far the images' reading can be trusted elsewhere
(``kappa``, ``trust``, ``trust_low``, ``stacked``). The solver reads them in two forms:
:func:`site_readings`, the stated symbols the description length codes
(:func:`vggc_cp.solvers.mdl.reading_length`), and :func:`site_reads`, what every site holds,
stated or read, with its trust (:class:`~vggc_cp.solvers.base.SiteReads`: the read cuts,
read doubts and episode doubts). Nothing here reads ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.vision.footprints import Footprints


def site_readings(fp: Footprints) -> np.ndarray:
    """What the actions state every taken site holds in every observation, as symbols,
    shape (N, S), int64.

    0 where the actions do not state it (``fp.stated``: the site is read from the images
    there, and an arm, a shaking camera or a covered slot may mislead the reading), 1 where
    the site is empty,
    ``2 + c`` where it holds an object of colour ``c``. Sites stated alike in every
    observation (the pick and place of one slot, the classes of one region) are kept once, so
    a place counts once however many actions act there
    (:func:`vggc_cp.solvers.mdl.reading_length`). All zeros without ``fp.stated``.

    >>> fp = Footprints(*[None] * 2, np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), None,
    ...                 np.ones((2, 3, 1)), np.zeros(3, np.int64), None, np.array([3, 2, 1]),
    ...                 stated=np.array([[True, True, True], [True, True, False]]))
    >>> site_readings(fp).tolist()                    # sites 0 and 1 state alike: one column
    [[1, 2], [0, 1]]
    """
    taken = fp.taken
    if fp.stated is None:
        return np.zeros((len(fp.presence), 1), dtype=np.int64)
    rows = np.where(fp.stated[:, taken], 1 + _held(fp), 0)
    return np.unique(rows.astype(np.int64), axis=1)


def site_reads(fp: Footprints) -> tuple[np.ndarray, ...] | None:
    """What every taken site holds in every observation, stated or read, and how far each
    site's reading can be trusted: ``(held, stated, kappa, action, trust, trust_low)`` of
    shapes (N, S), (N, S), (S,), (S,), (N, S), (N, S) (the fields of
    :class:`~vggc_cp.solvers.base.SiteReads`; ``trust`` None without ``fp.trust``,
    ``trust_low`` without ``fp.trust_low``) and ``stacked`` (shape (S,), None without
    ``fp.stacked``); None without ``fp.stated``.

    ``held`` is 0 where the site is empty and ``1 + c`` where it holds colour ``c``;
    ``stated`` where the actions state it (``fp.stated``); ``kappa`` is ``fp.kappa``;
    ``action`` the taken action of each site (``fp.taken``); ``trust`` is ``fp.trust``.

    >>> fp = Footprints(*[None] * 2, np.array([[1.0, 0.2], [0.0, 0.9]]), None,
    ...                 np.ones((2, 2, 1)), np.zeros(2, np.int64), None, np.array([3, 2]),
    ...                 stated=np.array([[True, False], [True, False]]),
    ...                 kappa=np.array([np.nan, 0.3]))
    >>> held, stated, kappa, action, trust, trust_low, stacked = site_reads(fp)
    >>> held.tolist(), stated.tolist(), kappa.tolist(), trust
    ([[1, 0], [0, 1]], [[True, False], [True, False]], [nan, 0.3], None)
    """
    if fp.stated is None:
        return None
    taken = fp.taken
    kappa = (np.full(len(taken), np.nan) if fp.kappa is None
             else np.asarray(fp.kappa, dtype=np.float64)[taken])
    trust = None if fp.trust is None else np.asarray(fp.trust, dtype=np.float64)[:, taken]
    low = (None if fp.trust_low is None
           else np.asarray(fp.trust_low, dtype=np.float64)[:, taken])
    stacked = None if fp.stacked is None else np.asarray(fp.stacked, dtype=bool)[taken]
    return (_held(fp), fp.stated[:, taken].copy(), kappa, taken.astype(np.int64), trust, low,
            stacked)


def _held(fp: Footprints) -> np.ndarray:
    """What every taken site holds in every observation as the settled presence and colour
    say: 0 empty, ``1 + c`` colour ``c``; int64 shape (N, S)."""
    taken = fp.taken
    held = (fp.presence[:, taken] >= 0.5) * (1 + fp.posterior[:, taken].argmax(axis=-1))
    return held.astype(np.int64)
