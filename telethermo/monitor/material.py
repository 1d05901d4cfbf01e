"""The identified material as the bus shows it (issue 25: "monitor and status show the identified material
with its posterior, and "unknown" when it abstains").

The slave publishes ``identified_material`` (0x2610, the rendering table's 1-based code) and
``identified_touches`` (0x2614) in its TPDO5; ``identified_posterior`` (0x2613, REAL32) is in no PDO of the
shipped EDS, so the monitor has it only when someone reads it by SDO (``telethermo get slave
identified_posterior``, ``status``) or when a remapping puts it into a PDO; it is then shown for the touch
it was read in, and said to be missing otherwise. Code 0 is "none" (no estimate yet); :data:`ABSTAIN_CODE`
is the classifier's abstention, shown as "unknown".

The answer improves while the touch lasts (issue 23): ``identified_material`` first holds the touch's first
answer (0.3 s of contact) and then the refined one (1.2 s); the slave's TPDO6 carries ``identified_stage``
(0x261E: 1 first, 2 refined) and the first answer's code ``identified_early_material`` (0x261C), whose
posterior ``identified_early_posterior`` (0x261D) is read by SDO like the other. Each is shown for the touch
it was seen in.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from telethermo.control.render_table import material_name

ABSTAIN_CODE = 0xFF  # identified_material when the classifier abstains (too unsure to name a material)
MATERIAL, POSTERIOR, TOUCHES = "identified_material", "identified_posterior", "identified_touches"
EARLY, EARLY_POSTERIOR, STAGE = "identified_early_material", "identified_early_posterior", "identified_stage"
STAGE_NAMES = {1: "first answer", 2: "refined"}


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
    posterior_touch: int | None = None  # identified_touches when the posterior was seen
    #: (value, how it was seen, identified_touches then) of the stage, the first answer and its posterior
    seen: dict[str, tuple[Any, str, int | None]] = field(default_factory=dict)

    def _fresh(self, name: str) -> tuple[Any, str | None]:
        v = self.seen.get(name)
        return (v[0], v[1]) if v is not None and v[2] == self.touches else (None, None)

    def to_json(self) -> dict[str, Any]:
        fresh = self.posterior is not None and self.posterior_touch == self.touches
        stage, early = self._fresh(STAGE)[0], self._fresh(EARLY)[0]
        early_post, early_how = self._fresh(EARLY_POSTERIOR)
        return {
            "code": self.code,
            "material": None if self.code is None else material_text(self.code),
            "touches": self.touches,
            "posterior": self.posterior if fresh else None,
            "posterior_source": self.posterior_how if fresh else None,
            "stage": STAGE_NAMES.get(stage) if stage is not None else None,
            "early_code": early,
            "early_material": None if early is None else material_text(early),
            "early_posterior": early_post,
            "early_posterior_source": early_how,
        }

    def _early_text(self, j: dict[str, Any]) -> str:
        if j["early_code"] is None:
            return ""
        post = (
            f", posterior {j['early_posterior']:.3f} ({j['early_posterior_source']})"
            if j["early_posterior"] is not None
            else ""
        )
        return f"; first answer {j['early_material']} (code {j['early_code']}){post}"

    def text(self) -> str:
        if self.code is None:
            return "no identified_material seen yet"
        touch = self.touches if self.touches is not None else "?"
        j = self.to_json()
        stage = f", {j['stage']}" if j["stage"] is not None else ""
        what = f"{material_text(self.code)} (code {self.code}, touch {touch}{stage})"
        if j["posterior"] is not None:
            return f"{what}, posterior {j['posterior']:.3f} ({j['posterior_source']})" + self._early_text(j)
        if self.code in (0, ABSTAIN_CODE):
            return what + self._early_text(j)
        return (
            f"{what}, posterior not on the bus (identified_posterior is in no PDO: "
            f"telethermo get NODE {POSTERIOR})"
        ) + self._early_text(j)


class MaterialSeen:
    """Each node's identified material, touch counter and posterior, from PDO values and SDO transfers."""

    def __init__(self) -> None:
        self.by_node: dict[int, NodeMaterial] = {}

    def observe(self, node: int | None, name: str, value: Any, how: str) -> None:
        if node is None or name not in (MATERIAL, POSTERIOR, TOUCHES, EARLY, EARLY_POSTERIOR, STAGE):
            return
        if isinstance(value, (bytes, bytearray)):  # a length mismatch decoded as raw bytes
            return
        m = self.by_node.setdefault(node, NodeMaterial())
        if name == MATERIAL:
            m.code = int(value)
        elif name == TOUCHES:
            m.touches = int(value)
        elif name in (EARLY, EARLY_POSTERIOR, STAGE):
            m.seen[name] = (float(value) if name == EARLY_POSTERIOR else int(value), how, m.touches)
        else:
            m.posterior, m.posterior_how, m.posterior_touch = float(value), how, m.touches

    def to_json(self) -> list[dict[str, Any]]:
        return [{"node": n, **m.to_json()} for n, m in sorted(self.by_node.items()) if m.code is not None]
