"""Certifying a risk level (eaplan_drake.studies.certify, ``eaplan-drake certify``): faults drawn
from a fault model, excess failures counted on the worlds the lowest plan completes, the exact
upper bound, the verdict, and a small run that resumes."""

import json
import math

import numpy as np
import pytest

from eaplan_drake.cli import main as cli_main
from eaplan_drake.params import FaultModelParams
from eaplan_drake.studies.certify import CERTIFY_RANGES, Certify, CertifyReport, CertifyStudy
from eaplan_drake.studies.statistics import ClopperPearsonUpper
from eaplan_drake.studies.sweep import DrawFaults, StudyFlights


def test_faults_drawn_from_a_model_have_its_rate_and_sizes():
    model = FaultModelParams(rate=0.01, size_bounds=[0.02, 0.08])
    rng = np.random.default_rng(5)
    draws = [DrawFaults(rng, model, 400.0) for _ in range(2000)]
    counts = np.array([len(d) for d in draws])
    assert counts.mean() == pytest.approx(4.0, abs=4 * math.sqrt(4.0 / 2000))  # Poisson(λT)
    sizes = np.array([f.soc_drop for d in draws for f in d])
    assert sizes.min() >= 0.02 and sizes.max() <= 0.08
    assert sizes.mean() == pytest.approx(0.05, abs=0.002)
    times = np.array([f.time for d in draws for f in d])
    assert times.min() >= 0.0 and times.max() <= 400.0
    assert all(np.all(np.diff([f.time for f in d]) >= 0) for d in draws)
    exp = FaultModelParams(rate=0.01, sizes="exponential", size_mean=0.03)
    sizes = [f.soc_drop for _ in range(500) for f in DrawFaults(rng, exp, 400.0)]
    assert np.mean(sizes) == pytest.approx(0.03, rel=0.1)
    emp = FaultModelParams(rate=0.01, sizes="empirical", size_values=[0.05, 0.1])
    assert {f.soc_drop for f in DrawFaults(rng, emp, 4000.0)} <= {0.05, 0.1}


def test_the_certify_study_draws_its_worlds_and_flies_lowest_and_policy():
    study = CertifyStudy("plan_i", 4, overrides={"planner.policy": "mpc"})
    assert study.uniform == CERTIFY_RANGES and study.policies == ["mpc"]
    assert study.fault_model == FaultModelParams()  # the scenario's belief, made true
    flights = StudyFlights(study)
    assert len(flights) == 8
    assert [k["policy"] for k, _ in flights[:2]] == ["lowest", "mpc"]
    assert flights[0][1].battery.faults == flights[1][1].battery.faults  # one world each
    assert 0.0 <= flights[0][1].wind.speed <= 12.0
    again = StudyFlights(CertifyStudy("plan_i", 4, overrides={"planner.policy": "mpc"}))
    assert [s.battery.faults for _, s in again] == [s.battery.faults for _, s in flights]
    with pytest.raises(ValueError, match="worlds: must be an integer"):
        CertifyStudy("plan_i", 0)


def _Rows(outcomes):
    """Rows of worlds given as (lowest completed, policy completed, policy quality)."""
    rows = []
    for w, (low, done, quality) in enumerate(outcomes):
        rows.append(
            dict(world=w, policy="lowest", completed=low, status="x", quality=0.0, final_margin=0.2)
        )
        rows.append(
            dict(
                world=w,
                policy="mpc",
                completed=done,
                status="complete" if done else "reserve_reached",
                quality=quality,
                final_margin=0.05,
            )
        )
    return rows


def test_excess_failures_count_only_where_the_lowest_plan_completes():
    outcomes = [(True, True, 0.6)] * 95 + [(True, False, 0.7)] * 3 + [(False, False, 0.5)] * 2
    (c,) = Certify(_Rows(outcomes), eps=0.05)
    assert (c.worlds, c.feasible, c.excess_failures) == (100, 98, 3)
    assert c.rate == pytest.approx(3 / 98)
    assert c.upper == ClopperPearsonUpper(3, 98)
    assert c.mission_quality == pytest.approx(95 * 0.6 / 98)
    assert c.completion == pytest.approx(0.95)
    assert not c.certified  # 3/98 has a 95 % upper bound of about 0.078
    (clean,) = Certify(_Rows([(True, True, 0.5)] * 59), eps=0.05)
    assert clean.certified and clean.worlds_needed == 59
    text = CertifyReport(clean)
    assert "certified at ε = 0.05" in text and "not certified" not in text
    assert "not certified" in CertifyReport(c)


@pytest.mark.slow
def test_certify_command_writes_its_report_and_resumes(tmp_path, capsys):
    args = [
        "certify",
        "plan_ii",
        "--worlds",
        "2",
        "--out",
        str(tmp_path),
        "--set",
        "planner.policy=mpc",
        "--set",
        "planner.reserve=risk",
        "--set",
        "simulation.time_limit=30",
    ]
    assert cli_main(args) == 0
    out = capsys.readouterr().out
    assert "policy `mpc` on 2 worlds" in out
    assert (tmp_path / "certify.md").read_text().startswith("# certify plan_ii")
    rows = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert len(rows) == 4
    before = (tmp_path / "rows.jsonl").read_bytes()
    assert cli_main(args) == 0  # resumes: nothing left to fly, the same rows
    assert (tmp_path / "rows.jsonl").read_bytes() == before
