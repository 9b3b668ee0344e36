"""What several test folders share: test-only Warp kernels, an example static solver, and the repository root."""

from pathlib import Path

#: the repository root (the README, the source tree the packaging test builds from)
ROOT = Path(__file__).resolve().parents[2]
