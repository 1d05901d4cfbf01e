"""Gain tuning of the bilateral pair: an objective built on offline sessions, a bounded search,
a robustness check.

    from telethermo.tuning import Objective, tuning_scenes, tune, gains_document
    obj = Objective(tuning_scenes("probe_touches_al_steel_wood"))      # nominal + a perturbed variant
    res = tune(obj, budget=60, method="nelder-mead", seed=0)           # search, then robust selection
    res.best.gains        # {"master.kp_A_per_C": ..., ...}
    gains_document(res, obj)   # the gains file (telethermo.control.gainsfile reads it; docs/tuning.md)

One module per concept:

- :mod:`~telethermo.tuning.space`: the searched gains and their bounds (:class:`GainSpec`,
  :data:`DEFAULT_SPACE`)
- :mod:`~telethermo.tuning.scenes`: the tuning scenes: the scene and its perturbed variant (the only
  ``sim`` user)
- :mod:`~telethermo.tuning.objective`: J(gains) from offline sessions (:class:`Objective`,
  :func:`score_figures`)
- :mod:`~telethermo.tuning.search`: the bounded search with stress corners (:func:`search`)
- :mod:`~telethermo.tuning.robust`: the ±rel box check and the robust choice (:func:`tune`)
- :mod:`~telethermo.tuning.document`: the gains file of a run (:func:`gains_document`) and its full record
  (:func:`run_record`)

The gains-file format itself (read, validate, write) lives in :mod:`telethermo.control.gainsfile`,
which the nodes import; it is re-exported here. The tuner sits above the control core and the offline
session (it runs sessions); the control package never imports it.

Pure: no wall clock, no files (except :func:`write_gains` / :func:`load_gains`), deterministic for
a seed (the sessions' sensor noise is seeded, the optimisers are seeded).
"""

from telethermo.control.gainsfile import GAIN_FIELDS, GAINS_FORMAT, load_gains, parse_gains, write_gains
from telethermo.tuning.document import gains_document, run_record, sensitivity_rows
from telethermo.tuning.objective import (
    MARGIN_GOAL_C,
    UNSTABLE_J,
    Evaluation,
    Objective,
    Weights,
    score_figures,
)
from telethermo.tuning.robust import Robustness, TuneResult, box_points, distinct_best, robustness, tune
from telethermo.tuning.scenes import perturbed_scene, tuning_scenes
from telethermo.tuning.search import SearchPoint, SearchResult, search, stress_corners
from telethermo.tuning.space import DEFAULT_SPACE, GainSpec, clip_gains, default_gains

__all__ = [
    "GAIN_FIELDS",
    "GAINS_FORMAT",
    "load_gains",
    "parse_gains",
    "write_gains",
    "gains_document",
    "run_record",
    "sensitivity_rows",
    "MARGIN_GOAL_C",
    "UNSTABLE_J",
    "Evaluation",
    "Objective",
    "Weights",
    "score_figures",
    "Robustness",
    "TuneResult",
    "box_points",
    "distinct_best",
    "robustness",
    "tune",
    "perturbed_scene",
    "tuning_scenes",
    "SearchPoint",
    "SearchResult",
    "search",
    "stress_corners",
    "DEFAULT_SPACE",
    "GainSpec",
    "clip_gains",
    "default_gains",
]
