"""A survey plan over a field read from a file: cells, sweep direction, route, time and energy
at the lowest plan, the figure, and the files the ``plan`` command writes.

:func:`MakeFieldPlan` decomposes the field into boustrophedon cells, convex or monotone,
whichever flies shorter (:func:`~eaplan_drake.field.decompose.Decompose`), for the sweep
direction whose route
(:func:`~eaplan_drake.field.route.MakeRoute`) is shortest, i.e. the quickest survey in still air
(or for the stated θ), at the line spacing x_d and the smallest turning radius r_min of the
scenario's ``coverage``. :func:`LowestPlanEnergy` predicts that survey with the scenario's own
models and no flight: motion power P_0 + P_2 ψ̇² (:mod:`eaplan_drake.flight.plant`) with ψ̇ = v_a/R
on turns, the computation table's power at its lowest parameters g(c̲2), and the battery model's
SoC rate ḃ(y) integrated leg by leg from ``battery.initial_soc``. At c̲1 and c̲2 this is the
paper's static lowest plan, without wind and without the approach to the first line.
:func:`LowestPlanRisk` adds its pre-flight fault risk under ``planner.fault_model``, and
:func:`BestStaticPlan` finds the highest-quality static plan (c1, c2) that still completes at the
scenario's risk level, with its point of no return (:func:`PointOfNoReturn`).

Lengths in m, times in s, powers in W, energies in J, angles in degrees.
"""

import dataclasses as dc
import math

import numpy as np

from eaplan_drake.field import nofly
from eaplan_drake.field.decompose import ChooseSweepDirection, Decompose, SweepChoice, SweepLines
from eaplan_drake.field.readers import Field
from eaplan_drake.field.route import Leg, Route, RouteEnergy

__all__ = [
    "AirspaceSummary",
    "BestStaticPlan",
    "EndsSummary",
    "FieldPlan",
    "FormatFieldPlan",
    "WithHomeLegs",
    "LineSpacing",
    "LowestPlanEnergy",
    "LowestPlanRisk",
    "PointOfNoReturn",
    "RoutePrediction",
    "MakeFieldPlan",
    "PlotFieldPlan",
    "SaveFieldPlan",
]


@dc.dataclass(frozen=True)
class FieldPlan:
    """A field's cells and route."""

    field: Field
    choice: SweepChoice
    """The decomposition for the chosen θ and its line count."""
    route: Route
    chosen_by: str
    """How θ was chosen (one line)."""
    no_fly: object = None
    """The :class:`~eaplan_drake.field.nofly.NoFly` the route keeps out of, or None."""


def LineSpacing(coverage, c1: float) -> float:
    """The spacing [m] of the Zamboni-like lines at path parameter c1 [m²]: the shift per
    repetition d = 2 r1 − 2 r2(c1), r1 = r + x_d/2, r2 = sqrt(r² + c1) (paper 003 Eq. 14;
    :mod:`eaplan_drake.flight.coverage`), x_d at c1 = 0; ``coverage`` a
    :class:`~eaplan_drake.params.CoverageParams`."""
    from eaplan_drake.flight.coverage import TurningRadius2

    r, x_d = float(coverage.turning_radius), float(coverage.swath_spacing)
    return 2.0 * (r + 0.5 * x_d) - 2.0 * TurningRadius2(float(c1), r)


def MakeFieldPlan(
    field: Field,
    spacing: float,
    min_turning_radius: float,
    *,
    theta_deg: float | None = None,
    cells: str = "best",
    min_line_length: float = 0.0,
    start=None,
    no_fly=(),
) -> FieldPlan:
    """The plan over ``field`` at line spacing x_d = ``spacing`` and turns of at least r_min =
    ``min_turning_radius`` [m]; θ = ``theta_deg`` [deg from east] or, when None, the direction
    with the shortest route; ``cells`` ``convex``, ``monotone`` (the classic boustrophedon cells,
    fewer and wider) or ``best`` (whichever gives the shorter route; the search compares routes
    that visit the nearest cell next, the plan's route then takes the shortest transits,
    :func:`~eaplan_drake.field.route.MakeRoute`); lines shorter than
    ``min_line_length`` [m] are left out (:func:`~eaplan_drake.field.route.CellSweepLines`: 4 ε
    for a plan the sequencer flies). With ``start`` [m] (home) the route enters the field at the
    cell and end nearest to it (the sweep direction is still the shortest route's). With
    ``no_fly`` polygons [m] the route keeps out of them (:mod:`eaplan_drake.field.nofly`): the
    cells are the field's minus them, and θ is the direction of the shortest route counting each
    metre of survey line the polygons cost as
    :data:`~eaplan_drake.field.nofly.LOST_LINE_WEIGHT` m flown."""
    kinds = {"convex": (True,), "monotone": (False,), "best": (True, False)}
    if cells not in kinds:
        raise ValueError(f"cells: must be one of {', '.join(kinds)}, got {cells!r}")
    if theta_deg is not None and not math.isfinite(theta_deg):
        raise ValueError(f"--sweep-deg: must be a finite angle [deg], got {theta_deg!r}")
    polygon, avoid = field.Polygon(), None
    if len(no_fly):
        avoid = nofly.MakeNoFly(no_fly)
        polygon = nofly.SurveyPolygon(polygon, avoid, spacing)

    def length(d):
        try:
            route = nofly.PlanRoute(
                d, spacing, min_turning_radius, None, min_line_length, avoid, "distance"
            )
        except ValueError:  # no route keeps out of the no-fly polygons
            return math.inf
        return round(Score(d, route), 6)

    def Score(d, route):
        if avoid is None:
            return route.Length()
        return route.Length() + nofly.LOST_LINE_WEIGHT * nofly.LostLineLength(d, route, spacing)

    best = None
    for convex in kinds[cells]:
        if theta_deg is None:
            choice = ChooseSweepDirection(polygon, spacing, cost=length, convex=convex)
            chosen_by = f"shortest route of {choice.candidates} directions (edges and every 5°)"
        else:
            d = Decompose(polygon, theta_deg, convex=convex)
            lines = [ln for c in d.cells for ln in SweepLines(c, d.theta_deg, spacing)]
            total = float(sum(np.linalg.norm(ln[1] - ln[0]) for ln in lines))
            choice = SweepChoice(d, len(lines), total, 1)
            chosen_by = "given (--sweep-deg)"
        d = choice.decomposition
        route = nofly.PlanRoute(d, spacing, min_turning_radius, start, min_line_length, avoid)
        score = Score(d, route)
        if best is None or score < best[0] - 1e-9:
            best = (score, FieldPlan(field, choice, route, chosen_by, avoid))
    return best[1]


def WithHomeLegs(route: Route, home) -> Route:
    """``route`` flown from and back to ``home`` [m]: a straight leg (kind ``home``) from home to
    the route's start and one from its end back home (straight: a lower bound of the climb-out
    and the return, without the turns onto and off the route); ``home`` None: ``route``."""
    if home is None:
        return route
    home = tuple(float(v) for v in home)
    first, last = route.legs[0].start, route.legs[-1].end
    legs = [Leg("home", home, first, math.dist(home, first)), *route.legs]
    legs.append(Leg("home", last, home, math.dist(last, home)))
    return dc.replace(route, legs=tuple(leg for leg in legs if leg.length > 0.0))


def RoutePrediction(route: Route, scenario, computation_parameters, *, table=None) -> dict:
    """Time [s], energy [J], mean power [W] and SoC of flying ``route`` in still air at the
    constant ``computation_parameters`` c2 with ``scenario``'s vehicle, computation table and
    battery (see the module docstring); ``soc_after_leg`` is the SoC at the end of each leg,
    ``final_soc_unclamped`` the final SoC had the pack no bottom (below 0 when it empties), and
    ``reserve_reached`` where the SoC reaches the reserve (leg, path length [m], fraction of the
    route, time [s]) or None.
    ``table``: the scenario's computation table, if already loaded."""
    from eaplan_drake.energy.computation import LoadComputationTable
    from eaplan_drake.flight.plant import MotionPowerCoefficients
    from eaplan_drake.registry import BATTERY_MODELS

    vehicle = scenario.vehicle
    coefficients = MotionPowerCoefficients(vehicle.airspeed, vehicle.motion_power)
    if table is None:
        table = LoadComputationTable(scenario.computation.table)
    c2 = [float(c) for c in computation_parameters]
    g = float(table.power(c2))
    time, energy, mean = RouteEnergy(route, vehicle.airspeed, coefficients, g)
    battery = BATTERY_MODELS.Make(scenario.battery.model, scenario.battery)
    soc = float(scenario.battery.initial_soc)
    reserve = float(scenario.battery.reserve_soc)
    p0, p2 = coefficients
    after, unclamped, flown, reached = [], soc, 0.0, None
    for k, leg in enumerate(route.legs):
        rate = vehicle.airspeed / leg.radius if leg.radius > 0.0 else 0.0
        power, duration = p0 + p2 * rate * rate + g, leg.length / vehicle.airspeed
        soc = battery.SocAfter(soc, power, duration)
        after.append(float(soc))
        drop = -float(battery.SocRate(power)) * duration  # the SoC rate depends on the load only
        if reached is None and unclamped - drop < reserve and drop > 0.0:
            at = flown + leg.length * (unclamped - reserve) / drop
            reached = {"leg": k, "path_m": at, "fraction": at / route.Length(), "time_s": None}
            reached["time_s"] = at / vehicle.airspeed
        unclamped -= drop
        flown += leg.length
    return {
        "time": time,
        "energy": energy,
        "mean_power": mean,
        "computation_power": g,
        "computation_parameters": c2,
        "initial_soc": float(scenario.battery.initial_soc),
        "final_soc": soc,
        "final_soc_unclamped": unclamped,
        "reserve_soc": reserve,
        "reserve_reached": reached,
        "soc_after_leg": after,
    }


def LowestPlanEnergy(plan: FieldPlan, scenario, home=None) -> dict:
    """:func:`RoutePrediction` of ``plan``'s route at the table's lowest parameters c̲2: at
    c̲1 the paper's static lowest plan, without wind; from and back to ``home`` [m] when given
    (:func:`WithHomeLegs`)."""
    from eaplan_drake.energy.computation import LoadComputationTable

    table = LoadComputationTable(scenario.computation.table)
    route = WithHomeLegs(plan.route, home)
    prediction = RoutePrediction(route, scenario, table.lower, table=table)
    del prediction["soc_after_leg"]
    prediction["home_legs_m"] = route.Length("home")
    return prediction


def PointOfNoReturn(route: Route, prediction: dict, scenario, home=None) -> dict | None:
    """The first point along ``route`` (a leg's end) from which flying straight back to ``home``
    [m] (default: the first line's start) at the route's computation power would end below the
    reserve: its leg index, position [m] and time along the route [s]; None when home stays
    reachable from every leg's end (``prediction`` from :func:`RoutePrediction`)."""
    from eaplan_drake.flight.plant import MotionPowerCoefficients
    from eaplan_drake.registry import BATTERY_MODELS

    vehicle = scenario.vehicle
    p0, _ = MotionPowerCoefficients(vehicle.airspeed, vehicle.motion_power)
    battery = BATTERY_MODELS.Make(scenario.battery.model, scenario.battery)
    lines = [leg for leg in route.legs if leg.kind == "line"]
    home = np.asarray(lines[0].start if home is None else home, dtype=float)
    power = p0 + float(prediction["computation_power"])
    t = 0.0
    for k, (leg, soc) in enumerate(zip(route.legs, prediction["soc_after_leg"], strict=True)):
        t += leg.length / vehicle.airspeed
        back = float(np.linalg.norm(np.asarray(leg.end) - home)) / vehicle.airspeed
        if battery.SocAfter(soc, power, back) < scenario.battery.reserve_soc:
            return {"leg": k, "position_m": [float(v) for v in leg.end], "time_s": t}
    return None


def BestStaticPlan(plan: FieldPlan, scenario, *, grid_size: int = 11, home=None) -> dict:
    """The highest-quality static plan (c1, c2) that a stock autopilot could fly over ``plan``'s
    cells without the in-flight planner and still complete at the scenario's risk level: among
    ``grid_size`` values of c1 over ``planner.path_parameter_bounds`` (each with its own line
    spacing over the same cells and direction) and the computation table's grid of c2, the one of
    highest quality ½ c̃1 + ½ c̃2 (ties: the lower) whose margin m = final SoC − reserve is ≥ 0
    and whose excess risk under ``planner.fault_model`` is at most ε = ``planner.risk``.

    The excess risk of a static plan (time τ, margin m) over the static lowest plan (τ_0, m_0) is
    the probability that it fails although the lowest plan would have completed (the risk
    planner's definition, :mod:`eaplan_drake.planning.risk`): as τ ≥ τ_0 and m ≤ m_0 the lowest
    plan's failures are among the plan's, so it is P(S(τ) > m) − P(S(τ_0) > m_0) with S(τ) the
    total SoC drop in τ. Returns the plan's c1 [m²], c2, quality, prediction, margin, excess
    risk, point of no return (:func:`PointOfNoReturn`) and how many grid plans were tried. With
    ``home`` [m] every plan flies from and back to it (:func:`WithHomeLegs`)."""
    import itertools

    from eaplan_drake.energy.computation import LoadComputationTable
    from eaplan_drake.planning.risk import TotalDropTail
    from eaplan_drake.planning.risk_margin import FaultModelFromParams

    if not (isinstance(grid_size, int) and grid_size >= 2):
        raise ValueError(f"grid_size: must be an integer >= 2, got {grid_size!r}")
    coverage = scenario.coverage
    lo, hi = (float(v) for v in scenario.planner.path_parameter_bounds)
    table = LoadComputationTable(scenario.computation.table)
    model = FaultModelFromParams(scenario.planner.fault_model)
    eps = float(scenario.planner.risk)
    lower, span = np.asarray(table.lower), np.asarray(table.upper) - np.asarray(table.lower)
    reserve = float(scenario.battery.reserve_soc)

    def Tail(tau, margin):
        return 1.0 if margin < 0.0 else float(TotalDropTail(model, tau, margin))

    d = plan.choice.decomposition
    lowest = None
    best = None
    tried = 0
    for c1 in np.linspace(lo, hi, grid_size):
        try:
            spacing, r_min = LineSpacing(coverage, c1), coverage.min_turning_radius
            route = nofly.PlanRoute(
                d, spacing, r_min, None, 4.0 * coverage.trigger_radius, plan.no_fly
            )
        except ValueError:  # no route at this spacing keeps out of the no-fly polygons
            continue
        flown = WithHomeLegs(route, home)
        for c2 in itertools.product(*table.parameter_grids):
            tried += 1
            p = RoutePrediction(flown, scenario, c2, table=table)
            margin = p["final_soc"] - reserve
            if lowest is None:  # c̲1, c̲2 come first
                lowest = (p["time"], margin)
            excess = max(0.0, Tail(p["time"], margin) - Tail(*lowest))
            u2 = np.divide(np.asarray(c2) - lower, span, out=np.zeros_like(span), where=span > 0)
            quality = 0.5 * (c1 - lo) / (hi - lo) + 0.5 * float(np.mean(u2)) if hi > lo else 0.0
            if margin >= 0.0 and excess <= eps and (best is None or quality > best[0] + 1e-12):
                best = (quality, float(c1), [float(v) for v in c2], flown, p, margin, excess)
    if best is None:
        return {"feasible": False, "risk": eps, "plans_tried": tried}
    quality, c1, c2, route, p, margin, excess = best
    pnr = PointOfNoReturn(route, p, scenario, home)
    if pnr is not None:
        pnr["lon_lat"] = [float(v) for v in plan.field.frame.ToLonLat([pnr["position_m"]])[0]]
    prediction = {k: v for k, v in p.items() if k != "soc_after_leg"}
    return {
        "feasible": True,
        "path_parameter_c1": c1,
        "computation_parameters": c2,
        "quality": quality,
        "prediction": prediction,
        "margin": margin,
        "excess_risk": excess,
        "risk": eps,
        "point_of_no_return": pnr,
        "plans_tried": tried,
    }


def LowestPlanRisk(energy: dict, scenario) -> dict:
    """The pre-flight risk of the lowest plan under ``scenario``'s ``planner.fault_model``
    (:mod:`eaplan_drake.planning.risk`): the probability P(S(τ_0) > m_0) that the SoC drops
    during its time τ_0 [s] exceed its margin m_0 = final SoC − reserve [-] (1 when m_0 < 0), and
    the margin at risk: the smallest margin m with P(S(τ_0) > m) <= ε = ``planner.risk``."""
    from eaplan_drake.planning.risk import MarginAtRisk, TotalDropTail
    from eaplan_drake.planning.risk_margin import FaultModelFromParams

    model = FaultModelFromParams(scenario.planner.fault_model)
    eps = float(scenario.planner.risk)
    tau, margin = float(energy["time"]), float(energy["final_soc"] - energy["reserve_soc"])
    return {
        "fault_rate": model.rate,
        "risk": eps,
        "margin": margin,
        "failure_probability": float(TotalDropTail(model, tau, margin)),
        "margin_at_risk": float(MarginAtRisk(model, tau, eps)),
    }


def Summary(plan: FieldPlan, energy: dict | None = None) -> dict:
    """The plan's numbers as a JSON-ready dict."""
    route, d = plan.route, plan.choice.decomposition
    out = {
        "field": plan.field.source,
        "origin_lon_lat": [plan.field.frame.lon, plan.field.frame.lat],
        "area_m2": plan.field.area,
        "holes": len(plan.field.holes),
        "notes": list(plan.field.notes),
        "cells": len(d.cells),
        "cell_kind": "convex" if d.convex else "monotone",
        "trapezoids": d.trapezoids,
        "sweep_deg_from_east": d.theta_deg,
        "line_bearing_deg": (90.0 - d.theta_deg) % 180.0,
        "sweep_chosen_by": plan.chosen_by,
        "line_spacing_m": route.spacing,
        "min_turning_radius_m": route.min_turning_radius,
        "lines": route.Count("line"),
        "turns": route.turns,
        "loops": route.loops,
        "transits": route.transits,
        "line_length_m": route.Length("line"),
        "turn_length_m": route.Length("turn"),
        "transit_length_m": route.Length("transit"),
        "path_length_m": route.Length(),
    }
    if plan.no_fly is not None:
        out["no_fly"] = nofly.NoFlySummary(plan.no_fly, route, plan.field.Polygon())
    if energy is not None:
        out["lowest_plan"] = energy
    return out


def EndsSummary(field: Field, ends, altitude: float, ground_source: str | None) -> dict:
    """Home, altitudes and the end of the missions as a JSON-ready dict (``ends`` a
    :class:`~eaplan_drake.field.missions.MissionEnds` with its home set; ``ground_source``: where
    the ground altitude came from, None when nothing gave it)."""
    lon, lat = (float(v) for v in field.frame.ToLonLat(np.array([ends.home]))[0])
    return {
        "home_lon_lat": [lon, lat],
        "home_m": [float(v) for v in ends.home],
        "altitude_above_home_m": float(altitude),
        "ground_alt_amsl_m": float(ends.ground_alt),
        "ground_alt_from": ground_source,
        "end": ends.end,
    }


def AirspaceSummary(airspace, check: dict) -> dict:
    """The airspace (:class:`~eaplan_drake.field.airspace.Airspace`) and the route's check
    against its exported fence as a JSON-ready dict."""
    return {
        "margin_m": airspace.margin,
        "required": airspace.required,
        "area_m2": float(airspace.polygon.area),
        "vertices": len(airspace.polygon.exterior.coords) - 1,
        "no_fly": len(airspace.no_fly),
        "check": check,
    }


def _AirspaceLines(a: dict | None) -> list[str]:
    """The ``airspace`` and ``fence check`` lines."""
    if a is None:
        return []
    r, c = a["required"], a["check"]
    return [
        f"airspace        field + {a['margin_m']:.1f} m (smallest that works: lines "
        f"{r['line_m']:.1f} m + turns {r['route_m'] - r['line_m']:.1f} m × {r['stretch']:.3f} in "
        f"the wind + {r['allowance']:g} m tracking = {r['margin']:.1f} m); inclusion fence of "
        f"{a['vertices']} vertices, {a['no_fly']} no-fly exclusions",
        f"fence check     {c['outside']} of {c['points']} route points outside the exported "
        f"fence, {c['in_no_fly']} in no-fly polygons",
    ]


def _MissionLines(m: dict | None) -> list[str]:
    """The ``home`` and ``altitudes`` lines of the summary's ``mission``."""
    if m is None:
        return []
    lines = []
    end = "return to launch" if m["end"] == "rtl" else "approach and landing at home"
    lines.append(
        f"home            lon {m['home_lon_lat'][0]:.6f}, lat {m['home_lon_lat'][1]:.6f}: "
        f"takeoff, survey, {end}"
    )
    ground = (
        f"ground {m['ground_alt_amsl_m']:g} m AMSL (from {m['ground_alt_from']})"
        if m["ground_alt_from"]
        else "ground assumed at 0 m AMSL: give --ground-alt (Paparazzi's altitudes are AMSL)"
    )
    lines.append(
        f"altitudes       {m['altitude_above_home_m']:g} m above home "
        f"({m['ground_alt_amsl_m'] + m['altitude_above_home_m']:g} m AMSL); {ground}"
    )
    return lines


def _LowestPlanLines(e: dict | None) -> list[str]:
    """The ``lowest plan``, ``battery`` and ``reserve at`` lines of the lowest plan."""
    if e is None:
        return []
    lines = []
    margin = e["final_soc"] - e["reserve_soc"]
    lines += [
        f"lowest plan     {e['time']:.0f} s ({e['time'] / 60:.1f} min) in still air"
        + (f" with {e['home_legs_m']:.0f} m to and from home" if e.get("home_legs_m") else "")
        + f", {e['energy'] / 1e3:.1f} kJ, mean {e['mean_power']:.1f} W (computation "
        f"{e['computation_power']:.1f} W at c2 = "
        f"{', '.join(f'{c:g}' for c in e['computation_parameters'])})",
        f"battery         SoC {e['initial_soc']:.3f} -> "
        + (
            f"{e['final_soc']:.3f}"
            if e.get("final_soc_unclamped", 0.0) >= 0.0
            else f"empty ({e['final_soc_unclamped']:.3f} had it no bottom)"
        )
        + f" (reserve {e['reserve_soc']:.2f}: margin "
        + (
            f"{margin:+.3f})"
            if margin >= 0.0
            else f"{e['final_soc_unclamped'] - e['reserve_soc']:+.3f}: below the reserve, "
            "the survey does not fit)"
        ),
    ]
    r = e.get("reserve_reached")
    if r is not None:
        lines.append(
            f"reserve at      {r['time_s']:.0f} s, {r['path_m']:.0f} m along the route "
            f"({100.0 * r['fraction']:.0f} % of it, leg {r['leg']}): the part that fits"
        )
    return lines


def FormatFieldPlan(summary: dict) -> str:
    """The summary as the ``plan`` command prints it."""
    s = summary
    lines = [
        f"field           {s['field']} ({s['area_m2'] / 1e4:.2f} ha, {s['holes']} holes)",
        f"origin          lon {s['origin_lon_lat'][0]:.6f}, lat {s['origin_lon_lat'][1]:.6f}",
    ]
    lines += [f"note            {n}" for n in s["notes"]]
    lines += [
        f"cells           {s['cells']} {s['cell_kind']} boustrophedon cells (from "
        f"{s['trapezoids']} trapezoids)",
        f"sweep           lines at {s['sweep_deg_from_east']:.1f}° from east (bearing "
        f"{s['line_bearing_deg']:.1f}°); {s['sweep_chosen_by']}",
        f"lines           {s['lines']} at {s['line_spacing_m']:.2f} m"
        + (f" (c1 = {s['path_parameter_c1']:g} m²)" if "path_parameter_c1" in s else "")
        + f", {s['line_length_m']:.0f} m",
        f"turns           {s['turns']} (r >= {s['min_turning_radius_m']:.2f} m; {s['loops']} "
        f"of three arcs where lines are closer than 2 r_min), {s['turn_length_m']:.0f} m",
        f"transits        {s['transits']} between cells, {s['transit_length_m']:.0f} m",
        f"path length     {s['path_length_m']:.0f} m",
    ]
    lines += nofly.NoFlyLines(s.get("no_fly"))
    lines += _MissionLines(s.get("mission"))
    lines += _AirspaceLines(s.get("airspace"))
    lines += _LowestPlanLines(s.get("lowest_plan"))
    r = s.get("lowest_plan_risk")
    if r is not None:
        ok = r["margin"] >= r["margin_at_risk"]
        lines.append(
            f"fault risk      P(drops > margin) = {r['failure_probability']:.3g} at "
            f"{r['fault_rate']:g} drops/s (planner.fault_model); margin at risk "
            f"{r['margin_at_risk']:.3f} for ε = {r['risk']:g}: "
            + (
                "the margin covers it"
                if ok
                else f"short by {r['margin_at_risk'] - r['margin']:.3f}"
            )
        )
    b = s.get("best_static_plan")
    if b is not None and not b["feasible"]:
        lines.append(
            f"best plan       none of {b['plans_tried']} static plans fits at ε = {b['risk']:g}"
        )
    elif b is not None:
        e = b["prediction"]
        c2 = ", ".join(f"{v:g}" for v in b["computation_parameters"])
        lines.append(
            f"best plan       c1 = {b['path_parameter_c1']:g} m², c2 = {c2} (quality "
            f"{b['quality']:.3f}): {e['time']:.0f} s, {e['energy'] / 1e3:.1f} kJ, SoC "
            f"{e['final_soc']:.3f} (margin {b['margin']:+.3f}), excess risk {b['excess_risk']:.3f}"
            f" <= ε = {b['risk']:g}; the highest-quality static plan of {b['plans_tried']}"
        )
        pnr = b["point_of_no_return"]
        lines.append(
            "no return       home stays within reach from the whole route"
            if pnr is None
            else f"no return       after {pnr['time_s']:.0f} s (leg {pnr['leg']}, lon "
            f"{pnr['lon_lat'][0]:.6f}, lat {pnr['lon_lat'][1]:.6f}): from there home is "
            "beyond the reserve"
        )
    return "\n".join(lines)


_ROUTE_STYLE = {
    "line": ("survey lines", {"color": "#1f5fbf", "lw": 0.8}),
    "turn": ("turns", {"color": "#e08a1e", "lw": 0.6}),
    "transit": ("transits", {"color": "#444444", "lw": 0.8, "ls": "--"}),
    "home": ("from and to home", {"color": "#7b3fa0", "lw": 0.9, "ls": ":"}),
}


def _DrawField(ax, plan: FieldPlan) -> list:
    """The field, its holes and its numbered cells; returns their legend handles."""
    from matplotlib.patches import Patch
    from matplotlib.patches import Polygon as PolygonPatch

    field = plan.field
    ax.add_patch(PolygonPatch(field.exterior, closed=True, fc="#e3f1d4", ec="#4d7a2a", lw=1.5))
    handles = [Patch(fc="#e3f1d4", ec="#4d7a2a", label="field")]
    for h in field.holes:
        ax.add_patch(PolygonPatch(h, closed=True, fc="white", ec="#4d7a2a", lw=1.2, hatch="//"))
    if field.holes:
        handles.append(Patch(fc="white", ec="#4d7a2a", hatch="//", label="hole (not surveyed)"))
    for k, cell in enumerate(plan.choice.decomposition.cells):
        ax.add_patch(PolygonPatch(cell.vertices, closed=True, fill=False, ec="#888888", lw=0.8))
        cx, cy = np.mean(cell.vertices, axis=0)
        ax.text(cx, cy, str(k), color="#555555", fontsize=9, ha="center", va="center")
    return handles + [Patch(fill=False, ec="#888888", label="cells (visiting order)")]


def _DrawRoute(ax, route: Route, home) -> list:
    """Every leg of ``route`` (from and back to ``home`` [m] if given) and the start; returns
    their legend handles."""
    from matplotlib.lines import Line2D

    from eaplan_drake.field.airspace import LegPoints

    flown = WithHomeLegs(route, home)
    for leg in flown.legs:
        ax.plot(*LegPoints(leg, 5.0).T, **_ROUTE_STYLE[leg.kind][1])
    handles = [
        Line2D([], [], label=label, **style)
        for kind, (label, style) in _ROUTE_STYLE.items()
        if flown.Count(kind)
    ]
    start, label = (route.legs[0].start, "start") if home is None else (home, "home")
    color = _ROUTE_STYLE["home" if home is not None else "line"][1]["color"]
    ax.plot(*start, "o", color=color, ms=6)
    return handles + [Line2D([], [], marker="o", ls="", ms=6, color=color, label=label)]


def _DrawAirspace(ax, airspace) -> list:
    """The inclusion fence and the no-fly polygons; returns their legend handles."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.patches import Polygon as PolygonPatch

    if airspace is None:
        return []
    ax.plot(*np.asarray(airspace.polygon.exterior.coords).T, color="tab:red", lw=1.0, ls="--")
    label = f"airspace, inclusion fence (field + {airspace.margin:.0f} m)"
    handles = [Line2D([], [], color="tab:red", lw=1.0, ls="--", label=label)]
    for zone in airspace.no_fly:
        ring = np.asarray(zone.exterior.coords)
        ax.add_patch(PolygonPatch(ring, closed=True, fc="#f4c7c3", ec="tab:red", hatch="xx"))
    if airspace.no_fly:
        handles.append(Patch(fc="#f4c7c3", ec="tab:red", hatch="xx", label="no-fly"))
    return handles


def _DrawScaleAndNorth(ax) -> None:
    """A scale bar (bottom left) and a north arrow (top right) in the axes' current limits."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    span = max(x1 - x0, y1 - y0)
    scale = 10 ** math.floor(math.log10(span / 4.0))
    scale *= 5 if span / 4.0 >= 5 * scale else (2 if span / 4.0 >= 2 * scale else 1)
    bx, by = x0 + 0.05 * (x1 - x0), y0 + 0.05 * (y1 - y0)
    ax.plot([bx, bx + scale], [by, by], color="black", lw=3)
    ax.text(bx + scale / 2, by + 0.015 * span, f"{scale:g} m", ha="center", va="bottom")
    nx, ny = x1 - 0.06 * (x1 - x0), y1 - 0.16 * (y1 - y0)
    ax.annotate(
        "N",
        xy=(nx, ny + 0.1 * span),
        xytext=(nx, ny),
        ha="center",
        va="top",
        fontsize=12,
        fontweight="bold",
        arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.5},
    )


def PlotFieldPlan(plan: FieldPlan, airspace=None, home=None):
    """A matplotlib ``Figure`` of the field, its holes and cells, the whole route (lines, every
    piece of the turns, transits, and with ``home`` [m] the legs from and to it), the
    ``airspace`` (:class:`~eaplan_drake.field.airspace.Airspace`: inclusion fence and no-fly
    polygons) if given, in the local frame, with a legend, a north arrow and a scale bar."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10.0, 7.0))
    ax = fig.add_subplot()
    handles = _DrawField(ax, plan)
    handles += _DrawRoute(ax, plan.route, home)
    handles += _DrawAirspace(ax, airspace)
    ax.set_aspect("equal")
    ax.autoscale_view()
    _DrawScaleAndNorth(ax)
    d = plan.choice.decomposition
    ax.set_title(
        f"{len(d.cells)} cells, {plan.route.Count('line')} lines at {d.theta_deg:.1f}° from "
        f"east, {plan.route.Length() / 1e3:.2f} km"
    )
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def SaveFieldPlan(
    plan: FieldPlan,
    directory,
    *,
    summary: dict,
    altitude: float,
    cruise_speed: float,
    ends=None,
    airspace=None,
    missions: bool = True,
) -> list:
    """Writes ``directory`` as a whole (:func:`~eaplan_drake.files.ResultDirectory`): the three
    missions (:func:`~eaplan_drake.field.missions.WriteMissions`, between ``ends`` and inside
    the ``airspace``'s fence, :class:`~eaplan_drake.field.airspace.Airspace`; left out when
    ``missions`` is False), ``plan.png`` (:func:`PlotFieldPlan`) and ``summary.json``; returns
    the paths written (in their final directory)."""
    from pathlib import Path

    from eaplan_drake.field.missions import MissionEnds, WriteMissions
    from eaplan_drake.files import AtomicWrite, ResultDirectory, StrictJson

    ends = MissionEnds() if ends is None else ends
    fence = None if airspace is None else airspace.Fence()
    home = None if ends.home is None else ends.Home(plan.route)
    final = Path(directory)
    with ResultDirectory(final) as tmp:
        written = []
        if missions:
            written += WriteMissions(
                tmp,
                plan.route,
                plan.field,
                altitude=altitude,
                cruise_speed=cruise_speed,
                ends=ends,
                fence=fence,
            ).values()
        fig = PlotFieldPlan(plan, airspace, home)
        written.append(
            AtomicWrite(tmp / "plan.png", lambda f: fig.savefig(f, format="png", dpi=120), True)
        )
        text = StrictJson(summary)
        written.append(AtomicWrite(tmp / "summary.json", lambda f: f.write(text), False))
    return [final / p.name for p in written]
