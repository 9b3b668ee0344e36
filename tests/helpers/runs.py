"""Comparing two run directories: every snapshot of every series (a ``.pvtu``'s pieces joined in global order), and
the summary's figures."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from warpfree.io.vtk import read_pvd, read_snapshot
from warpfree.scene_loader import load_scene, value_text


def smallest_sets(scene: str, without: tuple = ()) -> list[str]:
    """``--set`` arguments of a scene's smallest run, but for the parameters ``without`` (a caller that sets them
    itself: a name set twice is refused)."""
    return [a for k, v in load_scene(scene).SMALLEST.items() if k not in without
            for a in ("--set", f"{k}={value_text(v)}")]


def smallest_sets_then(scene: str, settings: list[str]) -> list[str]:
    """A scene's smallest run with ``settings`` (``--set name=value`` pairs) in place of its own values for the same
    names."""
    names = tuple(settings[i + 1].split("=", 1)[0] for i in range(0, len(settings), 2))
    return smallest_sets(scene, without=names) + settings


def snapshot_differences(a: Path, b: Path) -> list[str]:
    """What differs between the series of two runs (empty: every snapshot of every series bitwise the same, and the
    same series and times)."""
    out = []
    names_a, names_b = sorted(p.name for p in a.glob("*.pvd")), sorted(p.name for p in b.glob("*.pvd"))
    if names_a != names_b:
        return [f"series {names_a} against {names_b}"]
    for name in names_a:
        ea, eb = read_pvd(a / name), read_pvd(b / name)
        if [t for t, _ in ea] != [t for t, _ in eb]:
            out.append(f"{name}: times differ")
            continue
        for (t, fa), (_, fb) in zip(ea, eb):
            pa, da = in_id_order(*read_snapshot(a / fa))
            pb, db = in_id_order(*read_snapshot(b / fb))
            if not np.array_equal(pa, pb):
                out.append(f"{name} t={t}: points differ by {np.abs(pa - pb).max():.3g}")
            for k in da:
                if k not in db or not np.array_equal(da[k], db[k]):
                    out.append(f"{name} t={t}: field {k} differs")
    return out


#: the component suffixes of a tensor or vector written as one field per component (stress_xx, velocity_y)
COMPONENTS = ("_xx", "_yy", "_zz", "_xy", "_xz", "_yz", "_x", "_y", "_z")


def quantity_of(field: str) -> str:
    """The quantity a field is a component of (``stress_yy`` -> ``stress``), or the field itself."""
    for suffix in COMPONENTS:
        if field.endswith(suffix):
            return field[: -len(suffix)]
    return field


def field_differences(a: Path, b: Path) -> float:
    """The largest difference of any field of any snapshot of two runs with the same series and points, relative to
    its quantity's largest magnitude (a component field such as ``stress_yy`` is measured against the largest
    component of its tensor: one nearly zero everywhere has no scale of its own); 0: bitwise the same; inf when the
    series, times or points differ."""
    names_a, names_b = sorted(p.name for p in a.glob("*.pvd")), sorted(p.name for p in b.glob("*.pvd"))
    if names_a != names_b or not names_a:
        return float("inf")
    worst = 0.0
    for name in names_a:
        ea, eb = read_pvd(a / name), read_pvd(b / name)
        if [t for t, _ in ea] != [t for t, _ in eb]:
            return float("inf")
        for (_, fa), (_, fb) in zip(ea, eb):
            pa, da = in_id_order(*read_snapshot(a / fa))
            pb, db = in_id_order(*read_snapshot(b / fb))
            if not np.array_equal(pa, pb) or set(da) != set(db):
                return float("inf")
            scales: dict[str, float] = {}
            for k in da:
                x = np.asarray(da[k], float)
                if x.size:
                    scales[quantity_of(k)] = max(scales.get(quantity_of(k), 0.0), float(np.max(np.abs(x))))
            for k in da:
                x, y = np.asarray(da[k], float), np.asarray(db[k], float)
                if x.shape != y.shape:
                    return float("inf")
                scale = scales.get(quantity_of(k), 0.0)
                if scale > 0:
                    worst = max(worst, float(np.max(np.abs(x - y))) / scale)
    return worst


def in_id_order(points: np.ndarray, fields: dict) -> tuple[np.ndarray, dict]:
    """A snapshot's rows by ``particle_id`` when it has one (PIC writes its particles in their sorted slots; the
    pieces of a distributed run join in id order)."""
    if "particle_id" not in fields:
        return points, fields
    order = np.argsort(fields["particle_id"], kind="stable")
    return points[order], {k: v[order] for k, v in fields.items()}


def relative_differences(a, b, prefix: str = "") -> dict[str, float]:
    """Every number of two nested summaries' sections, flattened: |a - b| / max(|a|, tiny) where they differ."""
    out = {}
    if isinstance(a, dict) and isinstance(b, dict):
        for k in a:
            if k in b:
                out.update(relative_differences(a[k], b[k], f"{prefix}{k}/"))
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            out.update(relative_differences(x, y, f"{prefix}{i}/"))
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and a != b and not (a != a and b != b):
        out[prefix.rstrip("/")] = abs(a - b) / max(abs(a), 1e-300)
    return out


def summary(run: Path) -> dict:
    return json.loads((run / "summary.json").read_text())


def cut_and_resumed(build, directory: Path):
    """A run made by ``build()`` (a TimeLoop with checkpoints) run whole, and the same run cut a step past half way and
    resumed from its last checkpoint: (the whole run, the resumed run), for their states and series to be compared."""
    full = build()
    full.run(str(directory / "full"), progress=False)
    cut = build()
    cut.max_steps = full.step_count // 2 + 1
    cut.run(str(directory / "cut"), progress=False)
    resumed = build()
    resumed.run(str(directory / "cut"), resume=True, progress=False)
    assert resumed.step_count == full.step_count
    return full, resumed
