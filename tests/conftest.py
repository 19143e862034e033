"""Shared fixtures. Prefect runs against a throwaway home so tests never touch a user's profile."""

from __future__ import annotations

import os
import tempfile

os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("PREFECT_HOME", tempfile.mkdtemp(prefix="rescene-prefect-home-"))
