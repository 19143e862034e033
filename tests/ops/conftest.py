"""The fault drills share the session's Prefect server with the flow tests (``prefect_server``: this
process's client pointed at it)."""

from __future__ import annotations

import os

from tests.flows.conftest import prefect_server  # noqa: F401 - the fixture, shared with tests/flows

os.environ.setdefault("RESCENE_RETRY_DELAY_S", "0.2")
