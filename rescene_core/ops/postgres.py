"""A PostgreSQL cluster for a Prefect server that several workers share, from Debian's ``postgresql``
package (``make server-postgres``; docs/orchestration.md says when to choose it over SQLite).

The cluster lives in one data directory: ``initdb`` on first use (superuser ``postgres``, trust
authentication, listening on 127.0.0.1 only, its socket in the data directory), then ``pg_ctl start``;
the database ``prefect`` is created once. PostgreSQL refuses to run as root: as root, every server
command runs as the unprivileged user ``RUN_AS_WHEN_ROOT`` through ``runuser``, and the data directory
is handed to that user (so it must sit where that user can reach it, not under a 0700 home).

    python -m rescene_core.ops.postgres start --dir .postgres --port 5432   # prints the database URL
    python -m rescene_core.ops.postgres url --port 5432
    python -m rescene_core.ops.postgres stop --dir .postgres
"""

from __future__ import annotations

import argparse
import os
import pwd
import shutil
import subprocess
import sys
from pathlib import Path

RUN_AS_WHEN_ROOT = "nobody"
"""The user the server runs as when this process is root (PostgreSQL refuses root)."""

DATABASE = "prefect"
SUPERUSER = "postgres"


class PostgresError(RuntimeError):
    """PostgreSQL is missing, or a cluster command failed: the message names the command, its output and
    the fix."""


def bin_dir() -> Path:
    """The folder of PostgreSQL's server programs (``initdb``, ``pg_ctl``): ``RESCENE_PG_BIN``, else the
    newest ``/usr/lib/postgresql/<version>/bin`` (Debian), else the folder of ``pg_ctl`` on the PATH."""
    if env := os.environ.get("RESCENE_PG_BIN"):
        return Path(env)
    debian = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"), key=lambda p: float(p.parts[-3]))
    if debian:
        return debian[-1].parent
    if found := shutil.which("pg_ctl"):
        return Path(found).parent
    raise PostgresError(
        "PostgreSQL's server programs (initdb, pg_ctl) are not installed: `sudo apt-get install postgresql` "
        "(or `make setup`, which installs it), or set RESCENE_PG_BIN to the folder that holds them"
    )


def _as_server_user(cmd: list[str]) -> list[str]:
    return ["runuser", "-u", RUN_AS_WHEN_ROOT, "--", *cmd] if os.geteuid() == 0 else cmd


def _run(cmd: list[str], what: str, ok_if: str | None = None) -> str:
    out = subprocess.run(_as_server_user(cmd), capture_output=True, text=True, timeout=120)
    text = out.stdout + out.stderr
    if out.returncode != 0 and not (ok_if and ok_if in text):
        raise PostgresError(f"{what} failed ({' '.join(cmd)}):\n{text[-2000:]}")
    return text


def database_url(port: int, host: str = "127.0.0.1") -> str:
    """The SQLAlchemy URL Prefect's server takes (``PREFECT_API_DATABASE_CONNECTION_URL``)."""
    return f"postgresql+asyncpg://{SUPERUSER}@{host}:{port}/{DATABASE}"


def init_cluster(data_dir: str | Path) -> Path:
    """Create the cluster in ``data_dir`` unless it holds one; returns its absolute path."""
    data = Path(data_dir).absolute()
    if (data / "PG_VERSION").exists():
        return data
    if os.geteuid() == 0:
        for parent in (q for q in data.parents if q.exists()):  # the server user must reach its data directory
            if not os.stat(parent).st_mode & 0o001:
                raise PostgresError(
                    f"{data}: PostgreSQL runs as {RUN_AS_WHEN_ROOT!r} here (root is refused), which cannot enter "
                    f"{parent} (mode {oct(os.stat(parent).st_mode & 0o777)}); put the data directory elsewhere"
                )
    data.mkdir(parents=True, exist_ok=True)
    if os.geteuid() == 0:
        user = pwd.getpwnam(RUN_AS_WHEN_ROOT)
        os.chown(data, user.pw_uid, user.pw_gid)
    _run(
        [str(bin_dir() / "initdb"), "-D", str(data), "-U", SUPERUSER, "--auth=trust", "-E", "UTF8", "--no-sync"],
        "initdb",
    )
    return data


def start(data_dir: str | Path, port: int) -> str:
    """Initialise (first time) and start the cluster in ``data_dir`` on 127.0.0.1:``port``, wait until it
    accepts connections, create the database ``prefect`` once; returns its URL (``database_url``). A
    server already running there on that port is used as it is; on another port it is an error."""
    data = init_cluster(data_dir)
    if is_running(data):
        running = _running_port(data)
        if running == port:
            print(f"PostgreSQL already runs on {data}, port {port}", file=sys.stderr)
            return database_url(port)
        raise PostgresError(
            f"a PostgreSQL server already runs on {data} on port {running}, not {port}; stop it first "
            f"(python -m rescene_core.ops.postgres stop --dir {data_dir}) or use port {running}"
        )
    options = f"-p {port} -k {data} -c listen_addresses=127.0.0.1 -c max_connections=200"
    _run(
        [str(bin_dir() / "pg_ctl"), "-D", str(data), "-l", str(data / "server.log"), "-o", options, "-w", "start"],
        "pg_ctl start",
    )
    _run(
        [str(bin_dir() / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", SUPERUSER, DATABASE],
        "createdb",
        ok_if="already exists",
    )
    return database_url(port)


def _running_port(data: Path) -> int | None:
    """The port in the running server's ``postmaster.pid`` (its fourth line)."""
    try:
        return int((data / "postmaster.pid").read_text().splitlines()[3])
    except (OSError, IndexError, ValueError):
        return None


def is_running(data_dir: str | Path) -> bool:
    """Whether a server runs on the cluster in ``data_dir`` (``pg_ctl status``)."""
    data = Path(data_dir).absolute()
    if not (data / "PG_VERSION").exists():
        return False
    out = subprocess.run(_as_server_user([str(bin_dir() / "pg_ctl"), "-D", str(data), "status"]), capture_output=True)
    return out.returncode == 0


def stop(data_dir: str | Path) -> None:
    """Stop the cluster in ``data_dir`` (fast shutdown: open connections are closed); nothing when it is not
    running."""
    data = Path(data_dir).absolute()
    _run(
        [str(bin_dir() / "pg_ctl"), "-D", str(data), "-m", "fast", "-w", "stop"], "pg_ctl stop", ok_if="does not exist"
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m rescene_core.ops.postgres", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    for name in ("start", "stop", "url"):
        s = sub.add_parser(name)
        if name != "url":
            s.add_argument("--dir", type=Path, required=True, help="the cluster's data directory")
        if name != "stop":
            s.add_argument("--port", type=int, default=5432)
    args = p.parse_args(argv)
    try:
        if args.command == "start":
            print(start(args.dir, args.port))
        elif args.command == "stop":
            stop(args.dir)
        else:
            print(database_url(args.port))
    except PostgresError as err:
        print(err, file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
