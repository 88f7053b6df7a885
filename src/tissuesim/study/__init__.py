"""Studies: many cases (models × methods × materials × loads) declared in one TOML file, run as tasks on Dask."""
