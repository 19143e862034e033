"""Operating ReScene's orchestration at scale: a local PostgreSQL for a Prefect server that several workers
share (``postgres``). Nothing here imports Prefect; the servers run as subprocesses."""
