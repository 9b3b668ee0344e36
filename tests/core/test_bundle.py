"""Offline bundles, on small bundles made here from hand-made wheels (no network, no package index): sizes read as
split(1) reads them, the platform tags a target runs, the selection that leaves out what the target has, parts that
join to the payload, the tree form's compressed and dropped files restored and left out, every kind of damage refused
with one line before anything is installed, and the installer's two ways to install (pip --no-index into a venv, a
.pth to the tree). The full build downloads from the package index and is run by hand (docs/offline-install.md)."""

from __future__ import annotations

import ast
import hashlib
import json
import os
import random
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import warpfree
from warpfree.bundle import build, install
from warpfree.cli import main
from warpfree.errors import ParameterError

INSTALLER = [sys.executable]


# -- hand-made wheels ----------------------------------------------------------------------------------------------
def make_wheel(folder: Path, name: str, version: str, files: dict[str, bytes], requires: list[str] = ()) -> Path:
    """A minimal wheel (METADATA, WHEEL, RECORD) holding ``files``."""
    dist = f"{name}-{version}.dist-info"
    meta = f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n" + "".join(
        f"Requires-Dist: {r}\n" for r in requires)
    contents = {**files, f"{dist}/METADATA": meta.encode(),
                f"{dist}/WHEEL": b"Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\nTag: py3-none-any\n"}
    record = "".join(f"{path},,\n" for path in contents) + f"{dist}/RECORD,,\n"
    path = folder / f"{name}-{version}-py3-none-any.whl"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for arc, data in {**contents, f"{dist}/RECORD": record.encode()}.items():
            z.writestr(arc, data)
    return path


def native_library(size: int, seed: int) -> bytes:
    """Bytes that compress as a shared library does (repeated runs with random ones between)."""
    rng = random.Random(seed)
    block = bytes(rng.randrange(256) for _ in range(512))
    out = bytearray()
    while len(out) < size:
        out += block if rng.random() < 0.7 else bytes(rng.randrange(256) for _ in range(64))
    return bytes(out[:size])


@pytest.fixture
def wheels(tmp_path):
    """A fake Warp wheel (a 300 KB warp/bin/warp.so, an 80 KB warp-clang.so), a pure package and a fake warpfree of
    this version requiring both."""
    folder = tmp_path / "wheels"
    folder.mkdir()
    fake_warp = {"warp/__init__.py": b"", "warp/bin/warp.so": native_library(300_000, 1),
                 "warp/bin/warp-clang.so": native_library(80_000, 2)}
    return [make_wheel(folder, "fakewarp", "1.0", fake_warp),
            make_wheel(folder, "hello", "2.0", {"hello/__init__.py": b"VALUE = 42\n"}),
            make_wheel(folder, "warpfree", warpfree.__version__,
                       {"warpfree/__init__.py": f"__version__ = {warpfree.__version__!r}\n".encode(),
                        "warpfree/cli.py": b"def entry():\n    print('fake warpfree')\n    return 0\n"},
                       requires=["hello>=1.5", "fakewarp"])]


def make_bundle(tmp_path: Path, wheels: list[Path], form: str, part_size: int | None = 4 << 10, **options) -> Path:
    """A bundle of ``wheels`` in ``tmp_path/bundle`` through the builder's own assembly (xz preset 0: fast)."""
    src = tmp_path / "src"
    (src / "bench" / "core").mkdir(parents=True, exist_ok=True)
    (src / "bench" / "core" / "gpu_check.py").write_text("print('gpu check')\n")
    out = tmp_path / "bundle"
    build.require_out(out, overwrite=False)
    manifest = {"format": build.FORMAT, "warpfree": warpfree.__version__, "form": form,
                "target": {"python": build.host_python(), "machine": os.uname().machine, "platforms": []},
                "source": {"archive": "repo.tar.gz"}, "selection": {"have": []},
                "packages": [{"name": w.name.split("-")[0], "version": w.name.split("-")[1], "wheel": w.name}
                             for w in wheels]}
    options = {"xz_over": 64 << 10, "preset": "0", **options}
    build.assemble(out, tmp_path / "work", wheels, src, manifest, part_size=part_size, **options)
    return out


def run_installer(bundle: Path, *args: str, env=None) -> subprocess.CompletedProcess:
    """The bundle's own install_bundle.py, as the target runs it."""
    return subprocess.run([sys.executable, str(bundle / build.INSTALLER), *args], capture_output=True, text=True,
                          env=env)


def sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


# -- options -------------------------------------------------------------------------------------------------------
def test_sizes_read_as_split_reads_them():
    assert build.parse_size("55M") == 55 * 2**20
    assert build.parse_size("64MiB") == 64 * 2**20
    assert build.parse_size("60MB") == 60 * 10**6
    assert build.parse_size("1.5G") == 3 * 2**29
    assert build.parse_size("4096") == 4096
    for bad in ("5Q", "", "-1M", "100"):
        with pytest.raises(ParameterError, match="--part-size"):
            build.parse_size(bad)


def test_a_manylinux_target_runs_every_older_manylinux_tag_of_its_processor():
    tags = build.platform_tags("manylinux_2_28_x86_64")
    assert tags[0] == "manylinux_2_28_x86_64" and "manylinux_2_29_x86_64" not in tags
    assert {"manylinux_2_17_x86_64", "manylinux2014_x86_64", "manylinux2010_x86_64", "manylinux1_x86_64"} <= set(tags)
    assert all(t.endswith("_x86_64") for t in tags)
    assert build.platform_tags("manylinux2014_aarch64")[:2] == ["manylinux_2_17_aarch64", "manylinux2014_aarch64"]
    assert build.machine_of("manylinux_2_34_aarch64") == "aarch64"
    target = build.make_target("3.12", "manylinux_2_28_x86_64")
    options = target.pip_options()
    assert options[:4] == ["--python-version", "3.12", "--implementation", "cp"]
    assert options.count("--platform") == len(tags) and target.machine == "x86_64"
    with pytest.raises(ParameterError, match="--python-version"):
        build.make_target("12", None)
    with pytest.raises(ParameterError, match="--platform"):
        build.make_target("3.12", "win_amd64")


def report_item(name: str, requires: list[str] = ()) -> dict:
    return {"metadata": {"name": name, "version": "1.0", "requires_dist": list(requires)},
            "download_info": {"url": f"https://example.invalid/{name}-1.0-py3-none-any.whl",
                              "archive_info": {"hashes": {"sha256": sha(name.encode())}}}}


#: a resolution shaped like warpfree's: the plotting package (which the target has) needs two packages nothing else
#: needs and one that the mesh reader needs too; the mesh reader needs a backport on Pythons before 3.11 only
RESOLUTION = [report_item("kernel-lib", ["num-py"]), report_item("num-py"),
              report_item("mesh_reader", ["num-py", "Shared.Dep>=1", "backport; python_version < '3.11'",
                                          "docs-tool; extra == 'docs'"]),
              report_item("plot-lib", ["num-py", "shared-dep", "plot-only"]), report_item("shared-dep"),
              report_item("plot-only"), report_item("docs-tool")]
ROOTS = ["kernel-lib>=1", "num-py", "mesh-reader", "plot-lib"]


def test_what_the_target_has_is_left_out_with_what_only_it_needs():
    target = build.make_target("3.12", "manylinux_2_28_x86_64")
    chosen, missing = build.select(RESOLUTION, ROOTS, ["num-py", "plot-lib"], target)
    assert [i["metadata"]["name"] for i in chosen] == ["kernel-lib", "mesh_reader", "shared-dep"]
    assert missing == []
    chosen, _ = build.select(RESOLUTION, ROOTS, [], target)
    assert len(chosen) == 6  # everything but the extra's docs-tool
    # on Python 3.10 the mesh reader needs its backport, which a resolution made on a newer Python lacks: said
    _, missing = build.select(RESOLUTION, ROOTS, ["num-py"], build.make_target("3.10", "manylinux_2_28_x86_64"))
    assert missing == ["backport"]
    assert build.names_list("numpy, SciPy Pillow,numpy") == ["numpy", "scipy", "pillow"]
    assert build.lock_lines(chosen[:1]) == [f"kernel-lib==1.0 --hash=sha256:{sha(b'kernel-lib')}"]


# -- parts ---------------------------------------------------------------------------------------------------------
def test_parts_are_at_most_the_part_size_and_join_to_the_payload(tmp_path):
    data = random.Random(3).randbytes(10_500)
    writer = build.PartWriter(tmp_path, "payload.tar", 1000)
    position = 0
    for chunk in (1, 999, 1, 2500, 7, 6992):  # writes that straddle the parts' ends
        writer.write(data[position:position + chunk])
        position += chunk
    writer.close()
    assert position == len(data) and writer.size == len(data) and writer.digest.hexdigest() == sha(data)
    sizes = [p["size"] for p in writer.parts]
    assert sizes == [1000] * 10 + [500]
    joined = b"".join((tmp_path / p["name"]).read_bytes() for p in writer.parts)
    assert joined == data
    assert all(sha((tmp_path / p["name"]).read_bytes()) == p["sha256"] for p in writer.parts)
    stream = install.JoinedParts([str(tmp_path / p["name"]) for p in writer.parts])
    assert stream.read() == data and stream.digest.hexdigest() == sha(data)


def test_a_tree_bundle_unpacks_to_the_wheels_files_with_the_cpu_backend_left_out(tmp_path, wheels):
    bundle = make_bundle(tmp_path, wheels, "tree", part_size=4 << 10, gpu_only=True)
    manifest = json.loads((bundle / "manifest.json").read_text())
    parts = manifest["parts"]
    assert len(parts) >= 3 and all((bundle / p["name"]).stat().st_size <= 4 << 10 for p in parts)
    assert manifest["files"]["tree/warp/bin/warp.so.xz"]["xz_of"]["path"] == "tree/warp/bin/warp.so"
    assert [d["path"] for d in manifest["dropped"]] == ["tree/warp/bin/warp-clang.so"]
    res = run_installer(bundle, "--unpack-to", str(tmp_path / "unpacked"))
    assert res.returncode == 0, res.stderr
    tree = tmp_path / "unpacked" / "tree"
    with zipfile.ZipFile(wheels[0]) as z:
        assert (tree / "warp/bin/warp.so").read_bytes() == z.read("warp/bin/warp.so")
    assert not (tree / "warp/bin/warp-clang.so").exists() and not list(tree.rglob("*.xz"))
    assert (tree / "hello/__init__.py").read_text() == "VALUE = 42\n"
    assert f"PYTHONPATH={tree}" in res.stdout
    assert (tmp_path / "unpacked" / "repo.tar.gz").is_file()


# -- refusals ------------------------------------------------------------------------------------------------------
def one_line_refusal(res: subprocess.CompletedProcess, *words: str) -> None:
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and lines[0].startswith("install_bundle: refused: "), res.stderr
    assert all(w in lines[0] for w in words), lines[0]


def test_a_tampered_part_is_refused_before_anything_is_unpacked(tmp_path, wheels):
    bundle = make_bundle(tmp_path, wheels, "wheels")
    part = bundle / json.loads((bundle / "manifest.json").read_text())["parts"][1]["name"]
    data = bytearray(part.read_bytes())
    data[len(data) // 2] ^= 0x01  # one bit: the size stays
    part.write_bytes(bytes(data))
    one_line_refusal(run_installer(bundle, "--verify-only"), part.name, "does not match", "transfer it again")
    one_line_refusal(run_installer(bundle, "--unpack-to", str(tmp_path / "u")), part.name)
    assert not (tmp_path / "u").exists()
    assert main(["bundle", "verify", str(bundle)]) == 1
    part.write_bytes(bytes(data[:-10]))  # truncated
    one_line_refusal(run_installer(bundle, "--verify-only"), part.name, "bytes")
    part.unlink()
    one_line_refusal(run_installer(bundle, "--verify-only"), part.name, "missing")


def test_a_file_that_differs_from_the_manifest_is_refused_and_nothing_is_left(tmp_path, wheels):
    """Parts that match their own checksums but carry a file the manifest does not describe (a manifest from another
    build beside these parts, say)."""
    bundle = make_bundle(tmp_path, wheels, "tree")
    path = bundle / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest["files"]["tree/hello/__init__.py"]["sha256"] = sha(b"something else")
    path.write_text(json.dumps(manifest))
    one_line_refusal(run_installer(bundle, "--unpack-to", str(tmp_path / "u")), "tree/hello/__init__.py")
    assert not (tmp_path / "u").exists()
    manifest["files"]["tree/hello/__init__.py"]["sha256"] = sha(b"VALUE = 42\n")
    manifest["files"]["tree/warp/bin/warp.so.xz"]["xz_of"]["sha256"] = sha(b"another library")
    path.write_text(json.dumps(manifest))
    one_line_refusal(run_installer(bundle, "--unpack-to", str(tmp_path / "u")), "tree/warp/bin/warp.so",
                     "decompressed")
    assert not (tmp_path / "u").exists()


def test_another_python_or_machine_is_refused():
    manifest = {"target": {"python": "3.12", "machine": "x86_64"}}
    install.check_target(manifest, (3, 12), "x86_64")
    with pytest.raises(install.Refused, match="Python 3.12, this is Python 3.11: run it with python3.12"):
        install.check_target(manifest, (3, 11), "x86_64")
    with pytest.raises(install.Refused, match="built for x86_64, this machine is aarch64"):
        install.check_target(manifest, (3, 12), "aarch64")


def test_bad_options_are_refused_by_name_before_anything_is_made(tmp_path, capsys):
    out = tmp_path / "b"
    assert main(["bundle", "build", "--out", str(out), "--gpu-only"]) == 2
    assert "--gpu-only" in capsys.readouterr().err and not out.exists()
    assert main(["bundle", "build", "--out", str(out), "--form", "tree", "--xz-preset", "10"]) == 2
    assert "--xz-preset" in capsys.readouterr().err and not out.exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    assert main(["bundle", "build", "--out", str(mine), "--overwrite", "--part-size", "55M"]) == 2
    assert "nothing is removed" in capsys.readouterr().err and (mine / "notes.txt").is_file()


def test_the_installer_needs_only_the_standard_library():
    tree = ast.parse(Path(install.__file__).read_text(encoding="utf-8"))
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "a relative import: the installer runs alone, outside the package"
            imported.add(node.module.split(".")[0])
    assert imported and imported <= sys.stdlib_module_names | {"__future__"}, imported - sys.stdlib_module_names


# -- installing ----------------------------------------------------------------------------------------------------
def no_index_env() -> dict:
    """An environment whose pip settings would fetch from an unreachable index (the installer must ignore them)."""
    return {**os.environ, "PIP_INDEX_URL": "http://127.0.0.1:9/simple", "PIP_FIND_LINKS": "http://127.0.0.1:9/"}


def test_the_wheels_form_installs_with_pip_and_no_index(tmp_path, wheels):
    bundle = make_bundle(tmp_path, wheels, "wheels")
    venv = tmp_path / "venv"
    res = run_installer(bundle, "--venv", str(venv), "--check", "none", env=no_index_env())
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr
    python = install.venv_python(str(venv))
    out = subprocess.run([python, "-c", "import hello, warpfree, warp; print(hello.VALUE, warpfree.__version__)"],
                         capture_output=True, text=True)
    assert out.stdout.split() == ["42", warpfree.__version__], out.stderr
    assert (venv / install.SOURCE_DIR / "bench" / "core" / "gpu_check.py").is_file()
    assert not list(venv.glob(".warpfree-bundle-*"))  # the unpacked payload is gone


def test_the_tree_form_is_put_on_the_path_with_a_launcher(tmp_path, wheels):
    bundle = make_bundle(tmp_path, wheels, "tree", part_size=None)
    assert [p["name"] for p in json.loads((bundle / "manifest.json").read_text())["parts"]] == ["payload.tar.gz"]
    venv = tmp_path / "venv"
    res = run_installer(bundle, "--venv", str(venv), "--check", "none")
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr
    python = install.venv_python(str(venv))
    out = subprocess.run([python, "-c", "import hello, warp, os; print(hello.VALUE, os.path.getsize(warp.__file__"
                                        ".replace('__init__.py', 'bin/warp.so')))"], capture_output=True, text=True)
    assert out.stdout.split() == ["42", "300000"], out.stderr
    launched = subprocess.run([str(venv / "bin" / "warpfree")], capture_output=True, text=True)
    assert launched.returncode == 0 and launched.stdout.strip() == "fake warpfree"
    # the packages the bundle left out must be there: refused by name when they are not
    manifest = json.loads((bundle / "manifest.json").read_text())
    manifest["selection"]["have"] = ["no-such-package-here"]
    (bundle / "manifest.json").write_text(json.dumps(manifest))
    one_line_refusal(run_installer(bundle, "--venv", str(venv), "--check", "none"), "lacks no-such-package-here")
