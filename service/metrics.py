"""Prometheus metrics of one app: its own registry, so every ``create_app`` starts from zero."""

from __future__ import annotations

from collections.abc import Callable, Iterator

from prometheus_client import CollectorRegistry, Counter, Histogram
from prometheus_client.core import GaugeMetricFamily, Metric
from prometheus_client.registry import Collector

from .jobs.backends.base import BackendStats
from .jobs.store import JobStatus

__all__ = ["Metrics"]

_DURATION_BUCKETS = (0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300, 1800, 3600)


class _Live(Collector):
    """Gauges read at scrape time from the store and the backend (never out of date)."""

    def __init__(
        self,
        counts: Callable[[], dict[JobStatus, int]],
        stats: Callable[[], BackendStats],
    ) -> None:
        self._counts = counts
        self._stats = stats

    def describe(self) -> Iterator[Metric]:
        return iter(())

    def collect(self) -> Iterator[Metric]:
        jobs = GaugeMetricFamily("evomesh_jobs", "Jobs in the store by status", labels=["status"])
        for status, n in self._counts().items():
            jobs.add_metric([status.value], n)
        yield jobs
        s = self._stats()
        yield GaugeMetricFamily("evomesh_queue_depth", "Tasks waiting for a worker", value=s.queued)
        workers = GaugeMetricFamily("evomesh_workers", "Worker processes", labels=["state"])
        workers.add_metric(["configured"], s.workers)
        workers.add_metric(["alive"], s.alive)
        workers.add_metric(["busy"], s.busy)
        yield workers


class Metrics:
    """The service's metrics."""

    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        self.submitted = Counter(
            "evomesh_jobs_submitted", "Jobs created", ["process"], registry=self.registry
        )
        self.outcomes = Counter(
            "evomesh_job_outcomes", "Runs ended, by outcome", ["process", "outcome"],
            registry=self.registry,
        )  # fmt: skip
        self.refused = Counter(
            "evomesh_jobs_refused",
            "Jobs refused because too many were waiting (429)",
            ["process"],
            registry=self.registry,
        )
        self.retries = Counter(
            "evomesh_job_retries", "Runs started again after a crash", registry=self.registry
        )
        self.duration = Histogram(
            "evomesh_job_duration_seconds",
            "Run time of successful jobs",
            ["process"],
            buckets=_DURATION_BUCKETS,
            registry=self.registry,
        )
        self.triangles = Counter(
            "evomesh_triangles_produced", "Triangles in results", registry=self.registry
        )

    def watch(
        self, counts: Callable[[], dict[JobStatus, int]], stats: Callable[[], BackendStats]
    ) -> Collector:
        """Report the store's and the backend's live figures (unregister the returned collector
        when they go away)."""
        collector = _Live(counts, stats)
        self.registry.register(collector)
        return collector
