"""The energy-conserving pair on jittered particles: which of its forms keeps a PEC square's mode frequency, and at what
set-up cost.

What it measures
    A 1 m PEC square, 24 (and 48) cells a side, 30 %-jittered (``staggered_box``, both sets), started in its TM21 mode
    Ez = sin(2πx) sin(πy), H = 0, stepped at 0.9 of the step limit for 3 periods: the frequency from the zero crossings
    of the mode's projection, against ω = cπ√5, and the model's set-up time (the pair's solve included; one
    process, 2 threads). Forms of the pair (``warpfree/solvers/spem/conservative.py``): the default (``pair_order=1``,
    FPM start of support 1.1 + 2·jitter spacings, pattern ``NEXT_SHELL`` = 0.6 spacings beyond it), the order-2 pair
    (``pair_order=2``: the quadratic moments in least squares), and the default with another FPM support or another
    pattern shell. The uniform layout for reference.

Usage
    python bench/spem/jittered_pair.py            # about 2 minutes on 2 cores
Writes bench/results/jittered_pair.{json,md}.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent)]  # bench/ (common.py)
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run).
RUN_ALL = [[]]

#: (label, cells, jitter, seed, pair order, FPM support (spacings; None: 1.1 + 2 jitter), pattern shell (spacings))
CASES = [("uniform", 24, 0.0, 0, 1, None, 0.6),
         ("default", 24, 0.3, 0, 1, None, 0.6), ("default", 24, 0.3, 1, 1, None, 0.6),
         ("order-2 pair", 24, 0.3, 0, 2, None, 0.6), ("order-2 pair", 24, 0.3, 1, 2, None, 0.6),
         ("support 1.5", 24, 0.3, 0, 1, 1.5, 0.6), ("support 2.0", 24, 0.3, 0, 1, 2.0, 0.6),
         ("shell 1.5", 24, 0.3, 0, 1, None, 1.5), ("shell 1.5", 24, 0.3, 1, 1, None, 1.5),
         ("support 1.5, shell 1.5", 24, 0.3, 0, 1, 1.5, 1.5), ("support 1.5, shell 1.5", 24, 0.3, 1, 1, 1.5, 1.5),
         ("support 1.3, shell 1.5", 24, 0.3, 0, 1, 1.3, 1.5),
         ("uniform", 48, 0.0, 0, 1, None, 0.6), ("default", 48, 0.3, 0, 1, None, 0.6),
         ("order-2 pair", 48, 0.3, 0, 2, None, 0.6), ("support 1.5, shell 1.5", 48, 0.3, 0, 1, 1.5, 1.5)]


def one(cells: int, jitter: float, seed: int, order: int, support: float | None, shell: float) -> dict:
    from warpfree.solvers.spem import C0, SPEMModel, SPEMSolver, conservative, staggered_box
    from warpfree.solvers.spem.model import support_for_jitter

    layout = staggered_box((0.0, 0.0), (1.0, 1.0), 1.0 / cells, jitter=jitter, seed=seed)
    mode = lambda p: np.sin(2.0 * np.pi * p[:, 0]) * np.sin(np.pi * p[:, 1])  # noqa: E731
    omega = C0 * math.pi * math.sqrt(5.0)
    default_shell, conservative.NEXT_SHELL = conservative.NEXT_SHELL, shell
    try:
        start = time.perf_counter()
        model = SPEMModel(layout, support=support or support_for_jitter(jitter), pair_order=order)
        setup = time.perf_counter() - start
    finally:
        conservative.NEXT_SHELL = default_shell
    solver = SPEMSolver(model, ez=mode)
    dt = 0.9 * solver.stable_dt()
    basis = mode(layout.e_position)
    projection = []
    for _ in range(int(3.0 * 2.0 * math.pi / omega / dt) + 2):
        solver.step(dt)
        projection.append(float(basis @ solver.electric.numpy("ez")))
    p = np.asarray(projection)
    t = (np.arange(p.size) + 0.5) * dt  # Ez's time after each step
    k = np.flatnonzero(np.sign(p[:-1]) * np.sign(p[1:]) < 0)
    crossings = t[k] - p[k] * dt / (p[k + 1] - p[k])
    return {"frequency_error": math.pi / float(np.mean(np.diff(crossings))) / omega - 1.0, "setup_s": setup}


def markdown(result: dict) -> str:
    rows = [[c["label"], c["cells"], c["jitter"], c["seed"], f"{100 * c['frequency_error']:+.3f} %",
             f"{c['setup_s']:.2f} s"] for c in result["cases"]]
    return ("# The energy-conserving pair on jittered particles: a PEC square's TM21 frequency\n\n"
            + common.md_table(["form", "cells a side", "jitter", "seed", "frequency error", "set-up"], rows) + "\n")


def main(argv=None) -> int:
    from warpfree import device

    device.use("cpu", 2)
    cases = []
    for label, cells, jitter, seed, order, support, shell in CASES:
        cases.append({"label": label, "cells": cells, "jitter": jitter, "seed": seed, "pair_order": order,
                      "support": support, "shell": shell, **one(cells, jitter, seed, order, support, shell)})
        print(cases[-1], flush=True)
    result = {"cases": cases, "machine": common.machine_info()}
    common.write_results("jittered_pair", result, markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
