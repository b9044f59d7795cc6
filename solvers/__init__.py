"""Solvers of the reach-avoid game: ``solvers.hj`` (Hamilton-Jacobi reach-avoid tubes for the
1 vs 1 and 2 vs 1 games) and ``solvers.assignment`` (the paper's assignment MIP and the
maximum-matching baseline). Nothing here imports ``policies``."""
