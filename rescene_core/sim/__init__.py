"""The physics check of an exported scene (``rescene simcheck RUN``): does the MJCF stay put under gravity?"""

from rescene_core.sim.check import ObjectDrift, SimcheckConfig, SimcheckResult, SimcheckSummary, simcheck, simcheck_run

__all__ = ["ObjectDrift", "SimcheckConfig", "SimcheckResult", "SimcheckSummary", "simcheck", "simcheck_run"]
