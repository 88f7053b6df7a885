"""Linear finite elements on tetrahedra (§3, §6.2)."""
