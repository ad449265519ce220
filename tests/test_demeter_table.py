"""Seed 004 Table 1 runner: rows, both methods, the seed's values beside ours, Markdown + CSV."""
from __future__ import annotations

import csv
from pathlib import Path

import pytest

from satfmu.sims.cli import main
from satfmu.synthesis.robust import demeter_table
from satfmu.synthesis.robust.demeter_variants import SEED_TABLE1, SEED_TABLE1_COLUMNS, Variant

ROW3 = Variant((1,), (1, 2), 1, 1)


def test_seed_table_is_complete() -> None:
    # 7 variants by 2 methods, in the seed's order; 2 variants infeasible by both methods
    assert len(SEED_TABLE1) == 14 and all(m in demeter_table.METHODS for _, m in SEED_TABLE1)
    assert sum(v is None for v in SEED_TABLE1.values()) == 4
    assert all(v is None or len(v) == len(SEED_TABLE1_COLUMNS) for v in SEED_TABLE1.values())


@pytest.mark.slow
def test_infeasible_rows_and_files(tmp_path: Path) -> None:
    rows = demeter_table.run([(ROW3, "Det"), (ROW3, "Prob")], n_scenarios=30)
    det, prob = rows
    assert det.status == "infeasible (proved)" and "need zeta > 0.577" in det.note and det.seed is None
    # the scenarios never hit the coincident set exactly, but come near it: no verified design
    assert prob.status.startswith("no design") and "30 scenarios" in prob.note
    md, path_csv = demeter_table.write(rows, tmp_path)
    text = md.read_text()
    assert "| 1 | 1,2 | 1 | 1 | Det | infeasible (proved) |" in text and "- / infeasible" in text
    with path_csv.open() as f:
        lines = list(csv.DictReader(f))
    # the file keeps the seed's order (Prob before Det), whatever the run's
    assert [r["method"] for r in lines] == ["Prob", "Det"] and lines[1]["seed_design_i2p"] == "infeasible"
    with pytest.raises(ValueError, match="method"):
        demeter_table.run_row(ROW3, "Both")


def test_table1_command(tmp_path: Path, capsys) -> None:
    assert main(["table1", "--rows", "4", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "infeasible (proved)" in out and (tmp_path / "table1.csv").exists()
    assert main(["table1", "--rows", "15", "--out", str(tmp_path)]) == 2  # rows are 1..14
    assert main(["table1", "--rows", "4", "--convention", "romuloc", "--out", str(tmp_path)]) == 0
    assert "infeasible (proved)" in capsys.readouterr().out  # a proof of the whole box, in any convention
    with pytest.raises(SystemExit):
        main(["table1", "--rows", "4", "--convention", "matlab", "--out", str(tmp_path)])


@pytest.mark.slow
def test_two_axis_det_row_designs_and_says_why_the_pdlf_is_skipped() -> None:
    # Row 10 (axes 1, 2; appendages 1, 2; identical appendages; norm-bounded): Clarabel fails at
    # its first iteration with the default regularization, the retry (REGULARIZED) designs it.
    row = demeter_table.run_row(Variant((1, 2), (1, 2), 2, 1), "Det")
    assert row.status == "feasible" and row.seed == SEED_TABLE1[(row.variant, "Det")]
    # measured 3.140 / 314.1 (the certificate is re-verified, so the numbers move with the solver)
    assert row.design_i2p == pytest.approx(3.14, rel=0.02) and row.design_hinf == pytest.approx(314.1, rel=0.02)
    # the PDLF program (32 vertex LMIs of size 48) is over the limit: reported, not run
    assert row.det_hinf != row.det_hinf and "PDLF program has 32 vertex LMIs of size 48" in row.note
    # the i2p analysis and the 132 sampled plants bound each other: sampled <= analysis <= design
    assert row.prob_i2p <= row.det_i2p <= row.design_i2p and row.prob_hinf <= row.design_hinf


@pytest.mark.slow
def test_row2_in_the_toolbox_convention_has_the_seeds_i2p() -> None:
    # Row 2 (Det, axis 1, appendage 1, norm-bounded) with the R-RoMulOC toolbox's LMI forms and
    # objective: design i2p 25.68 N m s against the seed's 22.3 (docs/models.md: the independent
    # stand-in gave 25.7), within the issue's ~15 %; H-infinity 7.48 (seed 4.7; ours 256.6).
    # 2 %: the certificate is re-verified, so the numbers move with the solver.
    key = list(SEED_TABLE1)[1]
    row = demeter_table.run_row(*key, convention="romuloc")
    assert row.status == "feasible" and row.result.design.convention == "romuloc"
    assert row.design_i2p == pytest.approx(25.68, rel=0.02) and row.design_hinf == pytest.approx(7.476, rel=0.02)
    assert abs(row.design_i2p / row.seed[0] - 1) < 0.16
    # the analyses bound the same gain as before: sampled <= analysis <= design for the i2p
    assert row.prob_i2p <= row.det_i2p <= row.design_i2p


def test_rows_run_at_once(tmp_path: Path, capsys) -> None:
    """Two rows without a design (about 1 s each) run in two worker processes: the rows in the
    selection's order, the files written in the seed's; the dearest rows are started first."""
    keys = [(ROW3, "Det"), (ROW3, "Prob")]
    rows = demeter_table.run(keys, n_scenarios=5, jobs=2, out_dir=tmp_path)
    assert [(r.method, r.status) for r in rows] == [("Det", "infeasible (proved)"), ("Prob", "no design (unverified)")]
    assert "5 scenarios" in rows[1].note and all(r.total_seconds > 0 for r in rows)
    assert [r.method for r in demeter_table.read(tmp_path / "table1.csv")] == ["Prob", "Det"]
    order = demeter_table.cost_order(list(SEED_TABLE1))
    assert order[:2] == [list(SEED_TABLE1)[12], list(SEED_TABLE1)[13]]  # three axes, Prob first
    assert [len(v.axes) for v, _ in order] == sorted((len(v.axes) for v, _ in order), reverse=True)
    with pytest.raises(ValueError, match="jobs"):
        demeter_table.run(keys, jobs=0)
    assert main(["table1", "--rows", "4", "--jobs", "2", "--out", str(tmp_path / "cli")]) == 0
    assert "1 rows in " in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["table1", "--rows", "4", "--jobs", "0", "--out", str(tmp_path)])


def test_runs_merge_and_both_conventions_side_by_side(tmp_path: Path, capsys) -> None:
    """Row 4, then row 1 written by a second run, end up in one table in the seed's order, read
    back equal (a row written again replaces its line); "both" writes each convention's folder
    and the comparison; --compare rebuilds it from the CSVs alone, and refuses a missing or
    corrupt one."""
    det = demeter_table.run([(ROW3, "Det")], out_dir=tmp_path / "one")
    key = list(SEED_TABLE1)[0]
    row1 = demeter_table.Row(*key, "feasible", design_i2p=25.33, design_hinf=float("inf"), seconds=29.9,
                             total_seconds=60.0,
                  note="962 scenarios", seed=SEED_TABLE1[key])
    demeter_table.write([row1], tmp_path / "one")
    demeter_table.write([demeter_table.Row(*key, "feasible", design_i2p=25.0, seed=SEED_TABLE1[key])], tmp_path / "one")
    demeter_table.write([row1], tmp_path / "one")
    back = demeter_table.read(tmp_path / "one" / "table1.csv")
    assert [r.method for r in back] == ["Prob", "Det"] and back[1].status == det[0].status == "infeasible (proved)"
    assert repr(back[0]) == repr(row1) and back[1].note == det[0].note and back[1].result is None  # repr: nan == nan
    assert main(["table1", "--rows", "4", "--convention", "both", "--out", str(tmp_path / "both")]) == 0
    text = (tmp_path / "both" / "table1.md").read_text()
    assert "| 1 | 1,2 | 1 | 1 | Det | infeasible (proved) |" in text and text.count("infeasible (proved)") == 2
    assert "in the toolbox's convention (1 rows), " in text and "in ours (1 rows)" in text
    (tmp_path / "both" / "table1.md").unlink()
    assert main(["table1", "--compare", "--out", str(tmp_path / "both")]) == 0
    assert (tmp_path / "both" / "table1.md").read_text() == text
    (tmp_path / "both" / "satfmu" / "table1.csv").write_text("axes,appendages\n1,x\n")
    assert main(["table1", "--compare", "--out", str(tmp_path / "both")]) == 1
    assert "line 2: not a Table 1 row" in capsys.readouterr().out
    assert main(["table1", "--compare", "--out", str(tmp_path / "none")]) == 1


def test_ratios_to_the_seed() -> None:
    """The comparison's ratio is ours / seed's, only where both are finite numbers."""
    key = list(SEED_TABLE1)[1]  # row 2: seed 22.3, 4.7, ..., 1 s
    ours = demeter_table.Row(*key, "feasible", design_i2p=25.68, design_hinf=7.47, seconds=0.5, total_seconds=9.0,
                  seed=SEED_TABLE1[key])
    text = demeter_table.comparison([ours], [])
    assert "25.68 / 22.3 (1.15)" in text and "7.47 / 4.7 (1.59)" in text and "0.5 / 1 (0.5)" in text
    assert "| not run |" in text and "- / 0.41 |" in text  # no ratio where ours is missing
