"""MDP value-iteration trajectories on 2D/3D grids (Liu & Du 2019, paper 000).

``solve`` computes the state values, ``generate_trajectories`` runs Algorithm 3 on a
grid, ``simulate`` runs the whole method on a Scene and returns Trajectories.
"""

from crowdmotion.mdp.grid import GridMap, load_grid, max_radius, min_cell_size, rasterise
from crowdmotion.mdp.simulate import MDPParams, MDPRun, resample, run, simulate
from crowdmotion.mdp.solvers import (
    METHODS,
    dijkstra,
    greedy_estimate,
    heuristic_value_iteration,
    improved_value_iteration,
    solve,
    value_iteration,
)
from crowdmotion.mdp.trajectory import RAW_GRID_RADIUS, generate_trajectories

Params = MDPParams

__all__ = [
    "GridMap", "load_grid", "max_radius", "min_cell_size", "rasterise", "MDPParams", "MDPRun", "Params",
    "resample", "run", "simulate", "METHODS", "dijkstra", "greedy_estimate", "heuristic_value_iteration",
    "improved_value_iteration", "solve", "value_iteration", "RAW_GRID_RADIUS", "generate_trajectories",
]
