"""Disturbance profiles and metrics against values computed by hand."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

import satfmu
from satfmu.fmus import profiles
from satfmu.fmus.errors import ScenarioError
from satfmu.fmus.profiles import ProfileError, make
from satfmu.sims.scenario import metrics

T = np.arange(0.0, 10.0001, 0.5)


def test_step_and_constant() -> None:
    v = make({"kind": "step", "time": 5.0, "before": 2.0, "after": 0.0}).sample(T)
    assert v[T < 5].tolist() == [2.0] * 10 and v[T >= 5].tolist() == [0.0] * 11  # eq. 44 switches AT t = 5
    assert make({"kind": "constant", "value": -1.5}).sample(T).tolist() == [-1.5] * len(T)


def test_table_previous_and_linear() -> None:
    spec = {"kind": "table", "times": [0.0, 2.0, 4.0], "values": [1.0, 3.0, -1.0]}
    assert make(spec).sample(np.array([0.0, 1.9, 2.0, 3.0, 9.0])).tolist() == [1, 1, 3, 3, -1]
    lin = make(dict(spec, interpolation="linear")).sample(np.array([1.0, 3.0, 9.0]))
    assert lin.tolist() == [2.0, 1.0, -1.0]


def test_sinusoid() -> None:
    v = make({"kind": "sinusoid", "amplitude": 2.0, "frequency_Hz": 0.25, "phase_rad": 0.0, "offset": 1.0}).sample(T)
    assert v == pytest.approx(1 + 2 * np.sin(2 * np.pi * 0.25 * T), abs=1e-15)


def test_random_is_seeded_and_held() -> None:
    spec = {"kind": "random", "seed": 7, "std": 0.3, "hold": 1.0}
    a, b = make(spec).sample(T), make(spec).sample(T)
    assert np.array_equal(a, b)  # same seed -> bit-identical
    assert a[0] == a[1] and a[2] == a[3]  # held for 1 s = two 0.5 s samples
    assert not np.array_equal(a, make(dict(spec, seed=8)).sample(T))
    long = make({"kind": "random", "seed": 1, "std": 0.3}, step_size=0.01).sample(np.arange(0, 100, 0.01))
    assert np.std(long) == pytest.approx(0.3, rel=0.05)  # 10^4 draws: 5 % covers ~7 sigma of the estimator


def test_cosine_ramp_is_seed_002_eq_24_and_its_derivatives_are_consistent() -> None:
    spec = {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": math.pi / 18, "after": 1 + math.pi / 18}
    t = np.linspace(0.0, 12.0, 1201)
    q = make(spec).sample(t)
    # The seed's own formula: -(1/2)(sin(pi t/4 - pi/2) - 1) + pi/18 on [4, 8].
    seed = np.where(t < 4, math.pi / 18, np.where(t > 8, 1 + math.pi / 18,
                                                  -(np.sin(np.pi * t / 4 - np.pi / 2) - 1) / 2 + math.pi / 18))
    assert np.max(np.abs(q - seed)) < 1e-15
    dq = make({**spec, "derivative": 1}).sample(t)
    ddq = make({**spec, "derivative": 2}).sample(t)
    # Central differences at h = 0.01 s: O(h^2) ~ 1e-5 of the amplitude away from the
    # corners at 4 and 8 s, where the second derivative jumps (an O(h) error there).
    smooth = (np.abs(t - 4) > 0.015) & (np.abs(t - 8) > 0.015)
    smooth[[0, -1]] = False
    assert np.max(np.abs(np.gradient(q, t)[smooth] - dq[smooth])) < 2e-4
    assert np.max(np.abs(np.gradient(dq, t)[smooth] - ddq[smooth])) < 2e-4
    with pytest.raises(ProfileError, match="'stop' must be after 'start'"):
        make({**spec, "stop": 4.0})
    with pytest.raises(ProfileError, match="'derivative' must be 0, 1 or 2"):
        make({**spec, "derivative": 3})


def test_csv_profile(tmp_path: Path) -> None:
    (tmp_path / "w.csv").write_text("time,wx\n0,0\n10,5\n")
    v = make({"kind": "csv", "file": "w.csv", "column": "wx"}, base_dir=tmp_path).sample(np.array([0.0, 4.0]))
    assert v.tolist() == [0.0, 2.0]
    with pytest.raises(ProfileError, match="needs columns"):
        make({"kind": "csv", "file": "w.csv", "column": "wy"}, base_dir=tmp_path)
    with pytest.raises(ProfileError, match="cannot read"):
        make({"kind": "csv", "file": "nope.csv", "column": "wx"}, base_dir=tmp_path)


def test_csv_profile_reads_a_byte_order_mark_and_quoted_names(tmp_path: Path) -> None:
    """Spreadsheets write a UTF-8 byte order mark and quote the header."""
    (tmp_path / "w.csv").write_bytes(b'\xef\xbb\xbf"time","wx"\r\n0,0\r\n10,5\r\n')
    v = make({"kind": "csv", "file": "w.csv", "column": "wx"}, base_dir=tmp_path).sample(np.array([0.0, 4.0]))
    assert v.tolist() == [0.0, 2.0]


@pytest.mark.parametrize("file, message", [
    ("/dev/zero", "is not a regular file"),
    ("fifo", "is not a regular file"),
    (".", "is not a regular file"),
    ("latin1.csv", r"is not UTF-8 text \(invalid continuation byte\)"),
    ("bad.csv", r"line 3 has a missing or non-numeric entry in column 'time' or 'wx'"),
    ("empty.csv", "has no rows after its header"),
    ("passwd", r"needs columns 'time' and 'wx'; its first line \(1 fields\) is no header of column names$"),
])
def test_csv_profile_refuses_what_is_no_table(file: str, message: str, tmp_path: Path) -> None:
    """Before reading: a FIFO would block forever and /dev/zero never ends. A file that is no
    CSV table is not quoted back (its first line may be a secret: /etc/passwd's is root's)."""
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "latin1.csv").write_bytes("time,wx\n0,\xe9\n".encode("latin-1"))
    (tmp_path / "bad.csv").write_text("time,wx\n0,0\n10,abc\n")
    (tmp_path / "empty.csv").write_text("time,wx\n")
    (tmp_path / "passwd").write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1::/:/bin/sh\n")
    with pytest.raises(ProfileError, match=message) as exc:
        make({"kind": "csv", "file": file, "column": "wx"}, base_dir=tmp_path)
    assert "root:x" not in str(exc.value)


def test_csv_profile_memory_stays_near_the_columns_read(tmp_path: Path) -> None:
    """A 40 MB CSV of six columns once took 18 times its size; numpy's parser holds the two
    columns read (9.6 MB) and its own chunks. Measured in a child process, whose peak resident
    memory is its own: the bound is 80 MB above the child's imports (about twice the file)."""
    import subprocess
    import sys

    code = f"""
import resource, numpy as np
from satfmu.fmus.profiles import make
n = 600_000
with open({str(tmp_path / 'big.csv')!r}, 'w') as f:
    f.write('time,a,b,c,d,e\\n')
    np.savetxt(f, np.column_stack([np.arange(n) * 0.01, np.ones((n, 5)) * 1.2345678901]), delimiter=',', fmt='%.10g')
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
make({{'kind': 'csv', 'file': {str(tmp_path / 'big.csv')!r}, 'column': 'c'}})
print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024)
"""
    grown = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    assert grown < 80, f"{grown:.0f} MB"


@pytest.mark.parametrize("spec,message", [
    ({"kind": "step", "time": 1.0, "before": 0.0}, "missing field 'after'"),
    ({"kind": "constant", "value": float("nan")}, "finite number"),
    ({"kind": "table", "times": [0, 0], "values": [1, 2]}, "strictly increasing"),
    ({"kind": "table", "times": [0, 1], "values": [1]}, "equal non-zero length"),
    ({"kind": "random", "std": 1.0}, "seed"),
    ({"kind": "chirp"}, "unknown kind"),
])
def test_bad_profiles(spec: dict, message: str) -> None:
    with pytest.raises(ProfileError, match=message):
        make(spec, step_size=0.1)


def test_l2_ratio_against_closed_form() -> None:
    # z = 0.5 w exactly -> ratio 0.5 at every T once ||w|| > 0 (rectangle rule on held w,
    # trapezoid on z: equal for a constant signal).
    t = np.linspace(0, 10, 101)
    w = np.ones((101, 2))
    r = metrics.l2_ratio_curve(t, 0.5 * w, w)
    assert math.isnan(r[0]) and np.allclose(r[1:], 0.5, rtol=1e-14)
    # z = t (ramp), w = 1: ||z||_T^2 = T^3/3 (trapezoid is exact up to O(dt^2) -> 1e-3 rel)
    r = metrics.l2_ratio_curve(t, t[:, None], np.ones((101, 1)))
    assert r[-1] == pytest.approx(math.sqrt(1000 / 3) / math.sqrt(10), rel=1e-3)


def test_settling_peak_rms_saturation() -> None:
    t = np.linspace(0, 10, 1001)
    y = np.exp(-t)[:, None]
    assert metrics.settling_time(t, y, 0.01) == pytest.approx(math.log(100), abs=0.01)  # grid 0.01 s
    assert metrics.settling_time(t, np.ones((1001, 1)), 0.5) == math.inf
    assert metrics.peak(np.array([[1.0, -3.0], [2.0, 0.5]])) == 3.0
    assert metrics.rms(t, np.full((1001, 1), 2.0)) == pytest.approx(2.0, rel=1e-14)
    u = np.where(t < 2.0, 5.0, 1.0)[:, None]
    assert metrics.time_in_saturation(t, u, 5.0) == pytest.approx(2.0, abs=1e-9)  # held samples, dt = 0.01


def test_metric_result_bounds() -> None:
    assert metrics.MetricResult("a", "peak", 1.0, None, 2.0).passed
    assert not metrics.MetricResult("a", "peak", 3.0, None, 2.0).passed
    assert not metrics.MetricResult("a", "peak", 1.0, 1.5, None).passed
    assert not metrics.MetricResult("a", "l2_ratio", math.nan, None, 2.0).passed  # NaN never passes


def test_time_to_limit_is_the_first_sample_at_the_level() -> None:
    from satfmu.sims.scenario.metrics import time_to_limit

    t = np.linspace(0.0, 10.0, 11)
    y = np.column_stack([np.linspace(0.0, 5.0, 11), -np.linspace(0.0, 8.0, 11)])  # the second reaches -4 at t = 5
    assert time_to_limit(t, y, 4.0) == 5.0
    assert time_to_limit(t, y[:, 0], 4.0) == 8.0
    assert time_to_limit(t, y, 100.0) == math.inf  # never reached
    assert time_to_limit(t, y, 4.0 * (1 + 1e-10)) == 5.0  # within the relative tolerance 1e-9


def test_a_misspelt_or_extra_field_is_named() -> None:
    # each kind takes its own fields: a misspelling is named with the closest field, not read as a
    # missing one, and a field of another kind is refused, not ignored
    with pytest.raises(ProfileError, match=r"unknown key 'aftr'.*'after'"):
        profiles.make({"kind": "step", "time": 1.0, "before": 0.0, "aftr": 1.0})
    with pytest.raises(ProfileError, match=r"unknown key 'value'"):
        profiles.make({"kind": "step", "time": 1.0, "before": 0.0, "after": 1.0, "value": 2.0})
    assert set(profiles.FIELDS) == {"constant", "step", "table", "sinusoid", "random", "csv", "cosine_ramp", "igrf"}


def test_a_misspelt_plot_key_is_named() -> None:
    data = {"name": "s", "stop_time": 1.0, "step_size": 0.1, "fmus": {"plant": {"model": "mrp_satellite"}},
            "plot": {"pannels": [["plant.phi"]]}}
    with pytest.raises(ScenarioError, match=r"plot: unknown key 'pannels'.*'panels'"):
        satfmu.Scenario.from_dict(data)
