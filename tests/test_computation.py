"""Tests of the powprofiler table g(c), the Eq. 11 scaling factors and ComputationLoad."""

import csv
import itertools
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (
    Adder,
    ConstantVectorSource,
    LogVectorOutput,
    Sine,
    ZeroOrderHold,
)

from eaplan_drake.energy.computation import (
    ComputationLoad,
    ComputationTable,
    ComputationTableError,
    LoadComputationTable,
    ParseComputationTable,
)
from eaplan_drake.packaged import PACKAGED_TABLES


def _rows(name):
    """The CSV rows of a packaged table, read independently of the module's parser."""
    with open(PACKAGED_TABLES[name], newline="") as f:
        return [[float(x) for x in row] for row in csv.reader(f) if row]


def test_pednet_table_exact_at_grid_points_and_linear_between():
    table = LoadComputationTable("pednet_jetson_nano")
    rows = _rows("pednet_jetson_nano")
    assert table.num_parameters == 1
    assert len(rows) == 5
    np.testing.assert_array_equal(table.lower, [2.0])
    np.testing.assert_array_equal(table.upper, [10.0])
    for c, w in rows:
        assert table.power([c]) == w  # exact at the measured points
    for (c0, w0), (c1, w1) in itertools.pairwise(rows):
        for t in (0.25, 0.5, 0.9):
            c = c0 + t * (c1 - c0)
            assert table.power([c]) == pytest.approx(w0 + t * (w1 - w0), abs=1e-12)
        assert table.gradient([0.5 * (c0 + c1)])[0] == pytest.approx((w1 - w0) / (c1 - c0))


def test_pednet_clamped_outside_range():
    table = LoadComputationTable("pednet_jetson_nano")
    rows = _rows("pednet_jetson_nano")
    assert table.power([-5.0]) == rows[0][1]
    assert table.power([1.999]) == rows[0][1]
    assert table.power([10.5]) == rows[-1][1]
    assert table.power([1e9]) == rows[-1][1]


def test_two_parameter_table_is_a_full_grid_and_multilinear():
    table = LoadComputationTable("two_parameters")
    rows = _rows("two_parameters")
    assert table.num_parameters == 2
    assert len(rows) == 25
    for a, b, w in rows:
        assert table.power([a, b]) == w
    lookup = {(a, b): w for a, b, w in rows}
    grid = sorted({a for a, _, _ in rows})
    rng = np.random.default_rng(3)
    for a0, a1 in itertools.pairwise(grid):
        for b0, b1 in itertools.pairwise(grid):
            # cell midpoint: mean of the four corners (bilinear, analytic)
            mid = table.power([0.5 * (a0 + a1), 0.5 * (b0 + b1)])
            corners = [lookup[(a0, b0)], lookup[(a0, b1)], lookup[(a1, b0)], lookup[(a1, b1)]]
            assert mid == pytest.approx(np.mean(corners), abs=1e-12)
            # random point: bilinear formula
            s, t = rng.uniform(size=2)
            expect = (
                (1 - s) * (1 - t) * lookup[(a0, b0)]
                + (1 - s) * t * lookup[(a0, b1)]
                + s * (1 - t) * lookup[(a1, b0)]
                + s * t * lookup[(a1, b1)]
            )
            got = table.power([a0 + s * (a1 - a0), b0 + t * (b1 - b0)])
            assert got == pytest.approx(expect, abs=1e-12)
            # gradient equals a finite difference inside the cell
            c = np.array([a0 + s * (a1 - a0), b0 + t * (b1 - b0)])
            for j in range(2):
                e = np.zeros(2)
                e[j] = 1e-6
                fd = (table.power(c + e) - table.power(c - e)) / 2e-6
                assert table.gradient(c)[j] == pytest.approx(fd, rel=1e-6, abs=1e-9)
    # clamped per parameter
    assert table.power([-3.0, 50.0]) == lookup[(2.0, 10.0)]
    assert table.power([4.0, 0.0]) == lookup[(4.0, 2.0)]


def test_scaling_factors_eq11_single_parameter():
    table = LoadComputationTable("pednet_jetson_nano")
    rows = _rows("pednet_jetson_nano")
    (c_lo, g_lo), (c_hi, g_hi) = rows[0], rows[-1]
    nu, tau = table.scaling_factors()
    assert nu.shape == tau.shape == (1,)
    assert nu[0] == pytest.approx((g_hi - g_lo) / (c_hi - c_lo), rel=1e-14)
    assert tau[0] == pytest.approx(c_lo * (g_lo - g_hi) / (c_hi - c_lo) + g_lo, rel=1e-14)
    # the linear model passes through both end points
    assert nu[0] * c_lo + tau[0] == pytest.approx(g_lo, abs=1e-12)
    assert nu[0] * c_hi + tau[0] == pytest.approx(g_hi, abs=1e-12)
    assert table.linear_power([6.0]) == pytest.approx(0.5 * (g_lo + g_hi), abs=1e-12)


def test_scaling_factors_two_parameters_first_order_about_lower_corner():
    table = LoadComputationTable("two_parameters")
    lookup = {(a, b): w for a, b, w in _rows("two_parameters")}
    nu, tau = table.scaling_factors()
    assert nu.shape == tau.shape == (2,)
    assert nu[0] == pytest.approx((lookup[(10.0, 2.0)] - lookup[(2.0, 2.0)]) / 8.0)
    assert nu[1] == pytest.approx((lookup[(2.0, 10.0)] - lookup[(2.0, 2.0)]) / 8.0)
    # exact at the lower corner and along both edges through it
    assert table.linear_power([2.0, 2.0]) == pytest.approx(lookup[(2.0, 2.0)], abs=1e-12)
    assert table.linear_power([10.0, 2.0]) == pytest.approx(lookup[(10.0, 2.0)], abs=1e-12)
    assert table.linear_power([2.0, 10.0]) == pytest.approx(lookup[(2.0, 10.0)], abs=1e-12)


def _write(tmp_path: Path, text: str) -> str:
    path = tmp_path / "table.csv"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(
    "text, line, words",
    [
        ("2,5.0\n4,abc\n", 2, "not a number"),
        ("2,5.0\n4,nan\n", 2, "finite"),
        ("4,5.0\n2,6.0\n", 2, "unsorted"),
        ("2,5.0\n2,6.0\n", 2, "duplicate"),
        ("2,5.0\n4,6.0,7.0\n", 2, "columns"),
        ("2,2,1.0\n2,4,1.0\n4,2,1.0\n4,2,1.0\n", 4, "duplicate"),
        ("2,2,1.0\n2,4,1.0\n4,4,1.0\n6,2,1.0\n", 3, "incomplete grid"),
    ],
)
def test_malformed_tables_name_file_and_line(tmp_path, text, line, words):
    path = _write(tmp_path, text)
    with pytest.raises(ComputationTableError, match=words) as info:
        LoadComputationTable(path)
    assert f"{path}:{line}:" in str(info.value)


@pytest.mark.parametrize(
    "text, words",
    [
        ("", "at least 2 data rows"),
        ("2,5.0\n", "at least 2 data rows"),
        ("fps,W\n2,5.0\n", "at least 2 data rows"),
        ("5.0\n6.0\n", ">= 2 columns"),
        ("2,2,1.0\n2,4,1.0\n4,2,1.0\n", "incomplete grid"),
        ("2,2,1.0\n4,2,1.0\n", "at least 2 values"),
    ],
)
def test_malformed_tables_name_file(tmp_path, text, words):
    path = _write(tmp_path, text)
    with pytest.raises(ComputationTableError, match=words) as info:
        LoadComputationTable(path)
    assert path in str(info.value)


def test_header_and_comments_are_accepted():
    table = ParseComputationTable("# measured\nfps,W\n\n2,5.0\n4,7.0\n", source="x.csv")
    assert table.power([3.0]) == pytest.approx(6.0)


def test_unknown_name_is_a_clear_error():
    with pytest.raises(ComputationTableError, match="pednet_jetson_nano"):
        LoadComputationTable("no_such_table")


def test_table_rejects_bad_direct_construction():
    with pytest.raises(ValueError, match="strictly increasing"):
        ComputationTable((np.array([2.0, 2.0]),), np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match="shape"):
        ComputationTable((np.array([2.0, 4.0]),), np.array([1.0, 2.0, 3.0]))
    table = LoadComputationTable("pednet_jetson_nano")
    with pytest.raises(ValueError, match="expected 1"):
        table.power([2.0, 4.0])
    with pytest.raises(ValueError, match="finite"):
        table.power([np.nan])


def test_computation_load_ports_and_output():
    table = LoadComputationTable("two_parameters")
    system = ComputationLoad(table)
    assert system.get_input_port(0).get_name() == "computation_parameters"
    assert system.GetInputPort("computation_parameters").size() == 2
    assert system.GetOutputPort("power").size() == 1
    context = system.CreateDefaultContext()
    for c in ([3.0, 7.0], [10.0, 10.0], [-1.0, 99.0]):
        system.GetInputPort("computation_parameters").FixValue(context, c)
        out = system.GetOutputPort("power").Eval(context)[0]
        assert out == pytest.approx(table.power(c), abs=1e-12)
    with pytest.raises(ValueError):
        ComputationLoad("pednet_jetson_nano")


def test_computation_load_in_simulated_diagram():
    table = LoadComputationTable("pednet_jetson_nano")
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource([7.0]))
    load = builder.AddSystem(ComputationLoad(table))
    builder.Connect(source.get_output_port(), load.GetInputPort("computation_parameters"))
    logger = LogVectorOutput(load.GetOutputPort("power"), builder, 0.1)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(1.0)
    data = logger.FindLog(simulator.get_context()).data()
    assert data.shape[1] >= 10
    assert np.all(np.isfinite(data))
    watts = dict(_rows("pednet_jetson_nano"))
    np.testing.assert_allclose(data, 0.5 * (watts[6.0] + watts[8.0]), atol=1e-12)


class _CountingTable(ComputationTable):
    """The PedNet table, counting its evaluations of g."""

    calls = 0

    def power(self, c) -> float:
        type(self).calls += 1
        return super().power(c)


def test_computation_load_is_evaluated_once_per_change_of_its_parameters():
    # c2 held for 1 s (a ZeroOrderHold, as the planner's state output holds it for h_T) and the
    # power read at 100 Hz: g is evaluated when c2 changes, not at every read.
    base = LoadComputationTable("pednet_jetson_nano")
    table = _CountingTable(base.parameter_grids, base.values, source="counting")
    builder = DiagramBuilder()
    ramp = builder.AddSystem(Sine(3.0, 1.0, 0.0, 1))
    offset = builder.AddSystem(ConstantVectorSource([6.0]))
    adder = builder.AddSystem(Adder(2, 1))
    hold = builder.AddSystem(ZeroOrderHold(1.0, 1))
    load = builder.AddSystem(ComputationLoad(table))
    builder.Connect(ramp.get_output_port(0), adder.get_input_port(0))
    builder.Connect(offset.get_output_port(), adder.get_input_port(1))
    builder.Connect(adder.get_output_port(), hold.get_input_port())
    builder.Connect(hold.get_output_port(), load.GetInputPort("computation_parameters"))
    logger = LogVectorOutput(load.GetOutputPort("power"), builder, 0.01)
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(10.0)
    data = logger.FindLog(simulator.get_context()).data()
    assert data.shape[1] >= 1000
    # One evaluation per hold update (t = 0, 1, …, 10 s), none per 100 Hz read.
    assert _CountingTable.calls <= 11
    # Between the updates (a log sample at t = k s precedes the hold's update at k) the power is
    # g of the value held since ⌊t⌋.
    k = np.flatnonzero(np.arange(data.shape[1]) % 100 != 0)
    held = 6.0 + 3.0 * np.sin(np.floor(k * 0.01))
    np.testing.assert_allclose(data[0, k], [base.power([c]) for c in held], atol=1e-12)
