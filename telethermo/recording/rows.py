"""The rows of a recording (:mod:`telethermo.recording.format`'s columns), built alike by every path: the
offline runner, the node programs (their per-SYNC row) and the I/O module's truth log.

- :func:`side_row`: one side's measured and controller columns (``m_*`` or ``s_*``) of one control step;
- :func:`truth_row`: one side's truth columns from its simulated rig (``X_true_*``, ``m_true_finger_C``);
- :func:`ref_row`: the direct-touch reference's columns (``ref_*``);
- :func:`scene_contacts`: the scene's touches as the meta's ``contacts`` list.

Units are in the column names (°C, W, A; s for times), see :mod:`telethermo.recording.format`.
"""

from __future__ import annotations

import math
from typing import Any, Protocol

from telethermo.control.core import StepResult
from telethermo.control.types import PeerValues
from telethermo.rig import RigSample


# What the rows read of the simulator's objects (telethermo.sim, which mypy cannot follow through the
# package-dir mapping): read-only views, so that sim's frozen dataclasses and properties match.
class Truth(Protocol):
    """A rig's ground truth now (``sim.RigTruth``)."""

    @property
    def T_surface_C(self) -> float: ...
    @property
    def Q_true_W(self) -> float: ...
    @property
    def Q_into_body_W(self) -> float: ...
    @property
    def touching(self) -> str | None: ...


class TruthSource(Protocol):
    """A simulated rig (``sim.SimRig``, or ``sim.WallClockRig`` around one)."""

    def truth(self) -> Truth: ...


class Reference(Protocol):
    """The direct-touch reference (``sim.DirectTouch``)."""

    @property
    def T_contact_C(self) -> float: ...
    @property
    def Q_finger_W(self) -> float: ...
    @property
    def touching(self) -> str | None: ...


class Contact(Protocol):
    """One touch of a scene's schedule (``sim.touch.Touch``)."""

    @property
    def start_s(self) -> float: ...
    @property
    def end_s(self) -> float: ...
    @property
    def body(self) -> str: ...
    @property
    def render(self) -> str | None: ...


class Contacts(Protocol):
    """A scene's touch schedules (``sim.Scene``)."""

    @property
    def master_contacts(self) -> tuple[Contact, ...]: ...
    @property
    def slave_contacts(self) -> tuple[Contact, ...]: ...


def side_row(p: str, sample: RigSample, res: StepResult, peer: PeerValues | None) -> dict[str, Any]:
    """The ``p``-prefixed (``"m"`` or ``"s"``) columns of one step: the rig's ``sample`` (°C, W), the
    controller's result ``res`` (current A, setpoints °C, contact, safety) and the ``peer`` values it
    used."""
    s = res.status
    return {
        f"{p}_T_sensor_C": sample.T_sensor_C,
        f"{p}_Q_W": sample.Q_W,
        f"{p}_T_sink_C": sample.T_sink_C,
        f"{p}_current_A": res.current_A,
        f"{p}_target_C": s.requested_setpoint_C,
        f"{p}_setpoint_C": s.setpoint_C,
        f"{p}_feedback_C": s.feedback_C,
        f"{p}_estimate_C": s.estimate_C,
        f"{p}_T_pred_C": s.T_pred_C,
        f"{p}_peer_estimate_C": peer.estimate_C if peer is not None else math.nan,
        f"{p}_peer_flux_W": peer.flux_W if peer is not None else math.nan,
        f"{p}_contact": float(s.contact),
        f"{p}_safety_state": int(s.safety.state),
        f"{p}_error_register": s.safety.error_register,
        f"{p}_limits": "|".join(s.safety.limits_active),
        f"{p}_new_trips": "|".join(t.value for t in s.safety.new_trips),
    }


def truth_row(p: str, rig: TruthSource) -> dict[str, Any]:
    """The ``p``-prefixed truth columns of a simulated ``rig`` now (°C, W, 0/1; the master's adds the
    operator's skin, ``m_true_finger_C``)."""
    tr = rig.truth()
    row: dict[str, Any] = {
        f"{p}_true_surface_C": tr.T_surface_C,
        f"{p}_true_Q_W": tr.Q_true_W,
        f"{p}_true_Q_into_body_W": tr.Q_into_body_W,
        f"{p}_true_touching": float(tr.touching is not None),
    }
    if p == "m":
        row["m_true_finger_C"] = finger_skin_C(rig, tr)
    return row


def finger_skin_C(rig: object, tr: Truth) -> float:
    """Truth: the operator's skin temperature on the master, touching or not (in air between touches), °C.
    ``rig``: the master's simulated rig, ``tr``: its truth now (a rig without bodies: NaN between touches)."""
    if tr.touching == "finger":
        return tr.T_surface_C
    body = getattr(rig, "bodies", {}).get("finger")
    if body is None:
        return math.nan
    body.advance_detached(rig.t_s)  # type: ignore[attr-defined]  # a rig with bodies is a sim.SimRig
    return float(body.surface_C())


def ref_row(ref: Reference) -> dict[str, Any]:
    """The direct-touch reference's columns now: its finger's skin (°C), the heat flux into it (W) and
    whether it touches (0/1)."""
    return {
        "ref_T_contact_C": ref.T_contact_C,  # the reference finger's skin, touching or in air
        "ref_Q_into_finger_W": -ref.Q_finger_W if ref.touching else 0.0,
        "ref_touching": float(bool(ref.touching)),
    }


def scene_contacts(sc: Contacts, side: str) -> list[dict[str, Any]]:
    """The scene's touches of the probe (slave) or of the display (master, render scenes)."""
    out = []
    if side == "slave":
        for t in sc.slave_contacts:
            out.append({"t_on_s": t.start_s, "t_off_s": t.end_s, "object": t.body})
    else:
        for t in sc.master_contacts:
            if t.render is not None:
                out.append({"t_on_s": t.start_s, "t_off_s": t.end_s, "object": t.render})
    return out
