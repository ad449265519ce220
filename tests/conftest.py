"""Shared fixtures: every FMU, up to date with the current source tree, built at most once."""
from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from distributed import Client, LocalCluster

from satfmu.controllers import catalog

ROOT = Path(__file__).resolve().parents[1]
PUBLISHED = ROOT / "controllers" / "artifacts" / "mrp_hinf_published.json"
# Seed 000, 200 deg case: s(0) = k tan(50 deg), as printed in the seed.
SIGMA_200 = {"sigma_0[1]": 0.5992, "sigma_0[2]": -0.7976, "sigma_0[3]": 0.6517}


def pytest_configure(config: pytest.Config) -> None:
    """The suite never writes into the user's satfmu folder: ``SATFMU_HOME`` is a temporary
    folder of this process (designs written with defaults, on-demand FMU builds land there)."""
    os.environ["SATFMU_HOME"] = tempfile.mkdtemp(prefix="satfmu_home_")


def pytest_unconfigure(config: pytest.Config) -> None:
    shutil.rmtree(os.environ["SATFMU_HOME"], ignore_errors=True)


LONGEST_FIRST = ("test_docs.py", "test_cli.py", "test_example_own_spacecraft.py", "test_robustness_suite.py",
                 "test_pythonfmu_parity.py", "test_compiled_loop.py", "test_generated_text.py", "test_build_cache.py",
                 "test_report.py", "test_campaign.py", "test_demeter_table.py", "test_l2_gain.py")
"""The test files that take longest (10-55 s each on one core; ``pytest --durations=0``), longest
first. ``make test`` hands whole files to its workers in collection order (xdist's loadfile), so
these start first and the short files fill in at the end: no worker is left running a long file
alone while the other idles."""


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Collection order: the files of :data:`LONGEST_FIRST` first, in its order, then the others as
    collected (the tests of a file keep their order)."""
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


@pytest.fixture(scope="session")
def fmu_dir() -> Path:
    """``build/fmus`` with every FMU of the catalog (:func:`satfmu.controllers.catalog.build_all`).

    The FMUs ``make build`` wrote are reused: an FMU is rebuilt only when it does not record
    the digest of its model, resources and generators (:mod:`satfmu.fmus.digest`), so the tests
    always run the FMUs of the current source tree. Tests only read this folder."""
    dest = ROOT / "build" / "fmus"
    catalog.build_all(dest)
    return dest


@pytest.fixture(scope="module")
def client() -> Iterator[Client]:
    """A Dask client of one in-process worker with one thread (the FMUs run in this process), one
    per test module."""
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as lc, \
            Client(lc) as cl:
        yield cl
