"""Worker entry point: ``python bench/_worker.py FUNCTION JSON`` runs ``common.FUNCTION(json.loads(JSON))`` in
this fresh process and prints its result as one tagged JSON line (see ``common.run_worker``)."""

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

WORKERS = {"dam_break_2d_run": common.dam_break_2d_run, "scene_run": common.scene_run}

if __name__ == "__main__":
    common.emit_worker_result(WORKERS[sys.argv[1]](json.loads(sys.argv[2])))
