"""Pictures made from Trajectories and method results (matplotlib), animations (MP4/GIF)."""

from crowdmotion.render.plots import (animate_formation_snapshots, plot_formation_snapshots, plot_group_report,
                                     plot_paths, plot_potential_field, plot_values)

__all__ = ["animate_formation_snapshots", "plot_formation_snapshots", "plot_group_report", "plot_paths",
           "plot_potential_field", "plot_values"]


def __getattr__(name):  # the animation module loads on first use
    if name in ("animate", "plot_density"):
        from crowdmotion.render import animation

        return getattr(animation, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
