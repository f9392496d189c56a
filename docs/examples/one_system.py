"""One eaplan_drake system in your own diagram: a Rint battery under a constant 33 W load."""

from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from eaplan_drake.energy.battery import Battery
from eaplan_drake.params import BatteryParams

builder = DiagramBuilder()
load = builder.AddSystem(ConstantVectorSource([33.0]))  # W
battery = builder.AddSystem(Battery(BatteryParams(), time_step=0.01))
builder.Connect(load.get_output_port(), battery.GetInputPort("power"))
diagram = builder.Build()
simulator = Simulator(diagram)
simulator.AdvanceTo(100.0)
context = battery.GetMyContextFromRoot(simulator.get_context())
print(f"SoC after 100 s: {battery.GetOutputPort('soc').Eval(context)[0]:.4f}")  # 0.9806
