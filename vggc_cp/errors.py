"""Exceptions that the command line turns into one line on stderr and exit code 2."""

from __future__ import annotations


class VggcError(Exception):
    """Base class of every user-facing error (bad input, bad option, bad file).

    The CLI prints ``str(error)`` on one line and exits with code 2; no traceback.
    """


class TraceError(VggcError):
    """A trace file is missing, unreadable or violates ``FORMATS.md``."""


class SolutionError(VggcError):
    """A solution JSON is unreadable or inconsistent with its trace."""


class UnknownNameError(VggcError):
    """A registry lookup with a name that is not registered."""


class EvidenceNotApplicable(VggcError):
    """A visual evidence cannot read this trace (e.g. no action changes the images in one place
    of its own, or the images are smaller than an attention grid).

    The only error that :func:`vggc_cp.pipeline.learn_graph` passes over when it tries the
    next evidence under ``evidence="auto"``; every other error propagates.
    """


def lookup(registry: dict, name: str, family: str):
    """Return ``registry[name]`` or raise :class:`UnknownNameError` listing the known names."""
    try:
        return registry[name]
    except KeyError:
        known = ", ".join(sorted(registry))
        raise UnknownNameError(f"unknown {family} {name!r}; known: {known}") from None
