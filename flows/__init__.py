"""Prefect flows (wiring only) and the `rescene` command line."""
