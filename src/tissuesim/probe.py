"""A rigid probe (a sphere, or a capsule: a probe tip or an instrument shaft) that pushes the surface by
frictionless unilateral contact."""
