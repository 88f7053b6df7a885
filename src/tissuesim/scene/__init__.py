"""Scene files: one TOML file describes a model, its material, method, supports, gravity and tools."""
