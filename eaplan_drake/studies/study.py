"""A study's schema: the :class:`Study` file (YAML) and its checks. Every range names its key and
the allowed values; the number of flights is counted from the study before any flight is built,
and a study of more than :data:`MAX_STUDY_FLIGHTS` is refused (:func:`StudyFlightCount`)."""

import dataclasses as dc
import math
from pathlib import Path

from eaplan_drake.errors import ScenarioError
from eaplan_drake.files import MissingFile, ReadTextFile
from eaplan_drake.loading import MAX_SCENARIO_BYTES, YamlData
from eaplan_drake.params import MAX_FAULTS, FaultModelParams
from eaplan_drake.rates import DEFAULT_STUDY_RATES, RATE_PRESETS

__all__ = [
    "FaultDistribution",
    "KEEP_RATES",
    "LoadStudy",
    "MAX_STUDY_FLIGHTS",
    "Study",
    "StudyFlightCount",
]

KEEP_RATES = "scenario"
"""``Study.rates`` value that keeps the base scenario's own rates."""

MAX_STUDY_FLIGHTS = 40_000
"""The most flights a study may ask for: its worlds' scenarios are built before the first flight
(about 20 kB each) and every row is kept, so a larger study would take the machine's memory."""

MAX_DRAWS = 1_000_000
"""Largest ``draws`` a study file may give (the flights are bounded apart)."""


@dc.dataclass
class FaultDistribution:
    """Random battery faults: a count, and each fault's time and size, all uniform."""

    count: list[int] = dc.field(default_factory=lambda: [0, 3])
    """[min, max] number of faults (integers, inclusive)."""
    time: list[float] = dc.field(default_factory=lambda: [0.0, 500.0])
    """[min, max] time of a fault [s]."""
    soc_drop: list[float] = dc.field(default_factory=lambda: [0.0, 0.15])
    """[min, max] SoC lost per fault [-] (a drop of 0 is stored as 1e-6)."""


@dc.dataclass
class Study:
    """A study file (YAML). Keys are scenario key paths (``wind.speed``)."""

    name: str = "study"
    base: str = "plan_i"
    """Shipped scenario name or YAML path (relative to the study file)."""
    set: dict = dc.field(default_factory=dict)
    """Fixed overrides, key path → YAML value (as ``--set``)."""
    grid: dict = dc.field(default_factory=dict)
    """Key path → list of YAML values; every combination is flown."""
    uniform: dict[str, list[float]] = dc.field(default_factory=dict)
    """Key path → [low, high]."""
    normal: dict[str, list[float]] = dc.field(default_factory=dict)
    """Key path → [mean, standard deviation]."""
    choice: dict = dc.field(default_factory=dict)
    """Key path → list of YAML values, one drawn uniformly."""
    faults: FaultDistribution | None = None
    """Random battery faults (replace the base's), or none."""
    fault_model: FaultModelParams | None = None
    """Random battery faults drawn from a fault model (replace the base's): Poisson arrivals of
    rate ``rate`` over the flight's ``simulation.time_limit``, sizes from its distribution. The
    base's own ``planner.fault_model`` makes the planner's belief true; another one is a
    mismatch. Not together with ``faults``."""
    fault_proposal: object = None
    """A :class:`~eaplan_drake.studies.sampling.FaultProposal` (Python only): draws from
    ``proposal_from`` on take the ``fault_model``'s drops in its window from it, and their rows
    carry ``weight`` (the exact likelihood ratio), ``weight_bound`` and ``stratum``."""
    proposal_from: int = 0
    """First draw drawn from ``fault_proposal`` (the ones before: as declared, weight 1)."""
    draws: int = 1
    """Number of random draws per grid point."""
    seed: int = 0
    """Study seed; each draw's ``random_seed`` (hence its sensor noise) derives from it."""
    policies: list[str] = dc.field(default_factory=lambda: ["mpc"])
    """Planner policies flown on every world."""
    lowest_reference: bool = True
    """Also fly every world with the static lowest plan (c1 = c̲1, c2 = c̲2)."""
    rates: str = DEFAULT_STUDY_RATES
    """Rates of every flight: a preset of :data:`~eaplan_drake.rates.RATE_PRESETS` applied to the
    base scenario before ``set`` (:func:`~eaplan_drake.rates.WithRates`): ``fast`` (default;
    20 Hz plant, 10 Hz averaging sensor and filter, README "Rates"), ``paper`` (100 Hz, as
    ``simulate``), or ``scenario`` (the base scenario's own rates)."""

    def Validate(self, where: str = "") -> "Study":
        """Checks every key (ScenarioError: one line, ``where`` + the key + its allowed values)
        and the number of flights (:func:`StudyFlightCount` at most :data:`MAX_STUDY_FLIGHTS`),
        before any flight is built. Returns the study."""
        if self.faults is not None and self.fault_model is not None:
            raise ScenarioError(f"{where}faults, fault_model: give one of them, not both")
        for key in ("set", "grid", "uniform", "normal", "choice"):
            if not isinstance(getattr(self, key), dict):
                raise ScenarioError(f"{where}{key}: expected a mapping of key paths")
        for k, v in self.uniform.items():
            _Range(where, f"uniform.{k}", v)
        for k, v in self.normal.items():
            _Range(where, f"normal.{k}", v, spread=True)
        for key in ("grid", "choice"):
            for k, v in getattr(self, key).items():
                if not (isinstance(v, list) and v):
                    raise ScenarioError(f"{where}{key}.{k}: expected a non-empty list, got {v!r}")
        if self.faults is not None:
            f = self.faults
            _Range(where, "faults.count", f.count, low=0, high=MAX_FAULTS, integer=True)
            _Range(where, "faults.time", f.time, low=0.0)
            _Range(where, "faults.soc_drop", f.soc_drop, low=0.0, high=1.0)
        if self.fault_model is not None:
            self.fault_model.Validate(f"{where}fault_model")
        for key, value, low, high in (
            ("draws", self.draws, 1, MAX_DRAWS),
            ("seed", self.seed, 0, None),
        ):
            inside = low <= value and (high is None or value <= high)
            if isinstance(value, bool) or not isinstance(value, int) or not inside:
                allowed = f"in [{low}, {high}]" if high is not None else f">= {low}"
                raise ScenarioError(f"{where}{key}: must be an integer {allowed}, got {value!r}")
        if not (isinstance(self.policies, list) and self.policies):
            raise ScenarioError(f"{where}policies: needs at least one policy")
        if self.rates not in (*RATE_PRESETS, KEEP_RATES):
            raise ScenarioError(
                f"{where}rates: must be one of {', '.join((*RATE_PRESETS, KEEP_RATES))}, "
                f"got {self.rates!r}"
            )
        flights = StudyFlightCount(self)
        if flights > MAX_STUDY_FLIGHTS:
            points = " × ".join(str(len(v)) for v in self.grid.values()) or "1"
            per_world = len(self.policies) + bool(self.lowest_reference)
            raise ScenarioError(
                f"{where}draws × grid × flights per world: {self.draws} × {points} × {per_world} "
                f"= {flights} flights; at most {MAX_STUDY_FLIGHTS} (fewer draws or grid values, "
                "or several studies)"
            )
        return self


def LoadStudy(filename: str | Path) -> tuple[Study, Path]:
    """The :class:`Study` of a YAML file and the file's directory. ScenarioError (one line
    naming the file and the key) on bad input."""
    path = Path(filename)
    if MissingFile(path, "study file"):
        raise ScenarioError(f"{path}: {MissingFile(path, 'study file')}")
    raw = YamlData(ReadTextFile(path, MAX_SCENARIO_BYTES, ScenarioError), str(path))
    if not isinstance(raw, dict):
        raise ScenarioError(f"{path}: a study is a mapping of keys")
    fields = {f.name for f in dc.fields(Study)}
    for key in raw:
        if key not in fields:
            raise ScenarioError(f"{path}: {key}: unknown key (known: {', '.join(sorted(fields))})")
    try:
        if raw.get("faults") is not None:
            raw["faults"] = FaultDistribution(**raw["faults"])
        if raw.get("fault_model") is not None:
            raw["fault_model"] = FaultModelParams(**raw["fault_model"])
            raw["fault_model"].Validate(f"{path}: fault_model")
        study = Study(**raw)
    except TypeError as e:
        raise ScenarioError(f"{path}: {e}") from None
    if raw.get("fault_proposal") is not None or raw.get("proposal_from"):
        raise ScenarioError(f"{path}: fault_proposal, proposal_from: set by certify, not in a file")
    study.Validate(f"{path}: ")
    return study, path.parent


def StudyFlightCount(study: Study) -> int:
    """The number of flights of ``study``: grid points × draws × (policies + the lowest plan),
    counted from its keys, before any flight is built."""
    points = math.prod(len(v) for v in study.grid.values()) if study.grid else 1
    return points * int(study.draws) * (len(study.policies) + bool(study.lowest_reference))


def _Range(
    where: str, key: str, value, *, low=-math.inf, high=math.inf, integer=False, spread=False
):
    """[a, b] of finite numbers (integers) with low <= a <= b <= high (for ``spread``: a mean and a
    standard deviation >= 0), or a ScenarioError naming ``key`` and the allowed values."""
    kind = "integers" if integer else "finite numbers"
    bounds = "low <= high"
    if math.isfinite(low):
        bounds = f"{low:g} <= {bounds}"
    if math.isfinite(high):
        bounds = f"{bounds} <= {high:g}"
    rule = (
        f"[mean, standard deviation >= 0] of {kind}"
        if spread
        else (f"[low, high] of {kind} with {bounds}")
    )
    ok = isinstance(value, list | tuple) and len(value) == 2
    ok = ok and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value
    )
    if ok and integer:
        ok = all(float(v).is_integer() for v in value)
    if ok:
        a, b = (float(v) for v in value)
        ok = b >= 0.0 if spread else low <= a <= b <= high
    if not ok:
        raise ScenarioError(f"{where}{key}: must be {rule}, got {value!r}")
