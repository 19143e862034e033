"""One run per run directory: the lock file ``RUN/.lock``.

Two runs writing into one run directory would interleave their cache records and outputs, so a run holds
the directory while it works: ``hold_run_directory(run_dir)`` creates ``RUN/.lock`` (JSON naming the
holder's host, pid, start time and Prefect flow run id) before any stage and removes it when the run
ends, failed or not. A second run on a directory in use is refused with ``RunDirectoryBusy``, whose
message names the holder and what to do.

The lock is created atomically: its content is written to a file of its own, then hard-linked to
``RUN/.lock`` (``os.link`` fails when the name exists), so of two processes racing exactly one gets it and
nobody ever reads half a lock. A lock is taken over when its holder cannot be running any more:

- it names the same flow run (``prefect flow-run retry`` runs the flow function again, maybe elsewhere);
- it was taken on this host and its process is gone (a crashed or killed worker), or the host rebooted;
- it was taken on another host longer ago than ``stale_after_s`` (default ``STALE_AFTER_S``, or the
  environment's ``RESCENE_RUN_LOCK_STALE_S``): that host's processes cannot be seen from here.

A takeover is logged and recorded in the new lock (``took_over``). Two processes taking over one stale
lock at once are serialised by a claim file named after the stale lock's token (created exclusively):
only the claim's winner removes the stale lock, and it removes it only when the lock still carries that
token.
"""

from __future__ import annotations

import datetime as dt
import errno
import json
import logging
import os
import socket
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from rescene_core.paths import RunPaths

log = logging.getLogger(__name__)

LOCK_FORMAT = "rescene-run-lock"

STALE_AFTER_S = 24 * 3600.0
"""A lock taken on another host is taken over once it is this many seconds old: a run there may still be
going and its process cannot be checked from here, so the bound is generous (one day)."""

STALE_ENV = "RESCENE_RUN_LOCK_STALE_S"
"""Environment variable overriding ``STALE_AFTER_S`` (seconds)."""

CLAIM_TIMEOUT_S = 30.0
"""A takeover claim older than this was left by a process that died while taking over: removed."""

ACQUIRE_ATTEMPTS = 5
"""How often a takeover is retried when another process changes the lock meanwhile."""

UNREADABLE = "unreadable-"
"""Token prefix of the holder that stands for a lock file that does not parse."""

_BOOT_ID = Path("/proc/sys/kernel/random/boot_id")


class RunDirectoryBusy(RuntimeError):
    """The run directory is held by another run; ``holder`` is the lock it holds (None when unreadable)."""

    def __init__(self, lock_path: Path, holder: LockHolder | None, message: str):
        self.lock_path = lock_path
        self.holder = holder
        super().__init__(message)


@dataclass(frozen=True)
class LockHolder:
    """The content of ``RUN/.lock``: who holds the run directory.

    host: ``socket.gethostname()`` of the holder. pid: its process id. started: ISO 8601 UTC time the
    lock was taken. started_s: the same as seconds since the epoch. flow_run_id: the Prefect flow run
    holding it (None for the in-process pipeline). boot_id: the host's boot id (Linux; None elsewhere), so
    a lock from before a reboot is known stale. token: unique per acquisition (a release or takeover
    checks it). took_over: the holder this one replaced, when it took over a stale lock.
    """

    host: str
    pid: int
    started: str
    started_s: float
    flow_run_id: str | None
    boot_id: str | None
    token: str
    took_over: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        return {"format": LOCK_FORMAT, **asdict(self)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> LockHolder:
        return cls(
            host=str(d["host"]),
            pid=int(d["pid"]),
            started=str(d["started"]),
            started_s=float(d["started_s"]),
            flow_run_id=None if d.get("flow_run_id") is None else str(d["flow_run_id"]),
            boot_id=None if d.get("boot_id") is None else str(d["boot_id"]),
            token=str(d["token"]),
            took_over=d.get("took_over"),
        )

    def describe(self) -> str:
        """The holder for people: host, pid, since when, and the flow run."""
        run = f", flow run {self.flow_run_id}" if self.flow_run_id else ""
        return f"host {self.host}, pid {self.pid}, since {self.started}{run}"


def _boot_id() -> str | None:
    try:
        return _BOOT_ID.read_text().strip() or None
    except OSError:
        return None


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this host (signal 0: nothing is sent). A zombie (killed, not yet
    reaped by its parent, e.g. in a container whose first process reaps nothing) does not run."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, owned by another user
        pass
    try:  # Linux: the state follows the parenthesised command name in /proc/<pid>/stat
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return True


def stale_after_s() -> float:
    """The age in seconds after which another host's lock is taken over (``RESCENE_RUN_LOCK_STALE_S``)."""
    value = os.environ.get(STALE_ENV)
    if not value:
        return STALE_AFTER_S
    try:
        return float(value)
    except ValueError as err:
        raise ValueError(f"{STALE_ENV}={value!r} is not a number of seconds") from err


def read_lock(path: str | Path) -> LockHolder | None:
    """The holder recorded in the lock file at ``path``; None when there is none. Raises ValueError when
    the file exists but is not a lock."""
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        return None
    try:
        return LockHolder.from_json(json.loads(text))
    except (ValueError, KeyError, TypeError) as err:
        raise ValueError(f"{path} is not a run lock ({type(err).__name__}: {err})") from err


def stale_reason(
    holder: LockHolder, flow_run_id: str | None = None, stale_s: float | None = None, now_s: float | None = None
) -> str | None:
    """Why ``holder`` cannot be running any more (so its lock may be taken over), or None when it may be."""
    if flow_run_id is not None and holder.flow_run_id == flow_run_id:
        return f"it is held by the same flow run {flow_run_id} (an earlier attempt of a retried run)"
    if holder.host == socket.gethostname():
        boot = _boot_id()
        if boot is not None and holder.boot_id is not None and holder.boot_id != boot:
            return "this host has rebooted since it was taken"
        if not pid_alive(holder.pid):
            return f"process {holder.pid} is no longer running on this host"
        return None
    stale_s = stale_after_s() if stale_s is None else stale_s
    age = (time.time() if now_s is None else now_s) - holder.started_s
    if age > stale_s:
        return f"it was taken on another host {age:.0f} s ago, more than the {stale_s:.0f} s bound ({STALE_ENV})"
    return None


def _busy_message(lock: Path, holder: LockHolder, stale_s: float) -> str:
    if holder.token.startswith(UNREADABLE):
        return (
            f"run directory {lock.parent} holds a lock that cannot be read ({lock}, written {holder.started}): "
            f"a run may be starting on it. If none is, delete {lock} (it is taken over automatically "
            f"{stale_s:.0f} s after it was written; set {STALE_ENV} to change that)."
        )
    same_host = holder.host == socket.gethostname()
    gone = (
        "it is taken over automatically once that process is gone"
        if same_host
        else f"it is taken over automatically {stale_s:.0f} s after it was taken (set {STALE_ENV} to change that)"
    )
    return (
        f"run directory {lock.parent} is in use by another run ({holder.describe()}): two runs on one "
        "directory would interleave their outputs. Wait for that run to end or stop it, or choose another "
        f"run directory; if that run is gone and its lock stayed, delete {lock} ({gone})."
    )


def _create(lock: Path, holder: LockHolder) -> bool:
    """Create ``lock`` holding ``holder``, atomically; False when it exists."""
    tmp = lock.with_name(f"{lock.name}.{holder.token}.tmp")
    tmp.write_text(json.dumps(holder.to_json(), indent=2))
    try:
        try:
            os.link(tmp, lock)
        except FileExistsError:
            return False
        except OSError as err:  # a file system without hard links: exclusive create (the content follows)
            if err.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
                raise
            try:
                fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                return False
            with os.fdopen(fd, "w") as f:
                f.write(tmp.read_text())
        return True
    finally:
        tmp.unlink(missing_ok=True)


def _remove_stale(lock: Path, stale: LockHolder) -> None:
    """Remove ``lock`` if it still carries ``stale``'s token; one process at a time (the claim file)."""
    claim = lock.with_name(f"{lock.name}.takeover-{stale.token}")
    try:
        fd = os.open(claim, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:  # another process is taking it over; a claim of a dead one is cleared
        try:
            if time.time() - claim.stat().st_mtime > CLAIM_TIMEOUT_S:
                claim.unlink(missing_ok=True)
        except FileNotFoundError:
            pass
        time.sleep(0.05)
        return
    os.close(fd)
    try:
        try:
            current = read_lock(lock)
        except ValueError:
            current = _unreadable_holder(lock)  # the same unreadable file keeps its token (its mtime)
        except FileNotFoundError:
            current = None
        if current is not None and current.token == stale.token:
            lock.unlink(missing_ok=True)
    finally:
        claim.unlink(missing_ok=True)


def _unreadable_holder(lock: Path) -> LockHolder:
    """A lock file that does not parse (written by hand, or by a file system without hard links and a
    writer that died): held by nobody known, dated by its modification time."""
    mtime = lock.stat().st_mtime
    return LockHolder(
        host="unknown",
        pid=0,
        started=dt.datetime.fromtimestamp(mtime, dt.UTC).isoformat(),
        started_s=mtime,
        flow_run_id=None,
        boot_id=None,
        token=f"{UNREADABLE}{mtime}",
    )


@dataclass
class RunLock:
    """A held run-directory lock; ``release()`` (or leaving ``hold_run_directory``) removes it."""

    path: Path
    holder: LockHolder
    released: bool = False

    def release(self) -> None:
        """Remove the lock file when it is still this holder's (a takeover may have replaced it)."""
        if self.released:
            return
        self.released = True
        try:
            current = read_lock(self.path)
        except ValueError:
            current = None
        if current is not None and current.token == self.holder.token:
            self.path.unlink(missing_ok=True)
        else:
            log.warning("run lock %s was no longer held by this run (%s); left as it is", self.path, current)


def acquire_run_directory(
    run_dir: str | Path,
    flow_run_id: str | None = None,
    stale_s: float | None = None,
    logger: logging.Logger | logging.LoggerAdapter | None = None,
) -> RunLock:
    """Take the lock of ``run_dir`` (which must exist) for this process and ``flow_run_id``.

    Raises:
        RunDirectoryBusy: another run holds it; the message names the holder and what to do.
    """
    logger = logger or log
    lock = RunPaths(run_dir).lock
    stale_s = stale_after_s() if stale_s is None else stale_s
    took_over: LockHolder | None = None
    for _ in range(ACQUIRE_ATTEMPTS):
        now = time.time()
        me = LockHolder(
            host=socket.gethostname(),
            pid=os.getpid(),
            started=dt.datetime.fromtimestamp(now, dt.UTC).isoformat(),
            started_s=now,
            flow_run_id=flow_run_id,
            boot_id=_boot_id(),
            token=uuid.uuid4().hex,
            took_over=None if took_over is None else took_over.to_json(),
        )
        if _create(lock, me):
            if took_over is not None:
                logger.warning("run directory %s: took over the lock of %s", lock.parent, took_over.describe())
            return RunLock(lock, me)
        try:
            try:
                holder = read_lock(lock)
            except ValueError:
                holder = _unreadable_holder(lock)
        except FileNotFoundError:  # removed between the read and the stat
            continue
        if holder is None:  # released meanwhile: try again
            continue
        reason = stale_reason(holder, flow_run_id, stale_s)
        if reason is None:
            raise RunDirectoryBusy(lock, holder, _busy_message(lock, holder, stale_s))
        logger.warning("run directory %s: the lock of %s is stale (%s)", lock.parent, holder.describe(), reason)
        _remove_stale(lock, holder)
        took_over = holder
    raise RunDirectoryBusy(
        lock, None, f"run directory {lock.parent}: its lock {lock} kept changing; another run is starting on it"
    )


@contextmanager
def hold_run_directory(
    run_dir: str | Path,
    flow_run_id: str | None = None,
    stale_s: float | None = None,
    logger: logging.Logger | logging.LoggerAdapter | None = None,
) -> Iterator[RunLock]:
    """Hold ``run_dir`` for the ``with`` block: the lock is taken on entry (``acquire_run_directory``) and
    released on exit, whether the block ends normally or raises."""
    held = acquire_run_directory(run_dir, flow_run_id, stale_s, logger)
    try:
        yield held
    finally:
        held.release()
