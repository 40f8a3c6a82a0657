"""The kinds of route stage, by name: read by the scenario schema and each method's list
of the stages it follows without importing the stages themselves (and their numba draws)."""

KINDS = ("goto", "wait", "queue", "choose", "leave")
