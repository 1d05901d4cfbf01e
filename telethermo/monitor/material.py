"""The identified material as the bus shows it (issue 25: "monitor and status show the identified material
with its posterior, and "unknown" when it abstains").

The slave publishes ``identified_material`` (0x2610, the rendering table's 1-based code) and
``identified_touches`` (0x2614) in its TPDO5; ``identified_posterior`` (0x2613, REAL32) is in no PDO of the
shipped EDS, so the monitor has it only when someone reads it by SDO (``telethermo get slave
identified_posterior``, ``status``) or when a remapping puts it into a PDO; it is then shown for the touch
it was read in, and said to be missing otherwise. Code 0 is "none" (no estimate yet); :data:`ABSTAIN_CODE`
is the classifier's abstention, shown as "unknown".
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from telethermo.control.render_table import material_name

ABSTAIN_CODE = 0xFF   # identified_material when the classifier abstains (too unsure to name a material)
MATERIAL, POSTERIOR, TOUCHES = "identified_material", "identified_posterior", "identified_touches"


def material_text(code: int) -> str:
    """A material code for a person: the table's name, "none" (0), "unknown" (abstained)."""
    if code == ABSTAIN_CODE:
        return "unknown (abstained)"
    return material_name(code)


@dataclass
class NodeMaterial:
    code: int | None = None
    touches: int | None = None
    posterior: float | None = None
    posterior_how: str = ""
    posterior_touch: int | None = None   # identified_touches when the posterior was seen

    def to_json(self) -> dict[str, Any]:
        fresh = self.posterior is not None and self.posterior_touch == self.touches
        return {"code": self.code, "material": None if self.code is None else material_text(self.code),
                "touches": self.touches, "posterior": self.posterior if fresh else None,
                "posterior_source": self.posterior_how if fresh else None}

    def text(self) -> str:
        if self.code is None:
            return "no identified_material seen yet"
        touch = self.touches if self.touches is not None else "?"
        what = f"{material_text(self.code)} (code {self.code}, touch {touch})"
        j = self.to_json()
        if j["posterior"] is not None:
            return f"{what}, posterior {j['posterior']:.3f} ({j['posterior_source']})"
        if self.code in (0, ABSTAIN_CODE):
            return what
        return (f"{what}, posterior not on the bus (identified_posterior is in no PDO: "
                f"telethermo get NODE {POSTERIOR})")


class MaterialSeen:
    """Each node's identified material, touch counter and posterior, from PDO values and SDO transfers."""

    def __init__(self) -> None:
        self.by_node: dict[int, NodeMaterial] = {}

    def observe(self, node: int | None, name: str, value: Any, how: str) -> None:
        if node is None or name not in (MATERIAL, POSTERIOR, TOUCHES):
            return
        if isinstance(value, (bytes, bytearray)):   # a length mismatch decoded as raw bytes
            return
        m = self.by_node.setdefault(node, NodeMaterial())
        if name == MATERIAL:
            m.code = int(value)
        elif name == TOUCHES:
            m.touches = int(value)
        else:
            m.posterior, m.posterior_how, m.posterior_touch = float(value), how, m.touches

    def to_json(self) -> list[dict[str, Any]]:
        return [{"node": n, **m.to_json()} for n, m in sorted(self.by_node.items()) if m.code is not None]
