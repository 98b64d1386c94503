"""The SQLite job store: one file, WAL mode, a connection per thread.

WAL lets status reads run while a result is being written; ``synchronous=NORMAL`` keeps commits
cheap (a power loss may drop the last commits, never corrupt the file). Inputs and results are
stored zlib-compressed JSON.
"""

from __future__ import annotations

import functools
import json
import sqlite3
import threading
import time
from collections.abc import Callable, Collection, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

import orjson

from .store import (
    FINAL,
    BatchRecord,
    IdempotencyConflict,
    JobRecord,
    JobStatus,
    NewJob,
    StoreCorrupt,
    StoreUnavailable,
    read_inputs,
    stored_form,
)
from .task import encode_inputs

__all__ = ["SqliteJobStore"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    process TEXT NOT NULL,
    status TEXT NOT NULL,
    inputs BLOB NOT NULL,
    seed INTEGER,
    batch_id TEXT,
    idempotency_key TEXT UNIQUE,
    request_hash TEXT,
    progress INTEGER NOT NULL DEFAULT 0,
    message TEXT NOT NULL DEFAULT '',
    attempts INTEGER NOT NULL DEFAULT 0,
    created REAL NOT NULL,
    updated REAL NOT NULL,
    started REAL,
    finished REAL,
    meta TEXT NOT NULL DEFAULT '{}',
    owner TEXT NOT NULL DEFAULT '',
    subscriber TEXT NOT NULL DEFAULT '',
    failure TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS jobs_status ON jobs (status, seq);
CREATE INDEX IF NOT EXISTS jobs_finished ON jobs (finished);
CREATE INDEX IF NOT EXISTS jobs_batch ON jobs (batch_id);
CREATE TABLE IF NOT EXISTS results (
    job_id TEXT PRIMARY KEY REFERENCES jobs (id) ON DELETE CASCADE,
    data BLOB NOT NULL
);
CREATE TABLE IF NOT EXISTS batches (
    id TEXT PRIMARY KEY,
    process TEXT NOT NULL,
    created REAL NOT NULL,
    owner TEXT NOT NULL DEFAULT ''
);
CREATE TABLE IF NOT EXISTS heartbeat (id INTEGER PRIMARY KEY CHECK (id = 1), at REAL NOT NULL);
"""

_COLUMNS = (
    "id, process, status, created, updated, started, finished, progress, message, attempts, "
    "seed, batch_id, meta, owner, failure"
)
#: Columns added since the first release, created on opening an older file.
_ADDED = {
    "jobs": {
        "owner": "TEXT NOT NULL DEFAULT ''",
        "subscriber": "TEXT NOT NULL DEFAULT ''",
        "failure": "TEXT NOT NULL DEFAULT ''",
    },
    "batches": {"owner": "TEXT NOT NULL DEFAULT ''"},
}
_UNFINISHED = (JobStatus.accepted.value, JobStatus.running.value)
P = ParamSpec("P")
T = TypeVar("T")


def _record(row: sqlite3.Row | tuple[Any, ...]) -> JobRecord:
    (job_id, process, status, created, updated, started, finished, progress, message, attempts,
     seed, batch_id, meta, owner, failure) = row  # fmt: skip
    try:
        state = JobStatus(status)
    except ValueError:
        # A row this version did not write: shown as failed (with why), not an error of the list.
        state, message = JobStatus.failed, f"stored with an unknown status {status!r}"
        failure = "internal-error"
    try:
        figures = json.loads(meta) if meta and meta != "{}" else {}
    except ValueError:
        figures = {}
    return JobRecord(
        id=job_id,
        process=process,
        status=state,
        created=created,
        updated=updated,
        started=started,
        finished=finished,
        progress=progress,
        message=message,
        attempts=attempts,
        seed=seed,
        batch_id=batch_id,
        meta=figures if isinstance(figures, dict) else {},
        owner=owner,
        failure=failure,
    )


def _translated(method: Callable[P, T]) -> Callable[P, T]:
    """SQLite's errors as the store's: a write that failed is :class:`StoreUnavailable` (disk
    full, I/O error, locked), a file that is not a database :class:`StoreCorrupt`. The call
    counts as in use, so :meth:`SqliteJobStore.close` waits for it; once closed, a call is
    :class:`StoreUnavailable`."""

    @functools.wraps(method)
    def call(*args: P.args, **kwargs: P.kwargs) -> T:
        store = args[0]
        assert isinstance(store, SqliteJobStore)
        store._enter()
        try:
            return method(*args, **kwargs)
        except sqlite3.DatabaseError as exc:
            code = (getattr(exc, "sqlite_errorcode", None) or 0) & 0xFF
            if isinstance(exc, sqlite3.OperationalError) or code in _TRANSIENT:
                raise StoreUnavailable(f"the job store {store.path} failed: {exc}") from exc
            raise StoreCorrupt(f"the job store {store.path} cannot be read: {exc}") from exc
        finally:
            store._leave()

    return call


#: Seconds :meth:`SqliteJobStore.close` waits for calls in use (a write may wait out a lock).
CLOSE_WAIT = 60.0
#: SQLite result codes of a write that may succeed later.
_TRANSIENT = frozenset(
    getattr(sqlite3, name, -1)
    for name in ("SQLITE_FULL", "SQLITE_IOERR", "SQLITE_BUSY", "SQLITE_LOCKED", "SQLITE_CANTOPEN")
)


class SqliteJobStore:
    """A :class:`~service.jobs.store.JobStore` in one SQLite file.

    >>> import tempfile, pathlib
    >>> store = SqliteJobStore(pathlib.Path(tempfile.mkdtemp()) / "jobs.sqlite3")
    >>> store.create(NewJob("j1", "mesh", {"size": 0.1}))[0].status
    <JobStatus.accepted: 'accepted'>
    >>> store.inputs("j1")
    {'size': 0.1}
    >>> store.close()
    """

    def __init__(self, path: Path, *, clock: Any = time.time) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._clock = clock
        self._local = threading.local()
        self._all: list[sqlite3.Connection] = []
        self._lock = threading.Lock()
        self._idle = threading.Condition(self._lock)  #: notified when no call is in use
        self._busy = 0  #: calls in use (on any thread)
        self._closed = False
        try:
            conn = self._conn()
            conn.execute("PRAGMA journal_mode=WAL")
            conn.executescript(_SCHEMA)
            for table, columns in _ADDED.items():
                have = {row[1] for row in conn.execute(f"PRAGMA table_info({table})")}
                for name, decl in columns.items():
                    if name not in have:
                        conn.execute(f"ALTER TABLE {table} ADD COLUMN {name} {decl}")
            conn.execute("SELECT COUNT(*) FROM jobs").fetchone()
        except sqlite3.DatabaseError as exc:
            self.close()
            if isinstance(exc, sqlite3.OperationalError):
                raise StoreUnavailable(
                    f"the job store {self.path} cannot be opened: {exc}"
                ) from None
            raise StoreCorrupt(
                f"{self.path} is not a readable job store ({exc}); move it aside to start with"
                " an empty one"
            ) from None

    # -- connections -------------------------------------------------------------------------
    def _conn(self) -> sqlite3.Connection:
        conn: sqlite3.Connection | None = getattr(self._local, "conn", None)
        if conn is None:
            # (A closed store refuses calls in _enter; one in use may still open its thread's
            # connection, which close, waiting for it, closes with the rest.)
            conn = sqlite3.connect(
                self.path, timeout=30.0, isolation_level=None, check_same_thread=False
            )
            conn.execute("PRAGMA foreign_keys=ON")
            conn.execute("PRAGMA synchronous=NORMAL")
            conn.execute("PRAGMA busy_timeout=30000")
            self._local.conn = conn
            with self._lock:
                self._all.append(conn)
        return conn

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        conn = self._conn()
        # IMMEDIATE takes the write lock up front, so read-then-write cannot race another writer.
        conn.execute("BEGIN IMMEDIATE")
        try:
            yield conn
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        conn.execute("COMMIT")

    def _enter(self) -> None:
        with self._lock:
            if self._closed:
                raise StoreUnavailable(f"the job store {self.path} is closed")
            self._busy += 1

    def _leave(self) -> None:
        with self._lock:
            self._busy -= 1
            if self._busy == 0:
                self._idle.notify_all()

    def close(self) -> None:
        """Close every thread's connection once no call uses one: closing a connection under
        a call on another thread (a late write of a stopping service) crashed the process."""
        with self._lock:
            self._closed = True
            self._idle.wait_for(lambda: self._busy == 0, timeout=CLOSE_WAIT)
            conns, self._all = self._all, []
        for conn in conns:
            conn.close()
        self._local = threading.local()

    # -- creation ----------------------------------------------------------------------------
    def _insert(self, conn: sqlite3.Connection, job: NewJob, now: float) -> None:
        conn.execute(
            "INSERT INTO jobs (id, process, status, inputs, seed, batch_id, idempotency_key,"
            " request_hash, created, updated, owner) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (
                job.id,
                job.process,
                JobStatus.accepted.value,
                encode_inputs(job.inputs),
                job.seed,
                job.batch_id,
                job.idempotency_key,
                job.request_hash,
                now,
                now,
                job.owner,
            ),
        )

    @_translated
    def create(self, job: NewJob) -> tuple[JobRecord, bool]:
        now = self._clock()
        with self._write() as conn:
            if job.idempotency_key is not None:
                row = conn.execute(
                    f"SELECT request_hash, {_COLUMNS} FROM jobs WHERE idempotency_key = ?",
                    (job.idempotency_key,),
                ).fetchone()
                if row is not None:
                    if row[0] != job.request_hash:
                        raise IdempotencyConflict(job.idempotency_key, row[1])
                    return _record(row[1:]), False
            self._insert(conn, job, now)
        return JobRecord(
            id=job.id,
            process=job.process,
            status=JobStatus.accepted,
            created=now,
            updated=now,
            seed=job.seed,
            batch_id=job.batch_id,
            owner=job.owner,
        ), True

    @_translated
    def create_batch(
        self, batch_id: str, process: str, jobs: Sequence[NewJob], owner: str = ""
    ) -> BatchRecord:
        now = self._clock()
        with self._write() as conn:
            conn.execute(
                "INSERT INTO batches (id, process, created, owner) VALUES (?, ?, ?, ?)",
                (batch_id, process, now, owner),
            )
            for job in jobs:
                self._insert(conn, job, now)
        return BatchRecord(batch_id, now, process, tuple(j.id for j in jobs), owner)

    # -- reads -------------------------------------------------------------------------------
    @_translated
    def get(self, job_id: str) -> JobRecord | None:
        row = (
            self._conn().execute(f"SELECT {_COLUMNS} FROM jobs WHERE id = ?", (job_id,)).fetchone()
        )
        return _record(row) if row else None

    @_translated
    def batch(self, batch_id: str) -> BatchRecord | None:
        conn = self._conn()
        row = conn.execute(
            "SELECT process, created, owner FROM batches WHERE id = ?", (batch_id,)
        ).fetchone()
        if row is None:
            return None
        ids = conn.execute(
            "SELECT id FROM jobs WHERE batch_id = ? ORDER BY seq", (batch_id,)
        ).fetchall()
        return BatchRecord(batch_id, row[1], row[0], tuple(r[0] for r in ids), row[2])

    @_translated
    def inputs(self, job_id: str) -> dict[str, Any] | None:
        row = self._conn().execute("SELECT inputs FROM jobs WHERE id = ?", (job_id,)).fetchone()
        if row is None:
            return None
        return read_inputs(job_id, row[0])

    @_translated
    def stored_inputs(self, job_id: str) -> bytes | None:
        row = self._conn().execute("SELECT inputs FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return None if row is None else stored_form(job_id, row[0])

    @_translated
    def search(
        self,
        *,
        status: Collection[JobStatus] = (),
        process: Collection[str] = (),
        owner: str | None = None,
        limit: int = 10,
        offset: int = 0,
    ) -> tuple[list[JobRecord], int]:
        where, args = [], []
        if owner is not None:
            where.append("owner = ?")
            args.append(owner)
        if status:
            where.append(f"status IN ({', '.join('?' * len(status))})")
            args += [JobStatus(s).value for s in status]
        if process:
            where.append(f"process IN ({', '.join('?' * len(process))})")
            args += list(process)
        clause = f" WHERE {' AND '.join(where)}" if where else ""
        conn = self._conn()
        total = conn.execute(f"SELECT COUNT(*) FROM jobs{clause}", args).fetchone()[0]
        rows = conn.execute(
            f"SELECT {_COLUMNS} FROM jobs{clause} ORDER BY seq DESC LIMIT ? OFFSET ?",
            [*args, limit, offset],
        ).fetchall()
        return [_record(r) for r in rows], int(total)

    @_translated
    def records(self, job_ids: Sequence[str]) -> list[JobRecord]:
        found: dict[str, JobRecord] = {}
        conn = self._conn()
        ids = list(job_ids)
        for i in range(0, len(ids), 500):  # stay under SQLite's bound-parameter limit
            chunk = ids[i : i + 500]
            rows = conn.execute(
                f"SELECT {_COLUMNS} FROM jobs WHERE id IN ({', '.join('?' * len(chunk))})", chunk
            ).fetchall()
            found.update((r[0], _record(r)) for r in rows)
        return [found[i] for i in ids if i in found]

    @_translated
    def result(self, job_id: str) -> bytes | None:
        row = (
            self._conn().execute("SELECT data FROM results WHERE job_id = ?", (job_id,)).fetchone()
        )
        return bytes(row[0]) if row else None

    @_translated
    def unfinished(self) -> list[JobRecord]:
        rows = (
            self._conn()
            .execute(
                f"SELECT {_COLUMNS} FROM jobs WHERE status IN (?, ?) ORDER BY seq", _UNFINISHED
            )
            .fetchall()
        )
        return [_record(r) for r in rows]

    @_translated
    def counts(self) -> dict[JobStatus, int]:
        out = dict.fromkeys(JobStatus, 0)
        for status, n in self._conn().execute("SELECT status, COUNT(*) FROM jobs GROUP BY status"):
            out[JobStatus(status)] = int(n)
        return out

    # -- status changes ----------------------------------------------------------------------
    def _update(self, sql: str, args: tuple[Any, ...]) -> bool:
        with self._write() as conn:
            return conn.execute(sql, args).rowcount > 0

    @_translated
    def mark_running(self, job_id: str, attempt: int) -> bool:
        now = self._clock()
        return self._update(
            "UPDATE jobs SET status = 'running', attempts = ?, started = ?, updated = ?,"
            " progress = 0, message = 'started' WHERE id = ? AND status = 'accepted'",
            (attempt, now, now, job_id),
        )

    @_translated
    def set_progress(self, job_id: str, progress: int, message: str) -> bool:
        return self._update(
            "UPDATE jobs SET progress = ?, message = ?, updated = ?"
            " WHERE id = ? AND status = 'running'",
            (max(0, min(100, int(progress))), message, self._clock(), job_id),
        )

    @_translated
    def finish(self, job_id: str, result: bytes, meta: dict[str, Any]) -> bool:
        now = self._clock()
        with self._write() as conn:
            done = conn.execute(
                "UPDATE jobs SET status = 'successful', progress = 100, message = 'done',"
                " finished = ?, updated = ?, meta = ? WHERE id = ? AND status = 'running'",
                (now, now, json.dumps(meta), job_id),
            ).rowcount
            if done:
                conn.execute(
                    "INSERT OR REPLACE INTO results (job_id, data) VALUES (?, ?)", (job_id, result)
                )
        return done > 0

    @_translated
    def fail(self, job_id: str, reason: str, kind: str = "") -> bool:
        now = self._clock()
        return self._update(
            "UPDATE jobs SET status = 'failed', message = ?, failure = ?, finished = ?,"
            " updated = ? WHERE id = ? AND status IN ('accepted', 'running')",
            (reason, kind, now, now, job_id),
        )

    @_translated
    def requeue(self, job_id: str, message: str, *, keep_attempt: bool = True) -> bool:
        drop = "" if keep_attempt else ", attempts = MAX(attempts - 1, 0)"
        return self._update(
            "UPDATE jobs SET status = 'accepted', progress = 0, message = ?, started = NULL,"
            f" updated = ?{drop} WHERE id = ? AND status IN ('accepted', 'running')",
            (message, self._clock(), job_id),
        )

    @_translated
    def dismiss(self, job_id: str) -> JobRecord | None:
        now = self._clock()
        with self._write() as conn:
            conn.execute(
                "UPDATE jobs SET status = 'dismissed', message = 'dismissed', updated = ?,"
                " finished = COALESCE(finished, ?) WHERE id = ? AND status != 'dismissed'",
                (now, now, job_id),
            )
            conn.execute("DELETE FROM results WHERE job_id = ?", (job_id,))
            row = conn.execute(f"SELECT {_COLUMNS} FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return _record(row) if row else None

    @_translated
    def purge(self, finished_before: float) -> int:
        final = tuple(s.value for s in FINAL)
        with self._write() as conn:
            n = conn.execute(
                "DELETE FROM jobs WHERE finished < ? AND status IN (?, ?, ?)",
                (finished_before, *final),
            ).rowcount
            conn.execute(
                "DELETE FROM batches WHERE NOT EXISTS"
                " (SELECT 1 FROM jobs WHERE jobs.batch_id = batches.id)"
            )
        return int(n)

    # -- subscriber callbacks ----------------------------------------------------------------
    @_translated
    def set_subscriber(self, job_id: str, state: dict[str, Any] | None) -> bool:
        """Keep the callback state of a job (its subscriber and the deliveries done); None
        forgets it. Returns whether the job exists."""
        text = "" if state is None else orjson.dumps(state).decode()
        return self._update("UPDATE jobs SET subscriber = ? WHERE id = ?", (text, job_id))

    @_translated
    def subscribed(self) -> list[tuple[str, dict[str, Any]]]:
        """The jobs with a callback state, oldest first, each with its state (an unreadable
        state is skipped: it cannot be delivered)."""
        rows = (
            self._conn()
            .execute("SELECT id, subscriber FROM jobs WHERE subscriber != '' ORDER BY seq")
            .fetchall()
        )
        out = []
        for job_id, text in rows:
            try:
                state = json.loads(text)
            except ValueError:
                continue
            if isinstance(state, dict):
                out.append((job_id, state))
        return out

    @_translated
    def ping(self) -> None:
        with self._write() as conn:
            conn.execute(
                "INSERT OR REPLACE INTO heartbeat (id, at) VALUES (1, ?)", (self._clock(),)
            )
