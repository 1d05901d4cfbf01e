"""What one node runs, built from its options: the rig, the controller parameters, the model, and
the recording's meta. The only module of nodes/ that knows the simulator.

Built exactly as the offline runner (telethermo.offline.runner) builds them, so that a two-process
session and an offline session of the same scene give the same trajectories up to REAL32 rounding:
the same rigs (``sim.build_rig(scene, role, seed)``; seeds master 0, slave 1 by default), the same
default parameters (``telethermo.control.params.default_params``), the same cycle-0 peer values.
"""

from __future__ import annotations

import dataclasses
import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from telethermo import sim
from telethermo.bus_config.partable import BY_NAME
from telethermo.control.core import CoreParams, RenderSettings
from telethermo.control.detach import tem_limits
from telethermo.control.gain_rule import fit_gains, fitted_params
from telethermo.control.gainsfile import load_gains
from telethermo.control.material_lab import LabCorrection, lab_params, load_lab
from telethermo.control.material_stream import MaterialIdParams
from telethermo.control.params import default_params
from telethermo.control.types import Mode, Role
from telethermo.ident import load_model
from telethermo.inputfile import InputFileError, load_toml
from telethermo.iomodule.iorig import IoRig, IoRigError
from telethermo.iomodule.rigconfig import RigConfigError, load_rig_config
from telethermo.rig import Rig
from telethermo.offline.render_script import RenderScript
from telethermo.recording.rows import finger_skin_C
from telethermo.transport.bus import TransportSettings

from telethermo.nodes.options import NodeOptions, OptionError

#: ``--rig io``: the I/O rig driver (telethermo.iomodule.iorig), configured by ``--rig-config RIG.toml``
IO_RIG = "io"
#: default noise seeds, as the offline runner's default (seed=0: master 0, slave 1)
DEFAULT_SEEDS = {Role.MASTER: 0, Role.SLAVE: 1}


@dataclass
class NodeParts:
    """A node's rig and controller configuration.

    Attributes:
        rig: the rig (a simulated one advances only when asked).
        simulated: the rig has ``advance`` (lockstep possible).
        params_for: ``(mode, render=None)`` -> :class:`CoreParams`, the defaults read at run time
            (raises ValueError for a mode this node cannot run; RENDER needs ``render`` without a script).
        model: TEM model or None (the FLUX estimator needs none).
        period_s: control period, s.
        cycles: cycles of the scene's duration (None for hardware).
        meta: descriptive keys for the recording.
        truth: simulated rig's ground truth (None for hardware).
    """

    rig: Rig
    simulated: bool
    params_for: Callable[[Mode], CoreParams]
    model: Any
    period_s: float
    cycles: int | None
    meta: dict[str, Any]
    truth: Callable[[], Any] | None
    render_script: Any = None
    gain_fit: dict[str, Any] | None = None
    """The gains' fit to the loaded model (telethermo.control.gain_rule.fit_gains: ρ and the margins), None
    without a model: ``params_for`` scales every current gain by ρ. :meth:`fit_model` refreshes it."""

    def fit_model(self, model: Any, role: Role) -> None:
        """Derive the gains from ``model`` (None: the shipped gains) for the modes built from now on."""
        self.gain_fit = fit_gains(model, role) if model is not None else None

    """Render scenes (master): :class:`telethermo.offline.render_script.RenderScript`, the same script
    the offline runner follows (the next touch's material once the previous touch has ended; the
    finger's skin read before each touch)."""
    finger_skin: Callable[[], float] | None = None
    """The finger thermometer of a simulated master rig (skin temperature, °C)."""


def build_parts(
    opts: NodeOptions,
    *,
    period_s: float,
    node_id: int | None = None,
    transport: TransportSettings | None = None,
) -> NodeParts:
    """Rig, parameters and model of ``opts``; ``period_s`` is the network's SYNC period, s; ``node_id`` and
    ``transport`` are the node's (the I/O rig, ``--rig io``, commissions its modules to watch ``node_id`` over
    its own connection to ``transport``)."""
    model, gains = _model_and_gains(opts)
    meta: dict[str, Any] = {"role": opts.role}
    if gains:
        meta["gains"] = {"file": str(opts.gains), **gains}
    rig, cycles, truth, script, finger_skin = _rig(opts, period_s, node_id, transport, meta)
    simulated = callable(getattr(rig, "advance", None))
    if opts.timing == "lockstep" and not (simulated or getattr(rig, "lockstep", False)):
        raise OptionError(
            "--timing lockstep: this rig cannot advance on request (hardware runs in real time)"
        )
    lab = _material_lab(opts)
    if lab is not None:
        meta["material_lab"] = str(opts.material_lab)
    params_for = _params_maker(opts, period_s, gains, script, rig, lambda: parts.gain_fit, lab)
    parts = NodeParts(
        rig=rig,
        simulated=simulated,
        params_for=params_for,
        model=model,
        period_s=period_s,
        cycles=cycles,
        meta=meta,
        truth=truth,
        render_script=script,
        finger_skin=finger_skin,
    )
    parts.fit_model(model, opts.role)
    if parts.gain_fit is not None:
        meta["gain_fit"] = {
            "rho": parts.gain_fit["rho"],
            "max_cooling_A": parts.gain_fit["max_cooling_A"],
            **parts.gain_fit["margins"],
        }
    if not (
        opts.mode is Mode.RENDER and script is None
    ):  # without a script, RENDER renders the OD's settings
        try:
            params_for(opts.mode)  # refuse a mode this node cannot run now, not at the first SYNC
        except ValueError as exc:
            raise OptionError(f"--mode {opts.mode.name.lower()}: {exc}") from None
    if script is not None:
        meta["render"] = script.meta()
    return parts


def _model_and_gains(opts: NodeOptions) -> tuple[Any, dict[str, float]]:
    """The TEM model of ``--model`` (None without) and the telepresence gains of ``--gains`` ({} without)."""
    model = None
    if opts.model is not None:
        try:
            model = load_model(opts.model)
        except ValueError as exc:  # ModelFileError names the file and the field
            raise OptionError(str(exc)) from None
    gains: dict[str, float] = {}
    if opts.gains is not None:
        try:
            gains = dict(load_gains(opts.gains)[opts.role])
        except (ValueError, KeyError) as exc:  # load_gains names the file and the field
            raise OptionError(f"--gains: {exc}") from None
        _check_od_ranges(opts.gains, opts.role, gains)
    return model, gains


def _check_od_ranges(path: Path, role: Role, gains: dict[str, float]) -> None:
    """Refuse a gain the node's object dictionary would refuse by SDO (out of its EDS range, abort
    0609 0030), as ``telethermo apply-gains`` does: the node must not start with a value its own OD
    cannot hold. OptionError names the file, the field, the value and the range."""
    for key, value in gains.items():
        p = BY_NAME.get(key)
        if p is None or p.field != (key,):
            continue  # a gain with no object (kpQ, kiQ): CoreParams checks it
        lo, hi = p.value("low", role.value), p.value("high", role.value)
        if not lo <= value <= hi:
            raise OptionError(
                f"--gains {path}: {role.value}.{key} = {value:g} is out of the object dictionary's range "
                f"{lo:g} .. {hi:g} {p.unit} (0x{p.index:04X}, as telethermo apply-gains refuses it)"
            )


def _material_lab(opts: NodeOptions) -> LabCorrection | None:
    """The slave's lab calibration of the physics fit (``--material-lab``; None without)."""
    if opts.material_lab is None:
        return None
    if opts.role is not Role.SLAVE:
        raise OptionError("--material-lab: the slave's material identification; the master has none")
    try:
        lab = load_lab(opts.material_lab)
        lab_params(MaterialIdParams(), lab)  # windows the slave's: refused now, not at the first touch
    except ValueError as exc:  # InputFileError names the file and the field
        text = str(exc)
        raise OptionError(
            text if str(opts.material_lab) in text else f"{opts.material_lab}: {text}"
        ) from None
    return lab


def _rig(
    opts: NodeOptions,
    period_s: float,
    node_id: int | None,
    transport: TransportSettings | None,
    meta: dict[str, Any],
):
    """The rig of ``opts``: (rig, cycles of the scene, truth, render script, finger thermometer), the last
    four None unless a scene simulates it."""
    if opts.scene is not None:
        return _scene_rig(opts, period_s, meta)
    if opts.rig == IO_RIG:
        rig = _io_rig(opts, period_s, node_id, transport)
        meta.update(rig=opts.rig, rig_config=str(opts.rig_config))
        return rig, None, None, None, None
    rig = _hardware_rig(opts, period_s)
    meta.update(rig=opts.rig)
    return rig, None, None, None, None


def _params_maker(
    opts: NodeOptions,
    period_s: float,
    gains: dict[str, float],
    script,
    rig,
    gain_fit: Callable[[], dict | None],
    lab: LabCorrection | None = None,
) -> Callable[..., CoreParams]:
    """``params_for(mode, render=None)``: the controller's parameters of ``mode`` on this rig."""

    def params_for(mode: Mode, render: RenderSettings | None = None) -> CoreParams:
        """As the offline runner: the defaults of (role, mode) with the envelope at this rig's I_max.
        RENDER renders ``render`` (default: the render script's first touch)."""
        if mode is Mode.RENDER:
            render = render if render is not None else (script.first if script is not None else None)
            kw = {"render": render}
        else:
            kw = dict(gains) if mode is Mode.TELEPRESENCE else {}  # tuned gains are telepresence gains
        p = default_params(
            opts.role, period_s=period_s, mode=mode, **kw
        )  # ValueError: RENDER without settings
        fit = gain_fit()
        if fit is not None:  # gains that fit this rig: derived from its identified model (gain_rule)
            p = fitted_params(p, fit)
        if abs(p.safety.I_max_A - rig.I_max_A) > 1e-12:
            p = dataclasses.replace(p, safety=dataclasses.replace(p.safety, I_max_A=float(rig.I_max_A)))
        if lab is not None and p.material_id is not None:  # this probe's calibration of the physics fit
            p = dataclasses.replace(p, material_id=lab_params(p.material_id, lab))
        tem = tem_limits(rig)  # the detached-sensor check on this rig's TEM (as the offline runner)
        if any(getattr(p.safety, k) != v for k, v in tem.items()):
            p = dataclasses.replace(p, safety=dataclasses.replace(p.safety, **tem))
        return p

    return params_for


def _scene_rig(opts: NodeOptions, period_s: float, meta: dict[str, Any]):
    """The simulated rig of ``opts.scene``: (rig, cycles of the scene, truth, render script, finger
    thermometer)."""
    script = None
    finger_skin = None
    try:
        scene = sim.load_scene(opts.scene)
    except ValueError as exc:  # SceneError names the file and the field
        raise OptionError(str(exc)) from None
    seed = opts.seed if opts.seed is not None else DEFAULT_SEEDS[opts.role]
    try:
        rig = sim.build_rig(scene, opts.role, seed=seed)
    except ValueError as exc:  # SceneError: e.g. a virtual (display-only) scene given to the slave
        raise OptionError(str(exc)) from None
    if abs(rig.period_s - period_s) > 1e-12:
        raise OptionError(
            f"--scene {str(opts.scene)!r}: period_s = {rig.period_s} s but the network's SYNC "
            f"period is {period_s} s (network settings [sync] period_s); they must agree"
        )
    cycles = int(round(scene.duration_s / rig.period_s))
    meta.update(scene=getattr(scene, "name", str(opts.scene)), seed=seed)
    truth = rig.truth
    touches = getattr(getattr(rig, "schedule", None), "touches", ())
    # a virtual scene whose pad touches nothing (identification, idle) has nothing to script: RENDER then
    # renders the OD's material
    if opts.role is Role.MASTER and getattr(scene, "kind", "") == "virtual" and touches:
        try:
            script = RenderScript(scene)
        except ValueError as exc:  # a material missing from the rendering table, no touch to render
            raise OptionError(f"--scene {str(opts.scene)!r}: {exc}") from None
        finger_skin = lambda: finger_skin_C(rig, rig.truth())  # noqa: E731
    return rig, cycles, truth, script, finger_skin


def rig_settings(path: Path | None) -> dict[str, Any]:
    """The rig driver's keyword arguments from ``--rig-config FILE.toml`` (its top-level keys); {} without."""
    if path is None:
        return {}
    try:
        return load_toml(path, InputFileError, "a TOML file of the rig driver's settings")
    except InputFileError as exc:  # one line naming the file (and the line of a syntax error)
        raise OptionError(f"--rig-config {exc}") from None


def _io_rig(
    opts: NodeOptions, period_s: float, node_id: int | None, transport: TransportSettings | None
) -> IoRig:
    """``--rig io``: the I/O rig of ``--rig-config RIG.toml``, its modules commissioned and started."""
    if opts.rig_config is None:
        raise OptionError("--rig io: needs --rig-config RIG.toml (the modules, signals and drive)")
    if opts.rig_args:
        raise OptionError("--rig-arg: the I/O rig takes its settings from --rig-config RIG.toml only")
    if node_id is None or transport is None:
        raise OptionError("--rig io: the node's ID and bus are needed to commission its modules")
    try:
        config = load_rig_config(opts.rig_config)
        if config.controller not in (None, opts.role.value):
            raise OptionError(
                f"--rig-config {opts.rig_config}: controller = {config.controller!r}: this rig is driven by "
                f"the {config.controller}'s node, not by telethermo-{opts.role.value}"
            )
        return IoRig(
            config,
            transport=transport,
            controller_id=node_id,
            period_s=period_s,
            lockstep=opts.timing == "lockstep",
        ).start()
    except (RigConfigError, IoRigError) as exc:
        raise OptionError(str(exc)) from None


def _hardware_rig(opts: NodeOptions, period_s: float) -> Rig:
    """The hardware rig of ``opts.rig`` (``module:factory``), checked against the Rig protocol and the
    period."""
    module, _, factory = opts.rig.partition(":")
    try:
        make = getattr(importlib.import_module(module), factory)
    except (ImportError, AttributeError) as exc:
        raise OptionError(f"--rig {opts.rig!r}: cannot load the rig factory: {exc}") from None
    settings = rig_settings(opts.rig_config) | dict(opts.rig_args)
    try:
        rig = make(**settings)
    except Exception as exc:  # a driver's own error (no device, bad port, ...): one named line
        raise OptionError(
            f"--rig {opts.rig!r}: the rig factory failed: {type(exc).__name__}: {exc}"
        ) from None
    missing = [a for a in ("read", "apply_current", "period_s", "I_max_A") if not hasattr(rig, a)]
    if missing:
        raise OptionError(
            f"--rig {opts.rig!r}: the factory returned a {type(rig).__name__}, not a "
            f"telethermo.rig.Rig (missing {', '.join(missing)})"
        )
    if abs(float(rig.period_s) - period_s) > 1e-12:
        raise OptionError(
            f"--rig {opts.rig!r}: period_s = {rig.period_s} s but the network's SYNC period is "
            f"{period_s} s (network settings [sync] period_s); they must agree"
        )
    return rig
