"""Build an offline bundle of warpfree on a connected machine, for a target Python and platform without a package index.

Steps (:func:`build`):

1. **warpfree's wheel** from the source checkout's committed tree (``git archive HEAD``; uncommitted changes are said
   and left out), and the same tree as ``repo.tar.gz`` (the tests, benchmarks and scenes the GPU check runs).
2. **Resolution** of warpfree's runtime requirements (read from its wheel's metadata) and ``--include`` ones, by
   ``pip install --dry-run --report`` for the target (``--python-version``, ``--platform``, binary wheels only), then
   **selection**: a package the target already has (``--have``) is left out, and so is every package reached only
   through the ones it has (with ``--have matplotlib``, matplotlib's ``pyparsing`` goes too; ``rich``, which meshio
   needs, stays). Markers are evaluated for the target's Python and machine.
3. **Download** of the selected wheels with ``pip download --no-deps --require-hashes`` against the resolution's
   hashes (``requirements.lock`` in the bundle).
4. **Form**: ``wheels`` (the wheels as they are, installed on the target by ``pip install --no-index``) or ``tree``
   (every wheel unpacked into one importable folder, each file over ``--xz-over`` compressed with xz, preset 9e by
   default: Warp's 285 MiB ``warp/bin/warp.so`` becomes about 73 MiB; ``--gpu-only`` leaves out
   ``warp/bin/warp-clang.so``, Warp's CPU backend).
5. **Payload**: one tar stream (gzip-compressed in the tree form) of ``wheels/`` or ``tree/`` and ``repo.tar.gz``,
   written straight into parts of at most ``--part-size`` bytes; ``manifest.json`` lists the SHA-256 and size of every
   file in the payload, of the payload and of every part; ``install_bundle.py`` (:mod:`warpfree.bundle.install`,
   standard library only) and a ``README.txt`` beside them.

Downloads, the source tree and compressed files are kept in ``--work`` and reused by the next build.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tarfile
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from .. import __version__
from ..errors import ParameterError
from . import install

#: the manifest format written (the installer refuses another)
FORMAT = install.FORMAT
#: the installer's name in a bundle
INSTALLER = "install_bundle.py"
#: the oldest glibc minor that manylinux tags name (manylinux1 = glibc 2.5)
OLDEST_GLIBC_MINOR = 5
#: the manylinux tags named before PEP 600, by the glibc minor they stand for
LEGACY_MANYLINUX = {17: "manylinux2014", 12: "manylinux2010", 5: "manylinux1"}
#: size units of --part-size and --xz-over, as split(1) reads them: K, M, G binary; KB, MB, GB decimal
UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "KIB": 1 << 10, "MIB": 1 << 20, "GIB": 1 << 30,
         "KB": 10**3, "MB": 10**6, "GB": 10**9}
#: Warp's CPU backend (LLVM/Clang that compiles kernels for the CPU), left out by --gpu-only
CPU_BACKEND = "warp/bin/warp-clang.so"
#: folders of a source checkout that are never part of the repository's files (when it is not a git checkout)
NOT_SOURCE = {".git", ".venv", "venv", "build", "runs", "out", "site", "__pycache__", ".pytest_cache"}


class BundleError(RuntimeError):
    """A build step failed (pip, git, a download): the message says which and what to do."""


# -- options -------------------------------------------------------------------------------------------------------
def parse_size(text: str, option: str = "--part-size") -> int:
    """Bytes from ``55M`` (MiB), ``64MiB``, ``60MB`` (10^6), ``1G`` or a plain count; ParameterError naming
    ``option``."""
    match = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*([A-Za-z]*)\s*", str(text))
    unit = match.group(2).upper() if match else None
    if not match or unit not in UNITS:
        raise ParameterError(option, f"a size such as 55M (MiB), 64MiB, 60MB (10^6 bytes) or 1G, got {text!r}")
    size = int(float(match.group(1)) * UNITS[unit])
    if size < 1024:
        raise ParameterError(option, f"must be at least 1 KiB, got {text!r} ({size} bytes)")
    return size


def normalise(name: str) -> str:
    """A package name as PEP 503 compares them: lower case, runs of ``-_.`` as one ``-``."""
    return re.sub(r"[-_.]+", "-", name).lower()


def names_list(text: str | None) -> list[str]:
    """``numpy,scipy Pillow`` -> normalised names, in order, once each."""
    seen = []
    for name in re.split(r"[,\s]+", text or ""):
        if name and normalise(name) not in seen:
            seen.append(normalise(name))
    return seen


@dataclass
class Target:
    """The machine a bundle is for: its Python (``3.12``), the platform tags its wheels may carry (empty: this
    machine's, as pip knows them) and its processor (``x86_64``)."""

    python: str
    platforms: list[str] = field(default_factory=list)
    machine: str = ""

    @property
    def tag(self) -> str:
        """``cp312-manylinux_2_28_x86_64``: how the bundle's name says its target."""
        where = self.platforms[0] if self.platforms else f"{sys.platform}_{self.machine}"
        return f"cp{self.python.replace('.', '')}-{where}"

    def pip_options(self) -> list[str]:
        """pip's options that select wheels for this target (nothing for this machine's own Python and platform)."""
        options = []
        if self.python != host_python():
            options += ["--python-version", self.python, "--implementation", "cp"]
        for tag in self.platforms:
            options += ["--platform", tag]
        return options

    def marker_environment(self) -> dict:
        """The values PEP 508 markers see on the target."""
        return {"python_version": self.python, "python_full_version": f"{self.python}.0",
                "implementation_name": "cpython", "platform_python_implementation": "CPython",
                "platform_machine": self.machine, "sys_platform": "linux" if self.platforms else sys.platform,
                "platform_system": "Linux" if self.platforms else platform.system(), "os_name": "posix"}


def host_python() -> str:
    return f"{sys.version_info[0]}.{sys.version_info[1]}"


def platform_tags(tag: str) -> list[str]:
    """The platform tags a machine of ``tag`` runs: ``manylinux_2_28_x86_64`` -> itself and every older manylinux tag
    of that processor down to manylinux1 (pip takes a named platform literally); another tag as it is."""
    match = re.fullmatch(r"manylinux_2_(\d+)_(\w+)", tag)
    legacy = {name: minor for minor, name in LEGACY_MANYLINUX.items()}
    match_legacy = re.fullmatch(r"(manylinux2014|manylinux2010|manylinux1)_(\w+)", tag)
    if match_legacy:
        minor, arch = legacy[match_legacy.group(1)], match_legacy.group(2)
    elif match:
        minor, arch = int(match.group(1)), match.group(2)
    else:
        return [tag]
    tags = []
    for m in range(minor, OLDEST_GLIBC_MINOR - 1, -1):
        tags.append(f"manylinux_2_{m}_{arch}")
        if m in LEGACY_MANYLINUX:
            tags.append(f"{LEGACY_MANYLINUX[m]}_{arch}")
    return tags


def machine_of(tag: str) -> str:
    """The processor a platform tag names (``manylinux_2_28_x86_64`` -> ``x86_64``)."""
    for prefix in (r"manylinux_2_\d+_", r"manylinux(?:2014|2010|1)_", r"musllinux_\d+_\d+_", r"linux_"):
        match = re.fullmatch(prefix + r"(\w+)", tag)
        if match:
            return match.group(1)
    raise ParameterError("--platform", f"a Linux wheel platform tag such as manylinux_2_28_x86_64, got {tag!r}")


def make_target(python_version: str | None, platform_tag: str | None) -> Target:
    """The target from the options: ``--python-version 3.12`` (default this Python's), ``--platform TAG`` (default
    this machine's)."""
    python = python_version or host_python()
    if not re.fullmatch(r"3\.\d+", python):
        raise ParameterError("--python-version", f"a CPython version such as 3.12, got {python!r}")
    if not platform_tag:
        return Target(python, [], platform.machine())
    return Target(python, platform_tags(platform_tag), machine_of(platform_tag))


# -- running tools -------------------------------------------------------------------------------------------------
def run_tool(cmd: list[str], what: str, **kwargs) -> subprocess.CompletedProcess:
    """Run ``cmd`` (its output shown); BundleError naming ``what`` when it fails."""
    print("+ " + " ".join(str(c) for c in cmd), flush=True)
    proc = subprocess.run(cmd, **kwargs)
    if proc.returncode != 0:
        raise BundleError(f"{what} failed (exit {proc.returncode}; its message is above)")
    return proc


def pip(*args: str) -> list[str]:
    return [sys.executable, "-m", "pip", *args]


# -- the source ----------------------------------------------------------------------------------------------------
def default_source() -> Path:
    """The checkout warpfree runs from (the folder holding ``pyproject.toml`` above the package)."""
    root = Path(__file__).resolve().parents[2]
    if not (root / "pyproject.toml").is_file():
        raise ParameterError("--source", f"warpfree runs from {root}, which is no source checkout: give the "
                                         "checkout's folder")
    return root


def source_tree(source: Path, work: Path) -> tuple[Path, dict]:
    """The files of the source checkout copied to ``work/src`` (a git checkout: its committed tree, ``git archive
    HEAD``), and what they are (commit, whether the working tree had other changes)."""
    dest = work / "src"
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    git = ["git", "-C", str(source)]
    is_git = subprocess.run(git + ["rev-parse", "--is-inside-work-tree"], capture_output=True, text=True)
    if is_git.returncode == 0 and is_git.stdout.strip() == "true":
        commit = subprocess.run(git + ["rev-parse", "HEAD"], capture_output=True, text=True,
                                check=True).stdout.strip()
        dirty = subprocess.run(git + ["status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True, check=True).stdout.strip()
        archive = subprocess.run(git + ["archive", "--format=tar", "HEAD"], capture_output=True, check=True).stdout
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            install.extract(tar, str(dest))
        if dirty:
            print(f"warpfree bundle: the working tree has uncommitted changes; the bundle holds commit {commit[:12]} "
                  "(commit them first to include them)", flush=True)
        return dest, {"commit": commit, "uncommitted_changes_left_out": bool(dirty)}
    for path in sorted(source.rglob("*")):
        rel = path.relative_to(source)
        if any(part in NOT_SOURCE or part.endswith(".egg-info") for part in rel.parts) or rel.parts[:2] == (
                "bench", "work"):
            continue
        if path.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, dest / rel)
    return dest, {"commit": None, "uncommitted_changes_left_out": False}


def build_own_wheel(src: Path, work: Path) -> Path:
    """warpfree's wheel built from ``src`` into ``work/dist``."""
    dist = work / "dist"
    if dist.exists():
        shutil.rmtree(dist)
    run_tool(pip("wheel", "--no-deps", "--quiet", "--wheel-dir", str(dist), str(src)), "building warpfree's wheel")
    wheels = sorted(dist.glob("warpfree-*.whl"))
    if len(wheels) != 1:
        raise BundleError(f"building warpfree's wheel left {len(wheels)} wheels in {dist}, not one")
    return wheels[0]


def wheel_requirements(wheel: Path) -> list[str]:
    """The ``Requires-Dist`` lines of a wheel's metadata that no extra asks for."""
    with zipfile.ZipFile(wheel) as z:
        metadata = next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))
        lines = z.read(metadata).decode("utf-8").splitlines()
    return [line.split(":", 1)[1].strip() for line in lines
            if line.startswith("Requires-Dist:") and "extra ==" not in line and "extra==" not in line]


def repo_archive(src: Path, path: Path) -> None:
    """``src`` as a gzip-compressed tar (files in name order, the folders made on unpacking)."""
    with tarfile.open(path, "w:gz") as tar:
        for file in sorted(p for p in src.rglob("*") if p.is_file()):
            tar.add(file, arcname=file.relative_to(src).as_posix(), recursive=False)


# -- resolution and selection --------------------------------------------------------------------------------------
def _requirement_class():
    """packaging's Requirement (from pip's own copy where packaging is not installed)."""
    try:
        from packaging.requirements import Requirement
    except ImportError:
        from pip._vendor.packaging.requirements import Requirement
    return Requirement


def resolve(requirements: list[str], target: Target, work: Path) -> list[dict]:
    """pip's resolution of ``requirements`` for ``target`` (binary wheels only): its report's ``install`` items."""
    report = work / "resolution.json"
    run_tool(pip("install", "--dry-run", "--ignore-installed", "--quiet", "--only-binary=:all:", "--report",
                 str(report), "--target", str(work / "no-install"), *target.pip_options(), *requirements),
             "resolving the requirements with pip (is the package index reachable?)")
    return json.loads(report.read_text())["install"]


def select(items: list[dict], roots: list[str], have: list[str], target: Target) -> tuple[list[dict], list[str]]:
    """The items the target needs: those reached from ``roots`` (requirement strings) through the requirements of
    each item (markers evaluated for ``target``) without passing through a package in ``have``. Also the names a
    marker asks for on the target that the resolution lacks (pip evaluated markers for this Python, not the
    target's)."""
    Requirement = _requirement_class()
    environment = target.marker_environment()
    by_name = {normalise(item["metadata"]["name"]): item for item in items}
    have = set(have)

    def needed(spec: str) -> str | None:
        req = Requirement(spec)
        if req.marker is not None and not req.marker.evaluate({**environment, "extra": ""}):
            return None
        return normalise(req.name)

    chosen, missing, todo = [], [], [needed(r) for r in roots]
    while todo:
        name = todo.pop(0)
        if name is None or name in have or name in chosen:
            continue
        if name not in by_name:
            if name not in missing:
                missing.append(name)
            continue
        chosen.append(name)
        todo += [needed(r) for r in by_name[name]["metadata"].get("requires_dist", [])]
    return [by_name[n] for n in chosen], missing


def wheel_name(item: dict) -> str:
    from urllib.parse import unquote, urlsplit

    return unquote(os.path.basename(urlsplit(item["download_info"]["url"]).path))


def lock_lines(items: list[dict]) -> list[str]:
    """``name==version --hash=sha256:...`` per item (pip's hash-checking mode)."""
    lines = []
    for item in items:
        digest = item["download_info"].get("archive_info", {}).get("hashes", {}).get("sha256")
        if not digest:
            raise BundleError(f"the index gave no sha256 for {wheel_name(item)}: cannot check its download")
        lines.append(f"{item['metadata']['name']}=={item['metadata']['version']} --hash=sha256:{digest}")
    return lines


def download(items: list[dict], target: Target, work: Path) -> list[Path]:
    """The items' wheels, downloaded (or found from an earlier build) into ``work/wheels-TAG`` and checked."""
    folder = work / f"wheels-{target.tag}"
    folder.mkdir(parents=True, exist_ok=True)
    lock = work / "requirements.lock"
    lock.write_text("\n".join(lock_lines(items)) + "\n")
    run_tool(pip("download", "--no-deps", "--require-hashes", "--only-binary=:all:", "--quiet", "--dest",
                 str(folder), *target.pip_options(), "-r", str(lock)), "downloading the wheels with pip")
    paths = []
    for item in items:
        path = folder / wheel_name(item)
        expected = item["download_info"]["archive_info"]["hashes"]["sha256"]
        if not path.is_file() or install.sha256_file(str(path)) != expected:
            raise BundleError(f"{path.name} is not in {folder} as the resolution named it (sha256 {expected[:16]}...)")
        paths.append(path)
    return paths


# -- forms ---------------------------------------------------------------------------------------------------------
def unpack_wheel(wheel: Path, tree: Path, owners: dict) -> None:
    """A wheel's files into ``tree`` as an installed package would have them (``*.data/purelib`` and ``platlib`` at
    the top, its other ``.data`` folders left out); a file another wheel already put there is refused."""
    with zipfile.ZipFile(wheel) as z:
        for info in z.infolist():
            if info.is_dir():
                continue
            name = info.filename
            parts = name.split("/")
            if parts[0].endswith(".data"):
                if len(parts) < 3 or parts[1] not in ("purelib", "platlib"):
                    continue  # scripts, headers, data: not importable, not needed by warpfree's runs
                name = "/".join(parts[2:])
            if name in owners:
                raise BundleError(f"{name} is in both {owners[name]} and {wheel.name}")
            owners[name] = wheel.name
            target = tree / name
            if not str(target.resolve()).startswith(str(tree.resolve()) + os.sep):
                raise BundleError(f"{wheel.name} holds {info.filename!r}, a path outside its folder")
            target.parent.mkdir(parents=True, exist_ok=True)
            with z.open(info) as src, open(target, "wb") as out:
                shutil.copyfileobj(src, out, install.BLOCK)
            mode = (info.external_attr >> 16) & 0o777
            target.chmod(0o755 if mode & 0o111 else 0o644)


def xz_preset(text: str) -> int:
    """``9e`` -> lzma's preset 9 | PRESET_EXTREME (as ``xz -9e``); ``0``..``9`` plain."""
    import lzma

    match = re.fullmatch(r"([0-9])(e?)", str(text))
    if not match:
        raise ParameterError("--xz-preset", f"0 to 9, optionally with e (extreme), as xz takes it, got {text!r}")
    return int(match.group(1)) | (lzma.PRESET_EXTREME if match.group(2) else 0)


def compress_xz(path: Path, preset: str, cache: Path) -> Path:
    """``path`` compressed to ``path.xz`` (xz format, one thread), reusing an earlier compression of the same bytes
    and preset from ``cache``; the original removed."""
    import lzma

    digest = install.sha256_file(str(path))
    cached = cache / f"{digest}.{preset}.xz"
    if not cached.is_file():
        cache.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        print(f"compressing {path.name} ({path.stat().st_size / 2**20:.0f} MiB) with xz -{preset} ...", flush=True)
        partial = cached.with_suffix(".partial")
        with open(path, "rb") as src, lzma.open(partial, "wb", preset=xz_preset(preset)) as out:
            shutil.copyfileobj(src, out, install.BLOCK)
        partial.replace(cached)
        print(f"  {cached.stat().st_size / 2**20:.1f} MiB in {time.perf_counter() - start:.0f} s", flush=True)
    out = path.with_name(path.name + ".xz")
    shutil.copyfile(cached, out)
    path.unlink()
    return out


def make_tree(wheels: list[Path], stage: Path, gpu_only: bool, xz_over: int, preset: str, cache: Path) -> dict:
    """The tree form in ``stage/tree``: every wheel unpacked, ``--gpu-only`` dropping Warp's CPU backend, each file
    over ``xz_over`` bytes compressed. The manifest entries of the compressed files (``xz_of``) and the dropped
    files."""
    tree = stage / "tree"
    owners: dict[str, str] = {}
    for wheel in wheels:
        unpack_wheel(wheel, tree, owners)
    dropped = []
    if gpu_only:
        if not (tree / CPU_BACKEND).is_file():
            raise BundleError(f"--gpu-only: the bundle holds no {CPU_BACKEND} (is warp-lang left out with --have?)")
        dropped.append({"path": f"tree/{CPU_BACKEND}", "size": (tree / CPU_BACKEND).stat().st_size,
                        "why": "Warp's CPU backend (--gpu-only): Warp then has no CPU device"})
        (tree / CPU_BACKEND).unlink()
    originals = {}
    for path in sorted(p for p in tree.rglob("*") if p.is_file() and p.stat().st_size > xz_over):
        rel = f"tree/{path.relative_to(tree).as_posix()}"
        original = {"path": rel, "size": path.stat().st_size, "sha256": install.sha256_file(str(path)),
                    "executable": bool(path.stat().st_mode & 0o111)}
        compressed = compress_xz(path, preset, cache)
        originals[f"tree/{compressed.relative_to(tree).as_posix()}"] = original
    return {"xz_of": originals, "dropped": dropped}


# -- payload and parts ---------------------------------------------------------------------------------------------
class PartWriter:
    """A write-only stream cut into files ``NAME.000``, ``NAME.001``, ... of at most ``part_size`` bytes each (one file
    ``NAME`` when ``part_size`` is None); the SHA-256 and size of the whole and of each part."""

    def __init__(self, folder: Path, name: str, part_size: int | None):
        self.folder, self.name, self.part_size = folder, name, part_size
        self.parts: list[dict] = []
        self.digest, self.size = hashlib.sha256(), 0
        self._file = None
        self._part_digest = None

    def _open(self) -> None:
        name = self.name if self.part_size is None else f"{self.name}.{len(self.parts):03d}"
        self._file = open(self.folder / name, "wb")
        self._part_digest = hashlib.sha256()
        self.parts.append({"name": name, "size": 0, "sha256": None})

    def _close_part(self) -> None:
        if self._file is not None:
            self._file.close()
            self.parts[-1]["sha256"] = self._part_digest.hexdigest()
            self._file = None

    def write(self, data) -> int:
        data = memoryview(data).cast("B")
        self.digest.update(data)
        self.size += len(data)
        written = 0
        while written < len(data):
            if self._file is None:
                self._open()
            room = len(data) - written if self.part_size is None else self.part_size - self.parts[-1]["size"]
            chunk = data[written:written + room]
            self._file.write(chunk)
            self._part_digest.update(chunk)
            self.parts[-1]["size"] += len(chunk)
            written += len(chunk)
            if self.part_size is not None and self.parts[-1]["size"] == self.part_size:
                self._close_part()
        return len(data)

    def close(self) -> None:
        self._close_part()
        if not self.parts:  # an empty stream still makes its one (empty) part
            self._open()
            self._close_part()


def file_entries(stage: Path) -> dict:
    """``{relative path: {size, sha256}}`` for every file under ``stage``, in name order."""
    return {p.relative_to(stage).as_posix(): {"size": p.stat().st_size, "sha256": install.sha256_file(str(p))}
            for p in sorted(stage.rglob("*")) if p.is_file()}


def write_payload(stage: Path, out: Path, name: str, part_size: int | None, compress: bool) -> dict:
    """Every file under ``stage`` as one tar stream (gzip when ``compress``) cut into parts in ``out``; the manifest's
    ``payload`` and ``parts``."""
    writer = PartWriter(out, name, part_size)
    with tarfile.open(fileobj=writer, mode="w|gz" if compress else "w|", format=tarfile.PAX_FORMAT) as tar:
        for path in sorted(p for p in stage.rglob("*") if p.is_file()):
            info = tar.gettarinfo(str(path), arcname=path.relative_to(stage).as_posix())
            info.uid = info.gid = 0
            info.uname = info.gname = ""
            with open(path, "rb") as f:
                tar.addfile(info, f)
    writer.close()
    return {"payload": {"name": name, "size": writer.size, "sha256": writer.digest.hexdigest(),
                        "compression": "gzip" if compress else None},
            "parts": writer.parts}


def write_bundle(stage: Path, out: Path, manifest: dict, part_size: int | None) -> dict:
    """The bundle in ``out`` from the staged files: the payload's parts, ``manifest.json`` (``manifest`` with the files,
    payload and parts added), the installer and a README; the manifest written."""
    compress = manifest["form"] == "tree"
    manifest = {**manifest, "files": file_entries(stage)}
    for rel, original in manifest.pop("xz_of", {}).items():
        manifest["files"][rel]["xz_of"] = original
    name = "payload.tar.gz" if compress else "payload.tar"
    manifest.update(write_payload(stage, out, name, part_size, compress))
    manifest["part_size"] = part_size
    shutil.copyfile(install.__file__, out / INSTALLER)
    manifest["installer"] = {"name": INSTALLER, "sha256": install.sha256_file(str(out / INSTALLER))}
    (out / install.MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
    (out / "README.txt").write_text(readme(manifest), encoding="utf-8")
    return manifest


def readme(manifest: dict) -> str:
    target, parts = manifest["target"], manifest["parts"]
    python = f"python{target['python']}"
    where = ", ".join(target["platforms"][:1]) or "the building machine"
    files = f"{len(parts)} part{'s' if len(parts) > 1 else ''}, {install.MANIFEST}, {INSTALLER}"
    return f"""warpfree {manifest['warpfree']} offline bundle ({manifest['form']} form) for Python {target['python']} \
on {target['machine']} ({where})

Copy every file of this folder ({files})
into one folder on the target, then run there, with the Python that will run warpfree:

    {python} {INSTALLER}                # verify, install into ./warpfree-venv, warpfree validate --quick
    {python} {INSTALLER} --verify-only  # only check the parts against {install.MANIFEST}
    python{target['python']} {INSTALLER} --help

Packages left out because the target has them: {', '.join(manifest['selection']['have']) or 'none'}.
Nothing is fetched from a package index: a part that does not match {install.MANIFEST} is refused.
"""


# -- the command ---------------------------------------------------------------------------------------------------
def require_out(out: Path, overwrite: bool) -> None:
    """``--out`` new or empty, or an earlier bundle (it holds manifest.json) with ``--overwrite``: then cleared."""
    if out.exists() and not out.is_dir():
        raise ParameterError("--out", f"{out} is a file, not a folder")
    if out.is_dir() and any(out.iterdir()):
        if not overwrite:
            raise ParameterError("--out", f"{out} already holds files: give --overwrite to replace an earlier bundle "
                                          "there, or another --out")
        if not (out / install.MANIFEST).is_file():
            raise ParameterError("--overwrite", f"{out} holds files but no bundle ({install.MANIFEST}): nothing is "
                                                "removed; choose another --out")
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)


def build(out: Path, target: Target, *, form: str = "wheels", have: list[str] = (), include: list[str] = (),
          part_size: int | None = None, gpu_only: bool = False, xz_over: int = 16 << 20, preset: str = "9e",
          source: Path | None = None, work: Path | None = None, overwrite: bool = False) -> dict:
    """Build the bundle (the module docstring's steps); its manifest."""
    if form not in ("wheels", "tree"):
        raise ParameterError("--form", f"wheels or tree, got {form!r}")
    if gpu_only and form != "tree":
        raise ParameterError("--gpu-only", "leaves Warp's CPU backend out of the tree form only (--form tree): a "
                                           "wheel is installed as it was published")
    xz_preset(preset)
    source = Path(source) if source else default_source()
    if not (source / "pyproject.toml").is_file():
        raise ParameterError("--source", f"{source} has no pyproject.toml: give warpfree's source checkout")
    out, work = Path(out).resolve(), Path(work or f"{out}-work").resolve()
    require_out(out, overwrite)
    work.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    src, origin = source_tree(source, work)
    own = build_own_wheel(src, work)
    roots = wheel_requirements(own) + list(include)
    items = resolve(roots, target, work)
    chosen, missing = select(items, roots, list(have), target)
    if missing:
        raise BundleError(f"the target needs {', '.join(missing)} (by its markers), which pip's resolution on Python "
                          f"{host_python()} left out: build with Python {target.python}, or add them with --include")
    wheels = download(chosen, target, work)
    manifest = {"format": FORMAT, "warpfree": __version__, "form": form,
                "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "target": {"python": target.python, "machine": target.machine, "platforms": target.platforms},
                "built_on": {"python": platform.python_version(), "machine": platform.machine(),
                             "platform": platform.platform()},
                "source": {"archive": "repo.tar.gz", **origin},
                "selection": {"requirements": roots, "have": list(have),
                              "left_out": sorted({normalise(i["metadata"]["name"]) for i in items}
                                                 - {normalise(i["metadata"]["name"]) for i in chosen})},
                "packages": [{"name": i["metadata"]["name"], "version": i["metadata"]["version"],
                              "wheel": p.name, "sha256": i["download_info"]["archive_info"]["hashes"]["sha256"]}
                             for i, p in zip(chosen, wheels)] + [{"name": "warpfree", "version": __version__,
                                                                  "wheel": own.name,
                                                                  "sha256": install.sha256_file(str(own))}],
                "lock": lock_lines(chosen)}
    manifest = assemble(out, work, wheels + [own], src, manifest, part_size=part_size, gpu_only=gpu_only,
                        xz_over=xz_over, preset=preset)
    report(manifest, out, time.perf_counter() - started)
    return manifest


def assemble(out: Path, work: Path, wheels: list[Path], src: Path, manifest: dict, *, part_size: int | None,
             gpu_only: bool = False, xz_over: int = 16 << 20, preset: str = "9e") -> dict:
    """The bundle in ``out`` from its wheels and the repository's files ``src``, staged in ``work/stage`` in the form
    ``manifest["form"]`` (step 4 of the module docstring, then step 5); the manifest written."""
    stage = work / "stage"
    if stage.exists():
        shutil.rmtree(stage)
    stage.mkdir(parents=True)
    manifest = {**manifest, "dropped": []}
    if manifest["form"] == "wheels":
        (stage / "wheels").mkdir()
        for wheel in wheels:
            shutil.copyfile(wheel, stage / "wheels" / wheel.name)
    else:
        made = make_tree(wheels, stage, gpu_only, xz_over, preset, work / "xz-cache")
        manifest["xz_of"], manifest["dropped"] = made["xz_of"], made["dropped"]
    repo_archive(src, stage / manifest["source"]["archive"])
    manifest = write_bundle(stage, out, manifest, part_size)
    shutil.rmtree(stage)
    return manifest


def report(manifest: dict, out: Path, seconds: float) -> None:
    mib = 2**20
    files = manifest["files"]
    print(f"warpfree bundle: {manifest['form']} form for Python {manifest['target']['python']} "
          f"({manifest['target']['machine']}) in {out}, {seconds:.0f} s")
    for p in manifest["packages"]:
        print(f"  {p['name']} {p['version']}")
    for rel, entry in files.items():
        if entry["size"] > 4 * mib:
            extra = f" (xz of {entry['xz_of']['size'] / mib:.1f} MiB)" if "xz_of" in entry else ""
            print(f"  {rel}: {entry['size'] / mib:.1f} MiB{extra}")
    for d in manifest["dropped"]:
        print(f"  left out {d['path']} ({d['size'] / mib:.1f} MiB): {d['why']}")
    parts = manifest["parts"]
    print(f"  payload {manifest['payload']['size'] / mib:.1f} MiB in {len(parts)} part(s), the largest "
          f"{max(p['size'] for p in parts) / mib:.1f} MiB; manifest sha256 "
          f"{install.sha256_file(str(out / install.MANIFEST))}")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The ``build`` and ``verify`` commands of ``warpfree bundle`` (and ``python -m warpfree.bundle``)."""
    sub = p.add_subparsers(dest="bundle_command")
    b = sub.add_parser("build", help="build a bundle (on a connected machine)",
                       description=__doc__.split("\n\n")[0] + " Install it on the target with the bundle's "
                                                              f"{INSTALLER}.")
    b.add_argument("--out", required=True, help="the bundle's folder (new or empty)")
    b.add_argument("--overwrite", action="store_true", help="replace an earlier bundle in --out")
    b.add_argument("--python-version", default=None, metavar="X.Y", help="the target's Python (default: this one's)")
    b.add_argument("--platform", default=None, metavar="TAG",
                   help="the target's wheel platform, e.g. manylinux_2_28_x86_64 for glibc >= 2.28 (older manylinux "
                        "tags of the processor are taken too; default: this machine's)")
    b.add_argument("--have", default="", metavar="A,B",
                   help="packages the target has (left out, with what only they need), e.g. "
                        "numpy,scipy,matplotlib,pillow,tqdm")
    b.add_argument("--include", action="append", default=[], metavar="REQ",
                   help="another requirement to bundle, e.g. pytest or 'mpi4py>=4' (repeatable)")
    b.add_argument("--form", choices=["wheels", "tree"], default="wheels",
                   help="wheels: installed by pip --no-index (default); tree: unpacked, large libraries xz-compressed")
    b.add_argument("--gpu-only", action="store_true", help=f"tree form: leave out {CPU_BACKEND} (Warp's CPU "
                                                           "backend, 66 MiB)")
    b.add_argument("--part-size", default=None, metavar="SIZE",
                   help="cut the payload into parts of at most SIZE (55M = 55 MiB; default: one file)")
    b.add_argument("--xz-over", default="16M", metavar="SIZE", help="tree form: compress files over SIZE (16M)")
    b.add_argument("--xz-preset", default="9e", help="tree form: xz preset, 0-9 with e for extreme (9e, as xz -9e)")
    b.add_argument("--source", default=None, help="warpfree's source checkout (default: the one this runs from)")
    b.add_argument("--work", default=None, help="downloads and intermediate files, reused (default: OUT-work)")
    v = sub.add_parser("verify", help="check a bundle's parts against its manifest",
                       description="Check every part of a bundle (present, size, SHA-256) against its manifest.json.")
    v.add_argument("bundle", help="the bundle's folder")


def bundle_command(args) -> int:
    """``warpfree bundle build|verify``; the exit code (0 done, 1 a step failed or a part differs; bad options raise
    ParameterError, exit 2)."""
    try:
        if args.bundle_command == "build":
            part_size = parse_size(args.part_size) if args.part_size else None
            build(Path(args.out), make_target(args.python_version, args.platform), form=args.form,
                  have=names_list(args.have), include=args.include, part_size=part_size, gpu_only=args.gpu_only,
                  xz_over=parse_size(args.xz_over, "--xz-over"), preset=args.xz_preset, source=args.source,
                  work=args.work, overwrite=args.overwrite)
            return 0
        if args.bundle_command == "verify":
            manifest = install.read_manifest(args.bundle)
            install.verify_parts(args.bundle, manifest)
            print(f"warpfree bundle: {len(manifest['parts'])} parts of {args.bundle} match its manifest")
            return 0
    except BundleError as err:
        print(f"warpfree bundle: error: {err}", file=sys.stderr)
        return 1
    except install.Refused as err:
        print(f"warpfree bundle: {err}", file=sys.stderr)
        return 1
    print("warpfree bundle: give a command: build or verify (warpfree bundle build --help)", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    """``python -m warpfree.bundle``: :func:`bundle_command` with ParameterError as exit code 2."""
    parser = argparse.ArgumentParser(prog="python -m warpfree.bundle", description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return bundle_command(args)
    except ParameterError as err:
        print(f"warpfree bundle: error: {err}", file=sys.stderr)
        return 2
