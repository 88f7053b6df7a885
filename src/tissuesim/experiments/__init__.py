"""The paper's experiments (§8.3): load cases, metrics, sweeps, tables and plots."""
