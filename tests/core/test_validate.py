"""``warpfree validate``: every validation case's checks in one table, a failed check or a stopped case fails it, and
``--against`` compares a run with a table made before."""

import json

import pytest

from warpfree import validate
from warpfree.cli import main
from warpfree.scene_loader import shipped_scenes

#: two validation cases that run in about a second each
FAST = "efg_cylinder,efg_l_shape"


def test_every_shipped_scene_with_a_reference_is_a_validation_case():
    """Every shipped scene is a validation case (names its QUICK settings), and its QUICK settings are parameters of
    the scene (literals, so that ``validate --quick`` cannot fail on its own settings)."""
    from warpfree.scene_loader import load_scene, scene_parameters

    cases = validate.validation_cases()
    assert set(cases) == set(shipped_scenes())
    for name, path in cases.items():
        module = load_scene(path)
        assert set(module.QUICK) <= set(scene_parameters(module)), name


def test_quick_validation_writes_its_table_and_passes(tmp_path, capsys):
    out, table = tmp_path / "val", tmp_path / "table.md"
    assert main(["validate", "--quick", "--scenes", FAST, "--out", str(out), "--table", str(table)]) == 0
    printed = capsys.readouterr().out
    report = json.loads((out / "validation.json").read_text())
    assert report["quick"] and report["passed"] and [c["scene"] for c in report["cases"]] == FAST.split(",")
    checks = {(c["scene"], q): v for c in report["cases"] for q, v in c["validation"]["checks"].items()}
    assert ("efg_cylinder", "cylinder.energy_norm_error") in checks and ("efg_l_shape", "l_shape.l2_rate") in checks
    rows = validate.read_table(table.read_text())
    assert set(rows) == set(checks) and table.read_text() == (out / "validation.md").read_text()
    for key, check in checks.items():
        assert rows[key]["result"] == "pass" and rows[key]["value"] == pytest.approx(check["value"], rel=1e-3)
        assert f"PASS {key[1]} = " in printed
    assert "validation: 2 cases, 4 checks, all passed" in printed


def test_a_failed_check_fails_the_validation(tmp_path, monkeypatch, capsys):
    """The thick cylinder on 4 x 4 polar cells misses its 1 % energy-norm tolerance (9.4 %): the table says FAIL
    and the command exits with 1."""
    def coarse(module, quick):
        return {"cells_r": 4, "cells_t": 4, "frames": False, "vtk": False}

    monkeypatch.setattr(validate, "case_settings", coarse)
    out = tmp_path / "val"
    assert main(["validate", "--quick", "--scenes", "efg_cylinder", "--out", str(out)]) == 1
    printed = capsys.readouterr().out
    assert "FAIL cylinder.energy_norm_error" in printed and "1 FAILED" in printed
    row = validate.read_table((out / "validation.md").read_text())[("efg_cylinder", "cylinder.energy_norm_error")]
    assert row["result"] == "FAIL" and row["value"] > row["tolerance"] == 0.01
    assert not json.loads((out / "validation.json").read_text())["passed"]


def test_against_an_earlier_table(tmp_path, capsys):
    """The same run against its own table agrees; against a table whose value moved by 5 %, or that lacks a row,
    it differs and exits with 1, naming the quantity."""
    first = tmp_path / "first.md"
    assert main(["validate", "--quick", "--scenes", "efg_cylinder", "--out", str(tmp_path / "a"),
                 "--table", str(first)]) == 0
    capsys.readouterr()
    assert main(["validate", "--quick", "--scenes", "efg_cylinder", "--out", str(tmp_path / "b"),
                 "--against", str(first)]) == 0
    assert "the same table" in capsys.readouterr().out
    rows = validate.read_table(first.read_text())
    value = rows[("efg_cylinder", "cylinder.u_r_inner")]["value"]
    moved = tmp_path / "moved.md"
    moved.write_text(first.read_text().replace(f"| {value:.4g} |", f"| {value * 1.05:.4g} |"))
    assert main(["validate", "--quick", "--scenes", "efg_cylinder", "--out", str(tmp_path / "c"),
                 "--against", str(moved)]) == 1
    assert "DIFFERS efg_cylinder cylinder.u_r_inner: value" in capsys.readouterr().out
    lacking = tmp_path / "lacking.md"
    lacking.write_text("\n".join(line for line in first.read_text().splitlines() if "energy_norm_error" not in line))
    assert main(["validate", "--quick", "--scenes", "efg_cylinder", "--out", str(tmp_path / "d"),
                 "--against", str(lacking)]) == 1
    assert "cylinder.energy_norm_error: in this run, not in the earlier table" in capsys.readouterr().out


def test_bad_validate_input_names_the_option(tmp_path, capsys):
    assert main(["validate", "--scenes", "nope", "--out", str(tmp_path / "v")]) == 2
    assert "--scenes" in capsys.readouterr().err
    assert main(["validate", "--scenes", ",", "--out", str(tmp_path / "v")]) == 2
    assert "--scenes: names no case" in capsys.readouterr().err
    assert main(["validate", "--threads", "0", "--out", str(tmp_path / "v")]) == 2
    assert "threads" in capsys.readouterr().err
    assert not (tmp_path / "v").exists()  # refused before anything was made
    (tmp_path / "a_file").write_text("")
    assert main(["validate", "--quick", "--scenes", "efg_cylinder", "--table", str(tmp_path / "a_file" / "t.md"),
                 "--out", str(tmp_path / "x")]) == 2
    assert "--table: cannot write" in capsys.readouterr().err
    assert main(["validate", "--quick", "--against", str(tmp_path / "missing.md"), "--out", str(tmp_path / "w")]) == 2
    assert "--against" in capsys.readouterr().err
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "keep.txt").write_text("mine")
    assert main(["validate", "--quick", "--scenes", "efg_cylinder", "--out", str(tmp_path / "busy"),
                 "--overwrite"]) == 2
    assert (tmp_path / "busy" / "keep.txt").read_text() == "mine"  # not a validation directory: nothing removed
