"""The paper's published figures that our tables print beside ours (Table 1 of
Ajith and Chamzas, arXiv:2509.14460), by our metric and method names."""

from __future__ import annotations

PAPER_METRICS = ("opt_path", "any_path", "trans_prec", "trans_cov")
METRIC_TITLES = {"opt_path": "OptPath", "any_path": "AnyPath", "trans_prec": "TransPrec",
                 "trans_cov": "TransCov", "exec": "Exec"}
#: Methods of the paper's Table 1, by our method name.
PAPER_METHODS = {"greedy": "VGGC", "pca-hdbscan": "PCA-HDBSCAN", "lsr": "LSR"}
#: Published Table 1 values, ``(benchmark, method) -> {metric: fraction}``: the paper's main
#: results table (OptPath / AnyPath / TransPrec / TransCov, in %), as transcribed in the
#: project's shared PAPER-RESULTS.md. The paper reads these metrics its own way
#: (``vggc-cp evaluate --reading paper``, :mod:`vggc_cp.evaluate.paper_reading`).


def _row(opt_path: float, any_path: float, trans_prec: float, trans_cov: float
         ) -> dict[str, float]:
    return {"opt_path": opt_path / 100, "any_path": any_path / 100,
            "trans_prec": trans_prec / 100, "trans_cov": trans_cov / 100}


PAPER_TABLE1: dict[tuple[str, str], dict[str, float]] = {
    ("fruit-2x3", "greedy"): _row(100.0, 100.0, 100.0, 100.0),
    ("fruit-2x3", "pca-hdbscan"): _row(100.0, 100.0, 100.0, 100.0),
    ("fruit-2x3", "lsr"): _row(100.0, 100.0, 100.0, 100.0),
    ("multifruit-2x3", "greedy"): _row(66.0, 100.0, 83.3, 91.7),
    ("multifruit-2x3", "pca-hdbscan"): _row(32.0, 32.0, 55.3, 63.6),
    ("multifruit-2x3", "lsr"): _row(40.0, 70.0, 45.9, 77.3),
    ("blocks-2", "greedy"): _row(93.7, 100.0, 100.0, 90.0),
    ("blocks-2", "pca-hdbscan"): _row(16.1, 16.1, 42.9, 33.3),
    ("blocks-2", "lsr"): _row(76.7, 76.7, 100.0, 83.0),
    ("blocks-3", "greedy"): _row(72.0, 100.0, 77.8, 67.7),
    ("blocks-3", "pca-hdbscan"): _row(30.8, 32.5, 25.0, 40.5),
    ("blocks-3", "lsr"): _row(33.6, 60.7, 57.1, 69.4),
    ("fruit-4x6", "greedy"): _row(78.1, 99.1, 81.6, 85.8),
    ("fruit-4x6", "pca-hdbscan"): _row(33.4, 56.9, 58.6, 56.7),
    ("fruit-4x6", "lsr"): _row(37.5, 61.7, 50.0, 53.3),
    ("multifruit-4x6", "greedy"): _row(71.8, 98.2, 88.5, 81.6),
    ("multifruit-4x6", "pca-hdbscan"): _row(36.6, 88.9, 60.6, 57.4),
    ("multifruit-4x6", "lsr"): _row(12.0, 12.0, 23.5, 49.2),
    ("fruit-6x8", "greedy"): _row(64.8, 95.7, 72.9, 84.7),
    ("fruit-6x8", "pca-hdbscan"): _row(52.1, 84.1, 44.0, 56.9),
    ("fruit-6x8", "lsr"): _row(52.7, 88.9, 51.2, 65.2),
}
