"""MDP value-iteration trajectories on 2D/3D grids (Liu & Du 2019, paper 000).

``solve`` computes the state values, ``generate_trajectories`` runs Algorithm 3 on a
grid, ``simulate`` runs the whole method on a Scene and returns Trajectories.

Names load on first use, so that ``crowdmotion.mdp.params`` (the scenario schema) can be
imported without compiling or loading the numba kernels.
"""

from crowdmotion._lazy import lazy_exports

_EXPORTS = {
    "GridMap": "grid", "load_grid": "grid", "max_radius": "grid", "min_cell_size": "grid", "rasterise": "grid",
    "MDPParams": "params", "Params": "params",
    "MDPRun": "simulation", "resample": "simulation", "run": "simulation", "simulate": "simulation",
    "METHODS": "solvers", "dijkstra": "solvers", "dijkstra_unsorted": "solvers", "greedy_estimate": "solvers",
    "heuristic_value_iteration": "solvers", "improved_value_iteration": "solvers", "solve": "solvers",
    "value_iteration": "solvers",
    "RAW_GRID_RADIUS": "trajectory", "generate_trajectories": "trajectory",
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
