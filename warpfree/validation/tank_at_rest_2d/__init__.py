"""Tank at rest (2D hydrostatics): no data files, the reference is analytic.

After settling, the pressure in water of depth H must follow p = ρ0 g (H − y), y measured up from the
tank floor; ``scenes/tank_at_rest_2d.py`` compares its binned SPH pressure with this profile, errors
normalised by the bottom pressure ρ0 g H. See ``README.md`` in this folder.
"""
