"""Pictures made from Trajectories and method results (matplotlib)."""

from crowdmotion.render.plots import (animate_formation_snapshots, plot_formation_snapshots, plot_group_report,
                                     plot_paths, plot_values)

__all__ = ["animate_formation_snapshots", "plot_formation_snapshots", "plot_group_report", "plot_paths",
           "plot_values"]
