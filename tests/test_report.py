"""The report page (satfmu.sims.report, `satfmu report`): its numbers against the rows and statistics
computed here independently, its sections, bad input, and the page rendered in a real browser
(Debian's chromium driven by selenium).

Small campaigns keep it fast: seed 000's 200 deg manoeuvre cut to 2 s (40 steps), its three
MRP controllers (published, synthesized, mixed H2/H-infinity), each over the same dispersions
(initial rate, inertia), 8 samples each, on an in-process Dask cluster.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
import subprocess
import tomllib
from pathlib import Path

import lxml.html
import numpy as np
import pandas as pd
import pytest
from distributed import Client
from scipy import stats

from satfmu.fmus.errors import DesignMismatchWarning
from satfmu.sims.campaign import engine
from satfmu.sims.campaign.replay import replay
from satfmu.sims.campaign.results import write_envelopes
from satfmu.sims.scenario.run import run as run_scenario
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.campaign.scenario_task import campaign, reopen
from satfmu.sims.campaign.statistics import PERCENTILES
from satfmu.sims.cli import main
from satfmu.controllers.paths import SHIPPED_ARTIFACTS
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.sims.report import ReportError, build_report, limits, provenance
from satfmu.sims.report.folders import read_folder
from satfmu.sims.report.page import number, percent

SEED = 3
N = 8
CONTROLLERS = ("mrp_hinf_published", "mrp_hinf_satfmu", "mrp_h2hinf_satfmu")
DISPERSIONS = {"plant.omega_0[1]": {"kind": "uniform", "low": -0.01, "high": 0.01},  # rad/s
               "inertia": {"instance": "plant", "relative": 0.1}}
DIGITS = 5e-6
"""Relative tolerance of a number read from the page's text: printed with 6 significant digits."""


def scenario_data(controller: str) -> dict:
    """mrp_200deg for 2 s with ``controller``, dispersed; metrics: the shipped ones (the final angle
    at 120 s left out) and the angle at 2 s, bounded so that some samples pass and some fail."""
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_200deg.toml").read_text())
    metrics = [m for m in data["metrics"] if m["name"] != "attitude angle at 120 s"]
    metrics.append({"name": "peak rate", "kind": "peak", "signals": ["plant.omega"], "unit": "rad/s", "max": 0.2})
    return {**data, "name": f"r_{controller}", "stop_time": 2.0, "dispersions": DISPERSIONS, "metrics": metrics,
            "fmus": {**data["fmus"], "controller": {"model": controller, "parameters": {"saturation_on": False}}}}


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory: pytest.TempPathFactory, client: Client, fmu_dir: Path) -> dict[str, Path]:
    """Controller -> the folder of its campaign (seed SEED, N samples, chunks of 4)."""
    out = tmp_path_factory.mktemp("campaigns")
    folders = {}
    for ctrl in CONTROLLERS:
        camp = campaign(Scenario.from_dict(scenario_data(ctrl)), N, seed=SEED, chunk=4, fmu_dir=fmu_dir,
                        name=ctrl)
        engine.run(camp, out, client=client)
        folders[ctrl] = out / ctrl
    return folders


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory, fmu_dir: Path) -> Path:
    """The folder of mrp_200deg_sat (command saturated at 5 N m) run for 5 s."""
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_200deg_sat.toml").read_text())
    out = tmp_path_factory.mktemp("runs")
    run_scenario(Scenario.from_dict({**data, "stop_time": 5.0}), fmu_dir, out_dir=out)
    return out / data["name"]


@pytest.fixture(scope="module")
def page(campaigns: dict[str, Path], run_folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report of the three campaigns and the run, written by `satfmu report`."""
    out = tmp_path_factory.mktemp("page") / "report.html"
    assert main(["report", *map(str, campaigns.values()), str(run_folder), "--out", str(out)]) == 0
    return out


SLEW_N = 8


@pytest.fixture(scope="module")
def slew(tmp_path_factory: pytest.TempPathFactory, client: Client, fmu_dir: Path) -> Path:
    """mrp_slew_mc_synth (uniform attitudes, inertia +-20 %) cut to 4 s, SLEW_N samples, its
    angle recorded in deg and its percentile envelopes kept."""
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_slew_mc_synth.toml").read_text())
    data = {**data, "stop_time": 4.0, "name": "slew",
            "record": ["plant.omega", "plant.sigma", {"signal": "plant.phi", "unit": "deg"}, "controller.u"]}
    out = tmp_path_factory.mktemp("slew")
    camp = campaign(Scenario.from_dict(data), SLEW_N, seed=SEED, chunk=4, fmu_dir=fmu_dir, name="slew",
                    envelopes=["plant.phi"])
    write_envelopes(camp, engine.run(camp, out, client=client), out / "slew")
    return out / "slew"


@pytest.fixture(scope="module")
def slew_page(slew: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report of the slew campaign (its worst samples replayed)."""
    out = tmp_path_factory.mktemp("slew_page") / "report.html"
    assert main(["report", str(slew), "--out", str(out)]) == 0
    return out


def tree(path: Path) -> lxml.html.HtmlElement:
    return lxml.html.fromstring(path.read_bytes())


def section(doc: lxml.html.HtmlElement, label: str) -> lxml.html.HtmlElement:
    found = doc.xpath(f'//section[@data-label="{label}"]')
    assert len(found) == 1, label
    return found[0]


def cell(row: lxml.html.HtmlElement, column: str) -> lxml.html.HtmlElement:
    found = row.xpath(f'./td[@data-column="{column}"]')
    assert len(found) == 1, column
    return found[0]


def within(values: np.ndarray, metric: dict) -> np.ndarray:
    """Whether each value meets the metric's bounds (NaN: a sample that did not run, fails)."""
    ok = ~np.isnan(values)
    if "max" in metric:
        ok &= values <= metric["max"]
    if "min" in metric:
        ok &= values >= metric["min"]
    return ok


def percentile(values: np.ndarray, p: float) -> float:
    """The p-th percentile by linear interpolation between order statistics (numpy's default,
    written out here)."""
    x = np.sort(values)
    rank = p / 100.0 * (x.size - 1)
    lo = int(math.floor(rank))
    hi = min(lo + 1, x.size - 1)
    return float(x[lo] + (rank - lo) * (x[hi] - x[lo]))


def test_campaign_statistics_in_the_page_are_those_of_the_rows(page: Path, campaigns: dict[str, Path]) -> None:
    doc = tree(page)
    mixed = False
    for ctrl, folder in campaigns.items():
        rows = engine.load(folder)
        sec = section(doc, ctrl)
        for metric in scenario_data(ctrl)["metrics"]:
            row = sec.xpath(f'.//table[@class="statistics"]/tr[@data-metric="{metric["name"]}"]')[0]
            values = rows[metric["name"]].to_numpy(dtype=float)
            passes = int(within(values, metric).sum())
            mixed |= 0 < passes < N
            rate = cell(row, "rate")
            assert float(rate.get("data-value")) == passes / N  # a ratio of counts: exact
            assert rate.text_content() == f"{100 * passes / N:.2f} %"
            interval = cell(row, "interval")
            # Clopper-Pearson bounds are Beta quantiles; rel 1e-9: scipy.stats' route against scipy.special's
            low = stats.beta.ppf(0.025, passes, N - passes + 1) if passes > 0 else 0.0
            high = stats.beta.ppf(0.975, passes + 1, N - passes) if passes < N else 1.0
            assert float(interval.get("data-low")) == pytest.approx(low, rel=1e-9, abs=1e-12)
            assert float(interval.get("data-high")) == pytest.approx(high, rel=1e-9, abs=1e-12)
            finite = values[np.isfinite(values)]
            for p in PERCENTILES:
                c = cell(row, f"p{p:g}")
                if finite.size == 0:  # a settling time never reached in 2 s: no percentile
                    assert c.get("data-value") == "" and c.text_content() == ""
                    continue
                # rel 1e-12: the same interpolation, rounding of the last bits only
                assert float(c.get("data-value")) == pytest.approx(percentile(finite, p), rel=1e-12)
                assert float(c.text_content()) == pytest.approx(percentile(finite, p), rel=DIGITS)
        overall = sec.xpath('.//table[@class="statistics"]/tr[@data-metric="all metrics (passed)"]')[0]
        assert float(cell(overall, "rate").get("data-value")) == float((rows["passed"] == 1.0).mean())
    assert mixed, "no metric with both passing and failing samples: the test checks too little"


def test_worst_samples_show_their_rows(page: Path, campaigns: dict[str, Path]) -> None:
    doc = tree(page)
    for ctrl, folder in campaigns.items():
        rows = engine.load(folder).set_index("sample")
        shown = section(doc, ctrl).xpath('.//table[@class="worst"]/tr[@data-sample]')
        assert len(shown) == 5  # --worst default
        for tr in shown:
            k = int(tr.get("data-sample"))
            for td in tr.xpath("./td[@data-column]"):
                col = td.get("data-column")
                if col == "sample":
                    continue
                expected = rows.loc[k, col]
                value = float(td.get("data-value"))
                assert value == expected or (math.isnan(value) and math.isnan(expected)), (ctrl, k, col)
                assert td.text_content() == (str(int(expected)) if col in ("passed", "failed") else number(expected))


def test_worst_samples_link_to_their_replayed_histories(slew_page: Path, slew: Path) -> None:
    """Each worst sample's number links to its time histories, replayed on the page; the
    dispersed attitude has its rotation angle beside its MRP components (4 atan |sigma|, in deg);
    every column says its unit."""
    doc = tree(slew_page)
    rows = engine.load(slew).set_index("sample")
    table = section(doc, "slew").xpath('.//table[@class="worst"]')[0]
    header = {th.get("data-column"): th.text_content() for th in table.xpath("./tr/th")}
    assert header["plant.I_x"] == "plant.I_xkg.m2" and header["plant attitude angle"] == "plant attitude angledeg"
    assert header["peak rate"] == "peak ratedeg/s" and header["settling time to 0.1 deg"].endswith("s")
    assert list(header).index("plant attitude angle") == list(header).index("plant.sigma_0[3]") + 1
    shown = table.xpath("./tr[@data-sample]")
    assert len(shown) == 5
    for tr in shown:
        k = int(tr.get("data-sample"))
        link = cell(tr, "sample").xpath("./a")[0].get("href")
        target = doc.xpath(f'//*[@id="{link[1:]}"]')
        assert link == f"#item-1-sample-{k}" and len(target) == 1 and target[0].tag == "details"
        texts = " ".join(target[0].xpath(".//*[local-name()='svg']//*[local-name()='text']/text()"))
        assert f"slew, sample {k}:" in texts and "plant.phi" in texts
        sigma = np.array([rows.loc[k, f"plant.sigma_0[{i}]"] for i in (1, 2, 3)])
        angle = math.degrees(4.0 * math.atan(float(np.linalg.norm(sigma))))  # the MRP's rotation angle
        assert float(cell(tr, "plant attitude angle").get("data-value")) == pytest.approx(angle, rel=1e-12)


def test_the_page_says_which_samples_start_outside_the_certified_region(slew_page: Path, slew: Path) -> None:
    """mrp_hinf_satfmu is certified on |sigma| <= 0.9 for the design inertia: the inertia dispersed
    by +-20 % puts every sample outside; the attitudes beyond the ball are counted on their own."""
    rows = engine.load(slew)
    sigma = rows[[f"plant.sigma_0[{i}]" for i in (1, 2, 3)]].to_numpy(dtype=float)
    beyond = int((np.linalg.norm(sigma, axis=1) > 0.9).sum())
    off = {a: int((np.abs(rows[f"plant.I_{a}"] - d) > 1e-3 * d).sum()) for a, d in zip("xyz", (15.0, 16.0, 12.5))}
    p, = section(tree(slew_page), "slew").xpath('.//p[contains(@class, "coverage")]')
    assert (int(p.get("data-samples")), int(p.get("data-outside"))) == (SLEW_N, SLEW_N)
    text = " ".join(p.text_content().split())
    assert f"{SLEW_N} of {SLEW_N} samples (100.00 %) start outside what it covers" in text
    for a, d in zip("xyz", ("15", "16", "12.5")):
        assert f"I_{a} is not its design value {d} ({off[a]}, {percent(off[a] / SLEW_N)})" in text
    assert (f"starts outside |sigma[1..3]| <= 0.9 ({beyond}, {percent(beyond / SLEW_N)})" in text) == (beyond > 0)


def test_envelopes_are_kept_in_the_unit_the_record_asks_for(slew: Path, slew_page: Path) -> None:
    """The kept histories of plant.phi are in deg (the record's unit), as a replay of the sample
    records them, bit for bit; the envelope figure labels them deg."""
    rows = engine.load(slew).set_index("sample")
    task = reopen(slew).task
    assert task.envelopes == ("plant.phi",) and len(task.trace_steps) > 10
    for k in (0, SLEW_N - 1):
        with pytest.warns(DesignMismatchWarning, match="designed for 15"):  # the inertia dispersed
            res = replay(slew, k)
        assert res.units["plant.phi"] == "deg"
        kept = rows.loc[k, [f"plant.phi@{j}" for j in range(len(task.trace_steps))]].to_numpy(dtype=float)
        assert np.array_equal(kept, res.results["plant.phi"][list(task.trace_steps)])
    assert rows[[c for c in rows.columns if c.startswith("plant.phi@")]].to_numpy().max() > 3.2  # deg, not rad
    fig = tree(slew_page).xpath("//h3[. = 'Percentile envelopes']/following-sibling::figure[1]/*[local-name()='svg']")
    labels = " ".join(fig[0].xpath(".//*[local-name()='text']/text()"))
    assert "(deg)" in labels and "(rad)" not in labels


def test_campaigns_side_by_side(page: Path, campaigns: dict[str, Path]) -> None:
    doc = tree(page)
    table = doc.xpath('//section[@id="comparison"]//table[@class="comparison"]')[0]
    for ctrl, folder in campaigns.items():
        rows = engine.load(folder)
        for metric in scenario_data(ctrl)["metrics"]:
            tr = table.xpath(f'./tr[@data-metric="{metric["name"]}"]')[0]
            rate = tr.xpath(f'./td[@data-campaign="{ctrl}"][@data-column="rate"]')[0]
            values = rows[metric["name"]].to_numpy(dtype=float)
            assert float(rate.get("data-value")) == within(values, metric).sum() / N
            worst = tr.xpath(f'./td[@data-campaign="{ctrl}"][@data-column="worst"]')[0]
            k = int(np.argmax(values))  # every metric here has a max: the largest value is the worst
            assert float(worst.get("data-value")) == values[k]
            assert f"sample {int(rows['sample'][k])}" in worst.text_content()
    worst = doc.xpath('//section[@id="comparison"]//table[@class="comparison-worst"]')[0]
    assert [th.text_content() for th in worst.xpath("./tr[1]/th")][1:] == list(CONTROLLERS)
    # the same dispersions and seed: every campaign's sample k flew the same plant
    loaded = [engine.load(f) for f in campaigns.values()]
    for col in ("plant.I_x", "plant.omega_0[1]"):
        assert all(np.array_equal(loaded[0][col], other[col]) for other in loaded[1:])


def test_run_metrics_and_figure(page: Path, run_folder: Path) -> None:
    summary = json.loads((run_folder / "summary_native.json").read_text())
    sec = section(tree(page), "mrp_200deg_sat (native)")
    for m in summary["metrics"]:
        tr = sec.xpath(f'.//table[@class="metrics"]/tr[@data-metric="{m["name"]}"]')[0]
        assert float(cell(tr, "value").get("data-value")) == m["value"]
        assert tr.xpath("./td")[-1].text_content() == ("pass" if m["passed"] else "FAIL")
    csv = pd.read_csv(run_folder / "mrp_200deg_sat_native.csv")
    peak = float(np.max(np.abs(csv[["controller.u[1]", "controller.u[2]", "controller.u[3]"]].to_numpy())))
    assert [m["value"] for m in summary["metrics"] if m["name"] == "peak |u|"] == [peak]  # the CSV the page plots
    assert len(sec.xpath(".//figure/*[local-name()='svg']")) == 1


def test_requirement_and_actuator_lines(run_folder: Path) -> None:
    sc = Scenario.from_dict(tomllib.loads((SHIPPED_SCENARIOS / "mrp_200deg_sat.toml").read_text()))
    run = read_folder(run_folder)[0]
    lim = limits.actuator_limits(run.scenario, run.fmus)
    by_target = {(x.target, x.parameter): x for x in lim}
    # the scenario sets the controller's u_max = 5 N m with saturation on; the plant keeps its
    # declared u_max (5 N m) with saturation off (the FMU's default)
    assert by_target[("controller.u", "u_max")].value == 5.0 and by_target[("controller.u", "u_max")].active
    assert not by_target[("plant.u", "u_max")].active
    u = limits.signal_lines(sc, "controller.u", lim)
    levels = {(ln.kind, ln.value, ln.active) for ln in u if ln.axis == "level"}
    assert ("requirement", 5.000000001, True) in levels  # peak |u| max
    assert ("actuator", 5.0, True) in levels  # time in saturation's limit and the controller's u_max
    assert ("actuator", 5.0, False) in levels  # the plant's u_max, saturation off
    phi = limits.signal_lines(sc, "plant.phi", lim, "rad")
    band = [ln for ln in phi if "band" in ln.label][0]
    assert band.value == pytest.approx(0.1 * math.pi / 180.0, rel=1e-12)  # 0.1 deg in rad: rounding only
    assert band.label == "settling time to 0.1 deg: band |y| ≤ 0.1 deg"
    # drawn in deg (a record entry's unit), the band is the metric's own number
    assert [ln.value for ln in limits.signal_lines(sc, "plant.phi", lim, "deg", "rad") if "band" in ln.label] == [0.1]
    # a signal drawn in a unit the bound does not convert to gets no line rather than a wrong one
    assert not [ln for ln in limits.signal_lines(sc, "plant.phi", lim, "N.m") if "band" in ln.label]
    assert [ln.value for ln in phi if ln.axis == "time"] == [120.0]
    assert limits.signal_lines(sc, "plant.omega", lim) == []  # no metric or limit on the rates


def test_what_was_proved_is_the_embedded_artifact(page: Path, fmu_dir: Path) -> None:
    doc = tree(page)
    for name in CONTROLLERS:
        shipped = json.loads((SHIPPED_ARTIFACTS / f"{name}.json").read_text())
        block = doc.xpath(f'//section[@id="proved"]/div[@data-fmu="{name}.fmu"]')
        assert len(block) == 1, name  # used by a campaign (and the run, for the published one): listed once
        text = block[0].text_content()
        assert shipped["certificate"]["status"] in text and shipped["certificate"]["proved"] in text
        assert hashlib.sha256((fmu_dir / f"{name}.fmu").read_bytes()).hexdigest() in text
        assert shipped["provenance"]["design_plant"]["digest"] in text
        if "l2_gain" in shipped["certificate"]:
            c = block[0].xpath('.//td[@data-column="l2_gain"]')[0]
            assert float(c.get("data-value")) == shipped["certificate"]["l2_gain"]["c"]
    published = doc.xpath('//section[@id="proved"]/div[@data-fmu="mrp_hinf_published.fmu"]')[0].text_content()
    assert "mrp_200deg_sat (native): controller" in published and "mrp_hinf_published: controller" in published
    assert not doc.xpath('//section[@id="proved"]/div[@data-fmu="mrp_satellite.fmu"]')  # a plant claims nothing


def test_provenance(page: Path, fmu_dir: Path, tmp_path: Path) -> None:
    import satfmu

    sec = tree(page).xpath('//section[@id="provenance"]')[0]
    text = sec.text_content()
    assert satfmu.__version__ in text
    root = Path(__file__).resolve().parents[1]
    head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True)
    if head.returncode == 0:
        assert head.stdout.strip() in text
    assert provenance.git_commit(tmp_path) is None  # not a git checkout
    assert hashlib.sha256((fmu_dir / "mrp_satellite.fmu").read_bytes()).hexdigest() in text
    assert "numpy" in text and "matplotlib" in text and "CPython" in text


def test_the_margins_section_and_the_pass_rates_in_the_contents(page: Path, campaigns: dict[str, Path]) -> None:
    from satfmu.sims.workflows import analysis

    doc = tree(page)
    shown = {d.get("data-scenario") for d in doc.xpath('//section[@id="margins"]/div[@class="margins"]')}
    assert shown == {f"r_{c}" for c in CONTROLLERS} | {"mrp_200deg_sat"}
    # the campaign's controller on its plant at the origin, sampled at the scenario's 0.05 s: the
    # artifact's own margins (the same linearization; the dispersions are not drawn here)
    ref = analysis.margins("mrp_hinf_satfmu").sampled
    div = doc.xpath('//div[@class="margins"][@data-scenario="r_mrp_hinf_satfmu"]')[0]
    row = div.xpath('.//tr[@data-point="origin"]')[1]  # continuous, then sampled
    assert float(cell(row, "disk_gain_margin").get("data-value")) == pytest.approx(ref.disk_gain_margin_db, rel=1e-9)
    assert float(cell(row, "sensitivity_peak").get("data-value")) == pytest.approx(ref.sensitivity_peak, rel=1e-9)
    assert div.xpath(".//figure/svg")  # the frequency responses
    rows = engine.load(campaigns["mrp_hinf_satfmu"])
    nav = doc.xpath("//nav")[0].text_content()
    assert f"Campaign: mrp_hinf_satfmu: {percent(rows['passed'].sum() / N)} of {N} samples pass" in nav
    assert "Margins" in nav


def test_the_page_is_self_contained(page: Path) -> None:
    """Every reference of the page stays in it: anchors, data: URIs; no script, no stylesheet link."""
    doc = tree(page)
    assert not doc.xpath("//script") and not doc.xpath("//link[@rel='stylesheet']")
    refs = [(el.tag, k, v) for el in doc.iter() if isinstance(el.tag, str) for k, v in el.attrib.items()
            if k.split("}")[-1] in ("src", "href")]
    assert refs and all(v.startswith(("#", "data:")) for _, _, v in refs), [r for r in refs if not
                                                                           r[2].startswith(("#", "data:"))]
    assert "@import" not in page.read_text() and "url(http" not in page.read_text()


def test_result_write_records_the_scenario_and_its_fmus(run_folder: Path, fmu_dir: Path) -> None:
    record = json.loads((run_folder / "scenario_native.json").read_text())
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_200deg_sat.toml").read_text())
    assert record["scenario"] == Scenario.from_dict({**data, "stop_time": 5.0}).to_dict()
    for inst, f in record["fmus"].items():
        assert f["sha256"] == hashlib.sha256((fmu_dir / f["file"]).read_bytes()).hexdigest()
    header = (run_folder / "mrp_200deg_sat_native.csv").read_text().splitlines()[0].split(",")
    assert set(record["units"]) == set(header[1:])  # a unit for every recorded column
    assert record["units"]["plant.omega[1]"] == "rad/s" and record["units"]["controller.u[2]"] == "N.m"


def test_envelopes_only_when_the_folder_has_them(campaigns: dict[str, Path],
                                                 tmp_path_factory: pytest.TempPathFactory) -> None:
    folder = tmp_path_factory.mktemp("copy") / "campaign"  # (tmp_path's name would hold the word)
    shutil.copytree(campaigns["mrp_hinf_satfmu"], folder)
    without = lxml.html.fromstring(build_report([folder]))
    assert "envelope" not in without.text_content().lower()  # no section, no placeholder
    t = np.linspace(0.0, 2.0, 41)  # s
    pd.DataFrame({"time": t, "plant.phi:p50": 3.4 - t, "plant.phi:p99": 3.5 - 0.9 * t,
                  "controller.u[1]:p50": np.cos(t)}).to_parquet(folder / "envelopes.parquet")
    with_ = lxml.html.fromstring(build_report([folder]))
    fig = with_.xpath("//h3[. = 'Percentile envelopes']/following-sibling::figure[1]/*[local-name()='svg']")
    assert len(fig) == 1
    # one legend for the figure (bands, median, bound lines), not one per panel
    assert len(fig[0].xpath(".//*[local-name()='g'][starts-with(@id, 'legend_')]")) == 1
    pd.DataFrame({"time": t, "plant.phi": t}).to_parquet(folder / "envelopes.parquet")
    with pytest.raises(ReportError, match=r"envelopes.parquet: envelopes need .*'plant.phi'"):
        build_report([folder])


def _one_error(argv: list[str], match: str, capsys: pytest.CaptureFixture, out: Path) -> None:
    """`satfmu report argv --out out`: exit 2, one line matching ``match`` on stderr, nothing written."""
    assert main(["report", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("satfmu report: error: ") and re.search(match, err), err
    assert not out.exists()


def test_bad_input_exits_2_with_one_line(campaigns: dict[str, Path], run_folder: Path, tmp_path: Path,
                                         capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "out" / "report.html"
    _one_error([str(tmp_path / "nowhere")], r"nowhere: no such folder", capsys, out)
    (tmp_path / "empty").mkdir()
    _one_error([str(tmp_path / "empty")], r"empty: neither a run folder .* nor a scenario campaign folder", capsys,
               out)
    parent = campaigns["mrp_hinf_published"].parent
    _one_error([str(parent)], r"it holds run or campaign folders, name them: mrp_h2hinf_satfmu, mrp_hinf_published",
               capsys, out)
    bad = tmp_path / "bad_campaign"
    shutil.copytree(campaigns["mrp_hinf_published"], bad)
    (bad / "campaign.json").write_text('{"n": 8, "seed"')
    _one_error([str(bad)], r"bad_campaign/campaign.json: not a campaign record", capsys, out)
    (bad / "campaign.json").write_text(json.dumps({"n": 1}))
    _one_error([str(bad)], r"campaign.json: not a campaign record", capsys, out)
    run = tmp_path / "bad_run"
    shutil.copytree(run_folder, run)
    (run / "summary_native.json").write_text("{ not json")
    _one_error([str(run)], r"bad_run/summary_native.json: not readable JSON", capsys, out)
    (run / "summary_native.json").write_text(json.dumps({"scenario": "mrp_200deg_sat"}))
    _one_error([str(run)], r"summary_native.json: not a run summary of satfmu", capsys, out)
    shutil.copy(run_folder / "summary_native.json", run / "summary_native.json")
    (run / "scenario_native.json").unlink()
    _one_error([str(run)], r"no scenario_native.json beside summary_native.json .* run the scenario again", capsys,
               out)
    _one_error([str(run_folder), "--confidence", "1.5"], r"confidence must be in \(0, 1\)", capsys, out)


# ---------------------------------------------------------------- the page in a real browser

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync")


def browser(profile: Path):
    """Headless chromium through its chromedriver (selenium; both found on PATH, as Debian's
    chromium and chromium-driver install them), console messages kept."""
    found = {name: shutil.which(name) for name in ("chromium", "chromedriver")}
    missing = [name for name, path in found.items() if path is None]
    if missing:
        pytest.fail(f"the report's browser test needs chromium and chromedriver on PATH ({' and '.join(missing)} "
                    "missing): run `make browser-deps` (Debian: apt-get install chromium chromium-driver)",
                    pytrace=False)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = found["chromium"]
    for flag in (*CHROMIUM_FLAGS, f"--user-data-dir={profile}"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path=found["chromedriver"]), options=options)


SVG_TEXT_SIZES = (
    "document.querySelectorAll('details').forEach(d => d.open = true);"
    "const out = []; for (const t of document.querySelectorAll('figure svg text')) {"
    " if (!t.textContent.trim()) continue; const m = t.getScreenCTM();"
    " out.push([parseFloat(getComputedStyle(t).fontSize) * Math.hypot(m.a, m.b), t.textContent]); }"
    " return out;")
"""Browser script: open every <details>, and give each figure text's rendered size (px: its font
size times the scale the SVG is drawn at) and its text."""


def test_the_page_renders_in_chromium(page: Path, slew_page: Path, campaigns: dict[str, Path], fmu_dir: Path,
                                      tmp_path: Path) -> None:
    """The page opens from a file:// URL; its text shows a pass rate, a percentile, a metric
    value of the rows and an FMU digest; no text, in the page or in its figures, is drawn below
    8 px at a 1280 px wide window; the envelopes have one legend; the browser console has no error."""
    from selenium.webdriver.common.by import By

    rows = engine.load(campaigns["mrp_hinf_satfmu"])
    peak = rows["peak |u|"].to_numpy(dtype=float)
    metric = next(m for m in scenario_data("mrp_hinf_satfmu")["metrics"] if m["name"] == "peak |u|")
    rate = percent(within(peak, metric).sum() / N)
    p95 = number(percentile(peak[np.isfinite(peak)], 95.0))
    worst_rate = number(rows["peak rate"].max())  # in the comparison table, the worst rate of the campaign
    digest = hashlib.sha256((fmu_dir / "mrp_hinf_satfmu.fmu").read_bytes()).hexdigest()
    driver = browser(tmp_path / "profile")
    try:
        driver.get(page.resolve().as_uri())
        assert driver.title.startswith("satfmu report: mrp_hinf_published")
        body = driver.find_element(By.TAG_NAME, "body").text
        for expected in (rate, p95, worst_rate, digest):
            assert expected in body, expected
        svgs = driver.find_elements(By.CSS_SELECTOR, "figure svg")
        assert len(svgs) >= 10 and all(s.size["width"] > 100 and s.size["height"] > 50 for s in svgs)
        margins = driver.find_element(By.ID, "margins")
        assert margins.is_displayed() and "mrp_hinf_satfmu" in margins.text
        # every piece of the page's own text at 8 px or more (the figures' text is drawn in the SVGs)
        smallest = driver.execute_script(
            "let m = 1e9; for (const e of document.body.querySelectorAll('*')) {"
            " if (e.closest('svg')) continue;"
            " for (const n of e.childNodes) { if (n.nodeType === 3 && n.textContent.trim()) {"
            " m = Math.min(m, parseFloat(getComputedStyle(e).fontSize)); } } } return m;")
        assert smallest >= 8.0, smallest
        driver.set_window_size(1280, 900)
        for name in ("contents", "margins"):
            if name == "margins":
                driver.execute_script("document.getElementById('margins').scrollIntoView();")
            shot = tmp_path / f"{name}.png"
            assert driver.save_screenshot(str(shot))
            assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 10_000
        errors = [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]
        assert errors == [], errors
        sizes = driver.execute_script(SVG_TEXT_SIZES)
        driver.get(slew_page.resolve().as_uri())
        sizes += driver.execute_script(SVG_TEXT_SIZES)
        assert len(sizes) > 500  # the figures' text is text (svg.fonttype none), measurable
        small = sorted(sizes)[:3]
        assert small[0][0] >= 8.0, small
        envelopes = driver.find_element(By.XPATH, "//h3[. = 'Percentile envelopes']/following-sibling::figure[1]")
        assert len(envelopes.find_elements(By.CSS_SELECTOR, "svg g[id^='legend_']")) == 1
        for name, element in (("envelopes", envelopes),
                              ("worst", driver.find_element(By.CSS_SELECTOR, "table.worst"))):
            driver.execute_script("arguments[0].scrollIntoView();", element)
            shot = tmp_path / f"{name}.png"
            assert driver.save_screenshot(str(shot))
            assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 10_000
    finally:
        driver.quit()
