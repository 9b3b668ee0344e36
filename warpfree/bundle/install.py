"""Install an offline bundle of warpfree on a machine with no package index (a cluster's GPU node).

This file is shipped in every bundle as ``install_bundle.py`` and needs only the Python standard library: run it with
the Python that will run warpfree (the bundle's target version), in the folder that holds the bundle's parts::

    python3 install_bundle.py                   # verify, unpack, install into ./warpfree-venv, validate --quick
    python3 install_bundle.py --verify-only     # check every part against manifest.json, install nothing
    python3 install_bundle.py --here            # into the environment of this Python (a venv or conda env)
    python3 install_bundle.py --check gpu       # afterwards the one-shot GPU check (bench/core/gpu_check.py)

In order: the parts are checked against ``manifest.json`` (present, size, sha256); joined as one stream and unpacked
(no joined copy is written); every unpacked file is checked against the manifest; files shipped compressed
(``.xz``) are decompressed and checked again; then the ``wheels`` form is installed by
``pip install --no-index --find-links`` (pip's own configuration ignored: nothing is fetched from anywhere) and the
``tree`` form (wheels unpacked, the large native libraries compressed) is put on the path by a ``.pth`` file, with a
``warpfree`` launcher. A mismatch anywhere stops with one line naming the file, before anything is installed; the
exit code is then 2. The check afterwards (``--check``) decides the exit code of a completed install.

The joining, checking and unpacking are also importable (``warpfree.bundle.install``): the builder uses the same code
for its ``verify`` command and the tests use it on small bundles.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import os
import platform
import shutil
import subprocess
import sys
import tarfile
import tempfile

#: the manifest's name beside the parts
MANIFEST = "manifest.json"
#: the manifest format this installer reads
FORMAT = 1
#: the reading block (bytes)
BLOCK = 1 << 20
#: where a bundle's parts of the repository go in a venv (tests, benchmarks, scenes: what the GPU check runs)
SOURCE_DIR = "warpfree-source"
#: where the tree form's unpacked packages go in a venv
TREE_DIR = "warpfree-tree"


class Refused(Exception):
    """A check failed: the message is the one line said before leaving with exit code 2."""


# -- checking ------------------------------------------------------------------------------------------------------
def sha256_file(path: str) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(BLOCK), b""):
            digest.update(block)
    return digest.hexdigest()


def read_manifest(bundle: str) -> dict:
    """The bundle's manifest, or :class:`Refused` when it is missing, unreadable or of another format."""
    path = os.path.join(bundle, MANIFEST)
    try:
        with open(path, encoding="utf-8") as f:
            manifest = json.load(f)
    except OSError as exc:
        raise Refused(f"no readable {MANIFEST} in {bundle} ({exc.strerror or exc}): copy it beside the parts") from None
    except ValueError as exc:
        raise Refused(f"{path} is damaged ({exc}): copy it again") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise Refused(f"{path} is not a warpfree bundle manifest of format {FORMAT}")
    return manifest


def verify_parts(bundle: str, manifest: dict) -> list[str]:
    """Every part present with its size and SHA-256; their paths in order, or :class:`Refused` naming the first that
    is missing or differs."""
    paths = []
    for part in manifest["parts"]:
        path = os.path.join(bundle, part["name"])
        if not os.path.isfile(path):
            raise Refused(f"part {part['name']} is missing from {bundle} ({len(manifest['parts'])} parts): copy it "
                          "there")
        size = os.path.getsize(path)
        if size != part["size"]:
            raise Refused(f"part {part['name']} has {size} bytes, the manifest {part['size']}: transfer it again")
        digest = sha256_file(path)
        if digest != part["sha256"]:
            raise Refused(f"part {part['name']} does not match the manifest (sha256 {digest[:16]}..., expected "
                          f"{part['sha256'][:16]}...): transfer it again")
        paths.append(path)
    return paths


class JoinedParts(io.RawIOBase):
    """The parts read as one stream (for ``tarfile`` in stream mode), hashed on the way: nothing joined is written."""

    def __init__(self, paths: list[str]):
        self._paths = list(paths)
        self._file = None
        self.digest = hashlib.sha256()
        self.size = 0

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        while True:
            if self._file is None:
                if not self._paths:
                    return 0
                self._file = open(self._paths.pop(0), "rb")
            n = self._file.readinto(buffer)
            if n:
                self.digest.update(memoryview(buffer)[:n])
                self.size += n
                return n
            self._file.close()
            self._file = None

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
        super().close()


def _safe_member(member: tarfile.TarInfo, dest: str) -> str:
    """The member's path under ``dest``, or :class:`Refused` for one that would land outside it or is not a plain
    file or folder."""
    target = os.path.realpath(os.path.join(dest, member.name))
    if os.path.isabs(member.name) or not target.startswith(os.path.realpath(dest) + os.sep):
        raise Refused(f"the payload holds {member.name!r}, a path outside the unpacking folder: refused")
    if not (member.isfile() or member.isdir()):
        raise Refused(f"the payload holds {member.name!r}, which is not a plain file or folder: refused")
    return target


def extract(tar: tarfile.TarFile, dest: str) -> None:
    """The plain files and folders of ``tar`` (read in order: stream mode works) written under ``dest``; files keep
    only whether they are executable. :class:`Refused` for a member outside ``dest`` or of another kind."""
    for member in tar:
        target = _safe_member(member, dest)
        if member.isdir():
            os.makedirs(target, exist_ok=True)
            continue
        os.makedirs(os.path.dirname(target), exist_ok=True)
        with tar.extractfile(member) as src, open(target, "wb") as out:
            shutil.copyfileobj(src, out, BLOCK)
        os.chmod(target, 0o755 if member.mode & 0o111 else 0o644)


def unpack(bundle: str, manifest: dict, dest: str) -> None:
    """Verify the parts, unpack the payload into ``dest`` (a new folder), check every file against the manifest and
    decompress the ``.xz`` files (checked again); :class:`Refused` on any mismatch (``dest`` is then removed)."""
    paths = verify_parts(bundle, manifest)
    if os.path.exists(dest):
        raise Refused(f"{dest} exists: unpacking needs a new folder")
    os.makedirs(dest)
    try:
        stream = JoinedParts(paths)
        with tarfile.open(fileobj=io.BufferedReader(stream, BLOCK), mode="r|*") as tar:
            extract(tar, dest)
            for _ in iter(lambda: stream.read(BLOCK), b""):  # a tar ends in padding: hash the whole payload
                pass
        payload = manifest["payload"]
        if stream.digest.hexdigest() != payload["sha256"] or stream.size != payload["size"]:
            raise Refused("the joined parts are not the payload the manifest names (are parts from two bundles "
                          "mixed?): transfer them again")
        check_files(dest, manifest)
        decompress(dest, manifest)
    except BaseException:
        shutil.rmtree(dest, ignore_errors=True)
        raise


def check_files(dest: str, manifest: dict) -> None:
    """Every file the manifest lists is in ``dest`` with its size and SHA-256, and no other file is."""
    files = manifest["files"]
    found = set()
    for root, _, names in os.walk(dest):
        for name in names:
            found.add(os.path.relpath(os.path.join(root, name), dest).replace(os.sep, "/"))
    extra = sorted(found - set(files))
    if extra:
        raise Refused(f"the payload holds {extra[0]}, which the manifest does not list: refused")
    for rel, entry in files.items():
        path = os.path.join(dest, rel)
        if rel not in found:
            raise Refused(f"{rel}, listed in the manifest, is not in the payload: refused")
        if os.path.getsize(path) != entry["size"] or sha256_file(path) != entry["sha256"]:
            raise Refused(f"{rel} does not match the manifest's sha256: refused (transfer the parts again)")


def decompress(dest: str, manifest: dict) -> None:
    """Each file shipped compressed (its manifest entry has ``xz_of``) decompressed beside it and checked against the
    original's size and SHA-256; the ``.xz`` removed."""
    for rel, entry in manifest["files"].items():
        original = entry.get("xz_of")
        if not original:
            continue
        try:
            import lzma
        except ImportError:
            raise Refused("this Python has no lzma module (built without liblzma), which the tree form needs: use a "
                          "bundle of the wheels form (warpfree bundle build --form wheels)") from None
        src, out_path = os.path.join(dest, rel), os.path.join(dest, original["path"])
        digest, size = hashlib.sha256(), 0
        with lzma.open(src, "rb") as f, open(out_path, "wb") as out:
            for block in iter(lambda: f.read(BLOCK), b""):
                digest.update(block)
                size += len(block)
                out.write(block)
        if digest.hexdigest() != original["sha256"] or size != original["size"]:
            raise Refused(f"{original['path']} decompressed does not match the manifest's sha256: refused")
        os.chmod(out_path, 0o755 if original.get("executable") else 0o644)
        os.remove(src)


# -- the target ----------------------------------------------------------------------------------------------------
def check_target(manifest: dict, python: tuple[int, int] = sys.version_info[:2],
                 machine: str = platform.machine()) -> None:
    """:class:`Refused` when this Python's version or the machine is not the bundle's target."""
    target = manifest["target"]
    if target.get("python") and target["python"] != f"{python[0]}.{python[1]}":
        raise Refused(f"this bundle was built for Python {target['python']}, this is Python {python[0]}.{python[1]}: "
                      f"run it with python{target['python']}, or build one with --python-version "
                      f"{python[0]}.{python[1]}")
    if target.get("machine") and target["machine"] != machine:
        raise Refused(f"this bundle was built for {target['machine']}, this machine is {machine}: build one for it "
                      "(--platform)")


def _run(cmd: list[str], **kwargs) -> int:
    print("+ " + " ".join(cmd), flush=True)
    return subprocess.call(cmd, **kwargs)


def venv_python(venv: str) -> str:
    return os.path.join(venv, "Scripts" if os.name == "nt" else "bin", "python")


def make_venv(venv: str, with_pip: bool) -> str:
    """A virtual environment at ``venv`` that also sees this Python's packages (``--system-site-packages``: the ones
    the bundle left out because the target has them), made once; its Python."""
    python = venv_python(venv)
    if os.path.isfile(os.path.join(venv, "pyvenv.cfg")) and os.path.exists(python):
        return python
    if os.path.exists(venv) and os.listdir(venv):
        raise Refused(f"{venv} holds files but is no virtual environment: give another --venv")
    cmd = [sys.executable, "-m", "venv", "--system-site-packages"] + ([] if with_pip else ["--without-pip"]) + [venv]
    if _run(cmd) != 0:
        raise Refused(f"could not make a virtual environment at {venv} (python -m venv failed above)")
    return python


def _query(python: str, code: str) -> str:
    return subprocess.run([python, "-c", code], capture_output=True, text=True, check=True).stdout.strip()


def require_present(python: str, names: list[str], new_venv: bool = False) -> None:
    """The packages the bundle left out because the target has them (``--have``) are there for ``python`` (in a new
    venv: from its base Python, which is not the environment this script runs in when that is a venv)."""
    if not names:
        return
    code = ("import importlib.metadata as m, json, sys\nout = []\nfor n in sys.argv[1:]:\n    try: m.version(n)\n"
            "    except m.PackageNotFoundError: out.append(n)\nprint(json.dumps(out))")
    missing = json.loads(subprocess.run([python, "-c", code, *names], capture_output=True, text=True,
                                        check=True).stdout)
    if missing and new_venv and sys.prefix != sys.base_prefix:
        raise Refused(f"a new venv does not see {', '.join(missing)}, which the bundle left out (built with --have): "
                      f"this Python runs in the environment {sys.prefix}, and a venv made from it sees only its base "
                      f"Python's packages; give --here to install into {sys.prefix}")
    if missing:
        raise Refused(f"this Python lacks {', '.join(missing)}, which the bundle left out (built with --have): install "
                      "them, run this with a Python that has them, or give --here inside the environment that has "
                      "them")


def clean_pip_env() -> dict:
    """The environment for pip: no configuration file and no PIP_* variables (a node's pip.conf naming an index or a
    constraint would change what --no-index installs)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PIP_")}
    env["PIP_CONFIG_FILE"] = os.devnull
    return env


def install_wheels(python: str, wheels: str, manifest: dict) -> None:
    """``pip install --no-index --find-links wheels warpfree==VERSION`` with ``python``, then warpfree's own wheel again
    (``--force-reinstall --no-deps``: a bundle of the same version number replaces an earlier install)."""
    pip = [python, "-m", "pip", "install", "--no-index", "--find-links", wheels, "--disable-pip-version-check"]
    own = [os.path.join(wheels, p["wheel"]) for p in manifest["packages"] if p["name"] == "warpfree"]
    for cmd in (pip + [f"warpfree=={manifest['warpfree']}"], pip + ["--force-reinstall", "--no-deps", *own]):
        if _run(cmd, env=clean_pip_env()) != 0:
            raise Refused("pip could not install from the bundle's wheels (its message is above)")


def site_packages(python: str) -> str:
    return _query(python, "import sysconfig; print(sysconfig.get_paths()['purelib'])")


def install_tree(python: str, tree: str, scripts: str) -> None:
    """The tree form: ``tree`` on ``python``'s path through ``warpfree-bundle.pth``, and a ``warpfree`` launcher in
    ``scripts``."""
    with open(os.path.join(site_packages(python), "warpfree-bundle.pth"), "w", encoding="utf-8") as f:
        f.write(os.path.abspath(tree) + "\n")
    os.makedirs(scripts, exist_ok=True)
    launcher = os.path.join(scripts, "warpfree")
    with open(launcher, "w", encoding="utf-8") as f:
        f.write(f"#!{python}\nimport sys\nfrom warpfree.cli import entry\nsys.exit(entry())\n")
    os.chmod(launcher, 0o755)


# -- the check afterwards ------------------------------------------------------------------------------------------
DEVICES = ("import json, warp as wp\nwp.config.quiet = True\nwp.init()\n"
           "print(json.dumps({'warp': wp.__version__, 'devices': [str(d) for d in wp.get_devices()], "
           "'cuda': wp.get_cuda_device_count()}))")


def run_check(check: str, python: str, venv: str, device: str | None, threads: int | None) -> int:
    """``import``: Warp's devices and ``warpfree --version``; ``validate``: ``warpfree validate --quick`` on the GPU
    when there is one (else the CPU); ``gpu``: ``bench/core/gpu_check.py`` from the bundle's repository files. The
    exit code."""
    if check == "none":
        return 0
    try:
        info = json.loads(_query(python, DEVICES).splitlines()[-1])
    except (subprocess.CalledProcessError, ValueError, IndexError) as exc:
        err = getattr(exc, "stderr", "") or str(exc)
        print(f"install_bundle: warp does not import: {err.strip().splitlines()[-1] if err.strip() else err}",
              file=sys.stderr)
        return 1
    print(f"warp {info['warp']}: devices {', '.join(info['devices']) or 'none'}", flush=True)
    if _run([python, "-m", "warpfree", "--version"]) != 0:
        return 1
    if check == "import":
        return 0
    device = device or ("cuda" if info["cuda"] else "cpu")
    if device == "cpu" and "cpu" not in info["devices"]:
        print("install_bundle: no CUDA device here and the bundle has no CPU backend (built --gpu-only)",
              file=sys.stderr)
        return 1
    threads_args = ["--threads", str(threads)] if threads else []
    if check == "validate":
        out = os.path.join(venv, "validate_quick")
        return _run([python, "-m", "warpfree", "validate", "--quick", "--device", device, "--out", out,
                     "--overwrite", *threads_args])
    source = os.path.join(venv, SOURCE_DIR)
    env = dict(os.environ, PYTHONSAFEPATH="1")  # the installed warpfree, not the source folder's, from its root
    if sys.version_info < (3, 11):
        print("install_bundle: --check gpu needs Python >= 3.11 (PYTHONSAFEPATH); use --check validate",
              file=sys.stderr)
        return 1
    return _run([python, os.path.join("bench", "core", "gpu_check.py"), "--device", device], cwd=source, env=env)


# -- the command ---------------------------------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="install_bundle.py", description=__doc__.split("\n\n")[0],
                                epilog="Exit codes: 0 installed (and the check passed), 1 the check failed, 2 refused "
                                       "(nothing installed).")
    p.add_argument("--bundle", default=os.path.dirname(os.path.abspath(__file__)),
                   help="the folder holding manifest.json and the parts (default: this script's)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--venv", default="warpfree-venv",
                       help="the virtual environment to make (or add to) and install into (default ./warpfree-venv); "
                            "it sees this Python's packages too")
    where.add_argument("--here", action="store_true", help="install into the environment of the Python running this")
    where.add_argument("--unpack-to", metavar="DIR", help="only verify and unpack into DIR (a new folder)")
    where.add_argument("--verify-only", action="store_true", help="only check every part against the manifest")
    p.add_argument("--check", choices=["none", "import", "validate", "gpu"], default="validate",
                   help="afterwards: nothing, Warp's devices, warpfree validate --quick (default), or the one-shot GPU "
                        "check bench/core/gpu_check.py")
    p.add_argument("--device", default=None, help="the check's device (default: cuda when Warp sees one, else cpu)")
    p.add_argument("--threads", type=int, default=None, help="CPU threads of the check")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        manifest = read_manifest(args.bundle)
        if args.verify_only:
            verify_parts(args.bundle, manifest)
            print(f"install_bundle: {len(manifest['parts'])} parts match {MANIFEST} "
                  f"(sha256 {sha256_file(os.path.join(args.bundle, MANIFEST))[:16]}...)")
            return 0
        if args.unpack_to:
            unpack(args.bundle, manifest, args.unpack_to)
            print(f"install_bundle: unpacked and checked into {args.unpack_to}")
            if manifest["form"] == "tree":
                print(f"  export PYTHONPATH={os.path.abspath(os.path.join(args.unpack_to, 'tree'))}"
                      "${PYTHONPATH:+:$PYTHONPATH}   # then: python -m warpfree")
            return 0
        check_target(manifest)
        made = False
        if args.here:
            python, venv = sys.executable, sys.prefix
        else:
            venv = os.path.abspath(args.venv)
            made = not os.path.exists(venv)
            python = make_venv(venv, with_pip=manifest["form"] == "wheels")
        try:
            require_present(python, manifest["selection"]["have"], new_venv=made)
        except Refused:
            if made:  # the venv made a moment ago goes with the refusal
                shutil.rmtree(venv, ignore_errors=True)
            raise
        work = tempfile.mkdtemp(prefix=".warpfree-bundle-", dir=venv)
        try:
            unpacked = os.path.join(work, "payload")
            unpack(args.bundle, manifest, unpacked)
            if manifest["form"] == "wheels":
                install_wheels(python, os.path.join(unpacked, "wheels"), manifest)
            else:
                tree = os.path.join(venv, TREE_DIR)
                if os.path.exists(tree):
                    shutil.rmtree(tree)
                os.replace(os.path.join(unpacked, "tree"), tree)
                install_tree(python, tree, os.path.dirname(python))
            source = os.path.join(venv, SOURCE_DIR)
            if os.path.exists(source):
                shutil.rmtree(source)
            if manifest.get("source"):
                with tarfile.open(os.path.join(unpacked, manifest["source"]["archive"])) as tar:
                    extract(tar, source)
        finally:
            shutil.rmtree(work, ignore_errors=True)
        print(f"install_bundle: warpfree {manifest['warpfree']} installed ({manifest['form']} form) for {python}")
    except Refused as err:
        print(f"install_bundle: refused: {err}", file=sys.stderr)
        return 2
    return run_check(args.check, python, venv, args.device, args.threads)


if __name__ == "__main__":
    sys.exit(main())
