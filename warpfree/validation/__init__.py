"""Reference data for the validated scenes: one subpackage per case (``warpfree.validation.<case>``).

Each case folder holds its data as CSV files (shipped as package data) and a ``README.md`` giving
every source; the case's ``__init__`` loads the CSVs with :func:`read_csv` and exposes them as arrays,
so an installed scene can compare itself with them.
"""

from importlib import resources

import numpy as np

__all__ = ["read_csv", "tolerance_check", "validation_block", "check_lines", "running_mean"]


def read_csv(case: str, filename: str) -> tuple[list[str], np.ndarray]:
    """Read ``filename`` of the case package ``warpfree.validation.<case>``.

    The file has one header line of comma-separated column names (with units where they have any)
    followed by rows of numbers. Returns ``(header, data)`` with ``data`` a float64 array of shape
    ``(rows, columns)``. Found through :mod:`importlib.resources`, so it works from an installed
    package as well as from the source tree. Raises ``FileNotFoundError`` naming the case and the
    file when either is missing, and ``ValueError`` when the rows do not match the header.
    """
    package = f"{__name__}.{case}"
    try:
        res = resources.files(package).joinpath(filename)
    except ModuleNotFoundError as exc:
        raise FileNotFoundError(f"no validation case {case!r} (package {package} not found) "
                                f"while looking for {filename!r}") from exc
    if not res.is_file():
        raise FileNotFoundError(f"validation case {case!r} has no data file {filename!r} "
                                f"(looked in package {package})")
    lines = [ln.strip() for ln in res.read_text(encoding="utf-8").splitlines() if ln.strip()]
    if not lines:
        raise ValueError(f"validation data {case}/{filename} is empty")
    header = [c.strip() for c in lines[0].split(",")]
    try:
        rows = [[float(v) for v in ln.split(",")] for ln in lines[1:]]
    except ValueError as exc:
        raise ValueError(f"validation data {case}/{filename}: {exc}") from exc
    bad = [i + 2 for i, r in enumerate(rows) if len(r) != len(header)]
    if bad:
        raise ValueError(f"validation data {case}/{filename}: line(s) {bad} do not have "
                         f"{len(header)} columns ({','.join(header)})")
    data = np.array(rows, dtype=np.float64).reshape(len(rows), len(header))
    return header, data


def running_mean(t: np.ndarray, values: np.ndarray, width: float) -> np.ndarray:
    """The mean of ``values`` over ``width`` (in the units of ``t``) centred on each sample, fewer samples at the
    ends: a series sampled every Δt averages round(width/Δt) samples (a transducer's reading over its response)."""
    t, values = np.asarray(t, dtype=np.float64), np.asarray(values, dtype=np.float64)
    n = max(1, int(round(width / float(np.median(np.diff(t))))))
    kernel = np.ones(n)
    return np.convolve(values, kernel, mode="same") / np.convolve(np.ones_like(values), kernel, mode="same")


def tolerance_check(value: float, tolerance: float, source: str, reference: float = 0.0, unit: str = "",
                    basis: str = "") -> dict:
    """A validated quantity as ``summary.json`` reports it: its ``value``, the ``reference`` it is compared with, the
    ``tolerance`` on |value - reference| (in ``unit``, the quantity's own units; "" for a fraction, as for relative
    errors), ``source``: where the reference and its accuracy come from (a paper, a thesis figure, an exact
    solution), ``basis``: why the tolerance is what it is, and ``passed``. A value that is not a finite number fails."""
    value, reference, tolerance = float(value), float(reference), float(tolerance)
    passed = bool(np.isfinite(value) and abs(value - reference) <= tolerance)
    return {"value": value, "reference": reference, "tolerance": tolerance, "unit": unit, "source": source,
            "basis": basis, "passed": passed}


def validation_block(analysis: dict) -> dict | None:
    """``summary["validation"]``: every ``checks`` record (:func:`tolerance_check`) the analyses returned, named
    ``<analysis>.<quantity>``, and ``passed``: all of them passed. None when the analyses checked nothing."""
    checks = {}
    for key, result in analysis.items():
        if isinstance(result, dict):
            for name, record in (result.get("checks") or {}).items():
                checks[f"{key}.{name}"] = record
    if not checks:
        return None
    return {"passed": all(c["passed"] for c in checks.values()), "checks": checks}


def check_lines(validation: dict) -> list[str]:
    """One line per check of a validation block: PASS/FAIL, the quantity, value, reference, tolerance and source."""
    lines = []
    for name, c in validation["checks"].items():
        unit = f" {c['unit']}" if c.get("unit") else ""
        lines.append(f"{'PASS' if c['passed'] else 'FAIL'} {name} = {c['value']:.4g}{unit} (reference "
                     f"{c['reference']:.4g}, tolerance {c['tolerance']:.3g}{unit}; {c['source']})")
    return lines
