"""OGC subscriber callbacks: the status document of a job is POSTed to the execute request's
``inProgressUri`` when the job starts, and to ``successUri`` or ``failedUri`` when it ends.

Sending never blocks a request or the job manager: a status change puts one delivery on a
bounded queue (a full queue drops it, logged), and a few sender tasks POST them with retries
and exponential backoff, each delivery bounded in tries and in time. Subscriptions live in the
service's memory: a job requeued by a restart has none.

>>> private_host("http://127.0.0.1:9/x"), private_host("https://example.org/done")
(True, False)
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

import httpx
import orjson

from .inputs import Subscriber
from .jobs.store import FINAL, JobStatus, JobStore
from .problems import Problem
from .settings import Settings
from .views import status_info

__all__ = ["CallbackNotifier", "private_host"]

log = logging.getLogger(__name__)

#: Client errors a retry may cure (the receiver's timeout, rate limit); others are final.
_RETRIED_4XX = frozenset({408, 425, 429})


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
    subscriber: Subscriber
    started_sent: bool = False


@dataclass(frozen=True)
class Delivery:
    """One callback to send."""

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
        self._queue: asyncio.Queue[Delivery] = asyncio.Queue(settings.callback_queue)
        self._senders: list[asyncio.Task[None]] = []
        self._client: httpx.AsyncClient | None = None
        self.delivered = 0  #: callbacks answered 2xx
        self.dropped = 0  #: callbacks given up (tries, time or a full queue)

    async def start(self) -> None:
        self._client = httpx.AsyncClient(
            timeout=self.settings.callback_timeout,
            follow_redirects=False,  # a redirect could lead anywhere the URI check refused
            transport=self._transport,
        )
        self._senders = [
            asyncio.create_task(self._send_loop()) for _ in range(self.settings.callback_senders)
        ]

    async def close(self) -> None:
        for task in self._senders:
            task.cancel()
        for task in self._senders:
            with contextlib.suppress(asyncio.CancelledError):
                await task
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

    def subscribe(self, job_id: str, base: str, subscriber: Subscriber) -> None:
        """Call ``subscriber`` back on the job's changes (call right after the job is made)."""
        if subscriber.model_dump(exclude_none=True):
            self._subscriptions[job_id] = _Subscription(base, subscriber)
            # A free worker may have started it within the submission, before this call.
            self.changed(job_id)

    def changed(self, job_id: str) -> None:
        """The job manager's hook: the job's status was written."""
        subscription = self._subscriptions.get(job_id)
        if subscription is None:
            return
        record = self.store.get(job_id)
        if record is None:
            self._subscriptions.pop(job_id, None)
            return
        subscriber = subscription.subscriber
        uri: str | None = None
        if record.status is JobStatus.running and not subscription.started_sent:
            subscription.started_sent = True
            uri = subscriber.inProgressUri
        elif record.status is JobStatus.successful:
            uri = subscriber.successUri
        elif record.status is JobStatus.failed:
            uri = subscriber.failedUri
        if record.status in FINAL:
            self._subscriptions.pop(job_id, None)
        if uri is None:
            return
        try:
            self._queue.put_nowait(Delivery(uri, status_info(subscription.base, record)))
        except asyncio.QueueFull:
            self.dropped += 1
            log.warning("callback dropped: the queue is full", extra={"job_id": job_id})

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
