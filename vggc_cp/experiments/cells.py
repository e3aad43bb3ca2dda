"""Cached study rows checked before they are trusted (the cell files of ``vggc-cp robustness``
and ``vggc-cp benchmark``).

A cell file ``OUT/cells/<cell>.json`` holds ``{"key": ..., "trace_sha256": ..., "row": ...}``.
:func:`validate_cell` returns its row only when the file was made under the same settings
(``key``), from the very trace file now on disk (``trace_sha256``, the SHA-256 of its bytes),
and every field of the row has the type, range and finiteness the study writes. Anything else
is ``None``: the caller recomputes the cell (with a warning line when the file was damaged or
forged rather than merely made under other settings). A row written by hand with the right key
but no hash of the trace, or the row of another benchmark or seed, is therefore recomputed,
never reported.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

from vggc_cp.errors import VggcError

#: fields that are fractions in [0, 1] (None: not measured)
RATES = ("exec", "opt_path", "any_path", "trans_prec", "trans_cov", "localization", "i2p",
         "exec_i2p", "heldout_predicted", "heldout_contradicted", "p_change")
#: fields that are non-negative finite numbers (None: not measured)
NONNEGATIVE = ("nodes_ratio", "obs_per_state", "obs_per_node", "seconds_learn",
               "seconds_evaluate", "seconds_localizer")
#: fields that are finite numbers (None: none)
FINITE = ("threshold", "margin")
#: fields that are non-negative integers
COUNTS = ("transitions", "observations", "true_states", "nodes", "plateau", "runs", "changed",
          "doubts")
#: fields that are strings
TEXTS = ("benchmark", "look", "evidence", "reasons", "dynamics")
#: fields every robustness row has (the I2P ones only when measured)
REQUIRED = ("benchmark", "look", "seed", "transitions", "observations", "true_states", "nodes",
            "nodes_ratio", "exec", "opt_path", "any_path", "trans_prec", "trans_cov",
            "suspect")
#: fields of the row that must equal the key's (where the key has them)
FROM_KEY = ("benchmark", "look", "seed", "transitions", "method")
#: fields every Table-1 (``vggc-cp benchmark``) row has
TABLE1_REQUIRED = ("benchmark", "method", "seed", "transitions", "observations", "true_states",
                   "nodes", "status")


def file_sha256(path) -> str | None:
    """SHA-256 (hex) of the bytes of ``path``; None when it cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _is_number(x) -> bool:
    return (isinstance(x, (int, float)) and not isinstance(x, bool)
            and math.isfinite(float(x)))


def row_problem(row: dict, key: dict, required: tuple[str, ...] = REQUIRED) -> str | None:
    """What is wrong with ``row`` (naming the field), or None when it can be trusted;
    ``required``: the fields it must have (:data:`REQUIRED`, :data:`TABLE1_REQUIRED`)."""
    if not isinstance(row, dict):
        return "field 'row' is not an object"
    for f in required:
        if f not in row:
            return f"field 'row.{f}' is missing"
    for f in TEXTS:
        if f in row and not isinstance(row[f], str):
            return f"field 'row.{f}' is not a string"
    if not _is_int(row["seed"]) or row["seed"] < 0:
        return "field 'row.seed' is not a non-negative integer"
    for f in COUNTS:
        if f in row and not (_is_int(row[f]) and row[f] >= 0):
            return f"field 'row.{f}' is not a non-negative integer"
    for f in RATES:
        v = row.get(f)
        if v is not None and not (_is_number(v) and 0.0 <= float(v) <= 1.0):
            return f"field 'row.{f}' = {v!r} is not a fraction in [0, 1] or null"
    for f in NONNEGATIVE:
        v = row.get(f)
        if v is not None and not (_is_number(v) and float(v) >= 0.0):
            return f"field 'row.{f}' = {v!r} is not a finite non-negative number or null"
    for f in FINITE:
        v = row.get(f)
        if v is not None and not _is_number(v):
            return f"field 'row.{f}' = {v!r} is not a finite number or null"
    if "suspect" in row and not isinstance(row["suspect"], bool):
        return "field 'row.suspect' is not true or false"
    for f in FROM_KEY:
        if f in key and row.get(f) != key[f]:
            return f"field 'row.{f}' = {row.get(f)!r} is not the cell's {key[f]!r}"
    if row.get("nodes_ratio") is not None and row["true_states"] > 0 and not math.isclose(
            float(row["nodes_ratio"]), row["nodes"] / row["true_states"], rel_tol=1e-6):
        return "field 'row.nodes_ratio' is not nodes / true_states"
    if row["observations"] < 1 or row["true_states"] < 1:
        return "fields 'row.observations' and 'row.true_states' must be positive"
    return None


def validate_cell(record, key: dict, trace_sha: str | None, source: str = "cell",
                  required: tuple[str, ...] = REQUIRED) -> dict | None:
    """The row of the cell file ``record`` (parsed JSON) when it can be trusted, else None.

    Parameters
    ----------
    record : object
        The parsed cell file.
    key : dict
        The settings the cell must have been made under (a different key: None, silently).
    trace_sha : str or None
        SHA-256 of the cell's trace file now (None: no trace; the row cannot be trusted).
    source : str
        The file's name, for the warning.
    required : tuple of str
        The fields the row must have.

    Returns
    -------
    dict or None
        The row; None when the caller must recompute the cell (a damaged, forged or
        foreign row also prints one warning line).
    """
    from vggc_cp.safeio import warn

    if not isinstance(record, dict):
        warn(f"{source}: not a cell file (not a JSON object); ignored, recomputing")
        return None
    if record.get("key") != key:
        return None
    if trace_sha is None:
        return None
    if record.get("trace_sha256") != trace_sha:
        warn(f"{source}: field 'trace_sha256' does not match the cell's trace (a row of another "
             f"trace, or written by hand); ignored, recomputing")
        return None
    problem = row_problem(record.get("row"), key, required)
    if problem is not None:
        warn(f"{source}: {problem}; ignored, recomputing")
        return None
    return record["row"]


def read_cell(path: Path, key: dict, trace_path: Path, required: tuple[str, ...] = REQUIRED
              ) -> dict | None:
    """The trusted row of the cell file at ``path`` (:func:`validate_cell`), reading it with
    the JSON caps and refusing ``NaN``/``Infinity``; None when missing or untrusted."""
    from vggc_cp.safeio import NonFinite, read_json, warn

    if not Path(path).is_file():
        return None
    try:
        record = read_json(path, allow_nan=False)
    except VggcError as exc:
        warn(f"{exc}; ignored, recomputing")
        return None
    row = record.get("row") if isinstance(record, dict) else None
    if isinstance(row, dict) and any(isinstance(v, NonFinite) for v in row.values()):
        bad = next(k for k, v in row.items() if isinstance(v, NonFinite))
        warn(f"{path}: field 'row.{bad}' is {row[bad].text}; ignored, recomputing")
        return None
    return validate_cell(record, key, file_sha256(trace_path), str(path), required)
