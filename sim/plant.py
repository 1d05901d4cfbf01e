"""The thermal plant of one rig, and a body that can be detached from it.

A rig's chain (front to back): ambient —R_sink— heat sink — grease — TEM sink plate —K— TEM pad plate — grease
— flux sensor (graded cells, thermocouple in the middle cell) — contact resistance R''(F)/A — body (finger
layers / object slab) — body back (core at 37 °C / adiabatic / ambient air); with nothing touching, the
sensor's top face loses h_air·A to ambient. Each contact state is a separate linear system integrated
exactly (sim.expint); a body not touching the rig is a separate system (front face in air) advanced lazily,
in one exact step, when it is next needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from telethermo.sim import bodies as B
from telethermo.sim.chain import ADIABATIC, Boundary, System, assemble
from telethermo.sim.contact import contact_resistance_m2K_W
from telethermo.sim.expint import Modal
from telethermo.sim.materials import material
from telethermo.sim.tem import RigParams
from telethermo.sim.touch import BodySpec


@dataclass(frozen=True, slots=True)
class GridSettings:
    """Spatial resolution: first cell = √(a·t_min)/cells_per_length, geometric growth ``ratio``."""

    t_min_s: float = 0.01
    ratio: float = 1.3
    cells_per_length: float = 4.0

    @staticmethod
    def for_tolerance(tolerance_C: float, period_s: float) -> tuple["GridSettings", str, float]:
        """The coarsest preset whose measured error is within ``tolerance_C``: (grid, preset name, error °C).

        The errors are those measured by bench/sim_bench.py (max over both rigs of the probe scene, 10 ms,
        against a refined reference); they scale with the temperature contrasts of a scene, so they are a
        guide, not a guarantee. Below the finest preset's error, the finest preset is returned.
        """
        for name, (t_fac, ratio, cpl, err) in GRID_PRESETS.items():
            if err <= tolerance_C:
                return GridSettings(t_min_s=period_s * t_fac, ratio=ratio, cells_per_length=cpl), name, err
        t_fac, ratio, cpl, err = GRID_PRESETS["fine"]
        return GridSettings(t_min_s=period_s * t_fac, ratio=ratio, cells_per_length=cpl), "fine", err


GRID_PRESETS = {
    # name: (t_min / period, growth ratio, cells per diffusion length, measured max error °C)
    "coarse": (5.0, 1.5, 2.0, 0.11),
    "default": (1.0, 1.3, 4.0, 0.031),
    "fine": (0.25, 1.2, 6.0, 0.0062),
}


class Body:
    """A finger or object slab with its own state; it lives inside a rig's system while touching."""

    def __init__(
        self,
        spec: BodySpec,
        area_m2: float,
        ambient_C: float,
        h_air_W_m2K: float,
        grid: GridSettings,
        lumped: bool = False,
    ) -> None:
        self.spec, self.area_m2, self.ambient_C = spec, area_m2, ambient_C
        self.lumped = lumped
        if spec.kind == "finger":
            fp = spec.finger or B.FingerParams()
            self.segment = B.finger_segment(fp, area_m2, grid.t_min_s, grid.ratio, grid.cells_per_length)
            self.back = Boundary(math.inf, fp.core_C)
            self.surface_material = fp.surface_material
        else:
            mat = material(spec.material)
            self.surface_material = mat
            if lumped:
                self.segment = B.lump(spec.name, mat.rho_c_J_m3K * spec.thickness_m * area_m2)
            else:
                self.segment = B.slab(
                    spec.name, mat, spec.thickness_m, area_m2, grid.t_min_s, grid.ratio, grid.cells_per_length
                )
            self.back = ADIABATIC if spec.back == "adiabatic" else Boundary(h_air_W_m2K * area_m2, ambient_C)
        self.air = Boundary(h_air_W_m2K * area_m2, ambient_C)
        self.system = assemble([self.segment], [], self.air, self.back)
        self._modal: Modal | None = None
        self._steps: dict[float, tuple] = {}
        if spec.kind == "finger":
            x0 = self.system.steady_state()
        else:
            x0 = np.full(self.segment.n, float(spec.T0_C))
        self.x = np.append(x0, 0.0)  # [cells, E_out (J)]
        self.t_s = 0.0
        self.attached = False

    @property
    def n(self) -> int:
        return self.segment.n

    def stored_J(self) -> float:
        return float(self.segment.C_J_K @ self.x[: self.n])

    def surface_C(self) -> float:
        """Front-face temperature while detached (in air), °C."""
        f, f0 = self.system.face_functional(0, "front")
        return float(f @ self.x[: self.n] + f0)

    def advance_detached(self, t_s: float, cache: bool = False) -> None:
        """Bring the detached body to time t_s (one exact step)."""
        dt = t_s - self.t_s
        if dt <= 0:
            return
        if self._modal is None:
            self._modal = Modal(self.system)
        key = round(dt, 12)
        mats = self._steps.get(key) if cache else None
        if mats is None:
            Phi, c, _, _ = self._modal.step_matrices(dt)
            mats = (Phi, c)
            if cache:
                self._steps[key] = mats
        Phi, c = mats
        self.x = Phi @ self.x + c
        self.t_s = t_s


class Config:
    """One contact state of a rig: the assembled system, its modal form, probes and cached step matrices."""

    def __init__(
        self, params: RigParams, sensor: B.Segment, ambient_C: float, body: Body | None, force_N: float
    ):
        A = params.area_m2
        tem = params.tem
        segs = [
            B.lump("sink", params.sink_C_J_K),
            B.lump("plate_s", tem.plate_C_J_K),
            B.lump("plate_p", tem.plate_C_J_K),
            sensor,
        ]
        links = [1.0 / params.G_sink_plate_W_K, 1.0 / tem.K_W_K, 1.0 / params.G_plate_sensor_W_K]
        if body is not None:
            segs.append(body.segment)
            links.append(contact_resistance_m2K_W(force_N, params.R_at_1N_m2K_W, params.force_exponent) / A)
            back = body.back
        else:
            back = Boundary(params.h_air_W_m2K * A, ambient_C)
        self.system: System = assemble(segs, links, Boundary(1.0 / params.sink_R_K_W, ambient_C), back)
        self.body = body
        self.n = self.system.n
        self.i_sink, self.i_s, self.i_p = 0, 1, 2
        self.sensor_slice = slice(3, 3 + sensor.n)
        self.i_mid = 3 + sensor.n // 2
        self.modal = Modal(self.system, (self.i_s, self.i_p))
        # Q through the sensor = k·S·(T_bottom − T_top)/e = thickness-mean of the flux, W
        fb, fb0 = self.system.face_functional(3, "front")
        ft, ft0 = self.system.face_functional(3, "back")
        sens_mat = material(params.sensor_material)
        kSe = sens_mat.lambda_W_mK * A / params.sensor_thickness_m
        self.q_f, self.q_f0 = kSe * (fb - ft), kSe * (fb0 - ft0)
        self.q_full = np.append(self.q_f, 0.0)  # acts on the augmented state [x, E_out]
        if body is not None:
            self.surf_f, self.surf_f0 = self.system.face_functional(4, "front")
            # heat flow across the contact (sensor top -> body), W: what the touching body receives
            self.body_q_f, self.body_q_f0 = self.system.link_flux_functional(3)
        else:
            self.surf_f, self.surf_f0 = None, math.nan
            self.body_q_f, self.body_q_f0 = None, math.nan
        self.top_f, self.top_f0 = ft, ft0  # top face of the sensor (what a body touches), °C
        self._steps: dict[float, tuple] = {}
        self._last_dt, self._last_m = math.nan, None

    def step(self, dt_s: float) -> tuple:
        """Cached step matrices for dt: (Phi, c, Bcat, scalars of the two plate rows).

        x' = Phi·x + Bcat·[1, u_s,n, u_p,n, u_s,n+1, u_p,n+1] with Bcat = [c | B0 | B1] (sim.expint).
        """
        if dt_s == self._last_dt:
            return self._last_m
        key = round(dt_s, 12)
        m = self._steps.get(key)
        if m is None:
            Phi, c, B0, B1 = self.modal.step_matrices(dt_s)
            Bcat = np.column_stack([c, B0, B1])
            rows = tuple(
                float(v)
                for v in (
                    c[1],
                    B0[1, 0],
                    B0[1, 1],
                    B1[1, 0],
                    B1[1, 1],
                    c[2],
                    B0[2, 0],
                    B0[2, 1],
                    B1[2, 0],
                    B1[2, 1],
                )
            )
            m = (Phi, c, Bcat, rows)
            if len(self._steps) > 64:
                self._steps.clear()
            self._steps[key] = m
        self._last_dt, self._last_m = dt_s, m
        return m
