"""Fixtures of the identification tests: a known NARMA 'plant' with realistic thermal poles."""

from __future__ import annotations

import numpy as np
import pytest

from telethermo.ident.narma import NarmaModel, NarmaOrders

# A second-order NARMA model with the structure of a TEM pad (poles ~0.95 and ~0.66 at 10 ms, i.e.
# time constants ~0.2 s and ~0.025 s, current-dependent) and Joule heating (I² terms).
TRUE_ORDERS = NarmaOrders(n=2, m=2, p=1, q=1)
TRUE_THETA = np.array([1.6, 0.01, -0.62, -0.005, 0.05, 0.02, -0.03, 0.01])


@pytest.fixture()
def true_model() -> NarmaModel:
    return NarmaModel(
        orders=TRUE_ORDERS,
        theta=TRUE_THETA,
        period_s=0.01,
        T_ref_C=25.0,
        current_range_A=(-1.5, 1.5),
        T_range_C=(15.0, 43.0),
    )
