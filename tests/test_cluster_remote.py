"""A scenario campaign on a Dask cluster that shares no folder with the driver.

A scheduler and two worker processes on the loopback, each worker in its own mount namespace
(``unshare -m``, root) with empty tmpfs mounted over the driver's folders (pytest's, where the
campaign folder is; the driver's satfmu home; the repository's ``build/``, where the FMUs are):
as on another machine, a worker sees none of the driver's files. The campaign must complete with rows
identical to those of the same campaign on an in-process cluster: the FMUs travel by content
(:mod:`satfmu.sims.campaign.shipment`). Also with one worker killed half-way (Dask runs its
chunks again on the other), and over ``tls://`` with certificates made here by openssl.
"""
from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pandas as pd
import pytest
from distributed import Client
from distributed.security import Security

from satfmu.sims.campaign import cluster, engine
from satfmu.sims.campaign.scenario_task import campaign
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.sims.scenario.spec import Scenario

ROOT = Path(__file__).resolve().parents[1]
DASK = Path(sys.executable).parent / "dask"
N, CHUNK = 24, 3

pytestmark = pytest.mark.skipif(os.geteuid() != 0 or shutil.which("unshare") is None,
                                reason="mount namespaces need root and unshare (util-linux)")


def _scenario() -> Scenario:
    """mrp_slew_mc cut to 6 s: random attitudes and inertias, the published law."""
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_slew_mc.toml").read_text())
    return Scenario.from_dict({**data, "stop_time": 6.0})


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _tls_files(folder: Path) -> dict[str, Path]:
    """A certificate authority and one certificate it signed for 127.0.0.1 (openssl), PEM."""
    def ssl(*args: str) -> None:
        subprocess.run(["openssl", *args], check=True, capture_output=True, cwd=folder)

    ssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "1",
        "-subj", "/CN=satfmu test CA")
    ssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "node.key", "-out", "node.csr", "-subj", "/CN=127.0.0.1")
    (folder / "san.cnf").write_text("subjectAltName = IP:127.0.0.1\n")
    ssl("x509", "-req", "-in", "node.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial", "-out",
        "node.pem", "-days", "1", "-extfile", "san.cnf")
    return {"ca": folder / "ca.pem", "cert": folder / "node.pem", "key": folder / "node.key"}


def _tls_args(files: dict[str, Path] | None, folder: str | Path) -> list[str]:
    if files is None:
        return []
    return ["--tls-ca-file", f"{folder}/ca.pem", "--tls-cert", f"{folder}/node.pem", "--tls-key", f"{folder}/node.key"]


@contextlib.contextmanager
def _scheduler(log: Path, tls: dict[str, Path] | None) -> Iterator[str]:
    address = f"{'tls' if tls else 'tcp'}://127.0.0.1:{_port()}"
    cmd = [str(DASK), "scheduler", "--host", address.rsplit(":", 1)[0], "--port", address.rsplit(":", 1)[1],
           "--no-dashboard", *_tls_args(tls, tls["ca"].parent if tls else "")]
    with log.open("w") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        yield address
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=30)


def _hidden_worker(address: str, name: str, log: Path, tls: dict[str, Path] | None, hide: list[Path],
                   python_loop: bool = False) -> subprocess.Popen:
    """A worker in a mount namespace of its own, the folders ``hide`` under empty tmpfs (its own
    scratch folder, TMPDIR and satfmu home, in the first); its TLS files (if any) handed over in
    its environment and written there. With ``python_loop`` it steps in Python, as a worker
    without a C compiler does."""
    scratch = hide[0] / f"worker-{name}"
    env = {**os.environ, "SATFMU_HOME": str(scratch / "home"), "TMPDIR": str(scratch)}
    if python_loop:
        env["SATFMU_PYTHON_LOOP"] = "1"
    mounts = " && ".join(f"mount -t tmpfs tmpfs '{p}'" for p in hide)
    write_tls = ""
    if tls:
        env.update({f"SATFMU_TEST_{k.upper()}": p.read_text() for k, p in tls.items()})
        write_tls = (f'printf "%s" "$SATFMU_TEST_CA" > {scratch}/ca.pem && printf "%s" "$SATFMU_TEST_CERT" > '
                     f'{scratch}/node.pem && printf "%s" "$SATFMU_TEST_KEY" > {scratch}/node.key && ')
    script = (f"{mounts} && mkdir -p '{scratch}' && {write_tls}"
              f"exec '{DASK}' worker {address} --nthreads 1 --no-nanny --no-dashboard --host 127.0.0.1 "
              f"--name {name} {' '.join(_tls_args(tls, scratch))}")
    with log.open("w") as out:
        return subprocess.Popen(["unshare", "-m", "--propagation", "private", "sh", "-c", script], env=env,
                                stdout=out, stderr=subprocess.STDOUT, start_new_session=True)


def _hidden(tmp_path_factory: pytest.TempPathFactory, fmu_dir: Path) -> list[Path]:
    """The driver's folders a worker must not see: pytest's folders (the campaign's, the TLS
    files'), this process's satfmu home and the FMU folder's parent (the repository's build/)."""
    found = [tmp_path_factory.getbasetemp(), Path(os.environ["SATFMU_HOME"]), fmu_dir.parent]
    return [p for p in found if not any(p != q and p.is_relative_to(q) for q in found)]


def _connect(address: str, tls: dict[str, Path] | None, workers: int) -> Client:
    security = Security(tls_ca_file=str(tls["ca"]), tls_client_cert=str(tls["cert"]), tls_client_key=str(tls["key"]),
                        require_encryption=True) if tls else None
    client = Client(address, security=security, timeout=60)
    client.wait_for_workers(workers, timeout=60)
    return client


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory, client: Client, fmu_dir: Path) -> pd.DataFrame:
    """The rows of the campaign on the in-process cluster of the other tests."""
    camp = campaign(_scenario(), N, seed=5, chunk=CHUNK, fmu_dir=fmu_dir, name="remote")
    return engine.run(camp, tmp_path_factory.mktemp("local"), client=client)


@pytest.mark.parametrize("tls", [False, True], ids=["tcp", "tls"])
def test_workers_that_see_no_driver_file_give_the_same_rows(tls: bool, reference: pd.DataFrame, fmu_dir: Path,
                                                            tmp_path: Path,
                                                            tmp_path_factory: pytest.TempPathFactory) -> None:
    files = _tls_files(tmp_path) if tls else None
    hide = _hidden(tmp_path_factory, fmu_dir)
    sentinel = Path(os.environ["SATFMU_HOME"]) / "driver-only"  # a file of the driver's satfmu home
    sentinel.write_text("the driver's")
    with _scheduler(tmp_path / "scheduler.log", files) as address:
        # worker 0 steps in the compiled loop and is killed half-way; worker 1 steps in Python
        procs = [_hidden_worker(address, f"w{i}", tmp_path / f"worker{i}.log", files, hide, python_loop=i == 1)
                 for i in range(2)]
        try:
            with _connect(address, files, 2) as client:
                # the workers cannot read the FMUs, the campaign folder nor this process's satfmu home
                for path in (fmu_dir / "mrp_satellite.fmu", tmp_path, sentinel):
                    assert set(client.run(os.path.exists, str(path)).values()) == {False}, path
            killed: list[int] = []

            def kill_one_half_way(done: int, total: int) -> None:
                if done == total // 2 and not killed:  # one worker dies with its chunks
                    os.killpg(procs[0].pid, signal.SIGKILL)
                    killed.append(done)

            # the campaign goes through satfmu's own connection (cluster.cluster_client), as the CLI's
            camp = campaign(_scenario(), N, seed=5, chunk=CHUNK, fmu_dir=fmu_dir, name="remote")
            security = cluster.security(str(files["ca"]), str(files["cert"]), str(files["key"])) if files else None
            rows = engine.run(camp, tmp_path / "out", scheduler=address, tls=security, progress=kill_one_half_way)
            assert killed == [N // CHUNK // 2]
        finally:
            for p in procs:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=30)
    pd.testing.assert_frame_equal(rows, reference, check_exact=True)
    assert rows["sample"].tolist() == list(range(N))
    # the record says where each chunk ran, and in which loop (both give the same rows)
    workers = engine.read_record(tmp_path / "out" / "remote")["workers"]
    assert sorted(map(int, workers)) == list(range(N // CHUNK))
    assert "python" in {w["loop"] for w in workers.values()}
