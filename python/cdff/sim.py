"""The EGSE simulator from Python: run a scenario of the trajectory library (data/scenarios, or
a YAML file) into an MCAP recording, as `cdff sim -o` does.

    info = cdff.sim.run("mid_range_approach", seed=7, duration=5.0)   # -> mid_range_approach_seed7.mcap
    for msg in cdff.io.read(info["output"], channels=["/truth/target_pose"]): ...
"""
import pathlib
from cdff._core import _sim

__all__ = ["run", "scenarios"]


def run(scenario, output=None, seed=None, duration=None, overrides=None):
    """Simulates `scenario` (a library name or a YAML path) into the MCAP file `output`
    (default: <scenario>_seed<seed>.mcap in the working directory, or <scenario>.mcap with the
    scenario's own seed).

    seed: the random seed (default: the scenario's); the same seed gives the same file.
    duration: simulated seconds (default: the scenario's).
    overrides: scenario keys to change, {"dotted.key": value} or ["dotted.key=value", ...].
    Returns the run's scenario, file, seed, duration, renderer and output. Runs without the GIL.
    """
    if overrides is None:
        overrides = []
    elif isinstance(overrides, dict):
        overrides = [f"{k}={_yaml_value(v)}" for k, v in overrides.items()]
    if output is None:
        stem = pathlib.Path(str(scenario)).stem
        output = f"{stem}_seed{seed}.mcap" if seed is not None else f"{stem}.mcap"
    return _sim.run(str(scenario), str(output), seed, duration, list(overrides))


def _yaml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_yaml_value(x) for x in v) + "]"
    return str(v)


def scenarios():
    """The trajectory library: dicts of name, file, description and duration (s)."""
    return _sim.scenarios()
