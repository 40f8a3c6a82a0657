"""Algorithm 3 (paper §2.2): collision-free trajectories on the grid from the state values."""

from __future__ import annotations

from itertools import product

import numba
import numpy as np

from crowdmotion.mdp._kernels import PAD, trajectory_steps
from crowdmotion.mdp.grid import SQRT2, validate_grid
from crowdmotion.mdp.moves import crossing_masks, flat_move_tables
from crowdmotion.mdp.solvers import padded

AGENTS_PER_THREAD = 2000
"""Fewest agents per thread for Algorithm 3 to share its steps between threads: below,
sorting the turns into clusters costs more than the threads give back."""


def step_threads(n_agents: int) -> int:
    """How many threads Algorithm 3's steps use for ``n_agents``: numba's thread count
    (``NUMBA_NUM_THREADS``, ``numba.set_num_threads``), at most one per
    ``AGENTS_PER_THREAD`` agents."""
    return max(1, min(numba.get_num_threads(), n_agents // AGENTS_PER_THREAD))


RAW_GRID_RADIUS = 1.0 / (2.0 * SQRT2) * (1.0 - 1e-6)
"""Agent radius in cells assumed on a raw grid: the largest the paper's cell rule allows."""


class Walker:
    """Algorithm 3's state between chunks of steps: agents' cells, the ``block`` matrix.

    Used by :func:`generate_trajectories` and by scene runs that re-solve the values
    when obstacles move (``set_field``/``set_blocked`` between ``advance`` calls).
    ``present`` (default: all) marks the agents in the scene from the start; the others
    wait off-scene (inactive, on no cell) until :meth:`enter` places them.
    """

    def __init__(self, grid: np.ndarray, starts: np.ndarray, goal_masks: np.ndarray, field_of: np.ndarray,
                 corner_cutting: bool, radius_cells: float, present: np.ndarray | None = None):
        self.shape = grid.shape
        self.dim = grid.ndim
        self.blocked, self.strides = padded(grid)
        _, _, self.vectors, self.swept, self.swept_count = flat_move_tables(self.strides, corner_cutting)
        self.offsets = (self.vectors.astype(np.int64) @ self.strides).astype(np.int64)
        near = np.array(list(product(range(-2, 3), repeat=self.dim)), dtype=np.int64)
        self.near_offsets = near @ self.strides
        self.near_ahead = self.near_offsets[self.near_offsets > 0]  # its half ahead: the threads' clusters
        self.crossing = crossing_masks(near.astype(np.float64), self.vectors, (2.0 * radius_cells) ** 2)
        self.goal = np.stack([np.pad(np.asarray(m, dtype=np.uint8), PAD).ravel() for m in goal_masks])
        self.field_of = np.asarray(field_of, dtype=np.int64)
        self.coord = np.asarray(starts, dtype=np.int64) + PAD
        self.cur = self.coord @ self.strides
        here = np.ones(len(self.cur), dtype=bool) if present is None else np.asarray(present, dtype=bool)
        self.active = here.astype(np.uint8)
        self.gone_step = np.full(len(self.cur), -1, dtype=np.int64)
        self.entered_frame = np.where(here, 0, np.iinfo(np.int64).max)  # the frame each agent appears in
        self.steps_done = 0
        self.occ = np.full(self.blocked.size, -1, dtype=np.int32)
        self.occ[self.cur[here]] = np.flatnonzero(here)
        self.values = None

    def set_blocked(self, grid: np.ndarray) -> None:
        """Replace the obstacle cells (e.g. moving obstacles and their look-ahead)."""
        self.blocked = padded(grid)[0]

    def set_values(self, values: np.ndarray) -> None:
        """(F, *shape) value fields, one per goal; agents follow ``values[field_of[i]]``."""
        flat = np.stack([np.pad(v, PAD, constant_values=-np.inf).ravel() for v in values])
        self.values = flat

    def add_field(self, values: np.ndarray, goal_mask: np.ndarray) -> int:
        """Append a value field (``*shape``; goal cells >= 0, the rest < 0) and its goal
        mask; return its index for ``field_of``."""
        self.values = np.vstack([self.values, np.pad(values, PAD, constant_values=-np.inf).ravel()[None]])
        self.goal = np.vstack([self.goal, np.pad(np.asarray(goal_mask, dtype=np.uint8), PAD).ravel()[None]])
        return len(self.values) - 1

    def remove(self, ids: np.ndarray) -> None:
        """Take agents ``ids`` out of the scene after the steps done so far: they are
        drawn where they stand in the last frame, gone from the next, and free their cell."""
        ids = np.asarray(ids, dtype=np.int64)
        ids = ids[self.active[ids] == 1]
        self.active[ids] = 0
        self.gone_step[ids] = self.steps_done
        mine = self.occ[self.cur[ids]] == ids
        self.occ[self.cur[ids][mine]] = -1

    def free(self, cells: np.ndarray) -> np.ndarray:
        """(M,) whether each of ``cells`` ((M, D) grid indices) is free now: no obstacle
        (moving ones included, as last set) and no agent on it."""
        flat = (np.asarray(cells, dtype=np.int64) + PAD) @ self.strides
        return (self.blocked[flat] == 0) & (self.occ[flat] < 0)

    def enter(self, ids: np.ndarray, cells: np.ndarray) -> None:
        """Agents ``ids``, waiting off-scene, enter at ``cells`` ((len(ids), D), free and
        distinct: see :meth:`free`) after the steps done so far: they stand there in the
        last frame and are stepped from the next step on."""
        ids = np.asarray(ids, dtype=np.int64)
        self.coord[ids] = np.asarray(cells, dtype=np.int64) + PAD
        self.cur[ids] = self.coord[ids] @ self.strides
        self.occ[self.cur[ids]] = ids
        self.active[ids] = 1
        self.entered_frame[ids] = self.steps_done

    def advance(self, steps: int, rng: np.random.Generator, tau: float, forbid_crossing: bool,
                despawn: bool, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Run ``steps`` steps; return ((steps, N, D) cell indices, (steps, N) active).

        ``out``: an optional (steps, N, D) int64 array to write the cells into.
        """
        n = len(self.cur)
        uniforms = rng.random((steps, n))
        if out is None:
            out = np.empty((steps, n, self.dim), dtype=np.int64)
        parts = step_threads(n)
        partition = None
        kernel = trajectory_steps.serial
        if parts > 1:
            partition = (parts, self.near_ahead, *(np.empty(n, dtype=np.int64) for _ in range(3)))
            kernel = trajectory_steps.threaded
        kernel(
            self.blocked, self.values, self.goal, self.field_of, self.offsets, self.vectors, self.swept,
            self.swept_count, self.near_offsets, self.crossing, self.cur, self.coord, self.active, self.occ,
            uniforms, float(tau), bool(forbid_crossing), bool(despawn), self.gone_step,
            self.steps_done, out, partition,
        )
        self.steps_done += steps
        rows = self.steps_done - steps + np.arange(steps)[:, None]
        act = (self.gone_step < 0) | (rows < self.gone_step)  # gone from the step it left in
        act &= rows + 1 >= self.entered_frame  # (row r is frame r + 1) there from the frame it entered in
        return out, act

    def can_fill_deeper(self) -> np.ndarray:
        """(N,) whether each active agent on a goal cell has a free, deeper goal neighbour."""
        f = self.field_of[:, None]
        here = self.values[f[:, 0], self.cur][:, None]
        nb = self.cur[:, None] + self.offsets[None, :]
        free = (self.blocked[nb] == 0) & (self.occ[nb] < 0)
        deeper = (self.goal[f, nb] == 1) & free & (self.values[f, nb] > here)
        on_goal = self.goal[f[:, 0], self.cur] == 1
        return (self.active == 1) & on_goal & deeper.any(axis=1)

    @property
    def cells(self) -> np.ndarray:
        """(N, D) current cell of each agent."""
        return self.coord - PAD


def generate_trajectories(grid, values, starts, max_length: int, rng: np.random.Generator, tau: float = 1.0,
                          forbid_crossing: bool = True, corner_cutting: bool = True, despawn: bool = False,
                          radius: float | None = None, return_active: bool = False):
    """Algorithm 3: every agent's cell at each of ``max_length`` steps.

    Each step orders the agents by v of their current cell (largest first). In turn, an
    agent frees its cell in ``block``; its candidates are the free, unblocked neighbour
    cells (``neighbors0``: v(s') > v(s); ``neighbors1``: the rest plus staying); it picks
    from ``neighbors0`` if any, else ``neighbors1``, by roulette wheel on
    P(k) ∝ exp((v(k) - max v) / tau) (eq. 4), and marks its pick in ``block``.

    Parameters
    ----------
    grid : 0/1 occupancy, 2 or 3 axes
    values : state values from :func:`crowdmotion.mdp.solve` (same shape); goal cells are
        those with value 0, and agents on them stay (absorbing)
    starts : (N, D) distinct free start cells
    max_length : number of steps
    rng : numpy Generator; the only source of randomness
    tau : Boltzmann temperature (paper: 1)
    forbid_crossing : also reject a move that, with cell centres moving in straight lines
        during the step, passes closer than two radii to a move already chosen this step
        or to an agent yet to move (staying put is always allowed)
    corner_cutting : as in :func:`solve`; use the rule the values were solved with
    despawn : remove agents that reach a goal, freeing the goal cell
    radius : agent radius in cells (default: the largest the paper's cell rule allows)
    return_active : also return the (max_length + 1, N) active mask

    Returns
    -------
    (max_length + 1, N, D) int64 cell indices (row 0 = starts), and the mask if asked.
    Agents whose start cannot reach any goal (value -inf) stay where they are.
    """
    grid = validate_grid(grid)
    values = np.asarray(values, dtype=np.float64)
    if values.shape != grid.shape:
        raise ValueError(f"values must have the grid's shape {grid.shape}, got {values.shape}")
    if np.isnan(values).any():
        raise ValueError("values contain NaN")
    starts = check_starts(grid, starts)
    if isinstance(max_length, bool) or not isinstance(max_length, (int, np.integer)) or max_length < 0:
        raise ValueError(f"max_length must be a non-negative integer, got {max_length!r}")
    check_tau(tau)
    r = RAW_GRID_RADIUS if radius is None else float(radius)
    if not (0 < r <= RAW_GRID_RADIUS * (1 + 1e-9)):
        raise ValueError(f"radius must be in (0, {RAW_GRID_RADIUS:.6f}] cells (paper's cell rule), got {radius!r}")
    walker = Walker(grid, starts, [values == 0], np.zeros(len(starts), dtype=np.int64), corner_cutting, r)
    walker.set_values(values[None])
    cells = np.empty((int(max_length) + 1, len(starts), grid.ndim), dtype=np.int64)
    cells[0] = starts
    _, act = walker.advance(int(max_length), rng, tau, forbid_crossing, despawn, out=cells[1:])
    if not return_active:
        return cells
    return cells, np.concatenate([np.ones((1, len(starts)), dtype=bool), act])


def check_starts(grid: np.ndarray, starts) -> np.ndarray:
    """Start cells as (N, D) int64, or a ValueError naming the first bad one."""
    s = np.asarray(starts)
    if s.ndim != 2 or s.shape[1] != grid.ndim or not np.issubdtype(s.dtype, np.integer):
        raise ValueError(f"starts must be an (N, {grid.ndim}) integer array of cells, got shape {s.shape}")
    s = s.astype(np.int64)
    inside = np.all((s >= 0) & (s < np.array(grid.shape)), axis=1)
    if not inside.all():
        i = int(np.flatnonzero(~inside)[0])
        raise ValueError(f"start of agent {i} at {tuple(s[i])} lies outside the grid of shape {grid.shape}")
    on_obstacle = grid[tuple(s.T)] != 0
    if on_obstacle.any():
        i = int(np.flatnonzero(on_obstacle)[0])
        raise ValueError(f"start of agent {i} at {tuple(s[i])} is an obstacle cell")
    _, first, counts = np.unique(s, axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        cell = s[first[np.flatnonzero(counts > 1)[0]]]
        who = np.flatnonzero(np.all(s == cell, axis=1))
        raise ValueError(f"agents {who.tolist()} share the start cell {tuple(cell)}")
    return s


def check_tau(tau) -> None:
    if not (isinstance(tau, (int, float)) and np.isfinite(tau) and tau > 0):
        raise ValueError(f"tau must be a positive number, got {tau!r}")
