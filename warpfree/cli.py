"""Command line: ``warpfree run scenes/NAME.py [--set name=value ...] [--out DIR] [--threads N]
[--device D] [--frames/--no-frames] [--resume DIR]``."""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import json
import os
import sys

from .errors import ParameterError, RunError

DESCRIPTION = """warpfree: meshfree particle methods (WCSPH fluids, SPEM, EFG, PIDC) as NVIDIA Warp kernels.

Commands:
  run     run a scene script (a Python module with build(**params) returning a TimeLoop or StaticRun)

Example:
  warpfree run scenes/dam_break_2d.py --set dx=0.02 --out runs/db --threads 2
"""

RUN_HELP = """Run a scene. Every parameter of the scene's build() has a default; --set overrides one
(repeat it for several). The run directory gets summary.json, VTU files with a PVD index (vtk/,
*.pvd, open in ParaView), PNG frames (frames/) and the scene's own plots. With --checkpoint-every K
it also keeps checkpoints, and --resume DIR continues such a run (bitwise the same as an
uninterrupted one)."""


def load_scene(path: str):
    """Import a scene module from a file path."""
    if not os.path.isfile(path):
        raise ParameterError("scene", f"no such scene file: {path}")
    name = "warpfree_scene_" + os.path.splitext(os.path.basename(path))[0]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # a scene that does not import is bad input, not a crash of warpfree
        where = f" (line {exc.lineno})" if isinstance(exc, SyntaxError) else ""
        raise ParameterError("scene", f"{path} cannot be loaded{where}: {type(exc).__name__}: {exc}") from None
    if not hasattr(module, "build"):
        raise ParameterError("scene", f"{path} has no build(**params) function")
    return module


def scene_parameters(module) -> dict:
    """name -> default of the scene's build()."""
    return {k: p.default for k, p in inspect.signature(module.build).parameters.items()
            if p.default is not inspect.Parameter.empty}


def parse_overrides(pairs: list[str], defaults: dict) -> dict:
    """Turn ``name=value`` strings into typed values, using the type of each default."""
    out = {}
    for pair in pairs:
        if "=" not in pair:
            raise ParameterError("--set", f"expected name=value, got {pair!r}")
        name, text = pair.split("=", 1)
        name = name.strip()
        if name not in defaults:
            raise ParameterError(name, f"is not a parameter of this scene; choose from {sorted(defaults)}")
        out[name] = convert(name, text.strip(), defaults[name])
    return out


def convert(name: str, text: str, default):
    if isinstance(default, bool):
        if text.lower() in ("1", "true", "yes", "on"):
            return True
        if text.lower() in ("0", "false", "no", "off"):
            return False
        raise ParameterError(name, f"must be true or false, got {text!r}")
    if isinstance(default, tuple):
        # a sequence of numbers: "8,16", "(8, 16)" or "8 16", each typed like the default's items
        parts = [p for p in text.strip("()[] ").replace(",", " ").split() if p]
        if len(parts) != len(default):
            raise ParameterError(name, f"must be {len(default)} values like {default}, got {text!r}")
        return tuple(convert(name, p, d) for p, d in zip(parts, default))
    try:
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
    except ValueError:
        raise ParameterError(name, f"must be a {type(default).__name__}, got {text!r}") from None
    return text


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="warpfree", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command")
    run = sub.add_parser("run", help="run a scene script", description=RUN_HELP)
    run.add_argument("scene", nargs="?", help="path to a scene module, e.g. scenes/dam_break_2d.py")
    run.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                     help="override a scene parameter (repeatable)")
    run.add_argument("--out", default=None, help="run directory (default: runs/<scene>)")
    run.add_argument("--threads", type=int, default=None, help="CPU threads (default: all cores)")
    run.add_argument("--device", default="cpu", help="cpu (default), cuda or cuda:N")
    run.add_argument("--frames", dest="frames", action="store_true", default=None, help="write PNG frames")
    run.add_argument("--no-frames", dest="frames", action="store_false", help="do not write PNG frames")
    run.add_argument("--checkpoint-every", type=int, default=None, metavar="K",
                     help="write a checkpoint every K steps (keeps the two newest)")
    run.add_argument("--resume", default=None, metavar="DIR", help="continue the run in DIR from its last checkpoint")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--list", action="store_true", help="list the scene's parameters and defaults, then exit")
    return parser


def run_command(args) -> int:
    from . import device
    from .run import build_scene
    from .time_loop import TimeLoop

    if args.resume:
        meta_path = os.path.join(args.resume, "run.json")
        if not os.path.isfile(meta_path):
            raise ParameterError("--resume", f"{args.resume} has no run.json (not a warpfree run directory)")
        try:
            with open(meta_path) as f:
                meta = json.load(f)
            scene_path, overrides, out_dir = meta["scene"], dict(meta["overrides"]), args.resume
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ParameterError("--resume", f"{meta_path} is damaged: {exc}") from None
        if args.scene and os.path.abspath(args.scene) != os.path.abspath(scene_path):
            raise ParameterError("--resume", f"the run in {args.resume} is of {scene_path}, not {args.scene}")
        if args.out and os.path.abspath(args.out) != os.path.abspath(args.resume):
            raise ParameterError("--out", f"a resumed run continues in its own directory {args.resume}; "
                                          "copy it first to continue elsewhere")
        overrides.update(resume_overrides(args.overrides, overrides, load_scene(scene_path)))
    else:
        if not args.scene:
            raise ParameterError("scene", "give a scene file, e.g. warpfree run scenes/dam_break_2d.py")
        scene_path = args.scene
        module = load_scene(scene_path)
        overrides = parse_overrides(args.overrides, scene_parameters(module))
        if args.frames is not None:
            if "frames" not in scene_parameters(module):
                raise ParameterError("--frames", "this scene has no frames parameter")
            overrides["frames"] = args.frames
        out_dir = args.out or os.path.join("runs", os.path.splitext(os.path.basename(scene_path))[0])
    module = load_scene(scene_path)
    if args.list:
        for k, v in scene_parameters(module).items():
            print(f"{k} = {v!r}")
        return 0
    require_writable(out_dir)
    device.use(args.device, args.threads)
    run = build_scene(module, overrides)
    checkpoint_every = meta.get("checkpoint_every") if args.resume else args.checkpoint_every
    if checkpoint_every is not None:
        if not isinstance(run, TimeLoop):
            raise ParameterError("--checkpoint-every", "a static solve has no steps to checkpoint")
        if checkpoint_every < 0:
            raise ParameterError("--checkpoint-every", f"must be >= 0, got {checkpoint_every}")
        run.checkpoint_every = checkpoint_every
    meta = {"scene": os.path.abspath(scene_path), "overrides": overrides, "checkpoint_every": checkpoint_every}
    if not args.resume:
        _write_meta(out_dir, meta)
    try:
        summary = run.run(out_dir, resume=bool(args.resume), progress=not args.no_progress)
    except RunError:
        if args.resume:
            _write_meta(out_dir, meta)  # the checkpoint was loaded: the run now belongs to its new end time
        raise
    if args.resume:
        _write_meta(out_dir, meta)
    rate = summary["throughput"]
    done = (f"{summary['steps']} steps to t = {summary['time']:.4g} {summary.get('time_unit', 's')}"
            if "steps" in summary else "solved")
    print(f"{summary['scene']}: {done} in {summary['wall_s']:.1f} s"
          + (f", {rate['value']:,.0f} {rate['unit']}" if rate["value"] else "")
          + f" on {summary['device']} x{summary['threads']}")
    for key, val in summary.get("analysis", {}).items():
        if isinstance(val, dict):
            for k2, v2 in val.items():
                if isinstance(v2, (int, float)):
                    print(f"  {key}.{k2} = {v2:.4g}")
    print(f"outputs in {out_dir}")
    return 0


#: parameters a resumed run may change: they move the end, not the model
RESUMABLE = ("t_end",)


def resume_overrides(pairs: list[str], previous: dict, module) -> dict:
    """``--set`` on ``--resume``: only the end time may change (the model must stay the one checkpointed)."""
    changes = parse_overrides(pairs, scene_parameters(module))
    refused = sorted(k for k in changes if k not in RESUMABLE and changes[k] != previous.get(k))
    if refused:
        raise ParameterError(refused[0], f"cannot change on --resume (the checkpoint holds a run with the earlier "
                                         f"value); only {', '.join(RESUMABLE)} can")
    for k, v in changes.items():
        if k in RESUMABLE and v != previous.get(k, scene_parameters(module).get(k)):
            print(f"warpfree: resuming with {k} = {v} (was {previous.get(k, scene_parameters(module).get(k))})",
                  file=sys.stderr)
    return changes


def require_writable(out_dir: str) -> None:
    """Refuse, naming --out, a run directory that cannot be created or written, before anything runs."""
    try:
        os.makedirs(out_dir, exist_ok=True)
        probe = os.path.join(out_dir, f".warpfree_write_test_{os.getpid()}")
        with open(probe, "w") as f:
            f.write("")
        os.remove(probe)
    except OSError as exc:
        raise ParameterError("--out", f"cannot write the run directory {out_dir}: {exc.strerror or exc}") from None


def _write_meta(out_dir: str, meta: dict) -> None:
    tmp = os.path.join(out_dir, "run.json.tmp")
    with open(tmp, "w") as f:
        json.dump(meta, f, indent=2)
    os.replace(tmp, os.path.join(out_dir, "run.json"))


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command != "run":
        parser.print_help()
        return 0
    try:
        return run_command(args)
    except ParameterError as err:
        print(f"warpfree: error: {err}", file=sys.stderr)
        return 2
    except RunError as err:
        print(f"warpfree: run stopped: {err}", file=sys.stderr)
        return 3


def entry() -> None:
    """The ``warpfree`` command: :func:`main`, then leave without tearing the interpreter down. With Warp and
    Matplotlib loaded the module clean-up at exit takes 0.2-0.3 s and does nothing a finished run needs: every
    output file is closed and the writer process has finished when :func:`main` returns."""
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    entry()
