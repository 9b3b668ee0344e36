"""Validation reference data (warpfree/validation/<case>/): the dam-break CSVs load as package data,
hold exactly the transcription they replaced, and ``front_errors`` measures against them."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from importlib import resources

import numpy as np
import pytest

from helpers import ROOT
from warpfree.validation import read_csv
from warpfree.validation import dam_break_2d as db

# The literals of the former warpfree/validation/dam_break.py (transcribed from anchors.md §1.4a): the
# check on the CSVs.
MARTIN_MOYCE = np.array([
    (0.849, 1.245), (1.212, 1.443), (1.602, 1.884), (2.283, 2.689), (2.950, 3.728),
    (3.598, 4.528), (3.905, 4.999), (4.592, 5.841), (4.961, 6.271), (5.316, 6.717),
])
KOSHIZUKA_OKA = np.array([
    (0.0, 1.000), (0.381, 1.111), (0.769, 1.252), (1.153, 1.505), (1.537, 1.892),
    (1.935, 2.241), (2.323, 2.615), (2.719, 3.003), (3.096, 3.624),
])
KOSHIZUKA_OKA_DSPH_SI = np.array([
    (0.0920, 1.128), (0.1907, 1.244), (0.2663, 1.464), (0.3221, 1.695), (0.3681, 1.903),
    (0.4140, 2.123), (0.4466, 2.365), (0.4958, 2.584), (0.5219, 2.804), (0.5646, 3.034),
    (0.5940, 3.219), (0.6366, 3.462), (0.6693, 3.704), (0.7021, 3.900), (0.7513, 4.132),
])
KOSHIZUKA_OKA_DSPH = np.column_stack([KOSHIZUKA_OKA_DSPH_SI[:, 0] * np.sqrt(2 * 9.81 / 1.0),
                                      KOSHIZUKA_OKA_DSPH_SI[:, 1] / 1.0])

CSV = {
    "surge_front_martin_moyce_1952.csv": (["T", "Z"], MARTIN_MOYCE),
    "surge_front_koshizuka_oka_1996_pysph.csv": (["T", "Z"], KOSHIZUKA_OKA),
    "surge_front_koshizuka_oka_1996_dualsphysics.csv": (["t_s", "x_front_m"], KOSHIZUKA_OKA_DSPH_SI),
}


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype == np.float64 and np.array_equal(a.view(np.uint64),
                                                                                       b.view(np.uint64))


@pytest.mark.parametrize("filename", list(CSV))
def test_csv_header_shape_and_values(filename):
    header, data = read_csv("dam_break_2d", filename)
    want_header, want = CSV[filename]
    assert header == want_header
    assert data.shape == want.shape and data.shape[1] == 2
    assert same_bits(data, want), np.argwhere(data != want)


def test_module_arrays_equal_the_literals():
    assert same_bits(db.MARTIN_MOYCE, MARTIN_MOYCE) and db.MARTIN_MOYCE.shape == (10, 2)
    assert same_bits(db.KOSHIZUKA_OKA, KOSHIZUKA_OKA) and db.KOSHIZUKA_OKA.shape == (9, 2)
    assert same_bits(db.KOSHIZUKA_OKA_DSPH_SI, KOSHIZUKA_OKA_DSPH_SI) and db.KOSHIZUKA_OKA_DSPH_SI.shape == (15, 2)
    assert same_bits(db.KOSHIZUKA_OKA_DSPH, KOSHIZUKA_OKA_DSPH)
    assert list(db.DATASETS) == ["Martin & Moyce 1952", "Koshizuka & Oka 1996",
                                 "Koshizuka & Oka 1996 (DualSPHysics digitisation)"]
    assert db.DATASETS["Martin & Moyce 1952"] is db.MARTIN_MOYCE
    assert db.DATASETS["Koshizuka & Oka 1996"] is db.KOSHIZUKA_OKA
    assert db.DATASETS["Koshizuka & Oka 1996 (DualSPHysics digitisation)"] is db.KOSHIZUKA_OKA_DSPH


@pytest.mark.parametrize("name", ["MARTIN_MOYCE", "KOSHIZUKA_OKA", "KOSHIZUKA_OKA_DSPH_SI", "KOSHIZUKA_OKA_DSPH"])
def test_time_and_front_increase(name):
    data = getattr(db, name)
    assert np.all(np.diff(data[:, 0]) > 0), name
    assert np.all(np.diff(data[:, 1]) > 0), name
    assert np.all(data >= 0) and np.all(data[:, 1] >= 1.0), name  # the front starts at the column, Z >= 1


def test_front_errors_zero_on_martin_moyce_itself():
    """Fed the Martin & Moyce points as the 'simulated' front, its own error is zero at its points."""
    T, Z = MARTIN_MOYCE[:, 0], MARTIN_MOYCE[:, 1]
    # a = 1, g = 0.5: sqrt(2 g / a) = 1, so t = T and x = Z exactly
    err = db.front_errors(T, Z, a=1.0, g=0.5, t_max=10.0)
    mm = err["Martin & Moyce 1952"]
    assert mm["T"] == T.tolist() and mm["dZ"] == [0.0] * 10 and mm["max_abs"] == 0.0
    # the default t_max = 2.5 keeps the four points with T <= 2.5
    err = db.front_errors(T, Z, a=1.0, g=0.5)
    assert err["Martin & Moyce 1952"]["T"] == [0.849, 1.212, 1.602, 2.283]
    assert err["Martin & Moyce 1952"]["max_abs"] == 0.0
    assert set(err) == set(db.DATASETS) | {"max_abs"}


def test_front_errors_zero_on_martin_moyce_in_physical_units():
    """The same in physical units (a = 1.125 in, g = 9.81): t and x from T and Z, zero up to round-off.
    The front is padded beyond the data's T range so that round-off cannot drop the end points."""
    a, g = 1.125 * 0.0254, 9.81
    T = np.concatenate([[0.0], MARTIN_MOYCE[:, 0], [6.0]])
    Z = np.concatenate([[1.0], MARTIN_MOYCE[:, 1], [MARTIN_MOYCE[-1, 1]]])
    err = db.front_errors(T / np.sqrt(2.0 * g / a), Z * a, a, g, t_max=10.0)
    mm = err["Martin & Moyce 1952"]
    assert len(mm["T"]) == 10 and mm["max_abs"] < 1e-12
    # the other sets are measured against the same curve and are not zero (they disagree with it)
    assert err["Koshizuka & Oka 1996"]["max_abs"] > 0.05
    assert err["max_abs"] == max(v["max_abs"] for k, v in err.items() if k != "max_abs")


def test_package_data_found_through_importlib_resources():
    root = resources.files("warpfree.validation")
    for filename in CSV:
        assert root.joinpath("dam_break_2d", filename).is_file(), filename
        assert resources.files("warpfree.validation.dam_break_2d").joinpath(filename).is_file(), filename
    for case in ("dam_break_2d", "tank_at_rest_2d"):
        readme = resources.files(f"warpfree.validation.{case}").joinpath("README.md")
        assert readme.is_file(), case
        assert len(readme.read_text(encoding="utf-8")) > 200, case
    text = resources.files("warpfree.validation.dam_break_2d").joinpath("README.md").read_text(encoding="utf-8")
    for needle in ("10.1098/rsta.1952.0006", "10.13182/NSE96-A24205", "db_exp_data.py",
                   "EXP_X-DamTipPosition_Koshizula&Oka1996.txt", "sqrt(2 g / a)"):
        assert needle in text, needle


def test_read_csv_names_the_missing_case_or_file():
    with pytest.raises(FileNotFoundError, match=r"dam_break_2d.*no_such\.csv|no_such\.csv.*dam_break_2d"):
        read_csv("dam_break_2d", "no_such.csv")
    with pytest.raises(FileNotFoundError, match=r"no_such_case.*x\.csv|x\.csv.*no_such_case"):
        read_csv("no_such_case", "x.csv")


def test_loads_from_a_zipped_package(tmp_path):
    """importlib.resources, not file paths next to the source: the case package loads its CSVs when
    warpfree.validation is imported from a zip archive (a stand-in warpfree/__init__.py, no Warp)."""
    src = os.path.join(ROOT, "warpfree", "validation")
    archive = tmp_path / "pkg.zip"
    with zipfile.ZipFile(archive, "w") as zf:
        zf.writestr("warpfree/__init__.py", "")
        for dirpath, dirnames, filenames in os.walk(src):
            dirnames[:] = [d for d in dirnames if d != "__pycache__"]
            for f in filenames:
                if f.endswith((".py", ".csv", ".md")):
                    path = os.path.join(dirpath, f)
                    zf.write(path, os.path.join("warpfree", "validation", os.path.relpath(path, src)))
    code = ("import warpfree.validation.dam_break_2d as d, numpy as np; "
            "assert '.zip' in d.__file__, d.__file__; "
            "print(list(d.DATASETS), d.MARTIN_MOYCE.shape, d.KOSHIZUKA_OKA_DSPH_SI.sum().hex())")
    env = dict(os.environ, PYTHONPATH=str(archive))
    res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert "Martin & Moyce 1952" in res.stdout and "(10, 2)" in res.stdout
    assert KOSHIZUKA_OKA_DSPH_SI.sum().hex() in res.stdout


def test_buchner_wall_pressure_transcription():
    """Buchner's P1 as TrixiParticles.jl digitised it (README.md): 98 points in increasing time, its first and last
    rows and its two peaks as in the upstream file."""
    header, data = read_csv("dam_break_2d", "wall_pressure_buchner_2002_p1.csv")
    assert header == ["T", "p"] and data.shape == (98, 2) and same_bits(data, db.BUCHNER_P1)
    assert np.all(np.diff(data[:, 0]) > 0)
    assert tuple(data[0]) == (2.02512, -0.01792) and tuple(data[-1]) == (7.29946, 0.41565)
    first = data[data[:, 0] < 4.0]
    assert tuple(first[np.argmax(first[:, 1])]) == (2.77411, 0.68698)
    assert tuple(data[np.argmax(data[:, 1])]) == (5.83288, 0.87672)


def test_kleefsman_spheric2_record_transcription():
    """SPHERIC test 2's record (README.md): 2 500 rows to t = 2.5 s in strictly increasing time about 1 ms apart, its
    first and last rows as in the upstream file, its values on the record's 1/15 grid (a mistyped digit leaves it),
    and the figures the comparisons read from it (P1's first impact at 0.392 s, its 5 ms peak 10.62 kPa, the means
    over 1.2-2.0 s), which the literature quotes as 0.394 s (the first sample above 1 kPa) and 10.6 kPa."""
    import warpfree.validation.dam_break_3d as d3

    header, data = read_csv("dam_break_3d", "spheric2_kleefsman_2005.csv")
    assert header[0] == "t_s" and len(header) == 13 and data.shape == (2500, 13)
    assert same_bits(data[:, 0], d3.KLEEFSMAN["t"]) and same_bits(data[:, 1], d3.KLEEFSMAN["P1"])
    dt = np.diff(data[:, 0])
    assert np.all(dt > 0) and abs(np.mean(dt) - 1e-3) < 1e-6 and dt.max() < 1.01e-3
    assert data[0, 0] == 2.1929952850996415e-05 and data[0, 12] == 0.5466666666666666
    assert data[-1, 0] == 2.499025704259725
    scaled = np.concatenate([data[:, 1:9].ravel() * 15.0, data[:, 9:].ravel() * 15000.0])
    assert np.abs(scaled - np.round(scaled)).max() < 1e-6
    p1 = d3.EXPERIMENT["P1"]
    assert abs(p1["arrival"] - 0.3920) < 5e-4 and abs(p1["peak"] - 10619.1) < 1.0
    assert abs(p1["mean"] - 2850.4) < 1.0 and abs(d3.EXPERIMENT["P3"]["mean"] - 2151.6) < 1.0
    assert abs(data[np.argmax(data[:, 1] > 1000.0), 0] - 0.39403) < 1e-5


def test_buchner_reference_front_transcription():
    """TrixiParticles.jl's front in Buchner's tank (README.md): 31 values every 0.02 s to 0.6 s, increasing, its
    start W - dx/2 and its last value as in the upstream file."""
    header, data = read_csv("dam_break_2d", "front_buchner_trixiparticles_wcsph_h40.csv")
    assert header == ["t_s", "x_front_m"] and data.shape == (31, 2)
    assert same_bits(data, db.BUCHNER_FRONT_TRIXIPARTICLES)
    np.testing.assert_allclose(data[:, 0], np.arange(31) * 0.02, atol=1e-12)
    assert np.all(np.diff(data[:, 1]) > 0)
    assert data[0, 1] == 1.2 - 0.015 / 2 and data[-1, 1] == 3.2055490866952914


def test_buchner_figures_and_checks_pass_the_experiment_and_fail_what_is_off():
    """The experiment's own figures (its digitised points: arrival T = 2.47, impact mean +0.59, first peak 0.687 at
    2.77, run-up 0.567, second peak 0.877 at 5.83); a run that is the experiment (its points interpolated every 1 ms
    of t) passes every check; one arriving 10 % late, one pulled below 0 over the impact, one peaking 30 % high, each
    fails that check only."""
    f = db.BUCHNER_P1_FIGURES
    assert (f["arrival"], f["peak1"], f["peak1_T"], f["peak2"], f["peak2_T"]) == (2.47263, 0.68698, 2.77411,
                                                                                   0.87672, 5.83288)
    assert abs(f["mean_impact"] - 0.5922) < 1e-4 and abs(f["mean_run_up"] - 0.5670) < 1e-4
    unit = np.sqrt(db.BUCHNER_H / 9.81)   # s per unit of T
    T = np.arange(0.0, 2.0, 1e-3) / unit
    exp = np.interp(T, db.BUCHNER_P1[:, 0], db.BUCHNER_P1[:, 1], left=0.0)
    run = db.wall_pressure_figures(T, exp, smoothing=0.005 / unit)
    checks = db.wall_pressure_checks(run)
    assert set(checks) == {"arrival_T", "negative_mean_impact", "peak1", "mean_run_up"}
    assert all(c["passed"] for c in checks.values()), checks
    late = db.wall_pressure_checks(db.wall_pressure_figures(T, np.interp(T / 1.1, db.BUCHNER_P1[:, 0],
                                                                         db.BUCHNER_P1[:, 1], left=0.0), 0.005 / unit))
    assert not late["arrival_T"]["passed"] and late["peak1"]["passed"]
    pulled = np.where((T > 2.6) & (T < 3.0), -0.1, exp)
    assert not db.wall_pressure_checks(db.wall_pressure_figures(T, pulled, 0.005 / unit))["negative_mean_impact"]["passed"]
    high = np.where(T < 3.0, 1.3 * exp, exp)
    verdict = {k: c["passed"] for k, c in db.wall_pressure_checks(db.wall_pressure_figures(T, high, 0.005 / unit)).items()}
    assert verdict == {"arrival_T": True, "negative_mean_impact": True, "peak1": False, "mean_run_up": True}
    short = db.wall_pressure_figures(T[T < 3.5], exp[T < 3.5], 0.005 / unit)
    assert short["mean_run_up"] is None and set(db.wall_pressure_checks(short)) == {"arrival_T", "negative_mean_impact"}


def test_spheric2_comparison_of_the_record_with_itself_and_the_gauges_checks():
    """The record compared with itself: no error; its heights 0.2 of their range too high fail the gauges' checks;
    a run shorter than 1 s has no gauge checks."""
    import warpfree.validation.dam_break_3d as d3

    t = d3.KLEEFSMAN["t"]
    series = {n: np.column_stack([t, d3.KLEEFSMAN[n]]) for n in ("P1", "P3", "H2", "H4")}
    figures = d3.compare(series)
    assert figures["P1"]["arrival_error"] == 0.0 and figures["P1"]["peak_ratio"] == 1.0
    assert figures["P3"]["mean_error"] == 0.0 and figures["H2"]["rms"] == 0.0
    assert all(c["passed"] for c in d3.height_checks(figures, 2.0).values())
    raised = dict(series, H4=np.column_stack([t, d3.KLEEFSMAN["H4"] + 0.2 * np.ptp(d3.KLEEFSMAN["H4"])]))
    checks = d3.height_checks(d3.compare(raised), 2.0)
    assert checks["H2_rms_of_range"]["passed"] and not checks["H4_rms_of_range"]["passed"]
    assert d3.height_checks(figures, 0.6) == {}
