"""Studies that run the default pipeline end to end over many traces (above
:mod:`vggc_cp.evaluate`: they may import the pipeline, the evaluation and the simulator; only
the command line imports them).

* :mod:`vggc_cp.experiments.robustness` -- the default ``vggc-cp solve`` on every benchmark,
  seed and look, with a pass rule and the calibration of its warning.
* :mod:`vggc_cp.experiments.settle` -- on a robustness study's misses and warned runs, whether
  the episodes ``vggc-cp suggest`` proposes settle the graph, against as many random
  transitions.
"""
