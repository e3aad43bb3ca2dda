"""Recordings in: one module per layout, each registered in :data:`IMPORTERS`.

=============  ================================================================
``images``     image files listed by a CSV/JSONL log (:mod:`.images`)
``video``      one video and a CSV/JSONL log of frame indices or times (:mod:`.video`)
``robomimic``  an HDF5 file in robomimic's layout (:mod:`.robomimic`)
``lerobot``    a LeRobot dataset folder, parquet + mp4 (:mod:`.lerobot`)
=============  ================================================================

Adding a layout: a module that calls :func:`~vggc_cp.importers.base.register_importer`, listed
imported below, and its test; ``vggc-cp import`` finds it in the registry. The
readers h5py, pyarrow and PyAV are imported only when a layout needs them
(``pip install -e '.[import]'``).

Example
-------
>>> from vggc_cp.importers import ImportConfig, import_recording
>>> trace = import_recording("images", ImportConfig(size=(64, 64)), log="log.csv")  # doctest: +SKIP
"""

from __future__ import annotations

# importing a layout's module registers it
from vggc_cp.importers import images, lerobot, robomimic, video  # noqa: F401
from vggc_cp.importers.base import (
    IMPORTERS,
    Argument,
    ImportConfig,
    Importer,
    get_importer,
    parse_size,
    read_label_map,
    register_importer,
)
from vggc_cp.trace import Trace

__all__ = ["IMPORTERS", "Argument", "ImportConfig", "Importer", "get_importer",
           "import_recording", "parse_size", "read_label_map", "register_importer"]


def import_recording(layout: str, config: ImportConfig | None = None, **arguments) -> Trace:
    """Read a recording of ``layout`` into a validated trace.

    Parameters
    ----------
    layout : str
        A name in :data:`IMPORTERS`: ``images``, ``video``, ``robomimic``, ``lerobot``.
    config : ImportConfig, optional
        ``--size`` and ``--map``; default: the recording's size, no label map.
    **arguments
        The layout's arguments by name: ``log=`` (images); ``video=``, ``log=`` (video);
        ``file=``, ``camera=``, ``labels=``, ``states=`` (robomimic); ``folder=``,
        ``camera=``, ``labels=``, ``states=`` (lerobot).

    Returns
    -------
    Trace
        ``observations`` uint8 (N, H, W, 3), ``actions`` int64 (N-1,), ``action_names``
        sorted, ``states`` (N,) when the recording has them, ``meta["source"]``.

    Raises
    ------
    VggcError
        Naming the file and the row, frame or dataset of the first problem.
    """
    importer = get_importer(layout)
    return importer.read(config or ImportConfig(), **arguments)
