"""RVO crowds with OCEAN personalities (Huang & Liu 2012, paper 004).

``Simulator`` steps a sampling-RVO crowd interactively; ``simulate`` runs a Scene and
its Groups to Trajectories; ``personality_params`` maps an OCEAN personality to the
RVO parameters of Table 4.
"""

from crowdmotion.rvo.personality import (
    TABLE4,
    TRAITS,
    dominant_trait,
    personality_params,
    sample_personalities,
    trig_generator,
)
from crowdmotion.rvo.simulate import RVOParams, RVORun, run, simulate
from crowdmotion.rvo.simulator import Simulator

Params = RVOParams

__all__ = ["TABLE4", "TRAITS", "dominant_trait", "personality_params", "sample_personalities", "trig_generator",
           "Simulator",
           "RVOParams", "RVORun", "Params", "run", "simulate"]
