"""``warpfree validate``: run every validation case and tabulate its checks.

A validation case is a shipped scene whose analyses return ``checks``
(:func:`warpfree.validation.tolerance_check`) and whose module names its ``QUICK`` settings: literal overrides that
make a short run of it whose checks still hold at their stated tolerances. ``warpfree validate`` runs each case at its
defaults (``--quick``: at its ``QUICK`` settings) in this process, one after the other, frames and VTU off, and
writes ``validation.json`` (the machine, each case's settings, wall time and validation block) and ``validation.md``
(one table row per check) in its directory. Exit code 0 when every check passed, 1 when one failed or a case
stopped, 2 on bad input.

``--against FILE`` compares the run with a table made before (the documentation's, or another machine's): the same
cases and quantities with the same references, tolerances and results, and each value within
:data:`AGREEMENT` of the larger of the two values and its tolerance (round-off differs between CPUs and thread
counts; a value near its tolerance may differ but must keep its result).
"""

from __future__ import annotations

import datetime
import os
import re
import platform
import time

from .errors import ParameterError, RunError
from .scene_loader import load_scene, scene_parameters, shipped_scenes
from .validation import check_lines

__all__ = ["AGREEMENT", "validation_cases", "selected_cases", "run_cases", "markdown_table", "read_table", "table_differences"]

#: how closely a value must agree with a table made before: a fraction of max(|value|, |earlier value|, tolerance)
AGREEMENT = 0.01

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


def selected_cases(names: list[str] | None) -> dict[str, str]:
    """The cases ``names`` asks for (None: all), name -> path, in that order; ParameterError naming --scenes for a
    name that is not a case."""
    cases = validation_cases()
    names = list(cases) if names is None else names
    unknown = [n for n in names if n not in cases]
    if unknown:
        raise ParameterError("--scenes", f"not validation cases: {', '.join(unknown)} (the cases: {', '.join(cases)})")
    return {n: cases[n] for n in names}


def run_cases(names: list[str] | None, quick: bool, out_dir: str, say=print) -> dict:
    """Run the named cases (None: all), saying a line per check as each ends; the report ``validation.json`` holds."""
    cases = selected_cases(names)
    from .device import current_launcher

    launcher = current_launcher()
    report = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
              "device": f"{launcher.device} x{launcher.threads}", "quick": quick, "cases": []}
    for name in cases:
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
            rows.append(f"| {case['scene']} | (stopped) | | | | FAIL | {_cell(case.get('error', ''))} |")
            continue
        for quantity, c in case["validation"]["checks"].items():
            unit = f" {c['unit']}" if c.get("unit") else ""
            rows.append(f"| {case['scene']} | {quantity} | {c['value']:.4g}{unit} | {c['reference']:.4g}{unit} | "
                        f"{c['tolerance']:.3g}{unit} | {'pass' if c['passed'] else 'FAIL'} | {_cell(c['source'])} |")
    return "\n".join(rows) + "\n"


def _cell(text: str) -> str:
    """Text made safe for a Markdown table cell: its bars escaped, on one line."""
    return " ".join(str(text).split()).replace("|", "\\|")


#: the columns of :func:`markdown_table`'s rows
COLUMNS = ("case", "quantity", "value", "reference", "tolerance", "result", "source")


def _number(cell: str) -> float:
    """The number a table cell starts with (``3.5e-05 V`` -> 3.5e-05)."""
    return float(cell.split()[0])


def read_table(text: str) -> dict[tuple[str, str], dict]:
    """The rows of a table :func:`markdown_table` wrote: (case, quantity) -> its cells (value, reference and
    tolerance as numbers; a stopped case's row has quantity ``(stopped)``). Raises ValueError on a malformed row."""
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip()[1:-1])]
        if not line.startswith("|") or cells[0] in ("case", ":--"):
            continue
        if len(cells) < len(COLUMNS):
            raise ValueError(f"a validation table row needs {len(COLUMNS)} cells: {line!r}")
        row = dict(zip(COLUMNS, cells))
        if row["quantity"] != "(stopped)":
            for key in ("value", "reference", "tolerance"):
                row[key] = _number(row[key])
        rows[(row["case"], row["quantity"])] = row
    return rows


def table_differences(earlier: str, report: dict) -> list[str]:
    """How the run in ``report`` differs from the table ``earlier`` (Markdown text): a line per case or quantity
    missing from one of them, per changed reference, tolerance or result, and per value that moved by more than
    :data:`AGREEMENT` of max(|value|, |earlier value|, tolerance). Empty when they agree."""
    before, now = read_table(earlier), read_table(markdown_table(report))
    ran = {case["scene"] for case in report["cases"]}
    differences = [f"{case} {quantity}: in the earlier table, not in this run" for case, quantity in before
                   if case in ran and (case, quantity) not in now]
    for key, row in now.items():
        name = f"{key[0]} {key[1]}"
        old = before.get(key)
        if old is None:
            differences.append(f"{name}: in this run, not in the earlier table")
            continue
        if row["quantity"] == "(stopped)":
            continue
        if row["result"] != old["result"]:
            differences.append(f"{name}: {row['result']} here, {old['result']} in the earlier table")
        for column in ("reference", "tolerance"):
            if row[column] != old[column]:
                differences.append(f"{name}: {column} {row[column]:.4g} here, {old[column]:.4g} in the earlier table")
        scale = max(abs(row["value"]), abs(old["value"]), row["tolerance"])
        if abs(row["value"] - old["value"]) > AGREEMENT * scale:
            differences.append(f"{name}: value {row['value']:.4g} here, {old['value']:.4g} in the earlier table "
                               f"(they may differ by {AGREEMENT * scale:.3g})")
    return differences
