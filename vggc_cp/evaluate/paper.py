"""The paper's published figures that our tables print beside ours (Table 1 of
Ajith and Chamzas, arXiv:2509.14460), by our metric and method names."""

from __future__ import annotations

PAPER_METRICS = ("opt_path", "any_path", "trans_prec", "trans_cov")
METRIC_TITLES = {"opt_path": "OptPath", "any_path": "AnyPath", "trans_prec": "TransPrec",
                 "trans_cov": "TransCov", "exec": "Exec"}
#: Methods of the paper's Table 1, by our method name.
PAPER_METHODS = {"greedy": "VGGC", "pca-hdbscan": "PCA-HDBSCAN", "lsr": "LSR"}
#: Published Table 1 values, ``(benchmark, method) -> {metric: fraction}``. Only values checked
#: against the paper belong here; none could be checked when this was written, so every paper
#: cell prints ``n/a``.
PAPER_TABLE1: dict[tuple[str, str], dict[str, float]] = {}

