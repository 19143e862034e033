"""Prefect tasks: thin wrappers that load inputs, call one rescene_core function, and write outputs."""
