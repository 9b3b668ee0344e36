"""Peer: the standing wave of ``scenes/standing_wave_2d.py`` in PySPH 1.0b2's ``WCSPHScheme``, run in its own venv.

The same tank (L = 1 m, d = 0.5 m), amplitude, Tait EOS (γ = 7, c0 = 10 sqrt(2 g d)), kernel (``WendlandQuintic``,
PySPH's name for Wendland C2 in 2D) and h/dx as ours; PySPH's own scheme otherwise: δ-SPH (δ = 0.1) with its
artificial viscosity α = 0.02, Monaghan's dynamic boundary particles with the Hughes-Graham correction (3 layers on
a dx lattice around the tank), the PEC integrator with dt = 0.1 h/c0, and XSPH (ε = 0.5) unless ``xsph`` is off
(ε = 0: particles move with their own velocity, as ours do). The water starts on a square lattice (cell centres,
dx/2 from the walls) with hydrostatic densities and the linear-theory velocity of the first mode at its
flat-surface phase; every T/40 the driver records the water's horizontal centre of mass. PySPH lives in a separate
virtualenv (``--python``, default ``/work/peers-venv/bin/python``: ``pip install pysph==1.0b2 "cython<3.1" mako
cyarray``), never in warpfree's.

    python bench/wcsph/peers/pysph_standing_wave.py --dx 0.04 --h-factor 1.6 [--no-xsph] [--python PATH]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

DEFAULT_PYTHON = "/work/peers-venv/bin/python"

_DRIVER = r'''
import json, sys
import numpy as np
from pysph.base.kernels import WendlandQuintic
from pysph.base.utils import get_particle_array_wcsph
from pysph.solver.application import Application
from pysph.sph.integrator import PECIntegrator
from pysph.sph.scheme import WCSPHScheme

cfg = json.loads(sys.argv[1])
L, D, A, G, RHO0, GAMMA, DX, HDX = (cfg[k] for k in ("length", "depth", "amplitude", "g", "rho0", "gamma", "dx",
                                                     "h_factor"))
C0 = 10.0 * np.sqrt(2.0 * G * D)
k = np.pi / L
omega = np.sqrt(G * k * np.tanh(k * D))
period = 2.0 * np.pi / omega


class StandingWave(Application):
    def create_particles(self):
        xs, ys = (np.arange(int(round(L / DX))) + 0.5) * DX, (np.arange(int(round(D / DX))) + 0.5) * DX
        x, y = (a.ravel() for a in np.meshgrid(xs, ys, indexing="ij"))
        b = RHO0 * C0 ** 2 / GAMMA
        rho = RHO0 * (1.0 + RHO0 * G * (D - y) / b) ** (1.0 / GAMMA)
        c = A * omega / np.sinh(k * D)            # velocity potential of the mode: u = grad phi
        u, v = -c * np.sin(k * x) * np.cosh(k * y), c * np.cos(k * x) * np.sinh(k * y)
        walls = []
        for layer in range(3):
            o = (layer + 0.5) * DX
            walls += [(xx, -o) for xx in np.arange(-o, L + o + 1e-9, DX)]
            walls += [(side, yy) for yy in np.arange(-o + DX, 2.0 * D + 1e-9, DX) for side in (-o, L + o)]
        w = np.array(walls)
        h = HDX * DX
        fluid = get_particle_array_wcsph(name="fluid", x=x, y=y, u=u, v=v, rho=rho, m=np.full(x.size, RHO0 * DX * DX),
                                         h=np.full(x.size, h))
        wall = get_particle_array_wcsph(name="boundary", x=w[:, 0], y=w[:, 1], rho=np.full(len(w), RHO0),
                                        m=np.full(len(w), RHO0 * DX * DX), h=np.full(len(w), h))
        self.scheme.setup_properties([fluid, wall])
        return [fluid, wall]

    def create_scheme(self):
        return WCSPHScheme(["fluid"], ["boundary"], dim=2, rho0=RHO0, c0=C0, h0=HDX * DX, hdx=HDX, gy=-G, alpha=0.02,
                           beta=0.0, gamma=GAMMA, hg_correction=True, delta_sph=True, delta=0.1)

    def configure_scheme(self):
        self.scheme.configure_solver(kernel=WendlandQuintic(dim=2), integrator_cls=PECIntegrator,
                                     dt=0.1 * HDX * DX / C0, tf=cfg["periods"] * period, pfreq=10 ** 9)

    def create_equations(self):
        equations = self.scheme.get_equations()
        for group in equations:
            for eq in group.equations:
                if type(eq).__name__ == "XSPHCorrection" and not cfg["xsph"]:
                    eq.eps = 0.0                  # positions then move with the particle's own velocity
        return equations

    def post_step(self, solver):
        if not hasattr(self, "record"):
            self.record, self.next_time = [], 0.0
        if solver.t >= self.next_time - 1e-12:
            f = [p for p in solver.particles if p.name == "fluid"][0]
            self.record.append((float(solver.t), float(np.sum(f.m * f.x) / np.sum(f.m))))
            self.next_time += period / 40.0


app = StandingWave(fname="standing_wave")
app.run(["-d", cfg["out"], "--disable-output"])
json.dump({"omega_linear": float(omega), "time": [t for t, _ in app.record], "centre_of_mass_x": [x for _, x in app.record],
           "fluid": int(len(app.particles[0].x)), "steps": int(app.solver.count)}, open(cfg["out"] + "/record.json", "w"))
'''


def run(dx: float, h_factor: float, xsph: bool, python: str = DEFAULT_PYTHON, amplitude: float = 0.01,
        periods: float = 3.0, timeout: float | None = 3600.0) -> dict:
    """One PySPH run; returns its record (time, centre_of_mass_x, omega_linear, counts)."""
    with tempfile.TemporaryDirectory(prefix="pysph_sw_") as out:
        cfg = {"length": 1.0, "depth": 0.5, "amplitude": amplitude, "g": 9.81, "rho0": 1000.0, "gamma": 7.0,
               "dx": dx, "h_factor": h_factor, "xsph": xsph, "periods": periods, "out": out}
        proc = subprocess.run([python, "-c", _DRIVER, json.dumps(cfg)], capture_output=True, text=True,
                              timeout=timeout)
        if proc.returncode != 0:
            raise RuntimeError(f"PySPH driver failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        return json.loads(Path(out, "record.json").read_text())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dx", type=float, default=0.04)
    p.add_argument("--h-factor", type=float, default=1.6)
    p.add_argument("--no-xsph", action="store_true")
    p.add_argument("--python", default=DEFAULT_PYTHON)
    args = p.parse_args(argv)
    rec = run(args.dx, args.h_factor, not args.no_xsph, args.python)
    print(json.dumps({k: v for k, v in rec.items() if k not in ("time", "centre_of_mass_x")}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
