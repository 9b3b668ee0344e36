"""``python -m warpfree.validation.heave_decay_2d``: tabulate Ursell's coefficients anew into ``coefficients.csv``."""

import warnings
from pathlib import Path

from . import TABLE, write_table

warnings.simplefilter("ignore")  # quad's warnings where the wave integrals converge slowly (checked: λ from the waves)
write_table(Path(__file__).with_name(TABLE))
