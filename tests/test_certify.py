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
    from eaplan_drake.studies.certify import CHANGING_WORLD_RANGES

    study = CertifyStudy("plan_i", 4, overrides={"planner.policy": "mpc"})
    assert study.uniform == {**CERTIFY_RANGES, **CHANGING_WORLD_RANGES}  # changing by default
    assert study.policies == ["mpc"]
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
    assert "worlds: changing in flight: Dryden gusts of σ 0–2 m/s" in out  # the default
    assert (tmp_path / "certify.md").read_text().startswith("# certify plan_ii")
    assert "worlds: changing in flight" in (tmp_path / "certify.md").read_text()
    rows = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert len(rows) == 4
    before = (tmp_path / "rows.jsonl").read_bytes()
    assert cli_main(args) == 0  # resumes: nothing left to fly, the same rows
    assert (tmp_path / "rows.jsonl").read_bytes() == before
    steady = tmp_path / "steady"
    assert cli_main([*args[:5], str(steady), *args[6:], "--steady-worlds"]) == 0
    assert "worlds: steady (--steady-worlds)" in capsys.readouterr().out
    steady_rows = [json.loads(line) for line in (steady / "rows.jsonl").read_text().splitlines()]
    assert len(steady_rows) == 4
    assert all("wind.gusts.sigma" in r for r in rows)  # the changing worlds' draws
    assert not any("wind.gusts.sigma" in r for r in steady_rows)
    with pytest.raises(SystemExit) as exit_:  # one or the other (argparse's usage error)
        cli_main([*args, "--steady-worlds", "--changing-worlds"])
    assert exit_.value.code == 2
    assert "--changing-worlds: not allowed with argument --steady-worlds" in capsys.readouterr().err


def _WeightedRows(outcomes):
    """Rows of worlds given as (lowest completed, policy completed, weight, stratum)."""
    rows = []
    for w, (low, done, weight, stratum) in enumerate(outcomes):
        keys = dict(world=w, weight=weight, weight_bound=2.0, stratum=stratum, status="x")
        rows.append(dict(keys, policy="lowest", completed=low, quality=0.0, final_margin=0.2))
        rows.append(dict(keys, policy="mpc", completed=done, quality=0.5, final_margin=0.05))
    return rows


def test_weighted_rows_give_the_anytime_bound_and_reprint_the_same():
    rng = np.random.default_rng(0)
    outcomes = [(True, rng.uniform() > 0.02, 0.5, 2) for _ in range(200)]
    outcomes += [(True, True, 1.8, 0)] * 100
    rows = _WeightedRows(outcomes)
    (c,) = Certify(rows, eps=0.05)
    assert c.anytime and c.strata == {0: 100, 2: 200}
    k = c.excess_failures
    assert c.weighted_rate == pytest.approx(0.5 * k / (0.5 * 200 + 1.8 * 100))
    assert c.weighted_rate <= c.upper <= 1.0
    assert c.certified == (c.certified_at > 0) and 0.0 <= c.power <= 1.0
    text = CertifyReport(c)
    assert "anytime-valid betting bound" in text and "worlds per stratum" in text
    assert "worlds likely needed" in text
    assert CertifyReport(Certify(json.loads(json.dumps(rows)), eps=0.05)[0]) == text
    (plain,) = Certify(_Rows([(True, True, 0.5)] * 300), eps=0.05, anytime=True)
    assert plain.anytime and plain.certified_at > 0  # no failure: the bound falls below ε
    (counted,) = Certify(_Rows([(True, True, 0.5)] * 300), eps=0.05)
    assert not counted.anytime and counted.certified and counted.power == pytest.approx(1.0)
    assert "counting a fixed number" in CertifyReport(counted)


def test_a_proposal_changes_only_the_worlds_after_the_pilot():
    from eaplan_drake.studies.sampling import TiltedProposal

    overrides = {"planner.policy": "mpc"}
    plain = StudyFlights(CertifyStudy("plan_i", 6, overrides=overrides))
    model = FaultModelParams()
    proposal = TiltedProposal(model, 400.0, rate=0.009, size_tilt=10.0)
    study = CertifyStudy("plan_i", 6, overrides=overrides, proposal=proposal, proposal_from=3)
    tilted = StudyFlights(study)
    for (k0, s0), (k1, s1) in zip(plain[:6], tilted[:6], strict=True):
        assert k0 == k1 and s0.battery.faults == s1.battery.faults
    for k, s in tilted[6:]:
        assert 0.0 < k["weight"] <= k["weight_bound"] == 2.0
        assert k["stratum"] == sum(f.time <= 400.0 for f in s.battery.faults)
    with pytest.raises(ValueError, match="window"):
        CertifyStudy("plan_i", 6, proposal=TiltedProposal(model, 1e5, 0.009, 1.0))


def test_the_pilot_chooses_the_window_and_the_tilt_by_the_stated_rule():
    from eaplan_drake.studies.certify import ProposalFromPilot
    from eaplan_drake.studies.sampling import CountProbabilities

    study = CertifyStudy("plan_i", 40, overrides={"planner.policy": "mpc"})
    flights = StudyFlights(study)
    faults = {k["world"]: s.battery.faults for k, s in flights if k["policy"] == "lowest"}
    rows = []
    for w, drops in faults.items():  # lost exactly when two drops fall in the first 300 s
        lost = sum(f.time <= 300.0 for f in drops) >= 2
        for policy, done in (("lowest", True), ("mpc", not lost)):
            rows.append(
                dict(world=w, policy=policy, completed=done, duration=295.0, final_margin=0.1)
            )
    importance = ProposalFromPilot("importance", study, rows)
    assert importance.window == 300.0 and importance.mix == 0.5
    mean = float(np.sum(np.arange(len(importance.counts)) * np.array(importance.counts)))
    assert mean > study.fault_model.rate * 300.0  # more drops where the losses were
    stratified = ProposalFromPilot("stratified", study, rows)
    p = CountProbabilities(study.fault_model, 300.0)
    ratio = np.array(stratified.counts[:3]) / p[:3]
    assert ratio[2] > ratio[0] and ratio[2] > ratio[1]  # strata 0 and 1 never lost
    with pytest.raises(ValueError, match="sampling"):
        ProposalFromPilot("plain", study, rows)


def test_certify_options_are_checked_in_one_line(tmp_path, capsys):
    base = ["certify", "plan_ii", "--out", str(tmp_path), "--worlds", "5"]
    assert cli_main([*base, "--sampling", "importance", "--pilot", "5"]) == 2
    assert "--pilot: must be an integer in [1, 4]" in capsys.readouterr().err
    assert cli_main([*base, "--until-decided", "--batch", "0"]) == 2
    assert "--batch: must be an integer in [1, 20000]" in capsys.readouterr().err


@pytest.mark.slow
def test_certify_importance_until_decided_writes_weighted_rows_and_resumes(tmp_path, capsys):
    args = ["certify", "plan_ii", "--worlds", "4", "--pilot", "2", "--batch", "1"]
    args += ["--sampling", "importance", "--until-decided", "--out", str(tmp_path)]
    for assignment in ("planner.policy=mpc", "planner.reserve=risk", "simulation.time_limit=30"):
        args += ["--set", assignment]
    assert cli_main(args) == 0
    out = capsys.readouterr().out
    assert "sampling: the first 2 worlds as declared (pilot)" in out
    assert "3 worlds: mpc open" in out and "anytime-valid betting bound" in out
    rows = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert len(rows) == 8
    assert all(("weight" in r) == (r["world"] >= 2) for r in rows)
    assert all(0 < r["weight"] <= r["weight_bound"] == 2.0 for r in rows if r["world"] >= 2)
    before = (tmp_path / "rows.jsonl").read_bytes()
    report = (tmp_path / "certify.md").read_text()
    assert cli_main(args) == 0  # resumes: the same proposal from the same pilot, no flight
    assert (tmp_path / "rows.jsonl").read_bytes() == before
    assert (tmp_path / "certify.md").read_text() == report


def test_until_decided_stops_at_the_first_batch_that_settles_the_claim(tmp_path, capsys):
    import argparse

    from eaplan_drake.studies.certify import RunCertify

    flown = []

    def Fly(study):  # rows without flights: no world is ever lost
        flown.append(study.draws)
        rows = []
        for keys, _ in StudyFlights(study):
            rows.append(dict(keys, id=f"{keys['world']}{keys['policy']}", status="complete"))
            rows[-1].update(completed=True, quality=0.5, final_margin=0.1, duration=300.0)
            rows[-1].update(metric=1.0, wind_speed=3.0)
            rows[-1]["faults.in_flight_total_drop"] = 0.0
        return rows

    args = argparse.Namespace(
        scenario="plan_i",
        worlds=500,
        batch=25,
        pilot=30,
        seed=0,
        rates="fast",
        set=["planner.policy=mpc"],
        sampling="plain",
        until_decided=True,
        out=str(tmp_path),
    )
    (tmp_path / "rows.jsonl").write_text(
        "".join(json.dumps(r) + "\n" for r in Fly(CertifyStudy("plan_i", 1)))
    )
    flown.clear()
    assert RunCertify(args, Fly) == 0
    out = capsys.readouterr().out
    assert flown[-1] < 500 and flown == list(range(25, flown[-1] + 1, 25))
    assert f"{flown[-1]} worlds: mpc certified" in out and "25 worlds: mpc open" in out
    assert "certified at ε = 0.05" in (tmp_path / "certify.md").read_text()


def test_the_expected_power_is_said_before_a_run():
    from eaplan_drake.studies.certify import ExpectedPower

    line = ExpectedPower(0.03, 300, 0.05)
    assert line.startswith("if the rate is 0.03: 300 feasible worlds certify at ε = 0.05 with")
    assert "probability 0.45" in line and "900 for 90 %" in line
    assert "more than 100000" in ExpectedPower(0.05, 300, 0.05)
    with pytest.raises(ValueError, match="--expect: must be a rate in"):
        ExpectedPower(1.5, 300, 0.05)


def test_changing_worlds_draw_their_stated_ranges_and_keep_the_users_keys():
    from eaplan_drake.studies.certify import CHANGING_WORLD_RANGES, CertifyStudy
    from eaplan_drake.studies.sweep import StudyFlights

    study = CertifyStudy("survey", 60, changing=True, overrides={"battery.health": "0.9"})
    assert "battery.health" not in study.uniform  # the user's value, not a draw
    flights = [s for k, s in StudyFlights(study) if k["policy"] != "lowest"]
    assert len(flights) == 60
    for key, (lo, hi) in CHANGING_WORLD_RANGES.items():
        if key == "battery.health":
            assert {s.battery.health for s in flights} == {0.9}
            continue
        head, *rest = key.split(".")
        values = []
        for s in flights:
            v = getattr(s, head)
            for part in rest:
                v = getattr(v, part)
            values.append(v)
        assert (
            lo <= min(values) and max(values) <= hi and max(values) - min(values) > 0.5 * (hi - lo)
        )
    assert {s.wind.staircase for s in flights} == {"estimated"}
    steady = CertifyStudy("survey", 60, changing=False)
    assert not set(CHANGING_WORLD_RANGES) & set(steady.uniform)
    assert steady.uniform == CERTIFY_RANGES and "wind.staircase" not in steady.set


def test_the_worlds_fault_model_is_apart_from_the_belief_and_rows_count_in_flight_faults():
    from eaplan_drake.params import BatteryFault, FaultModelParams, Scenario
    from eaplan_drake.studies.certify import BeliefLine, CertifyStudy, WorldFaultModel
    from eaplan_drake.studies.sweep import InFlightFaults

    belief = FaultModelParams()
    harsh = WorldFaultModel(belief, ["rate=0.006", "size_bounds=[0.05, 0.25]"])
    assert (harsh.rate, harsh.size_bounds) == (0.006, [0.05, 0.25])
    assert belief.rate == 0.003  # the belief is untouched
    assert BeliefLine(belief, belief).startswith("faults: the worlds draw the planner's belief")
    assert "the planner believes rate 0.003/s, sizes U[0, 0.15]" in BeliefLine(belief, harsh)
    with pytest.raises(ValueError, match=r"^--world-fault-model: rate: must be in \[0, 0\.1\]"):
        WorldFaultModel(belief, ["rate=-1"])
    with pytest.raises(ValueError, match=r"^--world-fault-model: expected KEY=VALUE"):
        WorldFaultModel(belief, ["speed=1"])
    study = CertifyStudy("survey", 5, fault_model=harsh)
    assert study.fault_model.rate == 0.006
    s = Scenario()
    s.battery.faults = [
        BatteryFault(time=10.0, soc_drop=0.1),
        BatteryFault(time=900.0, soc_drop=0.2),
    ]
    assert InFlightFaults(s, 400.0) == {
        "faults.in_flight_count": 1,
        "faults.in_flight_total_drop": 0.1,
    }
