"""The [campaign] table of a scenario: a campaign's declared full size, demo size and seed, the
defaults of `satfmu campaign scenario`."""
from __future__ import annotations

from pathlib import Path

import pytest
from distributed import Client

from satfmu.fmus.errors import ScenarioError
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.campaign.scenario_task import campaign, campaign_size
from satfmu.sims.cli import main
from tests.test_scenario_campaign import mrp, toml


def with_campaign(table: object, **changes: object) -> dict:
    return {**mrp(**changes), "campaign": table}


@pytest.mark.parametrize("table, message", [
    ({"samples": 0}, r"campaign\.samples: must be an integer >= 1, got 0"),
    ({"samples": "100"}, r"campaign\.samples: must be an integer >= 1, got '100'"),
    ({"samples": True}, r"campaign\.samples: must be an integer >= 1, got True"),
    ({"samples": 10.0}, r"campaign\.samples: must be an integer >= 1, got 10\.0"),
    ({"demo_samples": 0}, r"campaign\.demo_samples: must be an integer >= 1"),
    ({"seed": -1}, r"campaign\.seed: must be an integer >= 0, got -1"),
    ({"samples": 10, "demo_samples": 11}, r"campaign\.demo_samples: 11 is more than samples = 10"),
    ({"sample": 10}, r"campaign: unknown key 'sample'.*did you mean 'samples'"),
    ([10], r"campaign: must be a table of samples, demo_samples, seed"),
])
def test_a_bad_campaign_table_is_refused_naming_the_key(table: object, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        Scenario.from_dict(with_campaign(table), where="mine.toml")


def test_a_campaign_table_needs_dispersions() -> None:
    data = {k: v for k, v in with_campaign({"samples": 10}).items() if k != "dispersions"}
    with pytest.raises(ScenarioError, match=r"mine\.toml: campaign: a campaign needs a \[dispersions\] table"):
        Scenario.from_dict(data, where="mine.toml")


def test_the_campaign_table_round_trips_and_stays_out_of_the_campaign_identity(fmu_dir: Path) -> None:
    """to_dict/from_dict keep the table; a sample's scenario has none; two declarations that differ
    only in their default sizes are the same campaign (a folder is resumed whatever the defaults)."""
    sc = Scenario.from_dict(with_campaign({"samples": 10, "demo_samples": 2, "seed": 5}))
    assert sc.campaign == {"samples": 10, "demo_samples": 2, "seed": 5}
    assert Scenario.from_dict(sc.to_dict()).campaign == sc.campaign
    assert sc.sample(5, 0, fmu_dir).campaign == {}
    other = Scenario.from_dict(with_campaign({"samples": 20, "demo_samples": 3}))
    a, b = (campaign(s, 2, seed=5, chunk=2, fmu_dir=fmu_dir) for s in (sc, other))
    assert a.identity() == b.identity() and "campaign" not in a.context["scenario"]


def test_campaign_size_takes_the_declared_defaults() -> None:
    sc = Scenario.from_dict(with_campaign({"samples": 10, "demo_samples": 2, "seed": 5}))
    assert campaign_size(sc) == (10, 5)
    assert campaign_size(sc, demo=True) == (2, 5)
    assert campaign_size(sc, samples=3, seed=0) == (3, 0)  # given values win
    with pytest.raises(ScenarioError, match="not both"):
        campaign_size(sc, samples=3, demo=True)
    bare = Scenario.from_dict(mrp())
    assert campaign_size(bare, samples=4) == (4, 0)  # seed 0 by default
    with pytest.raises(ScenarioError, match=r"campaign\.samples: not declared .*--samples N"):
        campaign_size(bare)
    with pytest.raises(ScenarioError, match=r"campaign\.demo_samples: not declared"):
        campaign_size(Scenario.from_dict(with_campaign({"samples": 10})), demo=True)


def test_the_command_runs_the_declared_sizes(tmp_path: Path, client: Client, fmu_dir: Path,
                                             capsys: pytest.CaptureFixture) -> None:
    """`campaign scenario FILE` without --samples runs [campaign] samples with its seed, --demo its
    demo_samples; without a declared size, or with both --samples and --demo, exit 2."""
    data = {**mrp(), "name": "sized"}
    path = toml(tmp_path / "sized.toml", data)
    path.write_text(path.read_text() + "[campaign]\nsamples = 3\ndemo_samples = 2\nseed = 5\n")
    common = ["--chunk", "2", "--scheduler", client.scheduler.address, "--fmu-dir", str(fmu_dir),
              "--out", str(tmp_path / "out")]
    assert main(["campaign", "scenario", str(path), *common]) == 1  # 2 s: too short to settle
    assert "3 samples" in capsys.readouterr().out and (tmp_path / "out" / "sized-n3-s5" / "campaign.json").is_file()
    assert main(["campaign", "scenario", str(path), "--demo", *common]) == 1
    assert "2 samples" in capsys.readouterr().out and (tmp_path / "out" / "sized-n2-s5" / "campaign.json").is_file()
    bare = toml(tmp_path / "bare.toml", {**data, "name": "bare"})
    assert main(["campaign", "scenario", str(bare), *common]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "campaign.samples: not declared" in err
    with pytest.raises(SystemExit) as exc:
        main(["campaign", "scenario", str(path), "--samples", "3", "--demo", *common])
    assert exc.value.code == 2 and "not allowed with argument" in capsys.readouterr().err
    assert not (tmp_path / "out" / "bare-n3-s0").exists()
