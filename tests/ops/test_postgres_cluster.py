"""``rescene_core.ops.postgres``, what `make server-postgres` runs: a cluster from Debian's PostgreSQL that
accepts the URL Prefect's server is given, started twice on one port without harm, refused on another,
and a data directory its server user could not reach refused before anything is written."""

from __future__ import annotations

import asyncio
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from rescene_core.ops import postgres
from tests.flows.prefect_server import free_port


@pytest.fixture
def pg_root():
    try:
        postgres.bin_dir()
    except postgres.PostgresError as err:
        pytest.skip(str(err))
    root = Path(tempfile.mkdtemp(prefix="rescene-pg-"))
    root.chmod(0o711)  # reachable by the unprivileged server user when this runs as root
    yield root
    postgres.stop(root / "data")
    shutil.rmtree(root, ignore_errors=True)


def test_cluster_serves_the_prefect_database(pg_root):
    import asyncpg

    port = free_port()
    url = postgres.start(pg_root / "data", port)
    assert url == f"postgresql+asyncpg://postgres@127.0.0.1:{port}/prefect"
    assert postgres.is_running(pg_root / "data")

    async def query() -> str:
        conn = await asyncpg.connect(url.replace("postgresql+asyncpg", "postgresql"))
        try:
            return await conn.fetchval("select current_database()")
        finally:
            await conn.close()

    assert asyncio.run(query()) == "prefect"
    assert postgres.start(pg_root / "data", port) == url  # already running there: used as it is
    with pytest.raises(postgres.PostgresError, match=f"already runs .* on port {port}, not {port + 1}"):
        postgres.start(pg_root / "data", port + 1)
    postgres.stop(pg_root / "data")
    assert not postgres.is_running(pg_root / "data")
    postgres.stop(pg_root / "data")  # stopping a stopped cluster is no error


@pytest.mark.skipif(os.geteuid() != 0, reason="only root hands the cluster to another user")
def test_a_data_directory_the_server_user_cannot_reach_is_refused(tmp_path):
    private = tmp_path / "private"
    private.mkdir(mode=0o700)
    with pytest.raises(postgres.PostgresError, match=r"runs as 'nobody' here .* cannot enter .*private \(mode 0o700\)"):
        postgres.init_cluster(private / "data")
    assert not (private / "data").exists()
