"""Real Dask ``LocalCluster``s of worker processes on loopback, for the tests that need one."""

from __future__ import annotations

import contextlib
from types import TracebackType
from typing import Any


class Clusters:
    """LocalClusters by worker count, started on first use and closed together.

    Workers are processes (``processes=True``, one thread each), as ``dask worker`` runs them;
    the scheduler and every worker listen on 127.0.0.1 only.
    """

    def __init__(self) -> None:
        self._clusters: dict[int, Any] = {}

    def address(self, workers: int) -> str:
        cluster = self._clusters.get(workers)
        if cluster is None:
            cluster = self._clusters[workers] = local_cluster(workers)
        address: str = cluster.scheduler_address
        return address

    def __enter__(self) -> Clusters:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        clusters, self._clusters = list(self._clusters.values()), {}
        for cluster in clusters:
            with contextlib.suppress(Exception):
                cluster.close()


def local_cluster(workers: int) -> Any:
    """A LocalCluster of ``workers`` single-threaded worker processes on 127.0.0.1."""
    from distributed import LocalCluster

    return LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address="127.0.0.1:0",  # None still binds 8787, which may be taken
    )
