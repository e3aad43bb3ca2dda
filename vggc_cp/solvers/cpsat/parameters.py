"""CP-SAT options of a cell: :class:`CpSatConfig` and the one ``--cpsat-params`` string."""

from __future__ import annotations

from dataclasses import dataclass

from vggc_cp.errors import VggcError
from vggc_cp.solvers.brute import CellConstraints

OBJECTIVES = ("J", "none")
HINTS = ("greedy", "none")
DEFAULT_PARAMS = "max_time_in_seconds:10,num_workers:2"


def parse_cpsat_params(text: str | None) -> str:
    """Validate a ``--cpsat-params`` string and return it as protobuf text format.

    Parameters
    ----------
    text : str or None
        Comma- or newline-separated ``field:value`` items of OR-Tools' ``SatParameters``,
        e.g. ``"max_time_in_seconds:30,num_workers:2"``.

    Raises
    ------
    VggcError
        Naming the offending item (unknown field, bad value).
    """
    if not text or not text.strip():
        return ""
    from google.protobuf import text_format
    from ortools.sat import sat_parameters_pb2

    msg = sat_parameters_pb2.SatParameters()
    items = [s.strip() for chunk in text.split("\n") for s in chunk.split(",")]
    for item in items:
        if not item:
            continue
        try:
            text_format.Merge(item, msg)
        except text_format.ParseError as exc:
            raise VggcError(f"--cpsat-params: cannot parse {item!r}: {exc}") from None
    return text_format.MessageToString(msg)


@dataclass(frozen=True)
class CpSatConfig:
    r"""Everything that shapes the CP-SAT model of a cell and its solve.

    Attributes
    ----------
    objective : {'J', 'none'}
        Minimize the quantized visual score, or decide feasibility only.
    deterministic : bool
    max_actions : int or None
    params : str
        CP-SAT parameters (``--cpsat-params`` syntax), merged over :data:`DEFAULT_PARAMS`.
    max_pair_terms : int
        Above this many pair variables the objective is dropped (feasibility only).
    hint : {'greedy', 'none'}
        Warm start from the greedy solver of the same cell.
    symmetry : bool
        Value-precedence symmetry breaking (and the conflict clique).
    codeterministic : bool
        One action into a node comes from one node: :math:`\sum_{c} y_{c,c',a} \le 1`.
    cannot_link : float or None
        Two observations of one role farther apart than this (visual distance) never share a
        colour: :math:`x_{o,c} + x_{o',c} \le 1`.
    enumerate_limit : int
        With objective ``J``, first enumerate the cell's valid colourings (up to renaming) and
        keep the lowest float J when there are at most this many; 0 disables, and so does
        ``symmetry=False`` (:mod:`vggc_cp.solvers.cpsat.enumeration`).
    """

    objective: str = "J"
    deterministic: bool = False
    max_actions: int | None = None
    params: str = ""
    max_pair_terms: int = 300_000
    hint: str = "greedy"
    symmetry: bool = True
    enumerate_limit: int = 20_000
    codeterministic: bool = False
    cannot_link: float | None = None

    def __post_init__(self):
        if self.objective not in OBJECTIVES:
            raise VggcError(f"unknown objective {self.objective!r}; known: {', '.join(OBJECTIVES)}")
        if self.hint not in HINTS:
            raise VggcError(f"unknown hint {self.hint!r}; known: {', '.join(HINTS)}")
        if self.enumerate_limit < 0:
            raise VggcError(f"enumerate_limit must be >= 0, got {self.enumerate_limit}")
        self.constraints  # noqa: B018  (validates max_actions and cannot_link)

    @property
    def constraints(self) -> CellConstraints:
        return CellConstraints(self.deterministic, self.max_actions, self.codeterministic,
                               self.cannot_link)

    def sat_parameters_text(self) -> str:
        """Default parameters with the user's merged over them, as protobuf text."""
        from google.protobuf import text_format
        from ortools.sat import sat_parameters_pb2

        msg = sat_parameters_pb2.SatParameters()
        text_format.Merge(parse_cpsat_params(DEFAULT_PARAMS), msg)
        text_format.Merge(parse_cpsat_params(self.params), msg)
        return text_format.MessageToString(msg)
