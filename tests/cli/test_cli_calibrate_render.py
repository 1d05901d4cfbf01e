"""calibrate-render-table: each material's β from direct touches (eq. 1 inverted), written as a table that
keeps the shipped materials, their order (= object-dictionary codes) and the entries it did not measure."""

from __future__ import annotations

import pytest

from telethermo.cli.main import EXIT_OK, EXIT_USAGE
from telethermo.control.render_table import DEFAULT_RENDER_TABLE, load_render_table


def contact_T(Tf0, To0, beta):
    """yamamoto eq. 1 with relative effusivities: the contact temperature of finger and object."""
    return (Tf0 + beta * To0) / (1 + beta)


def test_touches_give_each_material_its_beta_and_the_rest_of_the_table_is_kept(cli, tmp_path):
    out = tmp_path / "me.toml"
    touches = [("wood", 33.9, 12.5, 0.36), ("wood", 34.1, 42.5, 0.40), ("eps", 33.9, 12.5, 0.0175)]
    argv = [a for m, f, o, b in touches for a in ("--touch", f"{m}:{f}:{o}:{contact_T(f, o, b)!r}")]
    code, text, err = cli("calibrate-render-table", *argv, "--out", str(out))
    assert code == EXIT_OK, err
    mine, shipped = load_render_table(out), load_render_table(DEFAULT_RENDER_TABLE)
    assert list(mine) == list(shipped)  # same materials in the same order: the codes keep their meaning
    assert mine["wood"] == pytest.approx(0.38, rel=1e-9)  # the mean of its two touches
    assert mine["eps"] == pytest.approx(0.0175, rel=1e-9)
    assert {k: v for k, v in mine.items() if k not in ("wood", "eps")} == {
        k: v for k, v in shipped.items() if k not in ("wood", "eps")
    }
    assert "wood" in text and "was 0.74" in text and str(out) in text


@pytest.mark.parametrize(
    "touch, says",
    [
        ("wood:33.9:12.5", "expected MATERIAL:T_FINGER0:T_OBJECT:T_CONTACT"),
        ("wod:33.9:12.5:25", "unknown material 'wod'"),
        ("wood:33.9:12.5:35", "strictly between the initial temperatures"),  # a contact beyond the finger
        ("wood:33.9:x:25", "expected MATERIAL:T_FINGER0:T_OBJECT:T_CONTACT"),
    ],
)
def test_a_bad_touch_is_refused_by_name_and_nothing_is_written(cli, tmp_path, touch, says):
    out = tmp_path / "me.toml"
    code, _, err = cli(
        "calibrate-render-table", "--touch", "eps:33.9:12.5:33.4", "--touch", touch, "--out", str(out)
    )
    assert code == EXIT_USAGE and f"--touch {touch!r}" in err and says in err and "Traceback" not in err
    assert not out.exists()
