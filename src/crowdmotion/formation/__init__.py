"""Group formations with deformable guiding meshes (Li & He 2017): a Delaunay mesh per
group, deformed as rigidly as possible round obstacles' potential fields, torn and
relinked, with agents guided by attraction points.

>>> from crowdmotion import formation
>>> sim = formation.Simulator(scene, time_step=0.1)                          # doctest: +SKIP
>>> gid = sim.add_group(formation.block(10, 10), goal=(80, 0), start=(5, 0))  # doctest: +SKIP
>>> sim.step(); sim.positions; sim.mesh(gid)                                  # doctest: +SKIP

Names load on first use, so that ``crowdmotion.formation.params`` (the scenario schema)
can be imported without the numba kernels.
"""

from crowdmotion._lazy import lazy_exports

_EXPORTS = {
    "FormationParams": "params", "make_params": "params",
    "Template": "templates", "block": "templates", "wedge": "templates", "circle": "templates", "line": "templates",
    "cars": "templates", "points": "templates",
    "FormationMesh": "mesh", "MeshView": "mesh", "MeshFallbackWarning": "mesh",
    "ARAPSolver": "arap", "PotentialField": "field", "AttractionGuide": "guidance",
    "attraction_force": "guidance", "attraction_magnitude": "guidance",
    "Simulator": "simulator", "FormationRun": "simulation", "run": "simulation", "simulate": "simulation",
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
