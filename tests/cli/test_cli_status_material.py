"""``telethermo status`` shows the slave's identified material (issue 15) by its code and its name in the
rendering table, and the master's link-fallback flag; read from real devices on a virtual bus."""

from __future__ import annotations

import json

from telethermo.control.rendering import load_render_table


def test_status_names_the_identified_material(nodes, cli):
    names = list(load_render_table())
    nodes.devices["slave"].write(0x2610, names.index("brass") + 1, check=False)  # as the node writes it
    code, out, err = cli("status", "slave", *nodes.bus, "--timeout", "1")
    assert code == 0, err
    assert f"material (id)   {names.index('brass') + 1} (brass)" in out
    code, out, err = cli("status", "master", *nodes.bus, "--timeout", "1")
    assert "material (id)   0 (none)" in out and "link fallback" in out


def test_status_shows_the_first_answer_and_the_refined_one(nodes, cli):
    """Issue 23: the first answer (0x261C, its posterior 0x261D) stays when identified_material takes the
    refined one; identified_stage (0x261E) says which one it holds."""
    names = list(load_render_table())
    dev = nodes.devices["slave"]
    glass, brass = names.index("glass") + 1, names.index("brass") + 1
    for index, value in ((0x2610, glass), (0x2613, 0.75), (0x261C, brass), (0x261D, 0.5), (0x261E, 2)):
        dev.write(index, value, check=False)  # as the node writes them
    code, out, err = cli("status", "slave", *nodes.bus, "--timeout", "1")
    assert code == 0, err
    assert f"material (id)   {names.index('glass') + 1} (glass)" in out
    assert "material stage  2 (refined)" in out and "posterior (id)  0.75" in out
    assert f"first answer    {brass} (brass)" in out and "first posterior 0.5" in out
    code, out, err = cli("status", "slave", *nodes.bus, "--timeout", "1", "--json")
    v = json.loads(out)["nodes"][0]["values"]
    assert (v["identified_stage"], v["identified_early_material"]) == (2, brass), v
