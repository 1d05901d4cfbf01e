"""Identification of TEM models from data (guiatni §2.2-3.4): pure numpy/scipy, no CAN.

- :mod:`~telethermo.ident.prbs`: PRBS excitation with variable amplitude.
- :mod:`~telethermo.ident.narma`: the NARMA temperature model (eq. 10/11), batch LS fit, one-step and
  free-run prediction, streaming predictor for a node.
- :mod:`~telethermo.ident.rls`: RLS with two forgetting factors, square-root form, constant-trace bound.
- :mod:`~telethermo.ident.flux`: heat-flux ARMA model (eq. 12).
- :mod:`~telethermo.ident.capacity`: steady-state capacity model (eq. 13).
- :mod:`~telethermo.ident.stability`: stability check of an identified model.
- :mod:`~telethermo.ident.modelfile`: model files (JSON).
- :mod:`~telethermo.ident.odmodel`: a model in a node's object dictionary (the one model <-> OD API).
- :mod:`~telethermo.ident.experiment`: the identification experiment on a rig; its settings in
  :mod:`~telethermo.ident.experiment_settings`.
- :mod:`~telethermo.ident.capacity_experiment`: the capacity experiment (steady states, eq. 13 fit).
"""

from telethermo.ident.capacity import CapacityModel, fit_capacity
from telethermo.ident.flux import FluxArma, fit_flux_arma
from telethermo.ident.modelfile import ModelFileError, TemModel, default_model_path, load_model, save_model
from telethermo.ident.narma import NarmaModel, NarmaOrders, NarmaPredictor, UnstableModelError
from telethermo.ident.narma_fit import fit_narma
from telethermo.ident.prbs import prbs
from telethermo.ident.rls import Rls, RlsHealth
from telethermo.ident.stability import StabilityReport, check_stability

__all__ = [
    "CapacityModel",
    "fit_capacity",
    "FluxArma",
    "fit_flux_arma",
    "ModelFileError",
    "TemModel",
    "default_model_path",
    "load_model",
    "save_model",
    "NarmaModel",
    "NarmaOrders",
    "NarmaPredictor",
    "UnstableModelError",
    "fit_narma",
    "prbs",
    "Rls",
    "RlsHealth",
    "StabilityReport",
    "check_stability",
]
