"""Package discovery for warpfree's layout (everything else is in pyproject.toml).

``warpfree/`` is found as usual; ``kernels/`` and ``scenes/`` stand at the top of the tree (the kernels apart from the
orchestration layer, the scenes where a user finds them) and are installed as ``warpfree.kernels`` and
``warpfree.scenes``. Every package below each root is discovered, so a new subpackage needs no entry anywhere;
pyproject.toml cannot express discovery under a mapped folder, hence these lines.
"""

from setuptools import find_packages, setup

MAPPED = {"warpfree.kernels": "kernels", "warpfree.scenes": "scenes"}

packages = find_packages(include=["warpfree", "warpfree.*"])
for package, folder in MAPPED.items():
    packages += [package] + [f"{package}.{sub}" for sub in find_packages(folder)]

setup(packages=packages, package_dir={"warpfree": "warpfree", **MAPPED})
