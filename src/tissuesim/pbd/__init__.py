"""Position-based dynamics on the fine surface (§4, §6.3–6.5)."""
