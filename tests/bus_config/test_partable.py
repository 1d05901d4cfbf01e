"""The parameter table (bus_config/partable.py) is the one declaration of the operator parameters: the
checked-in EDS files (read by canopen's own parser), the generated docs page and the node's mapping to
CoreParams (nodes/odparams.py) all agree with it, row by row."""

from __future__ import annotations

import math

import canopen
import pytest

from telethermo.bus_config import edsgen, partable, path
from telethermo.bus_config.partable import PARAMS, ROLES
from telethermo.control.gain_fields import SDO_GAIN_FIELDS
from telethermo.control.params import default_params
from telethermo.control.rendering import load_render_table
from telethermo.control.coreparams import RenderSettings
from telethermo.control.types import Mode, Role
from telethermo.device.eds_info import EdsInfo
from telethermo.nodes.odparams import GAIN_KEYS, PARAM_KEYS, ParamBook, od_image


def test_the_docs_pages_and_eds_files_are_the_generated_ones():
    """docs/parameters.md, the table of docs/canopen.md and both EDS files are current (regenerate:
    python -m telethermo.bus_config.edsgen)."""
    assert partable.DOC.read_text(encoding="utf-8") == partable.markdown()
    assert edsgen.main(["--check"]) == 0


def test_the_check_sees_a_stale_docs_page_and_regenerates_it(tmp_path, monkeypatch, capsys):
    page, doc = tmp_path / "parameters.md", tmp_path / "canopen.md"
    page.write_text(partable.markdown().replace("proportional gain", "gain"), encoding="utf-8")
    doc.write_text(
        edsgen.CANOPEN_DOC.read_text(encoding="utf-8").replace("| kp_A_per_C |", "| kp |"), encoding="utf-8"
    )
    monkeypatch.setattr(partable, "DOC", page)
    monkeypatch.setattr(edsgen, "CANOPEN_DOC", doc)
    monkeypatch.setattr(edsgen, "_path", lambda name: tmp_path / name)
    assert edsgen.main(["--check"]) == 1
    err = capsys.readouterr().err
    assert all(str(tmp_path / f) in err for f in ("parameters.md", "canopen.md", "master.eds", "slave.eds"))
    assert edsgen.main([]) == 0 and edsgen.main(["--check"]) == 0
    assert page.read_text(encoding="utf-8") == partable.markdown()
    assert "| kp_A_per_C |" in doc.read_text(encoding="utf-8")


@pytest.mark.parametrize("role", ROLES)
def test_every_row_is_in_the_checked_in_eds_as_declared(role):
    """canopen's parser (not ours) for names, types, access, PDO flag, integer limits and units; EdsInfo
    for the REAL32 limits canopen drops; and the files are what edsgen writes today."""
    eds = path(f"{role}.eds")
    assert eds.read_text(encoding="ascii") == edsgen.render(role)  # stale: python -m ...bus_config.edsgen
    od = canopen.import_od(str(eds), edsgen.NODE_IDS[role])
    info = EdsInfo(eds)
    for p in PARAMS:
        var = od[p.index]
        assert isinstance(var, canopen.objectdictionary.ODVariable), p.name
        assert (var.name, var.data_type, var.access_type, var.pdo_mappable, var.unit) == (
            p.name,
            p.data_type,
            p.access,
            p.pdo,
            p.unit,
        ), p.name
        assert var.description == p.doc
        vi = info.get(p.name)
        lo, hi, default = (p.value(w, role) for w in ("low", "high", "default"))
        assert (vi.low, vi.high) == (lo, hi), p.name
        assert var.default == default, p.name


def test_the_table_names_each_object_once_and_the_sdo_gains():
    assert len({p.index for p in PARAMS}) == len({p.name for p in PARAMS}) == len(PARAMS)
    assert [p.index for p in PARAMS] == sorted(p.index for p in PARAMS)
    assert set(PARAM_KEYS) == {p.name for p in PARAMS}
    assert set(partable.DOCS) == set(PARAM_KEYS) and all(partable.DOCS.values())  # each row its doc line
    assert GAIN_KEYS == SDO_GAIN_FIELDS  # a per-mode gain object is named as its CoreParams field


def _params_for(role: Role):
    def params_for(mode, render=None):
        return (
            default_params(role, mode=mode, render=render)
            if render is not None
            else default_params(role, mode=mode)
        )

    return params_for


def _settable_on(p) -> str:
    """The role whose object can change the row's value: the master's unless its range is one value
    (a slave-side parameter such as osc_guard_C, fixed at 0 on the master)."""
    return "master" if p.value("low", "master") < p.value("high", "master") else "slave"


def _image(book: ParamBook) -> dict:
    rs = book.render_settings()
    return od_image(
        book.params(), rs, material_code=book.material_code(rs), peer_miss_limit=book.peer_miss_limit
    )


def _candidates(p, now, role):
    lo, hi = p.value("low", role), p.value("high", role)
    if p.is_real:
        return [c for c in (now * 0.9, now * 1.1, now - 0.5, now + 0.5, (lo + hi) / 2) if lo <= c <= hi]
    return [c for c in (int(now) + 1, int(now) - 1, int(now) + 2) if lo <= c <= hi]


@pytest.mark.parametrize("p", PARAMS, ids=lambda p: p.name)
def test_a_write_of_every_row_reaches_coreparams_and_shows_in_the_od_image(p):
    """For every row: a value the book accepts changes the parameters it builds and the OD image shows it
    back (the mapping object <-> CoreParams field is total and consistent). A row whose object has no
    mapping in nodes/odparams.py fails here."""
    table = load_render_table()
    role = Role(_settable_on(p))
    book = ParamBook(role, _params_for(role), has_model=True, table=table, od_material=(1, 0.4, 25.0))
    before = _image(book)
    assert set(before) == set(PARAM_KEYS)
    cands = _candidates(p, before[p.name], role.value)
    accepted = [c for c in cands if book.check(p.name, c) is None]
    assert accepted, f"{p.name}: none of {cands} accepted"
    value = accepted[0]
    params_before = book.params(Mode.RENDER if p.scope == partable.RENDER else None)
    book.apply(p.name, value)
    after = _image(book)
    assert math.isclose(after[p.name], value, rel_tol=1e-12), (p.name, value, after[p.name])
    if p.field and p.field[0] != "mode" and p.scope != partable.RENDER:
        assert book.params() != params_before, p.name
    changed = {k for k in after if k != p.name and after[k] != before[k]}
    # a material code sets beta and back; each mode has its own gains
    allowed = {"material_code", "material_beta"} | (set(GAIN_KEYS) if p.name == "mode" else set())
    assert changed <= allowed, (p.name, changed)


@pytest.mark.parametrize("role", ROLES)
def test_the_controller_defaults_lie_within_each_rows_range(role):
    """What a node shows at power-on (its controller's defaults through the mapping) is a value an SDO write
    could set back: inside every row's range, for the role's own range, in every mode the role runs."""
    modes = [m for m in Mode if role == "master" or m is not Mode.RENDER]
    rs = RenderSettings(beta_object=0.4, T_object0_C=25.0)
    for mode in modes:
        params = default_params(Role(role), mode=mode, **({"render": rs} if mode is Mode.RENDER else {}))
        img = od_image(params, rs, material_code=0, peer_miss_limit=10)
        for p in PARAMS:
            assert p.value("low", role) <= img[p.name] <= p.value("high", role), (role, mode.name, p.name)
