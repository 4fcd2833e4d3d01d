"""Column collapses on rigid and erodible beds (Martin et al. 2022)."""
