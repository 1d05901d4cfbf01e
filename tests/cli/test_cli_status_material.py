"""``telethermo status`` shows the slave's identified material (issue 15) by its code and its name in the
rendering table, and the master's link-fallback flag; read from real devices on a virtual bus."""
from __future__ import annotations

from telethermo.control.rendering import load_render_table


def test_status_names_the_identified_material(nodes, cli):
    names = list(load_render_table())
    nodes.devices["slave"].write(0x2610, names.index("brass") + 1, check=False)   # as the node writes it
    code, out, err = cli("status", "slave", *nodes.bus, "--timeout", "1")
    assert code == 0, err
    assert f"material (id)   {names.index('brass') + 1} (brass)" in out
    code, out, err = cli("status", "master", *nodes.bus, "--timeout", "1")
    assert "material (id)   0 (none)" in out and "link fallback" in out
