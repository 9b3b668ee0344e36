#!/usr/bin/env bash
# Run every benchmark one after the other (they must not overlap: each one times the CPU).
# Usage: bench/run_all.sh [--quick]     (extra arguments go to every script)
# Results: bench/results/*.json, *.md, *.png. Full run: ~25 min on a 2-core machine.
# Not included: vs_baseline.py and kernel_variants.py (they need --baseline DIR, a worktree of another commit).
set -euo pipefail
cd "$(dirname "$0")/.."
PY="${PYTHON:-.venv/bin/python}"
[ -x "$PY" ] || PY=python
run() {
    echo "=== bench/$* ($(date -Is), load $(cut -d' ' -f1-3 /proc/loadavg))"
    "$PY" "bench/$@"
    echo
}
run thread_sweep.py "$@"
run thread_sweep.py --cases control heat --rounds 3 --name thread_sweep_heat "$@"
run speed_vs_error.py "$@"
run speed_vs_error.py --case heat "$@"
run speed_vs_error.py --case poiseuille "$@"
run speed_vs_error.py --case taylor_green "$@"
run particle_order.py "$@"
run pic_vs_mesh.py "$@"
run thread_sweep.py --cases control pic_thermal --rounds 4 --steps 10 --repeats 2 --name thread_sweep_pic "$@"
run thread_sweep.py --scene scenes/pic_diode.py --set particles_per_step=400 --set injected_fraction=2 --warmup 400 --rounds 3 --name thread_sweep_pic_diode "$@"
run vs_warp_example.py "$@"
run vs_pysph.py "$@"
