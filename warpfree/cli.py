"""Command line: ``warpfree list``, ``warpfree run SCENE [--set name=value ...] [--out DIR] [--overwrite]
[--threads N] [--device D] [--frames/--no-frames] [--checkpoint-every K] [--resume DIR]``, ``warpfree --version``
(also ``python -m warpfree``). Exit codes: 0 done, 2 bad input (nothing run, nothing on disk lost), 3 a run that
stopped with its last good state kept, 130 (143) a run stopped by Ctrl-C (SIGTERM) with its last completed step
kept."""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import sys
import time

from . import __version__
from .errors import ParameterError, RunError, RunInterrupted
from .parallel import world
from .parallel.world import abort_on_error, world_started
from .parameters import listing, parse_overrides, scene_parameters
from .scene_loader import load_scene, scene_path, shipped_scenes, summary_line
from .stop import SIGNAL_NAMES, exit_code

DESCRIPTION = """warpfree: meshfree particle methods (WCSPH fluids, SPEM, EFG, PIC) as NVIDIA Warp kernels.

Commands:
  list      the scenes shipped with warpfree, one line each
  run       run a scene: a shipped scene's name or a path to a scene file (a Python module with build(**params)
            returning a TimeLoop or StaticRun)
  validate  run every validation case (--quick: at a short size) and print and write its table of checks
  bundle    build an offline bundle for a machine with no package index (warpfree bundle build --help)

Example:
  warpfree run dam_break_2d --set dx=0.02 --out runs/db --threads 2
"""

RUN_HELP = """Run a scene. Every parameter of the scene's build() has a default; --set overrides one
(repeat it for several; --list shows them with their types). The run directory gets summary.json, VTU files with a
PVD index (vtk/, *.pvd, open in ParaView), PNG frames (frames/) and the scene's own plots. A run directory that
already holds files is refused unless --overwrite replaces the earlier run in it. With --checkpoint-every K it also
keeps checkpoints, and --resume DIR continues such a run (bitwise the same as an uninterrupted one). Under
mpiexec -n N the scene runs over N ranks (one process each: pip install 'warpfree[mpi]'), with the same
results as one process; each rank writes its piece of every snapshot (a .pvtu joins them), rank 0 the rest."""

VALIDATE_HELP = """Run every validation case (a shipped scene with a reference: its checks compare computed
quantities with exact solutions, experiments or published results, each with a tolerance and its source) at its
default size, or with --quick at a short one. Prints each check as PASS or FAIL and writes validation.json and
validation.md into --out; --against FILE compares the table with one made before. Exit code 0 when every check
passed (and the tables agree), 1 when one failed (or they differ)."""

#: parameters a resumed run may change: they move the end, not the model
RESUMABLE = ("t_end",)
#: the file every run directory written by the command line holds (how the run was made)
RUN_JSON = "run.json"


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser: ``list``, ``run`` and ``validate`` with their options."""
    parser = argparse.ArgumentParser(prog="warpfree", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"warpfree {__version__}")
    sub = parser.add_subparsers(dest="command")
    sub.add_parser("list", help="list the shipped scenes", description="The scenes shipped with warpfree.")
    run = sub.add_parser("run", help="run a scene", description=RUN_HELP)
    run.add_argument("scene", nargs="?", help="a shipped scene's name (warpfree list) or a path to a scene file")
    run.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                     help="override a scene parameter (repeatable)")
    run.add_argument("--out", default=None, help="run directory (default: runs/<scene>)")
    run.add_argument("--overwrite", action="store_true",
                     help="replace the earlier run in --out (everything in that run directory is removed first)")
    run.add_argument("--threads", type=int, default=None,
                     help="CPU threads (default: all cores; under mpiexec, the cores shared among the ranks)")
    run.add_argument("--device", default="cpu", help="cpu (default), cuda or cuda:N (under mpiexec, cuda: one GPU "
                                                     "per rank, in turn)")
    run.add_argument("--frames", dest="frames", action="store_true", default=None, help="write PNG frames")
    run.add_argument("--no-frames", dest="frames", action="store_false", help="do not write PNG frames")
    run.add_argument("--checkpoint-every", type=int, default=None, metavar="K",
                     help="write a checkpoint every K steps (keeps the two newest)")
    run.add_argument("--sensor", action="append", default=[], metavar="NAME=KIND:X,Y[,Z][@DT]",
                     help="sample a sensor every DT seconds (default 0.001) into sensors/NAME.csv, apart from the "
                          "outputs (repeatable): pressure:X,Y[,Z][;...] (Pa at points; on a wall, its face), "
                          "height:X,Y[,Z][;...] (the water's height above floor points)")
    run.add_argument("--resume", default=None, metavar="DIR", help="continue the run in DIR from its last checkpoint")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--list", action="store_true", help="list the scene's parameters, types and defaults, then exit")
    check = sub.add_parser("validate", help="run the validation cases and tabulate their checks",
                           description=VALIDATE_HELP)
    check.add_argument("--quick", action="store_true", help="each case at its short QUICK settings")
    check.add_argument("--scenes", default=None, metavar="A,B", help="only these cases (default: all)")
    check.add_argument("--out", default=None, help="directory for the cases' runs and the tables "
                                                   "(default: runs/validate or runs/validate_quick)")
    check.add_argument("--overwrite", action="store_true", help="replace an earlier validation in --out")
    check.add_argument("--table", default=None, metavar="FILE", help="also write the Markdown table to FILE")
    check.add_argument("--against", default=None, metavar="FILE",
                       help="compare with a table made before (e.g. the documentation's): exit code 1 when a case, "
                            "quantity, reference, tolerance or result differs or a value moved by more than 1 %% of "
                            "max(|value|, tolerance)")
    check.add_argument("--threads", type=int, default=None, help="CPU threads (default: all cores)")
    check.add_argument("--device", default="cpu", help="cpu (default), cuda or cuda:N")
    from .bundle.build import add_arguments as add_bundle_arguments

    add_bundle_arguments(sub.add_parser("bundle", help="build or verify an offline bundle",
                                        description="Offline bundles for a machine with no package index."))
    return parser


def list_command() -> int:
    """``warpfree list``: each shipped scene's name and the first line of its docstring."""
    scenes = shipped_scenes()
    width = max(len(name) for name in scenes)
    for name, path in scenes.items():
        print(f"{name:{width}s}  {summary_line(path)}")
    print("\nwarpfree run NAME runs one (warpfree run NAME --list shows its parameters)")
    return 0


def run_command(args) -> int:
    """``warpfree run``: load the scene, build it with the ``--set`` overrides, run it into ``--out`` (or resume one),
    print its summary; the exit code."""
    started = time.perf_counter()  # the run's set-up starts here: loading the scene and Warp, building it
    from . import device, progress
    from .run import build_scene
    from .sensors import parse_sensor
    from .time_loop import TimeLoop

    meta = {}
    if args.resume:
        meta = read_meta(args.resume)
        scene_file, overrides, out_dir = meta["scene"], dict(meta["overrides"]), args.resume
        if args.scene and os.path.abspath(scene_path(args.scene)) != os.path.abspath(scene_file):
            raise ParameterError("--resume", f"the run in {args.resume} is of {scene_file}, not {args.scene}")
        if args.out and os.path.abspath(args.out) != os.path.abspath(args.resume):
            raise ParameterError("--out", f"a resumed run continues in its own directory {args.resume}; "
                                          "copy it first to continue elsewhere")
        if args.overwrite:
            raise ParameterError("--overwrite", "a resumed run continues its directory; it cannot also replace it")
        module = load_scene(scene_file)
        overrides.update(resume_overrides(args.overrides, overrides, module, time_reached(out_dir)))
    else:
        if not args.scene:
            raise ParameterError("scene", "give a scene's name or file, e.g. warpfree run dam_break_2d "
                                          "(warpfree list shows the shipped scenes)")
        scene_file = scene_path(args.scene)
        module = load_scene(scene_file)
        parameters = scene_parameters(module)
        if args.list:
            for line in listing(parameters):
                print(line)
            return 0
        overrides = parse_overrides(args.overrides, parameters)
        if args.frames is not None:
            if "frames" not in parameters:
                raise ParameterError("--frames", "this scene has no frames parameter")
            overrides["frames"] = args.frames
        out_dir = args.out or os.path.join("runs", os.path.splitext(os.path.basename(scene_file))[0])
        require_fresh(out_dir, args.overwrite)
    sensor_specs = list(meta.get("sensors", [])) + list(args.sensor)
    sensors = [parse_sensor(spec) for spec in sensor_specs]  # a malformed one refused before any set-up
    names = [s.name for s in sensors]
    if len(set(names)) != len(names):
        raise ParameterError("--sensor", f"two sensors are named {sorted(n for n in names if names.count(n) > 1)[0]!r}")
    ranks = world()
    progress.enable(not args.no_progress and ranks.is_root)
    ranks.barrier()  # every rank has looked at the run directory before rank 0 writes in it
    if ranks.is_root:
        require_writable(out_dir)
    device.use(*rank_device(args.device, args.threads, ranks))
    run = build_scene(module, overrides, started)
    if args.resume and isinstance(run, TimeLoop):
        require_end_after(run.t_end, time_reached(out_dir, run.output_interval))
    checkpoint_every = meta.get("checkpoint_every") if args.resume else args.checkpoint_every
    if checkpoint_every is not None:
        if not isinstance(run, TimeLoop):
            raise ParameterError("--checkpoint-every", "a static solve has no steps to checkpoint")
        if checkpoint_every < 0:
            raise ParameterError("--checkpoint-every", f"must be >= 0, got {checkpoint_every}")
        run.checkpoint_every = checkpoint_every
    if sensors and not isinstance(run, TimeLoop):
        raise ParameterError("--sensor", "a static solve has no time to sample; its fields are in its outputs")
    for sensor in sensors:
        run.add_sensor(sensor)
    meta = {"scene": os.path.abspath(scene_file), "overrides": overrides, "checkpoint_every": checkpoint_every,
            "sensors": sensor_specs}
    if ranks.is_root:
        if not args.resume and args.overwrite:
            clear_run_directory(out_dir)  # only now: a refused build above leaves the earlier run as it was
        if not args.resume:
            _write_meta(out_dir, meta)
    ranks.barrier()
    try:
        summary = run.run(out_dir, resume=bool(args.resume), progress=not args.no_progress)
    except RunError:
        if args.resume and ranks.is_root:
            _write_meta(out_dir, meta)  # the checkpoint was loaded: the run now belongs to its new end time
        raise
    if args.resume and ranks.is_root:
        _write_meta(out_dir, meta)
    ranks.barrier()  # every rank's pieces are written
    if ranks.is_root:
        print_summary(summary, out_dir)
    return 0


def validate_command(args) -> int:
    """``warpfree validate``: run the validation cases, write and print their table, compare it with ``--against``; the
    exit code."""
    from . import device
    from .run import write_json
    from .validate import markdown_table, read_table, run_cases, selected_cases, table_differences

    names = None
    if args.scenes is not None:
        names = [n.strip() for n in args.scenes.split(",") if n.strip()]
        if not names:
            raise ParameterError("--scenes", f"names no case, got {args.scenes!r}")
    selected_cases(names)  # unknown names refused before anything is made
    earlier = None
    if args.against:
        try:
            with open(args.against, encoding="utf-8") as f:
                earlier = f.read()
            read_table(earlier)
        except (OSError, ValueError) as err:
            raise ParameterError("--against", f"cannot read a validation table from {args.against}: {err}") from None
    device.use(args.device, args.threads)
    out_dir = args.out or os.path.join("runs", "validate_quick" if args.quick else "validate")
    require_fresh(out_dir, args.overwrite, marker="validation.json")
    require_writable(out_dir)
    if args.table:
        require_writable(os.path.dirname(os.path.abspath(args.table)), "--table")
    if args.overwrite:
        clear_run_directory(out_dir)
    report = run_cases(names, args.quick, out_dir)
    table = markdown_table(report)
    write_json(os.path.join(out_dir, "validation.json"), report)
    for path in [os.path.join(out_dir, "validation.md")] + ([args.table] if args.table else []):
        with open(path, "w") as f:
            f.write(table)
    checks = [c for case in report["cases"] if case["validation"] for c in case["validation"]["checks"].values()]
    failed = sum(not c["passed"] for c in checks) + sum(not case["validation"] for case in report["cases"])
    print(f"validation: {len(report['cases'])} cases, {len(checks)} checks, "
          f"{'all passed' if report['passed'] else f'{failed} FAILED'}; tables in {out_dir}")
    differences = table_differences(earlier, report) if earlier is not None else []
    if earlier is not None:
        for line in differences:
            print(f"  DIFFERS {line}")
        print(f"against {args.against}: " + (f"{len(differences)} differences" if differences else "the same table"))
    return 0 if report["passed"] and not differences else 1


def rank_device(device_name: str, threads: int | None, ranks) -> tuple[str, int | None]:
    """The device and CPU threads of this rank: in a distributed run each rank takes its share of the cores (at
    least one), and ``cuda`` the rank's GPU in turn (rank mod the GPUs)."""
    if not ranks.distributed:
        return device_name, threads
    from .device import default_threads, gpu_count

    if threads is None:
        threads = max(1, default_threads() // ranks.size)
    if device_name == "cuda":
        count = gpu_count()
        if count:
            device_name = f"cuda:{ranks.rank % count}"
    return device_name, threads


def print_summary(summary: dict, out_dir: str) -> None:
    """The lines a run ends with: steps and the whole time with its parts, throughput, the analyses' numbers, each check
    as PASS or FAIL last."""
    rate = summary["throughput"]
    done = f"{summary['steps']} steps to t = {_sim_time(summary)}" if "steps" in summary else "solved"
    print(f"{summary['scene']}: {done} in {_times(summary)}"
          + (f", {rate['value']:,.0f} {rate['unit']}" if rate["value"] else "")
          + f" on {summary['device']} x{summary['threads']}")
    for key, val in summary.get("analysis", {}).items():
        if isinstance(val, dict):
            for k2, v2 in val.items():
                if isinstance(v2, (int, float)) and not isinstance(v2, bool):
                    print(f"  {key}.{k2} = {v2:.4g}")
                elif isinstance(v2, dict):      # quantities with units ({"value", "unit"}), e.g. a plasma's SI block
                    for group in v2.values():
                        for name, q in (group.items() if isinstance(group, dict) else ()):
                            if isinstance(q, dict) and set(q) == {"value", "unit"}:
                                print(f"  {key}.{k2}.{name} = {q['value']:.4g} {q['unit']}")
    validation = summary.get("validation")
    if validation:                  # last, so that they are seen
        from .validation import check_lines

        for line in check_lines(validation):
            print(f"  {line}")
        print(f"  validation: {'passed' if validation['passed'] else 'FAILED'} "
              f"({sum(c['passed'] for c in validation['checks'].values())}/{len(validation['checks'])} checks)")
    print(f"outputs in {out_dir}")


def _sim_time(summary: dict) -> str:
    """The simulated time reached, in the progress bar's unit (``4.75 ns``, ``0.8 s``, ``25.13 /ω_pe``)."""
    from .progress import time_scale

    factor, unit = time_scale(summary.get("t_end", summary["time"]), summary.get("time_unit", "s"))
    return f"{summary['time'] / factor:.4g} {unit}"


def _times(summary: dict) -> str:
    """``229.0 s (set-up 102.0 s, run 123.8 s)``: the whole wall time, then its parts (set-up: loading and building
    the scene; run: stepping or solving and writing; analysis when it took a tenth of a second or more)."""
    phases = summary.get("phases_s", {})
    setup, run_s = phases.get("setup", 0.0), summary["wall_s"]
    analysis = phases.get("analysis", 0.0)
    total = summary.get("total_s", setup + run_s + analysis)
    parts = [f"set-up {setup:.1f} s", f"run {run_s:.1f} s"] + ([f"analysis {analysis:.1f} s"] if analysis >= 0.1
                                                                 else [])
    return f"{total:.1f} s ({', '.join(parts)})"


def read_meta(run_dir: str) -> dict:
    """The ``run.json`` of a run directory (how the command line ran it), or ParameterError naming --resume."""
    meta_path = os.path.join(run_dir, RUN_JSON)
    if not os.path.isfile(meta_path):
        raise ParameterError("--resume", f"{run_dir} has no {RUN_JSON} (not a warpfree run directory)")
    try:
        with open(meta_path) as f:
            meta = json.load(f)
        meta["scene"], meta["overrides"] = str(meta["scene"]), dict(meta["overrides"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ParameterError("--resume", f"{meta_path} is damaged: {exc}") from None
    return meta


def resume_overrides(pairs: list[str], previous: dict, module, reached: float = 0.0) -> dict:
    """``--set`` on ``--resume``: only the end time may change (the model must stay the one checkpointed), and not
    to before ``reached``, the time the run directory already holds."""
    parameters = scene_parameters(module)
    changes = parse_overrides(pairs, parameters)
    refused = sorted(k for k in changes if k not in RESUMABLE and changes[k] != previous.get(k))
    if refused:
        raise ParameterError(refused[0], f"cannot change on --resume (the checkpoint holds a run with the earlier "
                                         f"value); only {', '.join(RESUMABLE)} can")
    if changes.get("t_end"):
        require_end_after(changes["t_end"], reached)
    for k, v in changes.items():
        before = previous.get(k, parameters[k].default)
        if k in RESUMABLE and v != before:
            _say(f"warpfree: resuming with {k} = {v} (was {before})")
    return changes


def time_reached(run_dir: str, output_interval: float | None = None) -> float:
    """The latest simulated time a run directory holds: its summary's time, the last snapshot of its VTU series and,
    given the run's output interval, its last frame (frames are numbered by output); less the run's constant step
    where it has one (such a run ends at the first step at or after its end: any end within a step of the time
    reached reaches it again)."""
    from .io.vtk import read_pvd

    times, slack = [0.0], 0.0
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            summary = json.load(f)
        times.append(float(summary["time"]))
        slack = float(summary.get("constant_step") or 0.0)
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass
    for entry in os.scandir(run_dir):
        if entry.name.endswith(".pvd"):
            try:
                times += [t for t, _ in read_pvd(entry.path)]
            except Exception:  # a damaged index: the resume rewrites it
                pass
    frames = os.path.join(run_dir, "frames")
    if output_interval and os.path.isdir(frames):
        numbers = [int(m.group(1)) for m in map(FRAME_NUMBER.search, os.listdir(frames)) if m]
        times += [max(numbers) * output_interval] if numbers else []
    return max(0.0, max(times) - slack)


#: the output number of a frame file (``frame_00012.png``, ``particles_phi_00012.png``)
FRAME_NUMBER = re.compile(r"_(\d{5})\.png$")


def require_end_after(t_end: float, reached: float) -> None:
    """A resume must not end before the time its run directory already holds: the outputs after the new end would
    stay beside a summary that ends earlier."""
    if t_end < reached * (1.0 - 1e-12):
        raise ParameterError("t_end", f"{t_end:.6g} is before the time this run already reached ({reached:.6g}; its "
                                      f"outputs up to then stay on disk): a resume can only end at or after it")


def require_fresh(out_dir: str, overwrite: bool, marker: str = RUN_JSON) -> None:
    """Refuse, naming --out, a run directory that already holds files, unless ``overwrite`` is given and it is a
    warpfree directory (it holds ``marker``; then it is cleared once the scene has built:
    :func:`clear_run_directory`)."""
    if not os.path.isdir(out_dir) or not os.listdir(out_dir):
        if os.path.exists(out_dir) and not os.path.isdir(out_dir):
            raise ParameterError("--out", f"{out_dir} is a file, not a directory")
        return
    if not overwrite:
        raise ParameterError("--out", f"{out_dir} already holds files (an earlier run?): give --overwrite to replace "
                                      "that run, --resume to continue it, or another --out")
    if not os.path.isfile(os.path.join(out_dir, marker)):
        raise ParameterError("--overwrite", f"{out_dir} holds files but is not a warpfree run directory (no "
                                            f"{marker}): nothing is removed; choose another --out")


def clear_run_directory(out_dir: str) -> None:
    """Remove everything in a warpfree run directory (``--overwrite``), keeping the directory."""
    for entry in os.scandir(out_dir):
        if entry.is_dir(follow_symlinks=False):
            shutil.rmtree(entry.path)
        else:
            os.remove(entry.path)


def require_writable(out_dir: str, option: str = "--out") -> None:
    """Refuse, naming ``option``, a directory that cannot be created or written, before anything runs."""
    try:
        os.makedirs(out_dir, exist_ok=True)
        probe = os.path.join(out_dir, f".warpfree_write_test_{os.getpid()}")
        with open(probe, "w") as f:
            f.write("")
        os.remove(probe)
    except OSError as exc:
        raise ParameterError(option, f"cannot write the directory {out_dir}: {exc.strerror or exc}") from None


def _write_meta(out_dir: str, meta: dict) -> None:
    tmp = os.path.join(out_dir, RUN_JSON + ".tmp")
    with open(tmp, "w") as f:
        json.dump(meta, f, indent=2)
    os.replace(tmp, os.path.join(out_dir, RUN_JSON))


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv``); the exit code: 0 done, 1 a validation failed, 2 bad
    input, 3 a run stopped by a fault, 130 (143) a run stopped by Ctrl-C (SIGTERM)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "list":
            return list_command()
        if args.command == "run":
            return run_command(args)
        if args.command == "validate":
            return validate_command(args)
        if args.command == "bundle":
            from .bundle.build import bundle_command

            return bundle_command(args)
    except ParameterError as err:
        _say(f"warpfree: error: {err}")
        return 2
    except RunError as err:
        _say(f"warpfree: run stopped: {err}")
        return 3
    except RunInterrupted as stop:
        _say(f"warpfree: {interrupted_text(stop)}")
        return exit_code(stop.signum)
    except KeyboardInterrupt as stop:  # during set-up, or a second Ctrl-C or SIGTERM in the middle of a step
        signum = getattr(stop, "signum", signal.SIGINT)
        _say(f"warpfree: interrupted by {SIGNAL_NAMES[signum]}; what the run had written stays as it was")
        return exit_code(signum)
    finally:
        from .progress import enable

        enable(False)  # a run's announcements end with it (main is also called in-process, by tests)
    parser.print_help()
    return 0


def interrupted_text(stop: RunInterrupted) -> str:
    """The one line a run stopped by Ctrl-C or SIGTERM ends with: where it stopped, what it kept, how to go on."""
    text = f"stopped by {SIGNAL_NAMES.get(stop.signum, f'signal {stop.signum}')}"
    if stop.step is not None:
        text += f" after step {stop.step}"
    if stop.kept:
        run_dir = os.path.dirname(os.path.dirname(stop.kept))
        text += (f"; its outputs are written and its state is kept in {stop.kept}: continue with "
                 f"warpfree run --resume {run_dir}")
    return text


def _say(message: str) -> None:
    """An error line on stderr (in a distributed run from rank 0 only: every rank meets the same error)."""
    try:
        root = world().is_root
    except ParameterError:  # MPI missing: this is the error being said, by every rank alike
        root = True
    if root:
        print(message, file=sys.stderr)


def entry() -> None:
    """The ``warpfree`` command: :func:`main`, then leave without tearing the interpreter down. With Warp and
    Matplotlib loaded the module clean-up at exit takes a few tenths of a second and does nothing a finished run
    needs: every output file is closed and the writer process has finished when :func:`main` returns."""
    try:
        code = main()
        sys.stdout.flush()
    except BrokenPipeError:  # the reader of our output has gone (warpfree list | head): nothing left to say
        code = 0
    except BaseException:
        if world_started() and world().distributed:  # one rank's fault must not leave the others waiting
            import traceback

            traceback.print_exc()
            sys.stderr.flush()
            abort_on_error(1)
        raise
    sys.stderr.flush()
    if "mpi4py.MPI" in sys.modules:  # a distributed run ends its MPI before leaving (os._exit skips atexit)
        from mpi4py import MPI

        if MPI.Is_initialized() and not MPI.Is_finalized():
            MPI.Finalize()
    os._exit(code)


if __name__ == "__main__":
    entry()
