#!/usr/bin/env bash
# Run every benchmark one after the other (they must not overlap: each one times the CPU).
# Usage: bench/run_all.sh [--quick]     (extra arguments go to every script)
# Results: bench/results/*.json, *.md, *.png. Full run: ~20 min on a 2-core machine.
set -euo pipefail
cd "$(dirname "$0")/.."
PY="${PYTHON:-/work/venv/bin/python}"
[ -x "$PY" ] || PY=python
for script in thread_sweep vs_warp_example vs_pysph speed_vs_error; do
    echo "=== bench/${script}.py $* ($(date -Is), load $(cut -d' ' -f1-3 /proc/loadavg))"
    "$PY" "bench/${script}.py" "$@"
    echo
done
