"""OGC subscriber callbacks: the status document of a job is POSTed to the execute request's
``inProgressUri`` when the job starts, and to ``successUri`` or ``failedUri`` when it ends.

Sending never blocks a request or the job manager: a status change puts one delivery on a
bounded queue, and a few sender tasks POST them with retries and exponential backoff, each
delivery bounded in tries and in time. Delivery is at least once across restarts: the
subscriber is kept with the job in the store (before the execute request is answered), with the
deliveries done; a restarted service resumes the others (a job that ended meanwhile gets only its
final callback). A delivery given up after its tries counts as done.

>>> private_host("http://127.0.0.1:9/x"), private_host("https://example.org/done")
(True, False)
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
import threading
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

import httpx
import orjson

from .inputs import Subscriber
from .jobs.store import FINAL, JobStatus, JobStore, StoreError
from .problems import Problem
from .settings import Settings
from .views import status_info

__all__ = ["CallbackNotifier", "private_host"]

log = logging.getLogger("evomesh.callbacks")

#: Client errors a retry may cure (the receiver's timeout, rate limit); others are final.
_RETRIED_4XX = frozenset({408, 425, 429})
#: The subscriber URI called on each status (its field name in the execute request).
_EVENTS = {
    JobStatus.running: "inProgressUri",
    JobStatus.successful: "successUri",
    JobStatus.failed: "failedUri",
}


def private_host(uri: str) -> bool:
    """Whether ``uri`` names this machine or a private, link-local or unspecified address
    (checked on the URI's host as written; a name is resolved only when the POST is made)."""
    host = (urlsplit(uri).hostname or "").lower()
    if host == "localhost" or host.endswith(".localhost"):
        return True
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        return False
    return (
        address.is_loopback
        or address.is_private
        or address.is_link_local
        or address.is_unspecified
        or address.is_multicast
    )


@dataclass
class _Subscription:
    base: str  #: the service's base URL for the document's links
    uris: dict[str, str]  #: subscriber field -> URI
    sent: set[str] = field(default_factory=set)  #: events delivered (or given up)
    queued: set[str] = field(default_factory=set)  #: events on the queue or being sent
    final: bool = False  #: the job ended: forgotten once nothing is queued

    def state(self) -> dict[str, Any]:
        """What the store keeps (the stored form a restart reads back)."""
        return {"base": self.base, "uris": self.uris, "sent": sorted(self.sent)}

    @classmethod
    def of(cls, state: dict[str, Any]) -> _Subscription:
        uris = state.get("uris")
        sent = state.get("sent")
        return cls(
            str(state.get("base", "")),
            {str(k): str(v) for k, v in uris.items()} if isinstance(uris, dict) else {},
            {str(e) for e in sent} if isinstance(sent, list) else set(),
        )


@dataclass(frozen=True)
class Delivery:
    """One callback to send."""

    job_id: str
    event: str  #: the subscriber field it answers (``successUri``...)
    uri: str
    document: dict[str, Any] = field(repr=False)


class CallbackNotifier:
    """Subscriptions of jobs, and the tasks that deliver their callbacks."""

    def __init__(
        self,
        store: JobStore,
        settings: Settings,
        transport: httpx.AsyncBaseTransport | None = None,
    ) -> None:
        self.store = store
        self.settings = settings
        self._transport = transport
        self._subscriptions: dict[str, _Subscription] = {}
        # At most two deliveries (start, end) of each of at most ``callback_queue`` subscriptions.
        self._queue: asyncio.Queue[Delivery] = asyncio.Queue(2 * settings.callback_queue)
        self._senders: list[asyncio.Task[None]] = []
        self._writes: set[asyncio.Task[None]] = set()
        self._write_lock = threading.Lock()  # a state is read and written in one go
        self._client: httpx.AsyncClient | None = None
        self.delivered = 0  #: callbacks answered 2xx
        self.dropped = 0  #: callbacks given up (tries, time or a full queue)
        self.resumed = 0  #: subscriptions a start found in the store

    async def start(self) -> None:
        self._client = httpx.AsyncClient(
            timeout=self.settings.callback_timeout,
            follow_redirects=False,  # a redirect could lead anywhere the URI check refused
            transport=self._transport,
        )
        self._senders = [
            asyncio.create_task(self._send_loop()) for _ in range(self.settings.callback_senders)
        ]
        await self._resume()

    async def _resume(self) -> None:
        """Take up the subscriptions a stopped (or killed) service left in the store."""
        try:
            kept = await asyncio.to_thread(self.store.subscribed)
        except StoreError as exc:  # the service runs on; these wait for the next start
            log.error("callbacks not resumed: %s", exc)
            return
        for job_id, state in kept:
            self._subscriptions[job_id] = _Subscription.of(state)
            self.changed(job_id)
        self.resumed = len(kept)
        if kept:
            log.info("callbacks resumed", extra={"jobs": len(kept)})

    async def close(self) -> None:
        for task in self._senders:
            task.cancel()
        for task in self._senders:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        await asyncio.gather(*self._writes, return_exceptions=True)
        if self._client is not None:
            await self._client.aclose()

    def check(self, subscriber: Subscriber) -> None:
        """400 for a URI to a private host (unless allowed), 503 when too many jobs have
        subscribers; made before the job is created."""
        for name, uri in subscriber.model_dump(exclude_none=True).items():
            if not self.settings.callback_private_hosts and private_host(uri):
                raise Problem(
                    400,
                    f"subscriber.{name} names a loopback or private address, which this"
                    " service does not call back",
                    kind="invalid-parameter",
                    parameter=f"subscriber.{name}",
                )
        if len(self._subscriptions) >= self.settings.callback_queue:
            raise Problem(
                503,
                "too many jobs have subscribers; try again without one, or later",
                kind="callbacks-full",
                headers={"Retry-After": "30"},
            )

    async def subscribe(self, job_id: str, base: str, subscriber: Subscriber) -> None:
        """Call ``subscriber`` back on the job's changes (call right after the job is made, and
        answer the request once this returns: the subscriber is then kept in the store)."""
        uris = subscriber.model_dump(exclude_none=True)
        if not uris:
            return
        self._subscriptions[job_id] = _Subscription(base, uris)
        # A free worker may have started it within the submission, before this call.
        self.changed(job_id)
        await self._keep(job_id)

    def changed(self, job_id: str) -> None:
        """The job manager's hook: the job's status was written."""
        subscription = self._subscriptions.get(job_id)
        if subscription is None:
            return
        record = self.store.get(job_id)
        if record is None or record.status is JobStatus.dismissed:
            self._forget(job_id)
            return
        subscription.final = record.status in FINAL
        event = _EVENTS.get(record.status)
        uri = subscription.uris.get(event or "")
        if event and uri and event not in subscription.sent | subscription.queued:
            try:
                self._queue.put_nowait(
                    Delivery(job_id, event, uri, status_info(subscription.base, record))
                )
                subscription.queued.add(event)
            except asyncio.QueueFull:
                self.dropped += 1
                log.warning("callback dropped: the queue is full", extra={"job_id": job_id})
        if subscription.final and not subscription.queued:
            self._forget(job_id)

    def _forget(self, job_id: str) -> None:
        if self._subscriptions.pop(job_id, None) is not None:
            self._spawn_keep(job_id)

    def _spawn_keep(self, job_id: str) -> None:
        task = asyncio.get_running_loop().create_task(self._keep(job_id))
        self._writes.add(task)
        task.add_done_callback(self._writes.discard)

    async def _keep(self, job_id: str) -> None:
        """Write the job's callback state as it is now (none once forgotten) to the store."""
        try:
            await asyncio.to_thread(self._write_state, job_id)
        except StoreError as exc:  # delivered from memory still; a restart may resend
            log.warning("callback state not kept: %s", exc, extra={"job_id": job_id})

    def _write_state(self, job_id: str) -> None:
        with self._write_lock:  # the last write made carries the latest state
            subscription = self._subscriptions.get(job_id)
            self.store.set_subscriber(job_id, subscription.state() if subscription else None)

    async def _send_loop(self) -> None:
        while True:
            delivery = await self._queue.get()
            try:
                async with asyncio.timeout(self.settings.callback_deadline):
                    sent = await self._deliver(delivery)
            except TimeoutError:
                sent = False
            if sent:
                self.delivered += 1
            else:
                self.dropped += 1
                log.warning("callback given up", extra={"uri": delivery.uri})
            subscription = self._subscriptions.get(delivery.job_id)
            if subscription is None:
                continue
            subscription.queued.discard(delivery.event)
            subscription.sent.add(delivery.event)
            if subscription.final and not subscription.queued:
                self._subscriptions.pop(delivery.job_id, None)
            await self._keep(delivery.job_id)

    async def _deliver(self, delivery: Delivery) -> bool:
        """POST the document until a 2xx, a final client error or the last try."""
        assert self._client is not None
        body = orjson.dumps(delivery.document)
        headers = {"Content-Type": "application/json"}
        for attempt in range(self.settings.callback_attempts):
            if attempt:
                await asyncio.sleep(self.settings.callback_backoff * 2 ** (attempt - 1))
            try:
                response = await self._client.post(delivery.uri, content=body, headers=headers)
            except httpx.HTTPError as exc:
                log.info("callback try failed: %s", exc, extra={"uri": delivery.uri})
                continue
            if response.is_success:
                return True
            if response.is_client_error and response.status_code not in _RETRIED_4XX:
                return False
        return False
