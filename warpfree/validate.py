"""``warpfree validate``: run every validation case and tabulate its checks.

A validation case is a shipped scene whose analyses return ``checks``
(:func:`warpfree.validation.tolerance_check`) and whose module names its ``QUICK`` settings: literal overrides that
make a short run of it whose checks still hold at their stated tolerances. ``warpfree validate`` runs each case at its
defaults (``--quick``: at its ``QUICK`` settings) in this process, one after the other, frames and VTU off, and
writes ``validation.json`` (the machine, each case's settings, wall time and validation block) and ``validation.md``
(one table row per check) in its directory. Exit code 0 when every check passed, 1 when one failed or a case
stopped, 2 on bad input.
"""

from __future__ import annotations

import datetime
import os
import platform
import time

from .errors import ParameterError, RunError
from .scene_loader import load_scene, scene_parameters, shipped_scenes
from .validation import check_lines

__all__ = ["validation_cases", "run_cases", "markdown_table"]

#: the outputs a validation run switches off where a scene has them: the checks need neither
SILENT = {"frames": False, "vtk": False}


def validation_cases() -> dict[str, str]:
    """The shipped scenes that are validation cases (their module has ``QUICK``): name -> path."""
    return {name: path for name, path in shipped_scenes().items() if hasattr(load_scene(path), "QUICK")}


def case_settings(module, quick: bool) -> dict:
    """The overrides a case runs with: its ``QUICK`` settings (or none), outputs off."""
    parameters = scene_parameters(module)
    settings = dict(module.QUICK) if quick else {}
    settings.update({k: v for k, v in SILENT.items() if k in parameters})
    return settings


def run_case(name: str, path: str, quick: bool, out_dir: str) -> dict:
    """Run one case into ``out_dir/<name>``; its record: settings, wall time (set-up included), status and its
    validation block (None when its analyses checked nothing: then it fails)."""
    from .run import build_scene

    module = load_scene(path)
    settings = case_settings(module, quick)
    t0 = time.perf_counter()
    record = {"scene": name, "settings": settings}
    try:
        run = build_scene(module, settings)
        summary = run.run(os.path.join(out_dir, name), progress=False)
        record.update(status="ok", validation=summary.get("validation"))
    except RunError as err:
        record.update(status="stopped", error=str(err), validation=None)
    record["wall_s"] = time.perf_counter() - t0
    record["passed"] = bool(record["validation"] and record["validation"]["passed"])
    return record


def run_cases(names: list[str] | None, quick: bool, out_dir: str, say=print) -> dict:
    """Run the named cases (None: all), saying a line per check as each ends; the report ``validation.json`` holds."""
    cases = validation_cases()
    names = list(cases) if names is None else names
    unknown = [n for n in names if n not in cases]
    if unknown:
        raise ParameterError("--scenes", f"not validation cases: {', '.join(unknown)} (the cases: {', '.join(cases)})")
    from .device import current_launcher

    launcher = current_launcher()
    report = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
              "device": f"{launcher.device} x{launcher.threads}", "quick": quick, "cases": []}
    for name in names:
        say(f"{name}: running{' (quick)' if quick else ''} ...")
        record = run_case(name, cases[name], quick, out_dir)
        report["cases"].append(record)
        if record["validation"]:
            for line in check_lines(record["validation"]):
                say(f"  {line}")
        else:
            say(f"  FAIL {name}: {record.get('error') or 'its analyses checked nothing'}")
        say(f"  {name}: {'passed' if record['passed'] else 'FAILED'} in {record['wall_s']:.1f} s")
    report["passed"] = all(r["passed"] for r in report["cases"])
    return report


def markdown_table(report: dict) -> str:
    """The report as a Markdown table: one row per check (case, quantity, value, reference, tolerance, result,
    source), with the machine, date and size it was made on."""
    size = "quick" if report["quick"] else "default"
    rows = [f"Made by `warpfree validate{' --quick' if report['quick'] else ''}` on {report['date'][:10]} "
            f"({report['machine']}, {report['device']}; {size} sizes).", "",
            "| case | quantity | value | reference | tolerance | result | reference source |",
            "| :-- | :-- | --: | --: | --: | :-: | :-- |"]
    for case in report["cases"]:
        if not case["validation"]:
            rows.append(f"| {case['scene']} | (stopped) | | | | FAIL | {case.get('error', '')} |")
            continue
        for quantity, c in case["validation"]["checks"].items():
            unit = f" {c['unit']}" if c.get("unit") else ""
            rows.append(f"| {case['scene']} | {quantity} | {c['value']:.4g}{unit} | {c['reference']:.4g}{unit} | "
                        f"{c['tolerance']:.3g}{unit} | {'pass' if c['passed'] else 'FAIL'} | {c['source']} |")
    return "\n".join(rows) + "\n"
