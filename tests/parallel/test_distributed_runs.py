"""Scenes under ``mpiexec -n 2`` and ``-n 3`` (oversubscribed on a CI machine): the same outputs as one process,
bitwise (every snapshot, the probes, the diagnostics and the analyses), a ParaView index of the ranks' pieces, the
ranks' part of the summary, and the refusals of a distributed run."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import pytest

from helpers import ROOT
from helpers.runs import (field_differences, relative_differences, smallest_sets, smallest_sets_then,
                          snapshot_differences, summary)
from warpfree.cli import main
from warpfree.parallel import MPI_EXTRA
from warpfree.parallel.launch import find_mpiexec, run_ranks
from warpfree.parallel.petsc_system import PETSC_EXTRA

needs_mpi = pytest.mark.skipif(find_mpiexec() is None, reason=f"no MPI here: {MPI_EXTRA}")

#: (page, code) of the documentation's ```python blocks (a tutorial's scene run over ranks as written)
DOC_BLOCKS = [(str(page.relative_to(ROOT / "docs")), code) for page in sorted((ROOT / "docs").rglob("*.md"))
              for code in re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), re.S | re.M)]

#: (scene, ranks): walls and a rebalancing cut (2D dam break), a rank that starts with no fluid (3D), periodic
#: axes cut across (Taylor-Green, Poiseuille), a wall moving along its surface (the cavity's lid), a settled tank given its wave (standing wave); SPEM in 1D, with a PML
#: and a point source (waveguide), with a total-field box (plane wave), with an object and DFT and flux monitors
#: (scatterer, slab); the example solver in a doubly periodic box
#: (heat conduction: its 16 × 16 particles cut in 2 and in 3)
CASES = [("dam_break_2d", 2), ("dam_break_2d", 3), ("dam_break_3d", 3), ("taylor_green_2d", 3),
         ("poiseuille_2d", 2), ("lid_driven_cavity_2d", 3), ("standing_wave_2d", 2), ("em_line_1d", 3), ("em_waveguide_2d", 3),
         ("em_plane_wave_2d", 2), ("em_cavity_2d", 2), ("em_scatterer_2d", 3), ("em_slab_1d", 2),
         ("heat_conduction_2d", 2), ("heat_conduction_2d", 3)]

#: (scene, ranks, settings): model options with a halo exchange of their own (the renormalised density gradient),
#: held per rank (the walls' velocity factor) or reshaping the layout (a conductor cut out of it)
OPTION_CASES = [("dam_break_2d", 3, ["--set", "delta_gradient=true"]),
                ("lid_driven_cavity_2d", 3, ["--set", "lid_ramp=0.4"]),
                ("em_scatterer_2d", 2, ["--set", "cylinder=conductor"]),
                ("em_slab_1d", 3, ["--set", "plasma_frequency=1e9", "--set", "collision_rate=6.283e8"])]

#: the model's count of each scene family's main set, and the set's name in the distributed layout and the outputs
MAIN_SETS = {"n_fluid": "fluid", "n_electric": "electric", "n_particles": "particles"}


def run_distributed(ranks: int, args: list[str]) -> subprocess.CompletedProcess:
    return run_ranks(ranks, ["-m", "warpfree", *args], timeout=900)


@needs_mpi
@pytest.mark.parametrize("scene,ranks,settings", [
    pytest.param(scene, ranks, settings, id="-".join([scene, str(ranks), *settings[1::2]]))
    for scene, ranks, settings in [(scene, ranks, []) for scene, ranks in CASES] + OPTION_CASES])
def test_a_distributed_run_gives_the_one_process_outputs_bitwise(scene, ranks, settings, tmp_path):
    sets = smallest_sets_then(scene, settings)
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", scene, *sets, "--out", str(one), "--no-progress", "--no-frames", "--threads", "1"]) == 0
    done = run_distributed(ranks, ["run", scene, *sets, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.count(f"{scene}:") == 1                      # rank 0 alone reports
    assert snapshot_differences(one, many) == []
    for table in (one / "monitors").glob("*.csv"):  # the monitors' transforms: every rank's particles, one file
        assert (many / "monitors" / table.name).read_bytes() == table.read_bytes(), table.name
    a, b = summary(one), summary(many)
    for key in ("probes", "steps", "time"):
        assert a[key] == b[key], key
    for key in ("diagnostics", "analysis"):
        assert relative_differences(a[key], b[key]) == {}, key
    assert b["ranks"]["size"] == ranks and len(b["ranks"]["phases_s"]) == ranks
    memory = b["memory"]  # every rank's bytes, the whole run's per item
    assert len(memory["bytes_per_rank"]) == ranks and min(memory["bytes_per_rank"]) > 0
    assert memory["per_item"] == sum(memory["bytes_per_rank"]) / b["throughput"]["work_items"]
    spread = b["model"]["distributed"]
    assert spread["ghost_fraction"] > 0
    count, main_set = next((k, v) for k, v in MAIN_SETS.items() if k in a["model"])
    assert sum(spread[f"{main_set}_owned"]) == a["model"][count]
    assert list((many / "vtk").glob(f"{main_set}_*_0001.vtu")) and list((many / "vtk").glob(f"{main_set}_*.pvtu"))


@needs_mpi
@pytest.mark.parametrize("scene,settings", [
    ("carried_tank", []), ("floating_box_2d", ["--set", "dx=0.04", "--set", "settle=0", "--set", "t_end=0.6"]),
    ("heave_decay_2d", ["--set", "per_radius=4", "--set", "depth=3", "--set", "half_length=4", "--set", "settle=0.5",
                        "--set", "t_end=2", "--set", "output_interval=0.5"])])
def test_a_rigid_body_moves_across_the_ranks_bitwise(scene, settings, tmp_path):
    """A tank, a rigid body, carried 1 m along x (2.5 tank widths) on 3 ranks: its walls, cut among the ranks at the
    start, follow it into other ranks' boxes at the rebuilds, and its water with them; a floating box, its load
    summed over the ranks' walls in their global order; a cylinder held while the water settles, then released: the
    one process's outputs, bitwise (the sensors too)."""
    from pathlib import Path

    if scene == "carried_tank":
        scene = str(Path(__file__).parents[1] / "helpers" / "carried_tank_scene.py")
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", scene, *settings, "--out", str(one), "--no-progress", "--no-frames", "--threads", "1"]) == 0
    done = run_distributed(3, ["run", scene, *settings, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    assert snapshot_differences(one, many) == []
    for table in (one / "monitors").glob("*.csv"):  # the monitors' transforms: every rank's particles, one file
        assert (many / "monitors" / table.name).read_bytes() == table.read_bytes(), table.name
    a, b = summary(one), summary(many)
    assert a["steps"] == b["steps"] and relative_differences(a["diagnostics"], b["diagnostics"]) == {}
    assert sum(b["model"]["distributed"]["fluid_owned"]) == a["model"]["n_fluid"]
    for csv in (one / "sensors").glob("*.csv"):
        assert csv.read_bytes() == (many / "sensors" / csv.name).read_bytes(), csv.name


#: (scene, settings, the probes of its particles made and taken out): a channel (no δ-SPH); the flow past a cylinder
#: (δ-SPH, shifting, an obstacle with a force sensor) with outputs every 0.02 D/U: there an outlet's buffer particle,
#: past the buffer's far end before its rebuild, reads the fluid about its mirror point in another rank's box (without
#: that fluid held as ghosts its density differed by 2 units in the last place at t = 0.28 D/U)
OPEN_CASES = [("channel_flow_2d", [], "inlet_made", "outlet_taken_out"),
              ("cylinder_flow_2d", ["--set", "output_interval=0.02"], "made", "taken_out")]


@needs_mpi
@pytest.mark.parametrize("scene,settings,made,taken_out", OPEN_CASES, ids=[c[0] for c in OPEN_CASES])
def test_water_entering_and_leaving_across_the_ranks_keeps_the_one_process_ids_bitwise(scene, settings, made,
                                                                                       taken_out, tmp_path):
    """Water between an inlet and an outlet on 3 ranks: the particles each rank makes at the inlet take the one
    process's ids (in the crossing particles' id order over every rank), those beyond the outlet leave whichever rank
    holds them; every snapshot (in id order), the probes, the sensors and the openings' counts as the one process's,
    bitwise."""
    sets = smallest_sets_then(scene, settings)
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", scene, *sets, "--out", str(one), "--no-progress", "--no-frames", "--threads", "1"]) == 0
    done = run_distributed(3, ["run", scene, *sets, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    assert snapshot_differences(one, many) == []
    for table in (one / "monitors").glob("*.csv"):  # the monitors' transforms: every rank's particles, one file
        assert (many / "monitors" / table.name).read_bytes() == table.read_bytes(), table.name
    a, b = summary(one), summary(many)
    assert a["steps"] == b["steps"] and a["probes"] == b["probes"]
    assert a["probes"][made][-1] > 0 and a["probes"][taken_out][-1] > 0
    assert relative_differences(a["analysis"], b["analysis"]) == {}
    assert relative_differences(a["diagnostics"], b["diagnostics"]) == {}
    assert sum(b["model"]["distributed"]["fluid_owned"]) == a["probes"]["particles"][-1]
    for csv in (one / "sensors").glob("*.csv"):
        assert csv.read_bytes() == (many / "sensors" / csv.name).read_bytes(), csv.name


@needs_mpi
@pytest.mark.parametrize("scene,ranks", [("pic_plasma_oscillation", 2), ("pic_two_stream", 3)])
def test_a_distributed_plasma_moves_its_particles_bitwise_and_sums_them_to_round_off(scene, ranks, tmp_path):
    """The particles (every snapshot, in id order) and the nodal charge and potential bitwise; the step's particle
    sums (kinetic energy, momentum: each rank's own particles', added) to round-off, the momentum being round-off
    itself (< 1e-12 of the box's particle momentum scale)."""
    sets = smallest_sets(scene)
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", scene, *sets, "--out", str(one), "--no-progress", "--no-frames", "--threads", "1"]) == 0
    done = run_distributed(ranks, ["run", scene, *sets, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    assert snapshot_differences(one, many) == []
    for table in (one / "monitors").glob("*.csv"):  # the monitors' transforms: every rank's particles, one file
        assert (many / "monitors" / table.name).read_bytes() == table.read_bytes(), table.name
    a, b = summary(one), summary(many)
    for section in ("analysis", "diagnostics"):
        for key, rel in relative_differences(a[section], b[section]).items():
            if "momentum" in key:
                assert abs(_at(a[section], key) - _at(b[section], key)) < 1e-12, key
            else:
                assert rel < 1e-12, key
    assert sum(b["model"]["distributed"]["particles_owned"]) == a["model"]["particles"]


#: the vacuum diode beyond its space-charge limit (6 Γ_CL), small: its source fills an empty box (cut over the nodes),
#: the beam reaches the anode and its virtual cathode turns electrons back to the cathode within 80 steps, so both
#: walls absorb; as wide as the gap, the box is cut across x first (2 ranks: both share each wall, and particles
#: absorbed near the cut are ghosts on the other rank), then across y (3 ranks: the beam crosses from rank to rank)
#: (t_end set by each test)
DIODE = smallest_sets("pic_diode", without=("t_end", "particles_per_step", "output_every", "width")) + [
    "--set", "width=1.0", "--set", "injected_fraction=6", "--set", "particles_per_step=10", "--set", "output_every=10"]
#: the diode's history columns a distributed run gives bitwise: the tallies every rank keeps alike or sums as integers,
#: and the terms of the replicated field
OPEN_TALLIES = ("particles", "injected_charge", "wall_charge_lower", "wall_charge_upper", "deposited_charge",
                "field_energy")


@needs_mpi
@pytest.mark.parametrize("ranks", [2, 3])
def test_a_distributed_diode_injects_and_absorbs_its_particles_bitwise(ranks, tmp_path):
    """A wall source and absorbing walls on several ranks: every snapshot (the particles' positions, velocities and
    ids, the nodes' potential and charge) bitwise the one process's; the tallies (live count, injected charge, each
    wall's charge) and the field terms bitwise, and so the analysis made of them (currents, charge balance); the
    particle sums (kinetic energy, momentum) to round-off (< 1e-12: another order of the same additions)."""
    one, many = tmp_path / "one", tmp_path / "many"
    sets = [*DIODE, "--set", "t_end=1.6"]
    assert main(["run", "pic_diode", *sets, "--out", str(one), "--no-progress", "--no-frames", "--threads", "1"]) == 0
    done = run_distributed(ranks, ["run", "pic_diode", *sets, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    a, b = summary(one), summary(many)
    assert a["diagnostics"]["wall_charge_lower"] < 0 and a["diagnostics"]["wall_charge_upper"] < 0  # both absorbed
    assert snapshot_differences(one, many) == []
    for key in OPEN_TALLIES:
        assert a["diagnostics"][key] == b["diagnostics"][key], key
    for key, rel in relative_differences(a["diagnostics"], b["diagnostics"]).items():
        assert (abs(a["diagnostics"][key] - b["diagnostics"][key]) if "momentum" in key else rel) < 1e-12, key
    assert relative_differences(a["analysis"], b["analysis"]) == {}
    owned = b["model"]["distributed"]["particles_owned"]
    assert sum(owned) == a["model"]["particles"] and min(owned) > 0


@needs_mpi
def test_a_distributed_diode_resumes_on_another_rank_count_and_in_one_process_bitwise(tmp_path):
    """Stopped on 2 ranks after particles were injected and absorbed at both walls (the checkpoint's ids are sparse),
    resumed on 3 ranks and in one process: each continues as the uninterrupted one-process run, its snapshots, tallies
    and analysis bitwise."""
    sets = DIODE
    full, part = tmp_path / "full", tmp_path / "part"
    assert main(["run", "pic_diode", *sets, "--set", "t_end=1.8", "--out", str(full), "--no-progress", "--no-frames",
                 "--threads", "1"]) == 0
    done = run_distributed(2, ["run", "pic_diode", *sets, "--set", "t_end=1.4", "--checkpoint-every", "7",
                               "--out", str(part), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    stopped = summary(part)["diagnostics"]
    assert stopped["wall_charge_lower"] < 0 and stopped["wall_charge_upper"] < 0
    for ranks in (3, 1):
        again, done = resume_copy(part, tmp_path / f"again_{ranks}", ranks, "1.8")
        assert "resuming from step 70 written by 2 process(es)" in done.stderr
        assert snapshot_differences(full, again) == [], ranks
        a, b = summary(full), summary(again)
        for key in OPEN_TALLIES:
            assert a["diagnostics"][key] == b["diagnostics"][key], (ranks, key)
        assert relative_differences(a["analysis"], b["analysis"]) == {}, ranks


#: a loaded plasma with open boundaries: warm electrons and ions (cut over their positions) between grounded absorbing
#: walls, both species leaving through both walls, and a thermal source on the upper wall whose particles (ids after
#: the 1200 loaded ones) enter at random places along it and move sideways across the cuts
OPEN_PLASMA_SCENE = '''"""Warm electrons and ions between absorbing walls, a thermal source on the upper wall."""
import numpy as np

from warpfree.galerkin.mls import MLSModel, MLSSettings
from warpfree.solvers.pic import Injection, PICSolver, PlasmaPoisson, Species, load_species, random_positions
from warpfree.solvers.pic.scene_tools import lattice_nodes, walled_box
from warpfree.time_loop import TimeLoop


def build(t_end: float = 3.0):
    space = walled_box(1.0, 1.0)
    model = MLSModel(lattice_nodes(space, 0.125), MLSSettings(d_max=2.0), space=space)
    rng = np.random.default_rng(3)
    loads = [load_species(Species(name, q, m, 1.0, temperature=0.01), space, random_positions(space, 600, rng),
                          rng=rng) for name, q, m in (("e", -1.0, 1.0), ("i", 1.0, 4.0))]
    source = Injection(Species("hot", -1.0, 1.0, 0.5, temperature=0.04), "upper", 7.5, seed=11)
    solver = PICSolver(PlasmaPoisson(model, walls=(0.0, 0.0)), loads, 0.1, particle_walls="absorb",
                       injections=[source], modes=())
    return TimeLoop(solver, t_end=t_end, output_interval=0.5)
'''


@needs_mpi
def test_a_loaded_plasma_with_a_source_and_absorbing_walls_runs_and_resumes_bitwise_on_any_rank_count(tmp_path):
    """Run on 2 ranks to t = 2 with checkpoints, resumed on 3 ranks and in one process to t = 3: every snapshot (the
    2-rank run's, then the resumed runs') bitwise the uninterrupted one-process run's, and its tallies (live count,
    injected and each wall's charge) bitwise."""
    scene = tmp_path / "open_plasma.py"
    scene.write_text(OPEN_PLASMA_SCENE, encoding="utf-8")
    full, part = tmp_path / "full", tmp_path / "part"
    assert main(["run", str(scene), "--out", str(full), "--no-progress", "--threads", "1"]) == 0
    done = run_distributed(2, ["run", str(scene), "--set", "t_end=2.0", "--checkpoint-every", "5", "--out", str(part),
                               "--no-progress"])
    assert done.returncode == 0, done.stderr[-3000:]
    a = summary(full)["diagnostics"]
    assert a["wall_charge_lower"] < 0 and a["wall_charge_upper"] < 0 and a["injected_charge"] < 0
    for ranks in (3, 1):
        again, done = resume_copy(part, tmp_path / f"again_{ranks}", ranks, "3.0")
        assert "resuming from step 20 written by 2 process(es)" in done.stderr
        assert snapshot_differences(full, again) == [], ranks
        b = summary(again)["diagnostics"]
        for key in OPEN_TALLIES:
            assert a[key] == b[key], (ranks, key)


def _at(tree: dict, key: str):
    for part in key.split("/"):
        tree = tree[int(part)] if isinstance(tree, list) else tree[part]
    return tree


@needs_mpi
def test_a_distributed_run_resumes_bitwise_on_its_rank_count_on_another_and_in_one_process(tmp_path):
    """A 2-rank run stopped at an output time (the step landing is then the uninterrupted run's) after its fluid has
    moved between ranks, resumed on 2 ranks, on 3 and in one process: each continues as the uninterrupted run."""
    sets = ["--set", "dx=0.1", "--set", "output_interval=0.02"]
    full, part = tmp_path / "full", tmp_path / "part"
    assert main(["run", "dam_break_2d", *sets, "--set", "t_end=0.1", "--out", str(full), "--no-progress",
                 "--no-frames"]) == 0
    done = run_distributed(2, ["run", "dam_break_2d", *sets, "--set", "t_end=0.06", "--checkpoint-every", "7",
                               "--out", str(part), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    pieces = sorted(p.name for p in (part / "checkpoints").glob("*.npz"))
    assert pieces[-2:] == ["step_00000056_rank_0000_of_0002.npz", "step_00000056_rank_0001_of_0002.npz"], pieces
    for ranks in (2, 3, 1):
        again, done = resume_copy(part, tmp_path / f"again_{ranks}", ranks, "0.1")
        assert "resuming from step 56 written by 2 process(es)" in done.stderr
        assert snapshot_differences(full, again) == [], ranks
        assert summary(full)["probes"] == summary(again)["probes"], ranks


def resume_copy(part, again, ranks: int, t_end: str):
    """Copy the interrupted run ``part`` to ``again`` and resume it there to ``t_end`` on ``ranks`` ranks (1: one
    process, no launcher); the completed process (asserted to have succeeded)."""
    shutil.copytree(part, again)
    args = ["run", "--resume", str(again), "--set", f"t_end={t_end}", "--no-progress", "--no-frames"]
    done = run_distributed(ranks, args) if ranks > 1 else subprocess.run(
        [sys.executable, "-m", "warpfree", *args], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    return again, done


#: (scene, settings, stop, end, checkpoint every): the waveguide (PML, a point source: static E and H sets), the
#: two-stream plasma (moving particles, each piece holding its owned particles and the ghosts, one copy kept by id)
#: and the example solver (static particles, each step the stable one or shorter to land on an output)
RESUME_CASES = [("em_waveguide_2d", ["--set", "particles_per_wavelength=20", "--set", "output_interval=0.41e-9"],
                 "0.82e-9", "1.64e-9", "5"),
                ("heat_conduction_2d", smallest_sets("heat_conduction_2d", without=("t_end",)), "1.0", "2.0", "4"),
                ("pic_two_stream", smallest_sets("pic_two_stream", without=("t_end",)), "1.2", "2.4", "4")]


@needs_mpi
@pytest.mark.parametrize("scene,sets,stop,end,every", RESUME_CASES)
def test_a_distributed_run_resumes_bitwise_on_another_rank_count_and_in_one_process(scene, sets, stop, end, every,
                                                                                     tmp_path):
    """Run on 2 ranks to an output time with checkpoints, resumed on 3 ranks and in one process: each continues
    bitwise as the uninterrupted one-process run (every snapshot of every series)."""
    full, part = tmp_path / "full", tmp_path / "part"
    assert main(["run", scene, *sets, "--set", f"t_end={end}", "--out", str(full), "--no-progress", "--no-frames",
                 "--threads", "1"]) == 0
    done = run_distributed(2, ["run", scene, *sets, "--set", f"t_end={stop}", "--checkpoint-every", every,
                               "--out", str(part), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    for ranks in (3, 1):
        again, done = resume_copy(part, tmp_path / f"again_{ranks}", ranks, end)
        assert "written by 2 process(es)" in done.stderr
        assert snapshot_differences(full, again) == [], ranks
        assert summary(full)["steps"] == summary(again)["steps"], ranks


@needs_mpi
def test_a_distributed_run_is_refused_in_one_line_without_mpi_for_python(tmp_path):
    """Started by a launcher on two ranks, with no mpi4py to import: exit 2, the extra named, nothing written."""
    code = ("import sys; sys.modules['mpi4py'] = None; from warpfree.cli import main; "
            f"sys.exit(main(['run', 'dam_break_2d', '--out', {str(tmp_path / 'run')!r}]))")
    env = {"OMPI_COMM_WORLD_SIZE": "2", "PATH": "/usr/bin:/bin"}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1] == ("warpfree: error: mpi: this run was started on 2 ranks, and a "
                                                    f"distributed run needs MPI for Python: {MPI_EXTRA}")
    assert not (tmp_path / "run").exists()


#: a scene whose solver declares that it runs in one process only (every shipped solver distributes)
ONE_PROCESS_SCENE = '''"""Heat conduction on a solver that declares it runs in one process only."""
from warpfree.geometry import lattice_box
from warpfree.solvers.heat import HeatModel, HeatSolver
from warpfree.space import Space
from warpfree.time_loop import TimeLoop


class OneProcessSolver(HeatSolver):
    name, distributes = "one_process", False


def build():
    space = Space(2, (0.0, 0.0, 0.0), (1.0, 1.0, 0.0), (True, True, False))
    model = HeatModel(lattice_box((0.0, 0.0), (1.0, 1.0), 0.0625), 0.0625, 0.01, space)
    return TimeLoop(OneProcessSolver(model, [300.0] * model.particles.n), t_end=0.5, output_interval=0.25)
'''


@needs_mpi
def test_a_solver_that_does_not_distribute_is_refused_on_several_ranks(tmp_path):
    """A solver whose ``distributes`` is False: on two ranks it is refused in one line naming ``ranks``, exit 2,
    nothing written (the run directory --out names stays empty)."""
    scene = tmp_path / "one_process_heat.py"
    scene.write_text(ONE_PROCESS_SCENE, encoding="utf-8")
    done = run_distributed(2, ["run", str(scene), "--out", str(tmp_path / "run"), "--no-progress"])
    assert done.returncode == 2, done.stderr[-3000:]
    assert ("warpfree: error: ranks: the one_process solver runs in one process only: start it without mpiexec (this "
            "run has 2 ranks)") in done.stderr.splitlines()
    assert not any((tmp_path / "run").glob("*"))


def _has_petsc() -> bool:
    try:
        import petsc4py  # noqa: F401
    except ImportError:
        return False
    return True


needs_petsc = pytest.mark.skipif(not _has_petsc(), reason=f"no PETSc here: {PETSC_EXTRA}")

#: (scene, ranks, settings): the beam's saddle point (Lagrange multipliers, their rows rank 0's) and its penalty
#: form, the two-material resistor (Nitsche interface terms, each rank's rows of them), Cook's membrane, NEM on the
#: beam's Delaunay triangles (direct substitution: prescribed values eliminated from every rank's rows), there also
#: with algebraic multigrid; a region built from shapes (the plate with an elliptical hole: its nodes relaxed about
#: the exact ellipse, its cells and its load-free hole on the curve)
#: (three ranks need a beam of 24 cells: the smallest's 12 span two supports)
WIDER = ["--set", "cells_x=24", "--set", "cells_y=6"]
GALERKIN_CASES = [("efg_timoshenko", 2, []), ("efg_timoshenko", 3, WIDER + ["--set", "method=penalty"]),
                  ("efg_resistor", 3, []), ("efg_cook", 2, []), ("efg_coax", 3, []), ("efg_plate_hole", 3, []),
                  ("efg_timoshenko", 2, ["--set", "model=nem", "--set", "integration=gauss"]),
                  ("efg_timoshenko", 3, WIDER + ["--set", "model=nem", "--set", "integration=gauss",
                                         "--set", "preconditioner=gamg"])]
#: the solves' agreement: PETSc stops at a relative residual of 1e-12 and SuperLU's own is ~1e-15; the analysis's
#: numbers (integrals of the solution) and the fields (each against its quantity's largest value) measured 1e-14 to
#: 6e-9 apart, the largest in the penalty method's case (its penalty makes K the worst conditioned); 1e-7 is far
#: below any discretisation error these runs report (1e-3 and up) and above the solves' noise
GALERKIN_RTOL = 1e-7


@needs_mpi
@needs_petsc
@pytest.mark.parametrize("scene,ranks,settings", GALERKIN_CASES)
def test_a_distributed_galerkin_solve_through_petsc_gives_the_one_process_results_to_its_tolerance(
        scene, ranks, settings, tmp_path):
    """Each rank assembles its nodes' rows, PETSc solves the ranks' rows as one matrix: the analysis (errors
    against the exact or reference solution) and every output field agree with one process's SuperLU solve to
    the Krylov solve's tolerance, and summary.json names the solve and its relative residual."""
    sets = smallest_sets_then(scene, settings)
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", scene, *sets, "--out", str(one), "--no-progress", "--no-frames", "--threads", "1"]) == 0
    done = run_distributed(ranks, ["run", scene, *sets, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    a, b = summary(one), summary(many)
    differences = relative_differences(a["analysis"], b["analysis"])
    assert differences, "the analyses agree bitwise: the distributed run did not solve on its own"
    worst = max(differences.items(), key=lambda kv: kv[1])
    assert worst[1] < GALERKIN_RTOL, worst
    solve = b["model"]["linear_solver"]
    assert solve["library"] == "PETSc" and solve["relative_residual"] < 1e-11
    assert sum(solve["rows_per_rank"]) == solve["unknowns"] and len(solve["rows_per_rank"]) == ranks
    assert a["model"]["linear_solver"]["library"] == "SciPy SuperLU"
    assert field_differences(one, many) < GALERKIN_RTOL


@needs_mpi
@needs_petsc
def test_a_users_region_read_from_a_file_solves_over_ranks_to_the_one_process_results(tmp_path):
    """The geometry tutorial's scene as a user runs it (a shield's outline read from a spline file, a conductor's
    exact circle cut out of it, φ held on both curves by Lagrange multipliers; its analysis solves a coarser layout
    too) on 3 ranks: the surface field's errors and every output field within the Krylov solve's tolerance of one
    process's."""
    pages = [code for page, code in DOC_BLOCKS if page == "tutorials/geometry.md"]
    scene = tmp_path / "coax_from_a_file.py"
    scene.write_text(pages[0], encoding="utf-8")
    sets = ["--set", "spacing=0.2"]
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", str(scene), *sets, "--out", str(one), "--no-progress", "--threads", "1"]) == 0
    done = run_distributed(3, ["run", str(scene), *sets, "--out", str(many), "--no-progress"])
    assert done.returncode == 0, done.stderr[-3000:]
    a, b = summary(one), summary(many)
    differences = relative_differences(a["analysis"], b["analysis"])
    assert differences and max(differences.values()) < GALERKIN_RTOL, differences
    assert b["model"]["linear_solver"]["rows_per_rank"] and len(b["model"]["linear_solver"]["rows_per_rank"]) == 3
    assert field_differences(one, many) < GALERKIN_RTOL


@needs_mpi
def test_a_distributed_galerkin_solve_is_refused_in_one_line_without_petsc(tmp_path):
    """Two ranks, petsc4py hidden: exit 2, the extra named, nothing written."""
    code = ("import sys; sys.modules['petsc4py'] = None; from warpfree.cli import entry; sys.argv = ['warpfree', "
            f"'run', 'efg_timoshenko', '--out', {str(tmp_path / 'run')!r}, '--no-progress']; entry()")
    done = run_ranks(2, ["-c", code], timeout=600)
    assert done.returncode == 2, done.stderr[-2000:]
    assert (f"warpfree: error: linear_solver: a distributed Galerkin solve needs PETSc for Python: {PETSC_EXTRA}"
            in done.stderr.splitlines())
    assert not any((tmp_path / "run").glob("*"))


@needs_mpi
@pytest.mark.parametrize("scene,ranks,sensors", [
    ("dam_break_2d", 2, ["wall=pressure:4.0,0.05;0.0,0.3@0.005", "gauge=height:0.5,0;3.0,0@0.01",
                         "face=panel:0.0,0.0;0.0,0.05;0.0,0.1@0.005"]),
    ("dam_break_3d", 3, ["p1=pressure:0.8245,0.471,0.021@0.005", "h4=height:2.638,0.5,0@0.01",
                         "obstacle=force:0.75,0.5,0.08@0.005"])])
def test_distributed_sensors_record_the_one_process_series_bitwise(scene, ranks, sensors, tmp_path):
    """Pressure sensors (at points and a panel), water gauges and the force on the obstacle: the same rows, bitwise, on several ranks (each
    point read by the rank holding it, the force summed over the walls in their global order) as in one process."""
    # the 3D obstacle (0.16 m wide) has wall particles from dx = 0.06 down
    sets = smallest_sets(scene)
    if "3d" in scene:
        sets = smallest_sets_then(scene, ["--set", "dx=0.06", "--set", "t_end=0.02", "--set", "output_interval=0.01"])
    flags = [arg for spec in sensors for arg in ("--sensor", spec)]
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", scene, *sets, *flags, "--out", str(one), "--no-progress", "--no-frames", "--threads", "1"]) == 0
    done = run_distributed(ranks, ["run", scene, *sets, *flags, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    for spec in sensors:
        name = spec.split("=")[0]
        a, b = (run / "sensors" / f"{name}.csv" for run in (one, many))
        assert a.read_text() == b.read_text(), name
        assert len(a.read_text().splitlines()) > 2, name
    assert summary(one)["sensors"] == summary(many)["sensors"]


#: the cylindrical diode, small: the cathode circle emits space-charge limited into an empty annulus cut over the
#: nodes, and the electrons reach the anode by t = 3 (t_end set by the test)
CYLINDRICAL = smallest_sets("pic_cylindrical_diode", without=("t_end", "particles_per_step", "output_every")) + [
    "--set", "particles_per_step=10", "--set", "output_every=50"]
REGION_TALLIES = ("particles", "injected_charge", "absorbed_charge_cathode", "absorbed_charge_anode", "charge_cathode",
                  "charge_anode", "deposited_charge", "field_energy")


@needs_mpi
@pytest.mark.parametrize("ranks", [2, 3])
def test_a_distributed_cylindrical_diode_emits_and_absorbs_bitwise(ranks, tmp_path):
    """Space-charge-limited emission from a curved electrode and absorption at the region's boundary on 2 and 3 ranks:
    every snapshot bitwise the one process's, and the tallies (live count, emitted charge, each electrode's absorbed
    and induced charge) and field terms bitwise."""
    one, many = tmp_path / "one", tmp_path / "many"
    sets = [*CYLINDRICAL, "--set", "t_end=3.0"]
    assert main(["run", "pic_cylindrical_diode", *sets, "--out", str(one), "--no-progress", "--no-frames",
                 "--threads", "1"]) == 0
    done = run_distributed(ranks, ["run", "pic_cylindrical_diode", *sets, "--out", str(many), "--no-progress",
                               "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    a, b = summary(one), summary(many)
    assert a["diagnostics"]["absorbed_charge_anode"] < 0
    assert snapshot_differences(one, many) == []
    for key in REGION_TALLIES:
        assert a["diagnostics"][key] == b["diagnostics"][key], key
    owned = b["model"]["distributed"]["particles_owned"]
    assert sum(owned) == a["model"]["particles"] and min(owned) > 0


#: the sheath, small: a source emitting both species and a floating wall charging from what it absorbs (16 λ_D long:
#: three supports, one for each of 3 ranks)
SHEATH = smallest_sets("pic_sheath", without=("t_end", "length")) + ["--set", "t_end=6.0", "--set", "length=16.0"]
SHEATH_TALLIES = ("particles", "injected_charge", "absorbed_charge_source", "absorbed_charge_wall", "charge_source",
                  "charge_wall", "potential_wall", "deposited_charge", "field_energy")


@needs_mpi
@pytest.mark.parametrize("ranks", [2, 3])
def test_a_distributed_sheath_charges_its_floating_wall_bitwise(ranks, tmp_path):
    """Two species emitted from a source, absorbed at it and at a floating wall whose potential follows its charge,
    on 2 and 3 ranks: every snapshot bitwise the one process's, and the tallies (each electrode's absorbed and held charge,
    the wall's potential) bitwise."""
    one, many = tmp_path / "one", tmp_path / "many"
    assert main(["run", "pic_sheath", *SHEATH, "--out", str(one), "--no-progress", "--no-frames",
                 "--threads", "1"]) == 0
    done = run_distributed(ranks, ["run", "pic_sheath", *SHEATH, "--out", str(many), "--no-progress", "--no-frames"])
    assert done.returncode == 0, done.stderr[-3000:]
    a, b = summary(one), summary(many)
    assert a["diagnostics"]["absorbed_charge_wall"] != 0 and a["diagnostics"]["potential_wall"] < 0
    assert snapshot_differences(one, many) == []
    for key in SHEATH_TALLIES:
        assert a["diagnostics"][key] == b["diagnostics"][key], key
