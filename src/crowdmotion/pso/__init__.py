"""Particle-swarm group paths (Nie, Liu & Wang 2010): gathering, target following and
obstacle / agent avoidance on canonical PSO, many swarms at once.

>>> from crowdmotion import pso
>>> run = pso.gather(target=(0, 0, 0), n_particles=30, rng=np.random.default_rng(1))  # doctest: +SKIP
>>> traj = pso.simulate(scene, groups, pso.PSOParams(), rng)                           # doctest: +SKIP

Names load on first use, so that ``crowdmotion.pso.params`` (the scenario schema) can be
imported without compiling or loading the numba kernels.
"""

from crowdmotion._lazy import lazy_exports

_EXPORTS = {
    "PSOParams": "params", "ObstacleField": "params", "make_params": "params",
    "ObstacleArrays": "obstacles", "obstacle_field": "obstacles",
    "PSORun": "simulation", "run": "simulation", "simulate": "simulation",
    "COUNTER_NAMES": "swarm", "Swarm": "swarm", "SwarmRun": "swarm", "follow": "swarm",
    "follow_schedule": "swarm", "gather": "swarm",
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
