"""The Dask cluster a campaign runs on: a local one that listens on the loopback only, or an
existing one reached over TCP or TLS.

A local cluster (the default) binds its scheduler, its workers, their nannies and the dashboard
to 127.0.0.1: nothing of it answers from the host's network address. An existing cluster is
given by its scheduler's address: ``tls://host:port`` with Dask's TLS security (certificates
from :class:`distributed.security.Security` options, or from Dask's configuration,
``distributed.comm.tls.*``), or ``tcp://host:port``. Dask's TCP is neither authenticated nor
encrypted, and a scheduler runs whatever any client sends it: a ``tcp://`` address that is not
a loopback one is used, with an :class:`~satfmu.fmus.errors.InsecureConnectionWarning`.
"""
from __future__ import annotations

import contextlib
import ipaddress
import os
import socket
import warnings
from collections.abc import Iterator
from urllib.parse import urlsplit

import dask
from distributed import Client, LocalCluster
from distributed.security import Security

from satfmu.fmus.errors import CampaignError, InsecureConnectionWarning
from satfmu.sims.campaign import worker_server

LOOPBACK = "127.0.0.1"
"""The address a local cluster's scheduler, workers, nannies and dashboard listen on."""
SCHEMES = ("tls", "tcp", "inproc")
"""The schemes of a scheduler address satfmu connects to (``inproc``: a cluster in this process)."""

def is_loopback(host: str) -> bool:
    """Whether every address ``host`` names is a loopback one (``127.0.0.0/8``, ``::1``).

    Parameters
    ----------
    host : str
        An IP address or a host name (resolved; a name that does not resolve is not loopback).
    """
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        pass
    try:
        infos = socket.getaddrinfo(host, None)
    except (socket.gaierror, UnicodeError):
        return False
    return bool(infos) and all(ipaddress.ip_address(str(i[4][0]).split("%")[0]).is_loopback for i in infos)


def check_address(address: str) -> str:
    """Check a scheduler address, and warn when it is unauthenticated and off this host.

    Parameters
    ----------
    address : str
        ``tls://host:port``, ``tcp://host:port`` or ``inproc://...`` (a cluster in this process).

    Returns
    -------
    str
        The scheme, one of :data:`SCHEMES`.

    Raises
    ------
    CampaignError
        Another scheme (or none), or no host or port.

    Warns
    -----
    InsecureConnectionWarning
        A ``tcp://`` address that is not a loopback one.
    """
    parts = urlsplit(address)
    if parts.scheme == "inproc":
        return "inproc"
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.scheme not in SCHEMES or not parts.hostname or port is None:
        raise CampaignError(f"scheduler address {address!r}: give tls://host:port (or tcp://host:port on a "
                            f"trusted network)")
    if parts.scheme == "tcp" and not is_loopback(parts.hostname):
        warnings.warn(f"scheduler {address}: Dask's TCP is neither authenticated nor encrypted, and the scheduler "
                      "runs whatever any client sends it; use tls:// with certificates (docs: campaigns on a "
                      "cluster)", InsecureConnectionWarning, stacklevel=3)
    return parts.scheme


def security(ca_file: str | None = None, cert: str | None = None, key: str | None = None) -> Security:
    """The TLS security of a client: the files given, else Dask's configuration
    (``distributed.comm.tls.ca-file``, ``distributed.comm.tls.client.cert`` and ``.key``).

    Parameters
    ----------
    ca_file : str, optional
        The certificate authority the scheduler's certificate is checked against (PEM).
    cert, key : str, optional
        This client's certificate and private key (PEM; ``key`` may be left out when ``cert``
        holds both).

    Raises
    ------
    CampaignError
        A file given that does not exist.
    """
    given = {"tls_ca_file": ca_file, "tls_client_cert": cert, "tls_client_key": key}
    missing = [f"{k} {v}" for k, v in given.items() if v is not None and not os.path.isfile(v)]
    if missing:
        raise CampaignError(f"TLS: no such file: {', '.join(missing)}")
    return Security(**{k: v for k, v in given.items() if v is not None})


@contextlib.contextmanager
def cluster_client(scheduler: str | None, client: Client | None, n_workers: int = 2,
                   threads_per_worker: int = 1, tls: Security | None = None) -> Iterator[Client]:
    """The given client, a client of ``scheduler``, or that of a local cluster of ``n_workers``
    processes on the loopback (its dashboard on a free port; its workers forked from the fork
    server of :func:`satfmu.sims.campaign.worker_server.start`, with
    :data:`satfmu.sims.campaign.worker_server.WORKER_ENV`); the
    latter two closed at exit.

    Parameters
    ----------
    scheduler : str or None
        Address of a running Dask scheduler (``"tls://host:port"``, ``"tcp://host:port"``:
        :func:`check_address`), used when ``client`` is None.
    client : distributed.Client or None
        A client to use as is (not closed); it takes precedence.
    n_workers : int
        Worker processes of the local cluster (neither ``client`` nor ``scheduler`` given).
    threads_per_worker : int
        Threads of each local worker.
    tls : distributed.security.Security, optional
        The security of a ``tls://`` connection (default :func:`security`: Dask's configuration).

    Yields
    ------
    distributed.Client
    """
    if client is not None:
        yield client
    elif scheduler is not None:
        scheme = check_address(scheduler)
        with Client(scheduler, security=(tls or security()) if scheme == "tls" else None) as remote:
            yield remote
    else:
        # the workers are forked from the fork server (started here unless it runs), whose
        # environment has WORKER_ENV: malloc reads its settings when a process starts; Dask copies
        # its pre-spawn-environ into this process's os.environ, restored once the workers run
        pre = {**dask.config.get("distributed.nanny.pre-spawn-environ", default={}), **worker_server.WORKER_ENV}
        saved = {k: os.environ.get(k) for k in pre}
        # and no statistical profiler in the workers (it samples the task thread's stack every 10 ms,
        # for the dashboard: measured 4-9 % of a campaign worker's CPU)
        config = {"distributed.nanny.pre-spawn-environ": pre, "distributed.worker.profile.enabled": False,
                  "distributed.worker.multiprocessing-method": "forkserver"}
        worker_server.start()
        with dask.config.set(config), \
                LocalCluster(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=True,
                             host=LOOPBACK, dashboard_address=f"{LOOPBACK}:0") as cluster, \
                Client(cluster) as local:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
            yield local

