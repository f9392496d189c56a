"""Certifying a planner's risk level over many random worlds (``eaplan-drake certify``).

A scenario's planner promises (``planner.reserve: risk``) that each decision's *excess* risk, the
probability under its fault model that the mission fails although the lowest plan flown from the
same state would have completed, is at most ε = ``planner.risk``. What a user wants to know is the
rate over whole missions, and that is measured, not promised: :func:`CertifyStudy` draws N worlds
(wind 0–12 m/s from any direction, sensor noise 0.1–3 W that the estimator is not told, dropouts
0–30 %, battery faults drawn from the scenario's own fault model, or from another one to test a
mismatch), and the studies machinery (:func:`~eaplan_drake.studies.sweep.RunStudy`: joblib
locally, Dask on a cluster, resumable) flies the static lowest plan and the scenario's policy on
each. :func:`Certify` counts, on the worlds where the lowest plan completes, the missions the
policy loses: k excess failures in n such worlds. The rate k/n comes with its exact one-sided
upper confidence bound (Clopper–Pearson,
:func:`~eaplan_drake.studies.statistics.ClopperPearsonUpper`), and the scenario is *certified
at ε* only when that bound is at most ε.

What it does not mean: a certificate is about the world distribution it was measured on (a user's
real wind and faults may be harsher: certify with a mismatched fault model to see how much), and
it bounds the rate, not any one mission. With no failure at all, n worlds bound the rate by
1 − 0.05^(1/n): 59 worlds for 5 %, 299 for 1 %
(:func:`~eaplan_drake.studies.statistics.WorldsNeeded`).
"""

import dataclasses as dc
import math
from pathlib import Path

import numpy as np

from eaplan_drake.errors import ScenarioError
from eaplan_drake.loading import LayerScenario, LoadNamedScenario, OverrideFromAssignment
from eaplan_drake.params import POINT_MODEL_VALUES, FaultModelParams, Scenario
from eaplan_drake.planning.belief import PRIOR_DROPS
from eaplan_drake.studies.bounds import (
    PlainPower,
    SequentialDecision,
    SequentialPower,
    UpperBound,
    WorldsForPower,
)
from eaplan_drake.studies.sampling import FaultProposal
from eaplan_drake.studies.statistics import ClopperPearsonUpper, WorldsNeeded
from eaplan_drake.studies.study import MAX_STUDY_FLIGHTS, Study
from eaplan_drake.studies.sweep import LOWEST

__all__ = [
    "CERTIFY_RANGES",
    "CHANGING_WORLD_RANGES",
    "CHANGING_WORLD_SET",
    "MAX_WORLDS",
    "Certificate",
    "Certify",
    "CertifyReport",
    "CertifyStudy",
    "BatchLine",
    "BeliefLine",
    "WorldFaultModel",
    "ExpectedPower",
    "ProposalFromPilot",
    "ProposalLine",
    "RunCertify",
    "WorldSeries",
    "WorldsLine",
]

MAX_WORLDS = MAX_STUDY_FLIGHTS // 2
"""The most worlds one certify run flies (each world twice: the lowest plan and the policy)."""

CERTIFY_RANGES = {
    "wind.speed": [0.0, 12.0],
    "wind.direction_deg": [0.0, 360.0],
    "sensor.noise_std": [0.1, 3.0],
    "sensor.dropout_probability": [0.0, 0.3],
}
"""The world distribution besides the faults (uniform ranges; the benchmark's): wind [m/s],
its direction [deg], sensor noise [W] and the probability that a sample is lost [-]."""

CHANGING_WORLD_RANGES = {
    "wind.gusts.sigma": [0.0, 2.0],
    "wind.drift.speed_rate": [-0.6, 0.6],
    "wind.drift.direction_rate_deg": [-9.0, 9.0],
    "battery.health": [0.85, 1.0],
    "computation.power_offset": [-2.0, 2.0],
}
"""What ``certify --changing-worlds`` adds to :data:`CERTIFY_RANGES` (uniform ranges): Dryden
gusts of intensity σ [m/s] up to 2; a mean wind drifting by up to ±0.6 m/s and ±9° a minute
(±4 m/s and ±60° over a survey of about 7 minutes), clipped below the airspeed; a pack whose
usable capacity is 85–100 % of its label; a payload ±2 W off its table. The estimator and the
planner are told none of them; the remaining-time staircase is priced in the aircraft's own wind
estimate (``wind.staircase: estimated``)."""

CHANGING_WORLD_SET = {"wind.staircase": "estimated"}
"""The keys ``certify --changing-worlds`` sets on every world."""


def CertifyStudy(
    scenario: str,
    worlds: int = 300,
    *,
    seed: int = 0,
    rates: str = "fast",
    overrides: dict | None = None,
    fault_model: FaultModelParams | None = None,
    proposal: FaultProposal | None = None,
    proposal_from: int = 0,
    base: Scenario | None = None,
    changing: bool = True,
) -> Study:
    """The study that certifies ``scenario`` (a shipped name or a YAML path, with ``overrides``
    key path → YAML value): ``worlds`` worlds of :data:`CERTIFY_RANGES` with faults from
    ``fault_model`` (default: the scenario's ``planner.fault_model``, the belief made true),
    each flown with the lowest plan and the scenario's policy. With ``proposal``, worlds from
    ``proposal_from`` on draw the drops of its window from it (stratified or importance
    sampling, :mod:`eaplan_drake.studies.sampling`); world k is the same for any ``worlds``.
    ``base``: ``scenario`` with ``overrides`` already layered (a caller that has it), read for
    the study's name, policy and fault model instead of layering them again. ``changing`` (the
    default): the worlds change in flight (:data:`CHANGING_WORLD_RANGES`,
    :data:`CHANGING_WORLD_SET`; a key the overrides set keeps the overrides' value); False: steady
    worlds (a constant wind, the nominal pack, the payload on its table)."""
    if isinstance(worlds, bool) or not isinstance(worlds, int) or not 1 <= worlds <= MAX_WORLDS:
        raise ValueError(f"worlds: must be an integer in [1, {MAX_WORLDS}], got {worlds!r}")
    overrides = dict(overrides or {})
    ranges = dict(CERTIFY_RANGES)
    if changing:
        ranges.update({k: v for k, v in CHANGING_WORLD_RANGES.items() if k not in overrides})
        overrides = {**CHANGING_WORLD_SET, **overrides}
    if base is None:
        layers = [OverrideFromAssignment(f"{k}={v}") for k, v in overrides.items()]
        base = LayerScenario(LoadNamedScenario(scenario), layers)
    model = base.planner.fault_model if fault_model is None else fault_model
    model.Validate("fault_model")
    if proposal is not None:
        proposal.Validate(model, base.simulation.time_limit)
    return Study(
        name=f"certify_{base.name}",
        base=str(scenario),
        set=overrides,
        uniform=ranges,
        fault_model=model,
        draws=int(worlds),
        seed=int(seed),
        policies=[base.planner.policy],
        lowest_reference=True,
        rates=rates,
        fault_proposal=proposal,
        proposal_from=int(proposal_from) if proposal is not None else 0,
    )


def ProposalFromPilot(
    mode: str, study: Study, rows: list[dict], *, mix: float = 0.5, directory="."
) -> FaultProposal:
    """The proposal of a ``stratified`` or ``importance`` certify run, by a stated rule from the
    rows of its pilot (the first worlds of ``study``, drawn as declared):

    - window τ* = the longest pilot flight, rounded up to 10 s (at most the time limit);
    - stratified: Neyman allocation a_n = √(r̂_n (1 − r̂_n)), r̂_n = (k_n + ½) / (n_n + 1) the
      pilot's excess-failure rate among its feasible worlds with n drops in the window (strata
      beyond the pilot's take its last one's); no loss in the pilot: a_n = 1 for n >= 1;
    - importance: one cross-entropy step
      (:func:`~eaplan_drake.studies.sampling.CrossEntropyTilt`) over the elite worlds: the
      excess failures, or, with fewer than 3, the tenth (at least 3) of the feasible worlds
      with the largest total drop in the window.

    The pilot worlds stay in the run with weight 1: the proposal depends on worlds already
    flown only, so the bound stays valid."""
    from eaplan_drake.studies.sampling import CrossEntropyTilt, StratifiedProposal, TiltedProposal
    from eaplan_drake.studies.sweep import StudyFlights

    if mode not in ("stratified", "importance"):
        raise ValueError(f"sampling: must be stratified or importance here, got {mode!r}")
    flights = StudyFlights(study, directory)
    horizon = flights[0][1].simulation.time_limit
    durations = [float(r["duration"]) for r in rows if r.get("duration") is not None]
    window = min(horizon, 10.0 * math.ceil(max(durations, default=horizon) / 10.0))
    faults = {k["world"]: f.battery.faults for k, f in flights if k["policy"] == LOWEST}
    by_world: dict[int, dict[str, dict]] = {}
    for row in rows:
        by_world.setdefault(int(row["world"]), {})[row["policy"]] = row
    policy = study.policies[0]
    pilot = [(w, r) for w, r in sorted(by_world.items()) if LOWEST in r and policy in r]
    inside = [[x.soc_drop for x in faults[w] if x.time <= window] for w, _ in pilot]
    counts = np.array([len(x) for x in inside])
    sizes = np.array([np.mean(x) if x else np.nan for x in inside])
    feasible = np.array([bool(r[LOWEST]["completed"]) for _, r in pilot])
    lost = np.array([not r[policy]["completed"] for _, r in pilot]) & feasible
    model = study.fault_model
    if mode == "stratified":
        if not lost.any():
            return StratifiedProposal(model, window, mix=mix)
        top = int(counts.max(initial=0))
        k = np.array([np.sum(lost & (counts == n)) for n in range(top + 1)])
        m = np.array([np.sum(feasible & (counts == n)) for n in range(top + 1)])
        r = (k + 0.5) / (m + 1.0)
        return StratifiedProposal(model, window, mix=mix, allocation=np.sqrt(r * (1.0 - r)))
    elite = lost.copy()
    if elite.sum() < 3:  # too few losses: the feasible worlds with the most drop in the window
        total = np.where(feasible, np.nan_to_num(sizes) * counts, -np.inf)
        elite = np.zeros(len(pilot), bool)
        elite[np.argsort(-total, kind="stable")[: max(3, len(pilot) // 10)]] = True
        elite &= feasible
    rate, theta = CrossEntropyTilt(model, window, counts, sizes, np.ones(len(pilot)), elite)
    return TiltedProposal(model, window, rate, theta, mix=mix)


@dc.dataclass(frozen=True)
class Certificate:
    """What :func:`Certify` measured, for one policy at ε."""

    policy: str
    eps: float
    confidence: float
    worlds: int
    """Worlds with both flights' rows."""
    feasible: int
    """Worlds the lowest plan completes (n)."""
    excess_failures: int
    """Of those, missions the policy lost (k; an error row counts as lost)."""
    errors: int
    completion: float
    """Missions the policy completed, of all worlds [-]."""
    mission_quality: float
    """Mean quality over the feasible worlds, a lost mission counting 0 [-]."""
    mean_final_margin: float
    """Mean final SoC above the reserve over the policy's completed missions [-]."""
    anytime: bool = False
    """The anytime-valid betting bound (:mod:`eaplan_drake.studies.bounds`) rather than
    Clopper–Pearson: with weighted worlds or ``--until-decided``."""
    weighted_rate: float = math.nan
    """Σ W E / Σ W F, the weighted estimate of the rate [-] (k / n with weight 1)."""
    anytime_upper: float = 1.0
    """U_t after the last world [-]."""
    certified_at: int = 0
    """The first world count t with U_t <= ε (0: none)."""
    refuted_at: int = 0
    """The first world count t with L_t > ε: the claim can no longer pass (0: none)."""
    strata: dict = dc.field(default_factory=dict)
    """Worlds per stratum (drops in the proposal's window; ``pilot`` for worlds drawn as
    declared before the proposal was chosen)."""
    power: float = math.nan
    """P(this many worlds certify) at the rate measured so far."""
    worlds_for_power: tuple = (None, None)
    """Worlds likely needed at the rate measured so far: for a 50 % and a 90 % chance."""

    @property
    def rate(self) -> float:
        """k / n [-]."""
        return self.excess_failures / self.feasible if self.feasible else math.nan

    @property
    def upper(self) -> float:
        """The one-sided upper confidence bound of the excess-failure rate [-]: exact
        (Clopper–Pearson), or the anytime-valid one."""
        if self.anytime:
            return self.anytime_upper
        if not self.feasible:
            return 1.0
        return ClopperPearsonUpper(self.excess_failures, self.feasible, self.confidence)

    @property
    def certified(self) -> bool:
        """The upper bound is at most ε (anytime: at some world of the run)."""
        if self.anytime:
            return self.certified_at > 0
        return self.feasible > 0 and self.upper <= self.eps

    @property
    def worlds_needed(self) -> int:
        """Feasible worlds without a failure that a claim at ε needs."""
        return WorldsNeeded(self.eps, self.confidence)


def WorldSeries(rows: list[dict], policy: str) -> dict[str, np.ndarray]:
    """The worlds with both flights' rows, in world order, as arrays: ``weight`` W,
    ``weight_bound`` B, ``excess`` E, ``feasible`` F and ``stratum`` (−1: drawn as declared)."""
    by_world: dict[int, dict[str, dict]] = {}
    for row in rows:
        by_world.setdefault(int(row["world"]), {})[row["policy"]] = row
    pairs = [by_world[w] for w in sorted(by_world) if LOWEST in by_world[w]]
    pairs = [w for w in pairs if policy in w]
    low = [w[LOWEST] for w in pairs]
    feasible = np.array([bool(r["completed"]) for r in low], dtype=float)
    lost = np.array([not w[policy]["completed"] for w in pairs], dtype=float)
    stratum = [r.get("stratum") for r in low]
    return {
        "weight": np.array([float(r.get("weight", 1.0)) for r in low]),
        "weight_bound": np.array([float(r.get("weight_bound", 1.0)) for r in low]),
        "excess": feasible * lost,
        "feasible": feasible,
        "stratum": np.array([-1 if x is None else int(x) for x in stratum], dtype=int),
    }


def _Anytime(series: dict, eps: float, confidence: float, worlds: int) -> dict:
    """The anytime-valid fields of a :class:`Certificate` of a world series."""
    w, e, f, b = (series[k] for k in ("weight", "excess", "feasible", "weight_bound"))
    certified, refuted = SequentialDecision(w, e, f, b, eps, confidence)
    horizon = max(3 * worlds, 1000)
    power = SequentialPower(w, e, f, b, eps, horizon, runs=200)
    needed = tuple(
        int(np.argmax(power >= p)) + 1 if np.any(power >= p) else None for p in (0.5, 0.9)
    )
    strata = {}
    for x in series["stratum"]:
        key = "pilot" if x < 0 else int(x)
        strata[key] = strata.get(key, 0) + 1
    return dict(
        anytime=True,
        weighted_rate=float(np.sum(w * e) / np.sum(w * f)) if np.sum(w * f) else math.nan,
        anytime_upper=float(UpperBound(w, e, f, b, eps, confidence)),
        certified_at=int(certified),
        refuted_at=int(refuted),
        strata=strata,
        power=float(power[worlds - 1]),
        worlds_for_power=needed,
    )


def _PlainPower(k: int, n: int, worlds: int, eps: float, confidence: float) -> dict:
    """The power fields of a plain count: at the measured k / n and feasible fraction."""
    if not n:
        return {}
    rate, fraction = k / n, n / worlds

    def power(size):
        return PlainPower(rate, fraction, size, eps, confidence)

    needed = tuple(WorldsForPower(power, p, largest=20_000) for p in (0.5, 0.9))
    return dict(weighted_rate=rate, power=power(worlds), worlds_for_power=needed)


def Certify(
    rows: list[dict], eps: float, confidence: float = 0.95, *, anytime: bool | None = None
) -> list[Certificate]:
    """One :class:`Certificate` per policy of a certify study's rows (``world``, ``policy``,
    ``completed``, ``status``, ``quality``, ``final_margin``; ``weight``, ``weight_bound``,
    ``stratum`` of weighted worlds). ``anytime``: the betting bound (default: when a row is
    weighted), else Clopper–Pearson."""
    weighted = any("weight" in r for r in rows)
    anytime = weighted if anytime is None else bool(anytime or weighted)
    by_world: dict[int, dict[str, dict]] = {}
    for row in rows:
        by_world.setdefault(int(row["world"]), {})[row["policy"]] = row
    policies = sorted({r["policy"] for r in rows} - {LOWEST})
    certificates = []
    for policy in policies:
        pairs = [w for w in by_world.values() if LOWEST in w and policy in w]
        feasible = [w for w in pairs if w[LOWEST]["completed"]]
        lost = [w for w in feasible if not w[policy]["completed"]]
        done = [w[policy] for w in pairs if w[policy]["completed"]]
        quality = [w[policy]["quality"] if w[policy]["completed"] else 0.0 for w in feasible]
        if anytime and pairs:
            extra = _Anytime(WorldSeries(rows, policy), eps, confidence, len(pairs))
        else:
            extra = _PlainPower(len(lost), len(feasible), len(pairs), eps, confidence)
        certificates.append(
            Certificate(
                policy=policy,
                eps=float(eps),
                confidence=float(confidence),
                worlds=len(pairs),
                feasible=len(feasible),
                excess_failures=len(lost),
                errors=sum(w[policy]["status"] == "error" for w in pairs),
                completion=len(done) / len(pairs) if pairs else math.nan,
                mission_quality=float(np.mean(quality)) if quality else math.nan,
                mean_final_margin=(
                    float(np.mean([r["final_margin"] for r in done])) if done else math.nan
                ),
                **extra,
            )
        )
    return certificates


def _PowerLine(c: Certificate) -> str:
    """The chance that the claim passes, at the rate measured so far."""
    if math.isnan(c.power) or math.isnan(c.weighted_rate):
        return ""
    half, most = (f"{n}" if n else "more than we searched" for n in c.worlds_for_power)
    how = "stopping as soon as the bound allows" if c.anytime else "counting a fixed number"
    return (
        f"- power at the rate measured so far ({c.weighted_rate:.4f}, {how}): "
        f"{c.worlds} worlds certify at ε = {c.eps:g} with probability {c.power:.2f}; "
        f"worlds likely needed: {half} for a 50 % chance, {most} for 90 %"
        + (" (the measured rate is at or above ε)" if c.weighted_rate >= c.eps else "")
    )


def CertifyReport(certificate: Certificate) -> str:
    """The certificate as a few lines of Markdown."""
    c = certificate
    name = "anytime-valid betting bound" if c.anytime else "exact, Clopper–Pearson"
    verdict = (
        f"**certified at ε = {c.eps:g}**: the {c.confidence:.0%} upper bound "
        + (f"reached ε at world {c.certified_at}" if c.anytime else f"{c.upper:.4f} is at most ε")
        if c.certified
        else f"**not certified at ε = {c.eps:g}**: the {c.confidence:.0%} upper bound "
        f"{c.upper:.4f} is above ε"
    )
    lines = [
        f"policy `{c.policy}` on {c.worlds} worlds, {c.feasible} of them completed by the "
        f"lowest plan",
        "",
        f"- excess failures (lost where the lowest plan completes): {c.excess_failures} of "
        f"{c.feasible} = {c.rate:.4f}"
        + (f", weighted estimate {c.weighted_rate:.4f}" if c.anytime else "")
        + f", one-sided {c.confidence:.0%} upper bound ({name}) {c.upper:.4f}",
        f"- {verdict}",
    ]
    if c.anytime and c.refuted_at:
        lines.append(
            f"- the lower {c.confidence:.0%} bound passed ε at world {c.refuted_at}: the claim "
            f"at ε can no longer pass"
        )
    if c.anytime and set(c.strata) - {"pilot"}:
        parts = ", ".join(f"{k}: {v}" for k, v in sorted(c.strata.items(), key=str))
        lines.append(f"- worlds per stratum (drops in the window): {parts}")
    if not c.anytime:
        lines.append(
            f"- a claim at ε = {c.eps:g} needs at least {c.worlds_needed} feasible worlds "
            f"without a failure ({c.feasible} here)"
        )
    if line := _PowerLine(c):
        lines.append(line)
    lines.append(
        f"- completed: {c.completion:.1%} of all worlds; mission quality (lost = 0) on the "
        f"feasible worlds: {c.mission_quality:.3f}; mean final margin of the completed: "
        f"{c.mean_final_margin:.3f}"
    )
    if c.errors:
        lines.append(f"- {c.errors} flights ended in an error (counted as lost)")
    return "\n".join(lines) + "\n"


LEARNING_KEYS = tuple(POINT_MODEL_VALUES)
"""The keys of ``planner.fault_model`` that say how the planner's belief learns, not what a world
draws (a world's faults are drawn from the point model,
:meth:`~eaplan_drake.params.FaultModelParams.PointModel`)."""


def WorldFaultModel(belief: FaultModelParams, assignments) -> FaultModelParams:
    """The fault model the worlds draw from: the planner's ``belief`` (``planner.fault_model``)
    with ``--world-fault-model KEY=VALUE`` assignments (``rate=0.006``,
    ``size_bounds=[0.05,0.25]``, …) on a copy; a bad key or value is one line naming it. The
    worlds draw from a point model: the belief's learning keys (``prior_drops``, the records,
    ``prior_sizes``) are not theirs."""
    model = belief.PointModel()
    keys = [f.name for f in dc.fields(FaultModelParams) if f.name not in LEARNING_KEYS]
    for assignment in assignments or []:
        key, sep, value = str(assignment).partition("=")
        key = key.strip()
        if not sep or key not in keys:
            raise ValueError(
                f"--world-fault-model: expected KEY=VALUE with KEY one of {', '.join(keys)}, "
                f"got {assignment!r}"
            )
        try:
            assignment = OverrideFromAssignment(f"planner.fault_model.{key}={value}")
            layered = LayerScenario(Scenario(), [assignment]).planner.fault_model
        except ScenarioError as e:  # the same checks as the scenario's, named for this option
            raise ValueError(
                "--world-fault-model: " + str(e).replace("planner.fault_model.", "")
            ) from None
        setattr(model, key, getattr(layered, key))
    model.Validate("--world-fault-model")
    return model


def WorldsLine(changing: bool, overrides: dict | None = None) -> str:
    """One line stating what changes in the worlds' flights (:data:`CHANGING_WORLD_RANGES`; the
    keys of them ``overrides`` sets are named with their values, which every world keeps)."""
    if not changing:
        return (
            "worlds: steady (--steady-worlds): a constant wind, the nominal pack, the payload on "
            "its table"
        )

    def Span(key, unit=""):
        lo, hi = CHANGING_WORLD_RANGES[key]
        return f"±{hi:g}{unit}" if lo == -hi else f"{lo:g}–{hi:g}{unit}"

    health = CHANGING_WORLD_RANGES["battery.health"]
    return (
        f"worlds: changing in flight: Dryden gusts of σ {Span('wind.gusts.sigma', ' m/s')}, the "
        f"mean wind drifting by {Span('wind.drift.speed_rate', ' m/s')} and "
        f"{Span('wind.drift.direction_rate_deg', '°')} a minute, a pack at "
        f"{100 * health[0]:g}–{100 * health[1]:g} % of its label, a payload "
        f"{Span('computation.power_offset', ' W')} off its table"
        + "".join(
            f"; {k} = {v} in every world (--set)"
            for k, v in (overrides or {}).items()
            if k in CHANGING_WORLD_RANGES
        )
        + " (--steady-worlds: none of them)"
    )


def BeliefLine(belief: FaultModelParams, world: FaultModelParams) -> str:
    """One line stating the worlds' fault model and the planner's belief (the same, or not)."""

    def Text(m):
        sizes = {
            "uniform": f"U[{m.size_bounds[0]:g}, {m.size_bounds[1]:g}]",
            "exponential": f"exponential of mean {m.size_mean:g}",
        }.get(m.sizes, f"{m.sizes} {m.size_values}")
        text = f"rate {m.rate:g}/s, sizes {sizes}"
        if m.HoldsBelief():
            text += (
                f" (a belief worth {m.prior_drops or PRIOR_DROPS:g} drops, updated by "
                f"{m.recorded_drops:g} drops in {m.recorded_hours:g} h of records and in flight)"
            )
        if m.prior_size_scale != 1.0:
            text += f" (sizes up to {m.prior_size_scale:g}× the stated before a drop is seen)"
        if m.prior_sizes > 0.0:
            text += f" (sizes learnt in flight, the prior worth {m.prior_sizes:g})"
        return text

    if world == belief:
        return f"faults: the worlds draw the planner's belief ({Text(world)})"
    return f"faults: the worlds draw {Text(world)}; the planner believes {Text(belief)}"


def ProposalLine(proposal: FaultProposal | None, model: FaultModelParams, pilot: int) -> str:
    """One line saying how the worlds' faults were drawn."""
    if proposal is None:
        return "sampling: plain (faults drawn as declared)"
    mean = model.rate * proposal.window
    if proposal.counts:
        counts = np.asarray(proposal.counts)
        mean_tilted = float(np.sum(np.arange(counts.size) * counts))
    else:
        mean_tilted = mean
    return (
        f"sampling: the first {pilot} worlds as declared (pilot), then in the window "
        f"[0, {proposal.window:g}] s: {proposal.mix:.0%} as declared ({mean:.2f} drops on "
        f"average), the rest with {mean_tilted:.2f} drops on average"
        + (f" and sizes tilted by θ = {proposal.size_tilt:.3g}" if proposal.size_tilt else "")
        + f"; every weight at most {proposal.weight_bound:g}"
    )


def _Within(c: Certificate, worlds: int) -> str:
    """P(certified within ``worlds``) at the rate measured so far, as text."""
    if c.certified:
        return "1"
    half, most = c.worlds_for_power
    if most is not None and most <= worlds:
        return ">= 0.9"
    if half is not None and half <= worlds:
        return ">= 0.5"
    return "< 0.5"


def ExpectedPower(rate: float, worlds: int, eps: float, confidence: float = 0.95) -> str:
    """One line before a run: the chance that ``worlds`` feasible worlds certify at ``eps`` by
    counting if the excess-failure rate is ``rate``, and the worlds likely needed."""
    if isinstance(rate, bool) or not (isinstance(rate, float | int) and 0.0 <= rate < 1.0):
        raise ValueError(f"--expect: must be a rate in [0, 1), got {rate!r}")

    def power(n):
        return PlainPower(float(rate), 1.0, n, eps, confidence)

    half, most = (WorldsForPower(power, p, largest=100_000) for p in (0.5, 0.9))
    return (
        f"if the rate is {rate:g}: {worlds} feasible worlds certify at ε = {eps:g} with "
        f"probability {power(worlds):.2f} (counting); worlds likely needed: "
        f"{half or 'more than 100000'} for a 50 % chance, {most or 'more than 100000'} for 90 %"
    )


def _CheckCount(name: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{name}: must be an integer in [{low}, {high}], got {value!r}")
    return value


def _CheckArguments(args) -> bool:
    """Checks the counts and the seed of ``certify`` (one line naming the option); True when
    the faults are drawn with weights (``--sampling`` other than plain)."""
    _CheckCount("--worlds", args.worlds, 1, MAX_WORLDS)
    _CheckCount("--batch", args.batch, 1, MAX_WORLDS)
    if isinstance(args.seed, bool) or not isinstance(args.seed, int) or args.seed < 0:
        raise ValueError(f"--seed: must be an integer >= 0, got {args.seed!r}")
    weighted = args.sampling != "plain"
    if weighted:
        _CheckCount("--pilot", args.pilot, 1, max(1, args.worlds - 1))
    return weighted


def BatchLine(worlds: int, certificates, most: int) -> str:
    """The line ``certify --until-decided`` prints after a batch: each policy certified, refuted
    or open, its anytime bound and the chance of a verdict within ``most`` worlds."""
    states = [
        "certified" if c.certified else "refuted" if c.refuted_at else "open" for c in certificates
    ]
    return f"{worlds} worlds: " + ", ".join(
        f"{c.policy} {state} (bound {c.upper:.4f}; P(certified within {most}) {_Within(c, most)})"
        for c, state in zip(certificates, states, strict=True)
    )


def RunCertify(args, fly) -> int:
    """``eaplan-drake certify``: flies the worlds (``fly(study)`` → rows, or None when the
    cluster did not fly them), prints the certificates and writes ``certify.md`` beside the
    rows and the study report. Returns the exit status."""
    from eaplan_drake.files import AtomicWrite
    from eaplan_drake.studies.sweep import StudyReport

    weighted = _CheckArguments(args)
    overrides, layers = {}, []
    for assignment in args.set:  # parsed once (a malformed --set is one line naming it)
        layers.append(OverrideFromAssignment(assignment))
        key, _, value = assignment.partition("=")
        overrides[key.strip()] = value
    scenario = LayerScenario(LoadNamedScenario(args.scenario), layers)  # layered once
    eps = scenario.planner.risk
    world_model = WorldFaultModel(
        scenario.planner.fault_model, getattr(args, "world_fault_model", [])
    )
    changing = getattr(args, "changing_worlds", True)

    def Make(worlds, proposal=None):
        return CertifyStudy(
            args.scenario,
            worlds,
            seed=args.seed,
            rates=args.rates,
            overrides=overrides,
            proposal=proposal,
            proposal_from=args.pilot if weighted else 0,
            base=scenario,
            changing=changing,
            fault_model=world_model,
        )

    if getattr(args, "expect", None) is not None:
        print(ExpectedPower(args.expect, args.worlds, eps))
    proposal = None
    if weighted:
        rows = fly(Make(args.pilot))
        if rows is None:
            return 3
        proposal = ProposalFromPilot(args.sampling, Make(args.pilot), rows)
    model = Make(1).fault_model
    line = (
        ProposalLine(proposal, model, args.pilot)
        + "\n"
        + BeliefLine(scenario.planner.fault_model, model)
        + "\n"
        + WorldsLine(changing, overrides)
    )
    print(line)
    anytime = weighted or args.until_decided
    first = (args.pilot if weighted else 0) + args.batch
    sizes = list(range(first, args.worlds, args.batch)) if args.until_decided else []
    for worlds in [*sizes, args.worlds]:
        rows = fly(Make(worlds, proposal))
        if rows is None:
            return 3
        certificates = Certify(rows, eps, anytime=anytime)
        if args.until_decided:
            print(BatchLine(worlds, certificates, args.worlds))
            if all(c.certified or c.refuted_at for c in certificates):
                break
    StudyReport(args.out)
    text = "".join(CertifyReport(c) for c in certificates)
    out = Path(args.out) / "certify.md"
    header = f"# certify {scenario.name}\n\n{line}\n\n"
    AtomicWrite(out, lambda f: f.write(header + text), binary=False)
    print(text, end="")
    print(f"rows, report and figures in {args.out} ({out.name})")
    return 0
