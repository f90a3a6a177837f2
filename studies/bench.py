"""Speed benchmark: ``slipnav bench [SCENARIO] [--repeat N]`` (a benchmark, not a test).

Runs the scenario's closed loop as the Drake diagram (``run_scenario``, loggers included, as ``slipnav
run`` does) and as the plain sequential loop over the same pure functions (scenarios/plain_loop.py, fed
the seed's sensor noise, as the diagram's sensors read it, so both compute the same samples); each of
``repeat`` rounds runs the diagram, the plain loop and the floor (below) back to back, and the best time
of each counts. Prints the wall times, real-time factors, the plain loop's cost per part, the
Python callbacks the diagram makes per sample (counted in one more, profiled run), and the Drake
framework's overhead: the diagram's wall time per sample less the plain loop's, in units of a measured
floor, the cost of one trivial Python LeafSystem update (``python_block_floor``) on the same machine at
the same time, so that the figure does not move with the machine's speed as wall times do. The last line
is ``realtime_factor=<float> diagram_over_loop=<float> overhead_in_floors=<float>`` (docs/design.md).
"""

import collections
import sys
import time

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource
from slipnav.scenarios.config import ScenarioError, load_scenario
from slipnav.scenarios.plain_loop import run_scenario_plain_loop
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.robot.sensors import sensor_noise


class _PassThrough(LeafSystem):
    """A trivial T_N block: state <- 0.5 * input (for the framework-floor measurement)."""

    def __init__(self, period: float):
        super().__init__()
        self._u = self.DeclareVectorInputPort("u", 5)
        self._x = self.DeclareDiscreteState(5)
        self.DeclareStateOutputPort("y", self._x)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        discrete_state.set_value(self._x, 0.5 * self._u.Eval(context))


def python_block_floor(period: float, blocks: int = 12, steps: int = 1000) -> float:
    """Wall time (s) of one update of a trivial Python LeafSystem in a chain of ``blocks``."""
    builder = DiagramBuilder()
    port = builder.AddSystem(ConstantVectorSource(np.ones(5))).get_output_port()
    for _ in range(blocks):
        block = builder.AddSystem(_PassThrough(period))
        builder.Connect(port, block.get_input_port())
        port = block.get_output_port()
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    start = time.perf_counter()
    simulator.AdvanceTo(steps * period)
    return (time.perf_counter() - start) / (steps * blocks)


def python_callbacks_per_sample(scenario, seed: int) -> tuple[float, dict]:
    """Python functions Drake calls per T_N sample in ``run_scenario(scenario, seed)``: every Python
    function called directly from a pydrake function (an event handler, an output port's calc), counted by
    a profile hook over the whole run and divided by the samples. Returns (per sample, {callback: per
    sample})."""
    counts = collections.Counter()
    stack = []  # per open call: True for a pydrake function, False otherwise

    def hook(frame, event, arg):
        if event == "c_call":
            stack.append((getattr(arg, "__module__", None) or "").startswith("pydrake"))
        elif event == "call":
            if stack and stack[-1]:
                code = frame.f_code
                counts[f"{code.co_filename.rsplit('/', 1)[-1]}:{code.co_firstlineno} {code.co_name}"] += 1
            stack.append(False)
        elif event in ("return", "c_return", "c_exception") and stack:
            stack.pop()

    sys.setprofile(hook)
    try:
        result = run_scenario(scenario, seed=seed)
    finally:
        sys.setprofile(None)
    steps = len(result.arrays["t"])
    return sum(counts.values()) / steps, {name: n / steps for name, n in counts.most_common()}


def bench(name: str = "corner", repeat: int = 3, stream=None) -> dict:
    """Benchmark the closed loop of scenario ``name``; prints the report (to ``stream``, default stdout)
    and returns its figures: the samples, the simulated time and the best wall times of the diagram and
    the plain loop (s), the real-time factors, the plain loop's parts (``parts_s``, s in all), the floor,
    the callbacks per sample and the overhead in floors."""
    stream = stream or sys.stdout
    if not (isinstance(repeat, int) and repeat >= 1):
        raise ScenarioError(f"--repeat={repeat!r} is out of range: allowed 1, 2, ...")
    scenario = load_scenario(name)
    if scenario.controller != "closed_loop":
        raise ScenarioError(f"scenario {name!r} is open loop: bench needs controller: closed_loop")
    if scenario.plant_time_step <= 0.0:
        raise ScenarioError("bench needs the discrete plant (plant_time_step > 0): the plain loop has none")
    seed = scenario.seed
    rates = scenario.rates()
    # Each repeat runs the diagram, the plain loop and the floor back to back, so that on a shared machine
    # whose load moves the three best times come from the same quiet minutes.
    diagram_wall, loop_wall, floor_wall, parts, arrays, noise = [], [], [], {}, None, None
    for _ in range(repeat):
        result = run_scenario(scenario, seed=seed)
        diagram_wall.append(result.summary["wall_time_s"])
        arrays = result.arrays
        steps = len(arrays["t"])
        noise = sensor_noise(seed, steps) if noise is None else noise
        timings = {}
        start = time.perf_counter()
        plain = run_scenario_plain_loop(scenario, seed, steps, noise=noise, timings=timings)
        loop_wall.append(time.perf_counter() - start)
        if loop_wall[-1] == min(loop_wall):
            parts = timings
        floor_wall.append(python_block_floor(rates.T_N))
    # Real-time factor as slipnav run's summary: simulated time (the last sample's t) over the wall time
    # of the simulation alone (building the diagram, collecting the arrays and writing files excluded).
    simulated = float(arrays["t"][-1])
    same = float(
        np.max(np.abs(plain["true_x"] - arrays["true_x"]) + np.abs(plain["true_y"] - arrays["true_y"]))
    )
    diagram, loop, floor = min(diagram_wall), min(loop_wall), min(floor_wall)
    callbacks, _ = python_callbacks_per_sample(scenario, seed)
    per_step = 1e6 / steps
    # The framework's overhead per sample in units of the floor (one trivial Python update), measured
    # on the same machine in the same minute: (diagram - plain loop) per sample / floor.
    floors = (diagram - loop) / steps / floor
    lines = [
        f"{name}: closed loop, {steps} samples of T_N = {rates.T_N * 1e3:g} ms "
        f"({simulated:.2f} s simulated), best of {repeat}",
        f"  Drake diagram   {diagram:7.3f} s wall  real-time factor {simulated / diagram:6.2f}  "
        f"({diagram * per_step:6.0f} us per T_N; {callbacks:.1f} Python callbacks per T_N)",
        f"  plain loop      {loop:7.3f} s wall  real-time factor {simulated / loop:6.2f}  "
        f"({loop * per_step:6.0f} us per T_N; same samples: max position difference {same:.1e} m)",
        "  plain loop per T_N: "
        + ", ".join(f"{part} {seconds * per_step:.0f} us" for part, seconds in parts.items()),
        f"  Drake framework overhead {(diagram - loop) * per_step:.0f} us per T_N = {floors:.1f} floors; "
        f"floor: one trivial Python LeafSystem update costs {floor * 1e6:.1f} us",
        "  targets: real-time factor >= 15, overhead <= 40 floors",
        f"realtime_factor={simulated / diagram:.3f} diagram_over_loop={diagram / loop:.3f} "
        f"overhead_in_floors={floors:.3f}",
    ]
    print("\n".join(lines), file=stream)
    return {
        "samples": steps,
        "simulated_s": simulated,
        "diagram_s": diagram,
        "loop_s": loop,
        "realtime_factor": simulated / diagram,
        "loop_realtime_factor": simulated / loop,
        "diagram_over_loop": diagram / loop,
        "position_difference_m": same,
        "parts_s": parts,
        "python_block_floor_s": floor,
        "python_callbacks_per_sample": callbacks,
        "overhead_in_floors": floors,
    }
