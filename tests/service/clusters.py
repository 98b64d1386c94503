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
        self._config: Any = None

    def address(self, workers: int) -> str:
        cluster = self._clusters.get(workers)
        if cluster is None:
            cluster = self._clusters[workers] = local_cluster(workers)
        address: str = cluster.scheduler_address
        return address

    def __enter__(self) -> Clusters:
        import dask
        import distributed  # noqa: F401 - its defaults first, or leaving the set drops them

        self._config = dask.config.set(LOCAL_CLUSTER_CONFIG)
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
        if self._config is not None:
            self._config.__exit__(kind, value, tb)


#: A LocalCluster closes a nanny whose worker has been gone this long at *any* check, and checks
#: lost-worker-timeout after each removal: a worker killed twice 15 s apart (fault tests do) lost
#: its nanny for good. Its nanny restarts it in seconds anyway.
LOCAL_CLUSTER_CONFIG = {"distributed.deploy.lost-worker-timeout": "1h"}


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
