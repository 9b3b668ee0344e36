"""CPU time of the MLS kernels: the shape functions at the Gauss points of a beam (linear and quadratic basis) and
the PIC particles' fits, each the median of repeated launches after a warm-up.

What it measures
    ``efg_timoshenko.beam_solver(192, 48)`` (the linear basis at its defaults; the quadratic at d_max 2.5 and 3 x 3
    Gauss points): ``MLSModel.shape_at`` at every Gauss point (support rows and shape functions), median of 7;
    ``pic_thermal_plasma`` at box (32, 64): one ``particle_fits`` launch over every particle, median of 12.
    Compare two versions by running it in each, alternately (``bench/results/mls_speed.md``).

Usage
    python bench/efg/mls_speed.py [--threads N]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]
import common  # noqa: E402

sys.path.insert(0, str(common.SCENES))

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run, RUN_ALL_SKIPPED says why).
RUN_ALL = [[]]


def _median(fn, repeats: int, warmup: int = 1) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--threads", type=int, default=None)
    args = p.parse_args(argv)
    from warpfree import device
    from warpfree.scene_loader import load_scene

    device.use("cpu", args.threads)
    import efg_timoshenko

    out = {}
    for basis, extra in (("linear", {}), ("quadratic", {"d_max": 2.5, "gauss": 3})):
        s = efg_timoshenko.beam_solver(192, 48, basis=basis, **extra)
        out[f"shape_functions_{basis}_ms"] = 1e3 * _median(lambda: s.model.shape_at(s.cells.position), 7)
    sol = load_scene("pic_thermal_plasma").build(box=(32.0, 64.0), frames=False, vtk=False).solver
    c = sol.coupling
    out["pic_fits_ms"] = 1e3 * _median(lambda: c.launcher.launch(
        c.kernels.particle_fits, sol.count, [c.node_set, sol.particles.position32, sol.state.position, c.inv_scale,
                                             c.fit, c.node_count_of]), 12, warmup=3)
    print(" ".join(f"{k}={v:.2f}" for k, v in out.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
