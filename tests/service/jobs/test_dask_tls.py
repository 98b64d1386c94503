"""The Dask backend over TLS (issue 13, finding 7): scheduler_tls_* settings reach the client."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from service.jobs.factory import scheduler_security

from ..clusters import LOCAL_CLUSTER_CONFIG
from ..conftest import SQUARE, ClientFactory, make_settings, submit, wait_for

pytestmark = pytest.mark.anyio


@pytest.fixture(scope="module")
def certificate(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A self-signed certificate (its own CA) and its key, made by openssl(1)."""
    if shutil.which("openssl") is None:
        pytest.skip("making a test certificate needs openssl(1)")
    folder = tmp_path_factory.mktemp("tls")
    cert, key = folder / "cert.pem", folder / "key.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", str(key),
         "-out", str(cert), "-days", "1", "-subj", "/CN=evomesh-test"],
        check=True,
        capture_output=True,
    )  # fmt: skip
    return cert, key


@pytest.fixture(scope="module")
def tls_scheduler(certificate: tuple[Path, Path]) -> Iterator[str]:
    """A LocalCluster that speaks TLS only."""
    import dask
    from distributed import LocalCluster
    from distributed.security import Security

    cert, key = (str(p) for p in certificate)
    security = Security(  # type: ignore[no-untyped-call]
        tls_ca_file=cert,
        tls_scheduler_cert=cert,
        tls_scheduler_key=key,
        tls_worker_cert=cert,
        tls_worker_key=key,
        tls_client_cert=cert,
        tls_client_key=key,
        require_encryption=True,
    )
    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        cluster = LocalCluster(
            n_workers=1,
            threads_per_worker=1,
            processes=True,
            protocol="tls://",
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
            security=security,
        )
        try:
            yield str(cluster.scheduler_address)
        finally:
            cluster.close()


def test_no_tls_settings_is_plain_tcp(tmp_path: Path) -> None:
    assert scheduler_security(make_settings(tmp_path)) is None


def test_tls_settings_require_encryption(tmp_path: Path, certificate: tuple[Path, Path]) -> None:
    cert, key = certificate
    security: Any = scheduler_security(
        make_settings(
            tmp_path, scheduler_tls_ca=cert, scheduler_tls_cert=cert, scheduler_tls_key=key
        )
    )
    assert security.require_encryption
    assert (security.tls_ca_file, security.tls_client_cert) == (str(cert), str(cert))


async def test_jobs_run_on_a_tls_scheduler(
    make_client: ClientFactory, tls_scheduler: str, certificate: tuple[Path, Path]
) -> None:
    assert tls_scheduler.startswith("tls://")
    cert, key = certificate
    client = await make_client(
        backend="dask",
        scheduler=tls_scheduler,
        scheduler_tls_ca=cert,
        scheduler_tls_cert=cert,
        scheduler_tls_key=key,
    )
    job = await submit(
        client, "mesh", {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}
    )
    assert (await wait_for(client, job["jobID"], timeout=120))["status"] == "successful"
