"""Particle-swarm group paths (Nie, Liu & Wang 2010): gathering, target following and
obstacle / agent avoidance on canonical PSO, many swarms at once.

>>> from crowdmotion import pso
>>> run = pso.gather(target=(0, 0, 0), n_particles=30, rng=np.random.default_rng(1))  # doctest: +SKIP
>>> traj = pso.simulate(scene, groups, pso.PSOParams(), rng)                           # doctest: +SKIP
"""

from crowdmotion.pso.obstacles import ObstacleArrays, obstacle_field
from crowdmotion.pso.params import ObstacleField, PSOParams, make_params
from crowdmotion.pso.simulate import PSORun, run, simulate
from crowdmotion.pso.swarm import COUNTER_NAMES, Swarm, SwarmRun, follow, follow_schedule, gather

__all__ = ["PSOParams", "ObstacleField", "make_params", "Swarm", "SwarmRun", "gather", "follow", "follow_schedule",
           "simulate", "run", "PSORun", "obstacle_field", "ObstacleArrays", "COUNTER_NAMES"]
