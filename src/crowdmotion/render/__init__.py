"""Pictures made from Trajectories and method results (matplotlib), animations (MP4/GIF).

The names load on first use, so that importing a light submodule (the picture process,
:mod:`crowdmotion.render.background`) does not import matplotlib."""

from crowdmotion._lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    **{name: "plots" for name in ("animate_formation_snapshots", "plot_formation_snapshots", "plot_group_report",
                                  "plot_journeys", "plot_paths", "plot_potential_field", "plot_values")},
    "animate": "animation", "plot_density": "animation"})
