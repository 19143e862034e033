"""Prefect flows (wiring only) and the `rescene` command line.

Defaults for Prefect's embedded mode are set here, before Prefect is imported (its settings are read
then): analytics off, and a generous start-up timeout for the temporary API server on busy machines.
Values already in the environment win.
"""

import os

os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS", "180")
