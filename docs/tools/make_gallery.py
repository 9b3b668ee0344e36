"""Make the documentation's gallery: run each shipped scene with the command the gallery states, copy its pictures
into ``docs/gallery/`` as small PNGs and write ``docs/gallery.md``.

    .venv/bin/python docs/tools/make_gallery.py                              # every shipped scene
    .venv/bin/python docs/tools/make_gallery.py --scenes efg_cook,efg_l_shape  # only these; the others' entries stay

Each scene runs as ``warpfree run NAME --out runs/gallery/NAME`` with the settings in :data:`SETTINGS` (its defaults
for every scene not named there), in a process of its own. Its pictures are every plot at the top of its run
directory (the validation plots) and one frame of each frame series (:func:`liveliest`), downscaled and reduced to 256 colours so
that the whole gallery stays under :data:`BUDGET_BYTES`. ``docs/gallery/gallery.json`` keeps each scene's command,
pictures and result, so a partial run rewrites ``docs/gallery.md`` with every scene made so far. Exit code 1 when a
scene's run failed (its earlier entry, if any, is kept).
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
GALLERY = DOCS / "gallery"
RECORD = GALLERY / "gallery.json"
PAGE = DOCS / "gallery.md"
RUNS = ROOT / "runs" / "gallery"

#: the longest scenes run with these settings (``--set``), stated in the gallery beside their pictures, so that each
#: scene's run stays under about 5 minutes on 2 cores (the whole gallery takes about 10)
SETTINGS = {
    "pic_thermal_plasma": {"box": "16,32"},          # the default 64 x 128 λ_D box takes hours
    "dam_break_3d": {"dx": "0.05", "t_end": "1.0"},  # its defaults, stated: about 20 000 particles for 1 s
    "cylinder_flow_2d": {"per_diameter": "8"},      # its quick size: the default 10 across takes about 13 minutes
}
#: all the gallery's pictures together stay below this (bytes)
BUDGET_BYTES = 6_000_000
#: a picture is at most this many pixels wide in the gallery
MAX_WIDTH = 900


def command_for(scene: str) -> list[str]:
    """The ``warpfree run`` arguments the gallery states for ``scene``."""
    sets = [arg for name, value in SETTINGS.get(scene, {}).items() for arg in ("--set", f"{name}={value}")]
    return ["warpfree", "run", scene, *sets, "--out", f"runs/gallery/{scene}"]


def liveliest(frames: list[Path]) -> tuple[int, Path]:
    """The frame of a series that shows most, and its index: the one with the most distinct colours (in a thumbnail,
    at 5 bits a channel; the latest of equals). Frames of one series share their axes, labels and colour bar, so
    what differs is the particles: a field at rest (a dam break before it breaks, a plasma back at rest after whole
    periods) is one colour, a flow many."""
    from PIL import Image

    def colours(path: Path) -> int:
        with Image.open(path) as image:
            thumb = image.convert("RGB")
            thumb.thumbnail((300, 300))
            pixels = np.asarray(thumb) >> 3
            return len(np.unique(pixels.reshape(-1, 3), axis=0))

    index = max(range(len(frames)), key=lambda k: (colours(frames[k]), k))
    return index, frames[index]


def pictures_of(run_dir: Path) -> list[tuple[str, Path]]:
    """(label, file) of the pictures a run made: its plots at the top of the directory, then one frame of each frame
    series (``frames/<series>_NNNNN.png``): the one that shows most (:func:`liveliest`)."""
    chosen = [(path.stem, path) for path in sorted(run_dir.glob("*.png"))]
    series: dict[str, list[Path]] = {}
    for path in sorted((run_dir / "frames").glob("*.png")):
        match = re.fullmatch(r"(.+)_(\d+)", path.stem)
        if match:
            series.setdefault(match.group(1), []).append(path)
    for name, frames in sorted(series.items()):
        index, path = liveliest(frames)
        chosen.append((f"{name}, frame {index}" if name != "frame" else f"frame {index}", path))
    return chosen


def shrink(source: Path, target: Path, max_width: int) -> None:
    """``source`` at most ``max_width`` pixels wide, in 256 colours (plots lose nothing visible), saved as ``target``."""
    from PIL import Image

    with Image.open(source) as image:
        picture = image.convert("RGB")
    if picture.width > max_width:
        height = round(picture.height * max_width / picture.width)
        picture = picture.resize((max_width, height), Image.Resampling.LANCZOS)
    picture.quantize(colors=256, dither=Image.Dither.NONE).save(target, optimize=True)


def run_scene(scene: str) -> dict | None:
    """Run one scene as the gallery states; its record (command, wall time, result line, pictures), None if it
    failed."""
    args = command_for(scene)
    out_dir = ROOT / args[-1]
    print(f"{scene}: {' '.join(args)}", flush=True)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "warpfree", *args[1:], "--overwrite", "--no-progress"], cwd=ROOT,
                          capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        print(f"  FAILED (exit {done.returncode}) after {wall:.0f} s:\n{done.stderr[-2000:]}", flush=True)
        return None
    summary = json.loads((out_dir / "summary.json").read_text(encoding="utf-8"))
    for old in GALLERY.glob(f"{scene}--*.png"):
        old.unlink()
    images = []
    for label, path in pictures_of(out_dir):
        name = f"{scene}--{re.sub(r'[^a-z0-9]+', '-', label.lower()).strip('-')}.png"
        shrink(path, GALLERY / name, MAX_WIDTH)
        images.append({"file": name, "label": label})
    validation = summary.get("validation")
    result = None
    if validation:
        passed = sum(c["passed"] for c in validation["checks"].values())
        result = f"{passed} of {len(validation['checks'])} validation checks passed"
    print(f"  {wall:.0f} s, {len(images)} pictures{', ' + result if result else ''}", flush=True)
    return {"command": " ".join(args), "wall_s": round(wall, 1), "validation": result, "images": images}


def keep_within_budget() -> int:
    """Shrink every gallery picture by the same factor until all of them together fit :data:`BUDGET_BYTES`; their
    total size."""
    from PIL import Image

    def total() -> int:
        return sum(p.stat().st_size for p in GALLERY.glob("*.png"))

    size = total()
    while size > BUDGET_BYTES:
        for path in GALLERY.glob("*.png"):
            with Image.open(path) as image:
                width = image.width
            shrink(path, path, int(width * 0.85))
        size = total()
    return size


def write_page(record: dict, shipped: dict[str, str]) -> None:
    """``docs/gallery.md`` from the record: one section per scene made, in the order of the shipped scenes."""
    from warpfree.scene_loader import summary_line

    lines = ["<!-- Generated by docs/tools/make_gallery.py from docs/gallery/gallery.json: do not edit by hand; "
             "run the script to remake it. -->", "", "# Gallery", "",
             "Every shipped scene, run by the command printed above its pictures (its defaults unless the command "
             "sets a parameter), from a fresh checkout after `pip install -e .`. The pictures are the plots the run "
             "writes at the top of its run directory (the validation plots: the reference, the computed result and "
             "below it the error with the tolerance) and one frame of each frame series (the one with the most colours: the particles' field varies most), reduced in size for "
             "this page; the run directory holds them at full size. `warpfree list` names every scene; "
             "[Validation](validation.md) tabulates the checks.", ""]
    for scene, path in shipped.items():
        entry = record.get(scene)
        if entry is None:
            continue
        lines += [f"## {scene}", "", summary_line(path), "", "```bash", entry["command"], "```", ""]
        if entry.get("validation"):
            lines += [f"The run ends with {entry['validation']}.", ""]
        for image in entry["images"]:
            lines += [f"![{scene}: {image['label']}](gallery/{image['file']})", ""]
    PAGE.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=None, metavar="A,B", help="only these scenes (default: every shipped one)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from warpfree.scene_loader import shipped_scenes

    shipped = shipped_scenes()
    names = list(shipped) if args.scenes is None else [n.strip() for n in args.scenes.split(",") if n.strip()]
    unknown = [n for n in names if n not in shipped]
    if unknown:
        parser.error(f"not shipped scenes: {', '.join(unknown)} (the scenes: {', '.join(shipped)})")
    GALLERY.mkdir(parents=True, exist_ok=True)
    record = json.loads(RECORD.read_text(encoding="utf-8")) if RECORD.exists() else {}
    record = {k: v for k, v in record.items() if k in shipped}  # a scene no longer shipped leaves the gallery
    failed = []
    for scene in names:
        entry = run_scene(scene)
        if entry is None:
            failed.append(scene)
        else:
            record[scene] = entry
    kept = {image["file"] for entry in record.values() for image in entry["images"]}
    for path in glob.glob(str(GALLERY / "*.png")):
        if os.path.basename(path) not in kept:
            os.remove(path)
    size = keep_within_budget()
    RECORD.write_text(json.dumps(record, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    write_page(record, shipped)
    print(f"gallery: {len(record)} scenes, {len(kept)} pictures, {size / 1e6:.2f} MB; {PAGE.relative_to(ROOT)} written"
          + (f"; FAILED: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
