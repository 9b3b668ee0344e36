"""Device memory per work item of every method family: state, neighbour structures and the rest, by size.

What it measures
    Each family's benchmark scene (the one whose module declares ``BENCHMARK``) at each of its sizes, and the 3D dam
    break at dx = 0.05, 0.035 and 0.025 m (SPHERIC test 2's tank; with its fluid pairs in a table, the default, and
    read from the neighbour grid, no table): built, stepped 20 times (a static scene: solved), then
    ``warpfree.memory.solver_memory`` (what ``summary.json`` reports as ``memory``): the bytes of every Warp array and
    hash grid the solver holds, per work item (a particle, a Gauss point), split into the state a checkpoint holds,
    the neighbour structures and the rest (operators, coefficients, scratch). DualSPHysics' figure for WCSPH is about
    230 bytes a particle (350 M particles on an 80 GB card).

Usage
    python bench/core/memory_table.py            # about a minute on 2 cores
Writes bench/results/memory.{json,md}.
"""

from __future__ import annotations

import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE.parent), str(_HERE)]
import common  # noqa: E402

#: The runs bench/run_all.py makes of this script, in order (argument lists; [] = no run).
RUN_ALL = [[]]

#: beyond the families' benchmark scenes: the 3D dam break (the WCSPH figure DualSPHysics' is given for), with its
#: fluid pairs in a table (the default) and read from the neighbour grid (``fluid_pairs="grid"``, no table)
EXTRA = [("wcsph", "dam_break_3d", "dx", [0.05, 0.035, 0.025], {}),
         ("wcsph", "dam_break_3d", "dx", [0.05, 0.035, 0.025], {"fluid_pairs": "grid"})]

#: DualSPHysics' bytes a particle on a GPU (350 M particles in 80 GB)
DUALSPHYSICS_BYTES = 230.0


def one(scene: str, parameter: str, value, settings: dict | None = None) -> dict:
    from warpfree.memory import solver_memory
    from warpfree.time_loop import TimeLoop

    run = common.build_scene(scene, 2, **{parameter: value, **(settings or {})})
    if isinstance(run, TimeLoop):
        run.max_steps = 20
        run.t_end = run.output_interval = 1e6 * run.t_end  # no output in the steps
    run.run(None, progress=False)
    return {"scene": scene, "parameter": parameter, "value": value, "settings": dict(settings or {}),
            "work_items": int(run.solver.work_items), **solver_memory(run.solver)}


def markdown(result: dict) -> str:
    rows = []
    for r in result["cases"]:
        per = r["per_item"]
        parts = {k: v / r["work_items"] for k, v in r["parts"].items()}
        case = " ".join([f"{r['scene']} {r['parameter']}={r['value']}"]
                        + [f"{k}={v}" for k, v in r.get("settings", {}).items()])
        rows.append([r["family"], case, f"{r['work_items']:,}", r["item"],
                     f"{per:.0f}", f"{parts['state']:.0f}", f"{parts['neighbours']:.0f}", f"{parts['other']:.0f}",
                     f"{r['bytes'] / 2**20:.1f}"])
    return ("# Device memory per work item\n\n"
            + common.md_table(["family", "case", "items", "item", "bytes / item", "state", "neighbours", "other",
                               "MiB"], rows)
            + f"\n\nDualSPHysics: about {DUALSPHYSICS_BYTES:.0f} bytes a particle on a GPU.\n")


def main(argv=None) -> int:
    cases = []
    for family, b in common.benchmarks().items():
        for value in b["values"]:
            cases.append({"family": family, **one(b["scene"], b["parameter"], value)})
            print(cases[-1], flush=True)
    for family, scene, parameter, values, settings in EXTRA:
        for value in values:
            cases.append({"family": family, **one(scene, parameter, value, settings)})
            print(cases[-1], flush=True)
    result = {"cases": cases, "dualsphysics_bytes_per_particle": DUALSPHYSICS_BYTES,
              "machine": common.machine_info()}
    common.write_results("memory", result, markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
