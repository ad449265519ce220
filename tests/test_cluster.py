"""The cluster a campaign runs on (satfmu.sims.campaign.cluster): a local one listens on the
loopback only; a scheduler address is checked, and plain TCP off this host is warned about."""
from __future__ import annotations

import warnings

import psutil
import pytest

from satfmu.fmus.errors import CampaignError, InsecureConnectionWarning
from satfmu.sims.campaign import cluster


def _listening(pids: set[int]) -> list[tuple[str, int]]:
    """The TCP sockets the processes listen on, (address, port)."""
    return [(c.laddr.ip, c.laddr.port) for c in psutil.net_connections(kind="inet")
            if c.status == psutil.CONN_LISTEN and c.pid in pids]


def test_a_local_cluster_listens_on_the_loopback_only() -> None:
    """Scheduler, dashboard, two workers and their nannies: every listening socket on 127.0.0.1
    (the dashboard and worker ports once listened on 0.0.0.0, answering from the network)."""
    with cluster.cluster_client(None, None, n_workers=2) as client:
        me = psutil.Process()
        pids = {me.pid, *(p.pid for p in me.children(recursive=True))}
        found = _listening(pids)
        workers = client.scheduler_info()["workers"]
        assert len(workers) == 2
        assert len(found) >= 6  # scheduler, dashboard, 2 workers, 2 nannies (and the workers' own dashboards)
        assert {ip for ip, _ in found} == {cluster.LOOPBACK}, found
        assert all(w.startswith(f"tcp://{cluster.LOOPBACK}:") for w in workers)
        assert client.dashboard_link.startswith(f"http://{cluster.LOOPBACK}:")


@pytest.mark.parametrize("address, match", [
    ("127.0.0.1:8786", "give tls://host:port"),
    ("http://127.0.0.1:8786", "give tls://host:port"),
    ("tls://:8786", "give tls://host:port"),
    ("tcp://127.0.0.1", "give tls://host:port"),
    ("tcp://127.0.0.1:port", "give tls://host:port"),
])
def test_a_bad_scheduler_address_is_refused(address: str, match: str) -> None:
    with pytest.raises(CampaignError, match=match):
        cluster.check_address(address)


def test_plain_tcp_off_this_host_is_warned_about() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning for the loopback or TLS
        for quiet in ("tcp://127.0.0.1:8786", "tcp://localhost:8786", "tcp://[::1]:8786", "tls://10.1.2.3:8786",
                      "inproc://10.1.2.3/1234/1"):
            assert cluster.check_address(quiet) == quiet.split(":")[0]
    for loud in ("tcp://10.1.2.3:8786", "tcp://192.168.1.20:8786"):
        with pytest.warns(InsecureConnectionWarning, match="neither authenticated nor encrypted"):
            assert cluster.check_address(loud) == "tcp"
    assert not cluster.is_loopback("no-such-host.invalid")


def test_tls_files_that_do_not_exist_are_named(tmp_path) -> None:
    with pytest.raises(CampaignError, match=r"no such file: tls_ca_file .*ca\.pem"):
        cluster.security(str(tmp_path / "ca.pem"))
