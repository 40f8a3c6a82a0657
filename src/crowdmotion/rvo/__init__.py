"""RVO crowds with OCEAN personalities (Huang & Liu 2012, paper 004).

``Simulator`` steps a sampling-RVO crowd interactively (``Recorder`` keeps its frames as
Trajectories, ``warm_up`` readies its kernels); ``simulate`` runs a Scene and its Groups
to Trajectories; ``personality_params`` maps an OCEAN personality to the RVO parameters
of Table 4.

Names load on first use, so that ``crowdmotion.rvo.params`` (the scenario schema) can be
imported without loading the numba kernels.
"""

from crowdmotion._lazy import lazy_exports

_EXPORTS = {
    "TABLE4": "personality", "TRAITS": "personality", "dominant_trait": "personality",
    "personality_params": "personality", "sample_personalities": "personality", "trig_generator": "personality",
    "Simulator": "simulator", "warm_up": "simulator", "RVOParams": "params", "Params": "params",
    "RVORun": "simulation", "run": "simulation", "simulate": "simulation", "Recorder": "recorder",
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
