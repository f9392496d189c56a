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

import numpy as np

from eaplan_drake.loading import LayerScenario, LoadNamedScenario, OverrideFromAssignment
from eaplan_drake.params import FaultModelParams
from eaplan_drake.studies.statistics import ClopperPearsonUpper, WorldsNeeded
from eaplan_drake.studies.sweep import LOWEST, Study

__all__ = ["CERTIFY_RANGES", "Certificate", "Certify", "CertifyReport", "CertifyStudy"]

CERTIFY_RANGES = {
    "wind.speed": [0.0, 12.0],
    "wind.direction_deg": [0.0, 360.0],
    "sensor.noise_std": [0.1, 3.0],
    "sensor.dropout_probability": [0.0, 0.3],
}
"""The world distribution besides the faults (uniform ranges; the benchmark's): wind [m/s],
its direction [deg], sensor noise [W] and the probability that a sample is lost [-]."""


def CertifyStudy(
    scenario: str,
    worlds: int = 300,
    *,
    seed: int = 0,
    rates: str = "fast",
    overrides: dict | None = None,
    fault_model: FaultModelParams | None = None,
) -> Study:
    """The study that certifies ``scenario`` (a shipped name or a YAML path, with ``overrides``
    key path → YAML value): ``worlds`` worlds of :data:`CERTIFY_RANGES` with faults from
    ``fault_model`` (default: the scenario's ``planner.fault_model``, the belief made true),
    each flown with the lowest plan and the scenario's policy."""
    if isinstance(worlds, bool) or not isinstance(worlds, int) or not 1 <= worlds <= 100_000:
        raise ValueError(f"worlds: must be an integer in [1, 100000], got {worlds!r}")
    overrides = dict(overrides or {})
    layers = [OverrideFromAssignment(f"{k}={v}") for k, v in overrides.items()]
    base = LayerScenario(LoadNamedScenario(scenario), layers)
    model = base.planner.fault_model if fault_model is None else fault_model
    model.Validate("fault_model")
    return Study(
        name=f"certify_{base.name}",
        base=str(scenario),
        set=overrides,
        uniform=dict(CERTIFY_RANGES),
        fault_model=model,
        draws=int(worlds),
        seed=int(seed),
        policies=[base.planner.policy],
        lowest_reference=True,
        rates=rates,
    )


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

    @property
    def rate(self) -> float:
        """k / n [-]."""
        return self.excess_failures / self.feasible if self.feasible else math.nan

    @property
    def upper(self) -> float:
        """The exact one-sided upper confidence bound of the excess-failure rate [-]."""
        if not self.feasible:
            return 1.0
        return ClopperPearsonUpper(self.excess_failures, self.feasible, self.confidence)

    @property
    def certified(self) -> bool:
        """The upper bound is at most ε."""
        return self.feasible > 0 and self.upper <= self.eps

    @property
    def worlds_needed(self) -> int:
        """Feasible worlds without a failure that a claim at ε needs."""
        return WorldsNeeded(self.eps, self.confidence)


def Certify(rows: list[dict], eps: float, confidence: float = 0.95) -> list[Certificate]:
    """One :class:`Certificate` per policy of a certify study's rows (``world``, ``policy``,
    ``completed``, ``status``, ``quality``, ``final_margin``)."""
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
            )
        )
    return certificates


def CertifyReport(certificate: Certificate) -> str:
    """The certificate as a few lines of Markdown."""
    c = certificate
    verdict = (
        f"**certified at ε = {c.eps:g}**: the {c.confidence:.0%} upper bound {c.upper:.4f} "
        f"is at most ε"
        if c.certified
        else f"**not certified at ε = {c.eps:g}**: the {c.confidence:.0%} upper bound "
        f"{c.upper:.4f} is above ε"
    )
    lines = [
        f"policy `{c.policy}` on {c.worlds} worlds, {c.feasible} of them completed by the "
        f"lowest plan",
        "",
        f"- excess failures (lost where the lowest plan completes): {c.excess_failures} of "
        f"{c.feasible} = {c.rate:.4f}, exact one-sided {c.confidence:.0%} upper bound "
        f"(Clopper–Pearson) {c.upper:.4f}",
        f"- {verdict}",
        f"- a claim at ε = {c.eps:g} needs at least {c.worlds_needed} feasible worlds without a "
        f"failure ({c.feasible} here)",
        f"- completed: {c.completion:.1%} of all worlds; mission quality (lost = 0) on the "
        f"feasible worlds: {c.mission_quality:.3f}; mean final margin of the completed: "
        f"{c.mean_final_margin:.3f}",
    ]
    if c.errors:
        lines.append(f"- {c.errors} flights ended in an error (counted as lost)")
    return "\n".join(lines) + "\n"
