"""Pictures made from Trajectories and method results (matplotlib)."""

from crowdmotion.render.plots import plot_formation_snapshots, plot_group_report, plot_paths, plot_values

__all__ = ["plot_formation_snapshots", "plot_group_report", "plot_paths", "plot_values"]
