"""Model files: round trip, atomic write, validation errors naming file, field and expectation,
object-dictionary transfer (telethermo.ident.odmodel, REAL32 vs REAL64)."""

import json

import numpy as np
import pytest

from telethermo.ident import (
    CapacityModel,
    FluxArma,
    ModelFileError,
    TemModel,
    default_model_path,
    load_model,
    odmodel,
    prbs,
    save_model,
)


def od_reader(entries, *, real32=False, **changed):
    """``read(index, sub)`` of a node's object dictionary holding ``entries`` (the REAL64 ones rounded to
    REAL32 with ``real32``; ``changed``: name -> value written over an entry)."""
    table = {
        (e.index, e.sub): changed.get(
            e.name, odmodel.round_real32(e.value) if real32 and e.kind == "f64" else e.value
        )
        for e in entries
    }
    return lambda index, sub: table[(index, sub)]


@pytest.fixture()
def tem(true_model):
    flux = FluxArma(
        c=[-0.5, 0.1],
        d=[2.0, -1.5, 0.1],
        e=[0.01, 0.0],
        g=[0.001, 0.0],
        h=[1e-4, 0.0],
        period_s=0.01,
        T_ref_C=25.0,
    )
    cap = CapacityModel(theta=[0.01, 0.36, -0.04, 2.3, 1.1], current_range_A=(-0.2, 0.3))
    return TemModel(temperature=true_model, flux=flux, capacity=cap, meta={"rig": "test", "seed": 1})


def test_round_trip_preserves_everything(tmp_path, tem):
    p = save_model(tmp_path / "m.json", tem)
    back = load_model(p, expect_period_s=0.01)
    assert np.array_equal(back.temperature.theta, tem.temperature.theta)
    assert back.temperature.orders == tem.temperature.orders and back.temperature.T_ref_C == 25.0
    assert back.temperature.current_range_A == (-1.5, 1.5)
    for k in "cdegh":
        assert np.array_equal(getattr(back.flux, k), getattr(tem.flux, k))
    assert np.array_equal(back.capacity.theta, tem.capacity.theta) and back.meta == tem.meta
    u = prbs(500, seed=1)
    assert np.array_equal(
        back.temperature.free_run(current_A=u, T0_C=25.0), tem.temperature.free_run(current_A=u, T0_C=25.0)
    )
    assert [f.name for f in tmp_path.iterdir()] == ["m.json"]  # no temporary left behind
    doc = json.loads(p.read_text())
    assert doc["format"] == "telethermo-tem-model" and doc["units"]["temperature"] == "degC"
    assert doc["temperature"]["columns"][:2] == ["T1", "T1*I1^1"]


def corrupt(tmp_path, tem, edit):
    doc = json.loads(save_model(tmp_path / "m.json", tem).read_text())
    edit(doc)
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(doc))
    return p


@pytest.mark.parametrize(
    "edit, field, words",
    [
        (lambda d: d["temperature"]["theta"].pop(), "temperature.theta", "8 finite numbers"),
        (lambda d: d["temperature"]["theta"].__setitem__(3, "x"), "temperature.theta[3]", "finite number"),
        (
            lambda d: d["temperature"]["orders"].__setitem__("n", 0),
            "temperature.orders.n",
            "integer in [1, 8]",
        ),
        (lambda d: d["temperature"].__setitem__("period_s", -0.01), "temperature.period_s", "positive"),
        (
            lambda d: d["temperature"].__setitem__("current_range_A", [1.0, -1.0]),
            "temperature.current_range_A",
            "min <= max",
        ),
        (lambda d: d["temperature"]["columns"].reverse(), "temperature.columns", "regressors"),
        (lambda d: d.__setitem__("format_version", 2), "format_version", "1"),
        (lambda d: d.__setitem__("format", "other"), "format", "telethermo-tem-model"),
        (lambda d: d["flux"].__setitem__("period_s", 0.02), "flux.period_s", "temperature model's period"),
        (lambda d: d["flux"]["e"].pop(), "flux.e", "all empty or all"),
        (lambda d: d["capacity"].__setitem__("theta", [1, 2]), "capacity.theta", "5 finite numbers"),
        (lambda d: d["temperature"].pop("T_ref_C"), "temperature.T_ref_C", "missing"),
        (
            lambda d: d["temperature"]["theta"].__setitem__(0, 1.7),
            "temperature.theta",
            "stable model",
        ),  # Σα > 1
    ],
)
def test_bad_files_are_refused_naming_the_field(tmp_path, tem, edit, field, words):
    p = corrupt(tmp_path, tem, edit)
    with pytest.raises(ModelFileError) as ei:
        load_model(p)
    err = ei.value
    assert err.field == field and str(p) in str(err) and words in str(err), str(err)


def test_unreadable_and_mismatched_files(tmp_path, tem):
    with pytest.raises(ModelFileError, match="no such file"):
        load_model(tmp_path / "missing.json")
    p = tmp_path / "trunc.json"
    p.write_text(save_model(tmp_path / "m.json", tem).read_text()[:200])
    with pytest.raises(ModelFileError, match="valid JSON"):
        load_model(p)
    p.write_text('{"format": "telethermo-tem-model", "format_version": 1, "temperature": {"theta": NaN}}')
    with pytest.raises(ModelFileError):
        load_model(p)
    with pytest.raises(ModelFileError, match="control period"):
        load_model(tmp_path / "m.json", expect_period_s=0.001)


def test_object_dictionary_transfer_survives_real32(true_model):
    entries = odmodel.model_entries(TemModel(temperature=true_model))
    assert len(entries) == len(odmodel.SCALARS) + true_model.orders.d
    back, _ = odmodel.model_from_od(od_reader(entries, real32=True))
    u = prbs(5000, amplitude_A=(0.1, 1.5), hold_samples=20, seed=4)
    a = true_model.free_run(current_A=u, T0_C=25.0)
    b = back.temperature.free_run(current_A=u, T0_C=25.0)
    assert np.max(np.abs(a - b)) < 1e-3  # REAL32 rounding of θ: < 1 mK
    with pytest.raises(ModelFileError, match="theta"):  # one coefficient fewer than the orders need
        odmodel.model_from_od(od_reader(entries, theta_len=true_model.orders.d - 1))
    with pytest.raises(ModelFileError, match="valid orders"):  # the orders' own check (UNSIGNED8 objects)
        odmodel.model_from_od(od_reader(entries, narma_n=0))


def test_shipped_model_loads_and_is_stable():
    tem = load_model(default_model_path(), expect_period_s=0.01)
    assert tem.flux is not None
    assert tem.temperature.metrics["heldout_free_run_max_C"] <= 0.1
    assert tem.meta["rig"] == "sim.free_pad_rig"


def test_shipped_model_needs_real64_in_the_object_dictionary():
    """The shipped model's AR coefficients cancel to ~2e-8 (heat-sink pole 0.9996 at 10 ms): REAL64
    transfer is exact; REAL32 rounding either makes it unstable (the transfer is then refused) or
    wrong by degrees (steady-state gain and free run)."""
    m = load_model(default_model_path()).temperature
    entries = odmodel.model_entries(TemModel(temperature=m))
    assert np.array_equal(odmodel.model_from_od(od_reader(entries))[0].temperature.theta, m.theta)
    try:
        b = odmodel.model_from_od(od_reader(entries, real32=True))[0].temperature
    except ModelFileError as exc:
        assert "REAL64" in str(exc)
        return
    u = np.r_[np.zeros(100), prbs(20000, amplitude_A=(0.1, 1.0), hold_samples=25, seed=5)]
    assert np.max(np.abs(m.free_run(current_A=u, T0_C=25.0) - b.free_run(current_A=u, T0_C=25.0))) > 1.0
