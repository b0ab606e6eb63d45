"""Static scheduler: seed 002's resolution cases, offsets and call patterns, the main loop."""

from __future__ import annotations

import itertools
import math
import statistics
from collections.abc import Callable, Sequence

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.fcu import (
    OFFSET_STRATEGIES,
    BindingError,
    ConflictError,
    DependencyCycleError,
    EventSpec,
    InitSpec,
    ManualClock,
    MissingFunctionalityError,
    ModuleSpec,
    ModuleSpecError,
    OffsetRequest,
    PeriodicSpec,
    RateError,
    ResolvedSchedule,
    Scheduler,
    SchedulerError,
    SchedulerReport,
    TaskGroup,
    UnknownStrategyError,
    call_pattern,
    modules_from_yaml,
    resolve,
    sort_modules,
)
from sim.fcu.scheduler import _RateMeter

G = TaskGroup
MAIN_HZ = 500
# prescalers that divide a 500 Hz main loop, as real firmware rates do
PRESCALERS = (1, 2, 4, 5, 10, 20, 25, 50, 100, 125, 250, 500)


def names(modules: Sequence[ModuleSpec]) -> list[str]:
    return [m.name for m in modules]


def periodic_module(name: str, *rates_hz: float, group: TaskGroup = G.DEFAULT) -> ModuleSpec:
    return ModuleSpec(
        name,
        group,
        periodics=tuple(PeriodicSpec(f"{name}_{i}", freq_hz=hz) for i, hz in enumerate(rates_hz)),
    )


def noop_bindings(schedule: ResolvedSchedule) -> dict[str, Callable[[], object]]:
    funs = [c.fun for c in schedule.inits] + [p.fun for p in schedule.periodics]
    funs += [e.fun for e in schedule.events]
    return {f: (lambda: None) for f in funs}


# ---------------------------------------------------------------------------------------
# Resolution: seed 002, Algorithms 1-2


def test_order_respects_explicit_dependencies() -> None:
    catalogue = [
        ModuleSpec("mixer", depends=("rate_ctrl",)),
        ModuleSpec("rate_ctrl", depends=("ins",)),
        ModuleSpec("ins", depends=("imu",)),
        ModuleSpec("imu"),
    ]
    assert names(sort_modules(catalogue)) == ["imu", "ins", "rate_ctrl", "mixer"]


def test_dependencies_pull_in_unselected_modules() -> None:
    catalogue = [ModuleSpec("imu"), ModuleSpec("ins", depends=("imu",)), ModuleSpec("logger")]
    assert names(sort_modules(catalogue, ["ins"])) == ["imu", "ins"]


def test_second_pass_orders_functionality_providers_first() -> None:
    # pass 1 only follows module names, so it resolves ins_ekf before imu_mpu; the seed's
    # second pass, with @imu substituted by imu_mpu, puts the provider first
    catalogue = [
        ModuleSpec("ins_ekf", depends=("@imu",)),
        ModuleSpec("imu_mpu", provides=("imu",)),
    ]
    assert names(sort_modules(catalogue)) == ["imu_mpu", "ins_ekf"]


def test_cycle_is_detected_and_named() -> None:
    catalogue = [
        ModuleSpec("a", depends=("b",)),
        ModuleSpec("b", depends=("c",)),
        ModuleSpec("c", depends=("a",)),
        ModuleSpec("d", depends=("a",)),
    ]
    with pytest.raises(DependencyCycleError) as info:
        sort_modules(catalogue)
    assert info.value.cycle == ("a", "b", "c", "a")
    assert "a -> b -> c -> a" in str(info.value)


def test_self_dependency_is_a_cycle() -> None:
    with pytest.raises(DependencyCycleError) as info:
        sort_modules([ModuleSpec("a", depends=("a",))])
    assert info.value.cycle == ("a", "a")


def test_cycle_through_a_functionality_is_found_by_the_second_pass() -> None:
    catalogue = [
        ModuleSpec("ins", depends=("@imu",)),
        ModuleSpec("imu_driver", depends=("ins",), provides=("imu",)),
    ]
    with pytest.raises(DependencyCycleError) as info:
        sort_modules(catalogue)
    assert set(info.value.cycle) == {"ins", "imu_driver"}


def test_conflicting_modules_are_both_named() -> None:
    catalogue = [
        ModuleSpec("gps_ublox", conflicts=("gps_sim",)),
        ModuleSpec("gps_sim"),
    ]
    with pytest.raises(ConflictError) as info:
        sort_modules(catalogue)
    assert (info.value.module, info.value.other) == ("gps_ublox", "gps_sim")
    assert "gps_ublox" in str(info.value) and "gps_sim" in str(info.value)
    # without the conflicting module selected, there is no conflict
    assert names(sort_modules(catalogue, ["gps_ublox"])) == ["gps_ublox"]


def test_conflict_with_a_functionality_provided_by_another_module() -> None:
    catalogue = [
        ModuleSpec("ins_ekf", conflicts=("@ins",), provides=("ins_ekf",)),
        ModuleSpec("ins_complementary", provides=("ins",)),
    ]
    with pytest.raises(ConflictError) as info:
        sort_modules(catalogue)
    assert (info.value.module, info.value.other, info.value.name) == (
        "ins_ekf",
        "ins_complementary",
        "@ins",
    )


def test_conflict_with_a_required_functionality_comes_before_missing() -> None:
    # the seed checks "a functionality from required in conflict list" before checking
    # that required functionalities are provided
    catalogue = [
        ModuleSpec("nav", depends=("@gps",)),
        ModuleSpec("indoor", conflicts=("@gps",)),
    ]
    with pytest.raises(ConflictError) as info:
        sort_modules(catalogue)
    assert (info.value.module, info.value.other) == ("indoor", "nav")


def test_provider_conflicting_with_its_functionality_means_only_provider() -> None:
    imu_a = ModuleSpec("imu_a", provides=("imu",), conflicts=("@imu",))
    imu_b = ModuleSpec("imu_b", provides=("imu",))
    ins = ModuleSpec("ins", depends=("@imu",))
    assert names(sort_modules([ins, imu_a])) == ["imu_a", "ins"]
    with pytest.raises(ConflictError) as info:
        sort_modules([ins, imu_a, imu_b])
    assert (info.value.module, info.value.other) == ("imu_a", "imu_b")


def test_alternative_uses_the_first_selected_option() -> None:
    catalogue = [
        ModuleSpec("nav", depends=("gps_ublox|gps_sim",)),
        ModuleSpec("gps_ublox"),
        ModuleSpec("gps_sim"),
    ]
    assert names(sort_modules(catalogue, ["nav", "gps_sim"])) == ["gps_sim", "nav"]
    both = names(sort_modules(catalogue, ["nav", "gps_sim", "gps_ublox"]))
    assert both.index("gps_ublox") < both.index("nav")


def test_alternative_with_a_functionality_option() -> None:
    catalogue = [
        ModuleSpec("nav", depends=("gps_ublox|@position",)),
        ModuleSpec("mocap", provides=("position",)),
    ]
    assert names(sort_modules(catalogue)) == ["mocap", "nav"]


def test_alternative_options_are_not_pulled_in() -> None:
    catalogue = [
        ModuleSpec("nav", depends=("gps_ublox|gps_sim",)),
        ModuleSpec("gps_ublox"),
        ModuleSpec("gps_sim"),
    ]
    with pytest.raises(MissingFunctionalityError) as info:
        sort_modules(catalogue, ["nav"])
    assert (info.value.requirer, info.value.missing) == ("nav", "gps_ublox|gps_sim")
    assert info.value.candidates == ("gps_ublox", "gps_sim")


def test_missing_functionality_names_requirer_and_candidates() -> None:
    catalogue = [
        ModuleSpec("ins", depends=("@imu",)),
        ModuleSpec("imu_mpu", provides=("imu",)),
    ]
    with pytest.raises(MissingFunctionalityError) as info:
        sort_modules(catalogue, ["ins"])
    assert (info.value.requirer, info.value.missing) == ("ins", "@imu")
    assert info.value.candidates == ("imu_mpu",)
    assert "'ins'" in str(info.value) and "'@imu'" in str(info.value)


def test_unknown_module_dependency_is_missing() -> None:
    with pytest.raises(MissingFunctionalityError) as info:
        sort_modules([ModuleSpec("ins", depends=("imu",))])
    assert (info.value.requirer, info.value.missing) == ("ins", "imu")


def test_unknown_selected_module_is_missing() -> None:
    with pytest.raises(MissingFunctionalityError) as info:
        sort_modules([ModuleSpec("imu")], ["imu", "lidar"])
    assert (info.value.requirer, info.value.missing) == ("<selection>", "lidar")


def test_yaml_declarations_resolve_end_to_end() -> None:
    schedule = resolve(
        modules_from_yaml(
            """
modules:
  - {name: ctrl, group: control, depends: "@ins", periodics: [{fun: ctrl, freq_hz: 250}]}
  - {name: ekf, group: estimation, depends: imu, provides: [ins],
     periodics: [{fun: ekf, freq_hz: 250, delay: 0.5}]}
  - {name: imu, group: sensors, periodics: [{fun: imu, period_s: 0.002}]}
"""
        )
    )
    assert schedule.module_order == ("imu", "ekf", "ctrl")
    assert [(p.fun, p.prescaler) for p in schedule.periodics] == [
        ("imu", 1),
        ("ekf", 2),
        ("ctrl", 2),
    ]
    assert next(p for p in schedule.periodics if p.fun == "ekf").offset == 1


def test_duplicate_module_names_are_rejected() -> None:
    with pytest.raises(ModuleSpecError, match="duplicate module 'imu'"):
        sort_modules([ModuleSpec("imu"), ModuleSpec("imu")])


@st.composite
def module_dags(draw: st.DrawFn) -> tuple[list[ModuleSpec], list[str]]:
    """Acyclic catalogues mixing module, @functionality and a|b dependencies."""
    n = draw(st.integers(1, 12))
    modules = []
    for i in range(n):
        deps: list[str] = []
        for j in draw(st.lists(st.integers(0, max(0, i - 1)), max_size=3, unique=True)):
            if j >= i:
                continue
            kind = draw(st.sampled_from(["module", "functionality", "alternative"]))
            if kind == "module":
                deps.append(f"m{j}")
            elif kind == "functionality":
                deps.append(f"@f{j}")
            else:
                other = draw(st.integers(0, i - 1))
                deps.append(f"m{j}|@f{other}")
        modules.append(ModuleSpec(f"m{i}", depends=tuple(deps), provides=(f"f{i}",)))
    selection = draw(st.permutations([m.name for m in modules]))
    return modules, list(selection)


@given(module_dags())
def test_property_resolved_order_respects_dependencies(
    case: tuple[list[ModuleSpec], list[str]],
) -> None:
    modules, selection = case
    order = names(sort_modules(modules, selection))
    assert sorted(order) == sorted(selection), "every selected module is placed once"
    position = {name: i for i, name in enumerate(order)}
    for module in modules:
        for dep in module.depends:
            first = dep.split("|")[0]  # all modules are selected: the first option holds
            provider = first.replace("@f", "m")
            assert position[provider] < position[module.name], (
                f"{module.name} placed before {provider} although it depends on {dep!r}"
            )


@given(st.permutations([f"m{i}" for i in range(6)]), st.integers(2, 6))
def test_property_any_cycle_is_reported_with_its_members(
    ring_order: list[str], ring_size: int
) -> None:
    ring = ring_order[:ring_size]
    successor = {name: ring[(i + 1) % ring_size] for i, name in enumerate(ring)}
    modules = [
        ModuleSpec(name, depends=(successor[name],) if name in ring else ())
        for name in sorted(ring_order)
    ]
    with pytest.raises(DependencyCycleError) as info:
        sort_modules(modules)
    cycle = info.value.cycle
    assert cycle[0] == cycle[-1] and set(cycle[:-1]) == set(ring)


# ---------------------------------------------------------------------------------------
# Schedule: task groups, prescalers, rates


def test_periodics_are_grouped_in_task_group_order() -> None:
    catalogue = [
        periodic_module("tlm", 10, group=G.TELEMETRY),
        periodic_module("mixer", 500, group=G.ACTUATORS),
        ModuleSpec(
            "ctrl", G.CONTROL, depends=("ins",), periodics=(PeriodicSpec("ctrl", freq_hz=500),)
        ),
        ModuleSpec(
            "ins", G.ESTIMATION, depends=("imu",), periodics=(PeriodicSpec("ins", freq_hz=500),)
        ),
        periodic_module("imu", 500, group=G.SENSORS),
    ]
    schedule = resolve(catalogue)
    assert [p.group for p in schedule.periodics] == [
        G.SENSORS,
        G.ESTIMATION,
        G.CONTROL,
        G.ACTUATORS,
        G.TELEMETRY,
    ]


@pytest.mark.parametrize(
    ("spec", "prescaler"),
    [
        (PeriodicSpec("f", freq_hz=500), 1),
        (PeriodicSpec("f", freq_hz=250), 2),
        (PeriodicSpec("f", freq_hz=0.2), 2500),
        (PeriodicSpec("f", period_s=0.02), 10),
        (PeriodicSpec("f", period_s=0.1), 50),
    ],
)
def test_prescalers_of_realisable_rates(spec: PeriodicSpec, prescaler: int) -> None:
    schedule = resolve([ModuleSpec("m", periodics=(spec,))], main_freq_hz=MAIN_HZ)
    (placed,) = schedule.periodics
    assert placed.prescaler == prescaler
    assert placed.freq_hz == pytest.approx(spec.rate_hz)


@pytest.mark.parametrize(
    ("spec", "words"),
    [
        (PeriodicSpec("f", freq_hz=300), "prescaler of 1.667"),
        (PeriodicSpec("f", freq_hz=1000), "faster than the 500 Hz main loop"),
        (PeriodicSpec("f", period_s=0.003), "prescaler of 1.5"),
        (PeriodicSpec("f", freq_hz=333.0), "must be an integer"),
    ],
)
def test_unrealisable_rates_raise(spec: PeriodicSpec, words: str) -> None:
    with pytest.raises(RateError, match=words) as info:
        resolve([ModuleSpec("baro", periodics=(spec,))], main_freq_hz=MAIN_HZ)
    assert "'f'" in str(info.value) and "'baro'" in str(info.value)


@pytest.mark.parametrize("bad", [0, -500, 500.0, True])
def test_main_frequency_must_be_a_positive_integer(bad: object) -> None:
    with pytest.raises(RateError, match="main_freq_hz"):
        resolve([], main_freq_hz=bad)  # type: ignore[arg-type]


def test_duplicate_function_names_across_modules_are_rejected() -> None:
    with pytest.raises(ModuleSpecError, match="'tick' is declared by two modules"):
        resolve(
            [
                ModuleSpec("a", periodics=(PeriodicSpec("tick", freq_hz=10),)),
                ModuleSpec("b", periodics=(PeriodicSpec("tick", freq_hz=10),)),
            ]
        )


# ---------------------------------------------------------------------------------------
# Offsets and call patterns


def test_naive_offsets_step_a_tenth_of_the_period_per_function() -> None:
    # Paparazzi's counter is incremented before use: 0.1, ..., 0.9, 0.0, 0.1, ...
    schedule = resolve([periodic_module("m", *[50] * 12)], offsets="naive")
    assert [p.offset for p in schedule.periodics] == [1, 2, 3, 4, 5, 6, 7, 8, 9, 0, 1, 2]


def test_user_delay_is_kept_and_does_not_advance_the_naive_counter() -> None:
    module = ModuleSpec(
        "m",
        periodics=(
            PeriodicSpec("a", freq_hz=50),
            PeriodicSpec("pinned", freq_hz=50, delay=0.75),
            PeriodicSpec("b", freq_hz=50),
        ),
    )
    for strategy in OFFSET_STRATEGIES:
        offsets = {p.fun: p.offset for p in resolve([module], offsets=strategy).periodics}
        assert offsets["pinned"] == 7, strategy  # floor(0.75 * 10)
    naive = {p.fun: p.offset for p in resolve([module], offsets="naive").periodics}
    assert (naive["a"], naive["b"]) == (1, 2)


def test_seed_figure5_three_tasks_with_and_without_offsets() -> None:
    # Figure 5: three tasks, hyperperiod 6; without offsets all run in the same loop
    catalogue = [periodic_module("t", MAIN_HZ / 2, MAIN_HZ / 3, MAIN_HZ / 6)]

    class ZeroOffsets:
        name = "zero"

        def assign(self, requests: Sequence[OffsetRequest]) -> tuple[int, ...]:
            return tuple(0 for _ in requests)

    zero = call_pattern(resolve(catalogue, offsets=ZeroOffsets()))
    assert zero.ticks == (("t_0", "t_1", "t_2"), (), ("t_0",), ("t_1",), ("t_0",), ())
    assert zero.peak == 3

    naive = call_pattern(resolve(catalogue, offsets="naive"))
    # x = 0.1, 0.2, 0.3 -> offsets floor(0.2)=0, floor(0.6)=0, floor(1.8)=1
    assert naive.ticks == (("t_0", "t_1"), ("t_2",), ("t_0",), ("t_1",), ("t_0",), ())
    assert naive.peak == 2
    assert naive.mean == pytest.approx(1 / 2 + 1 / 3 + 1 / 6)


def test_naive_and_balanced_call_patterns_on_three_250hz_functions() -> None:
    catalogue = [periodic_module("f", 250, 250, 250)]
    naive = call_pattern(resolve(catalogue, offsets="naive"))
    # floor(0.1*2) = floor(0.2*2) = floor(0.3*2) = 0: all on even ticks
    assert naive.ticks == (("f_0", "f_1", "f_2"), ())
    assert naive.peak == 3
    balanced = call_pattern(resolve(catalogue, offsets="balanced"))
    assert balanced.ticks == (("f_0", "f_2"), ("f_1",))
    assert balanced.peak == 2
    assert balanced.mean == naive.mean == 1.5


def px4_like(cost: bool = False) -> list[ModuleSpec]:
    """A PX4-like firmware at 500 Hz (costs in us, or unit costs)."""

    def p(fun: str, hz: float, cost_us: float) -> PeriodicSpec:
        return PeriodicSpec(fun, freq_hz=hz, cost=cost_us if cost else 1.0)

    return [
        ModuleSpec("imu", G.SENSORS, provides=("imu",), periodics=(p("imu", 500, 20),)),
        ModuleSpec("baro", G.SENSORS, provides=("baro",), periodics=(p("baro", 50, 10),)),
        ModuleSpec("gps", G.SENSORS, provides=("gps",), periodics=(p("gps", 10, 10),)),
        ModuleSpec(
            "ekf",
            G.ESTIMATION,
            depends=("@imu", "@baro", "@gps"),
            provides=("ins",),
            periodics=(p("ekf_predict", 250, 80), p("ekf_baro", 50, 20), p("ekf_gps", 10, 30)),
        ),
        ModuleSpec("rate", G.CONTROL, depends=("@ins",), periodics=(p("rate", 500, 20),)),
        ModuleSpec("att", G.CONTROL, depends=("@ins", "rate"), periodics=(p("att", 250, 30),)),
        ModuleSpec("pos", G.CONTROL, depends=("att",), periodics=(p("pos", 50, 40),)),
        ModuleSpec("nav", G.CONTROL, depends=("pos",), periodics=(p("nav", 10, 40),)),
        ModuleSpec("mixer", G.ACTUATORS, depends=("rate",), periodics=(p("mixer", 500, 10),)),
        ModuleSpec("battery", G.CORE, periodics=(p("battery", 10, 5),)),
        ModuleSpec("rc", G.RADIO_CONTROL, periodics=(p("rc", 50, 5),)),
        ModuleSpec(
            "telemetry",
            G.TELEMETRY,
            periodics=tuple(p(f"tlm_{hz}hz", hz, 15) for hz in (100, 50, 10, 5, 1)),
        ),
        ModuleSpec("datalink", G.DATALINK, periodics=(p("datalink", 100, 10),)),
        ModuleSpec("logger", G.DEFAULT, periodics=(p("logger", 100, 25),)),
    ]


def test_balanced_lowers_the_peak_on_a_px4_like_set() -> None:
    naive = call_pattern(resolve(px4_like(), offsets="naive"))
    balanced = call_pattern(resolve(px4_like(), offsets="balanced"))
    assert naive.mean == balanced.mean
    assert balanced.peak < naive.peak, (naive.peak, balanced.peak)
    # ceil(mean) is a lower bound on the peak; balanced reaches it here
    assert balanced.peak == math.ceil(balanced.mean)


def test_balanced_lowers_the_peak_cost_with_declared_costs() -> None:
    naive = call_pattern(resolve(px4_like(cost=True), offsets="naive"))
    balanced = call_pattern(resolve(px4_like(cost=True), offsets="balanced"))
    assert balanced.peak_cost < naive.peak_cost


def test_unknown_strategy_is_named() -> None:
    with pytest.raises(UnknownStrategyError, match=r"'greedy'.*naive, balanced"):
        resolve([periodic_module("m", 50)], offsets="greedy")


def test_a_strategy_breaking_the_rules_is_rejected() -> None:
    class OutOfRange:
        name = "out_of_range"

        def assign(self, requests: Sequence[OffsetRequest]) -> tuple[int, ...]:
            return tuple(r.prescaler for r in requests)

    with pytest.raises(SchedulerError, match="out_of_range"):
        resolve([periodic_module("m", 50)], offsets=OutOfRange())


def test_with_offsets_reassigns_only_offsets() -> None:
    naive = resolve(px4_like(), offsets="naive")
    balanced = naive.with_offsets("balanced")
    assert balanced == resolve(px4_like(), offsets="balanced")
    assert [p.fun for p in balanced.periodics] == [p.fun for p in naive.periodics]


@st.composite
def periodic_sets(draw: st.DrawFn, costs: bool = False) -> list[ModuleSpec]:
    n = draw(st.integers(1, 14))
    modules = []
    for i in range(n):
        prescaler = draw(st.sampled_from(PRESCALERS))
        cost = draw(st.floats(0.0, 50.0)) if costs else 1.0
        delay = draw(st.one_of(st.none(), st.floats(0.0, 0.999))) if i % 4 == 3 else None
        spec = PeriodicSpec(f"f{i}", freq_hz=MAIN_HZ / prescaler, delay=delay, cost=cost)
        modules.append(ModuleSpec(f"m{i}", draw(st.sampled_from(list(G))), periodics=(spec,)))
    return modules


@settings(max_examples=60, deadline=None)
@given(periodic_sets())
def test_property_every_function_runs_at_its_rate_over_a_hyperperiod(
    modules: list[ModuleSpec],
) -> None:
    for strategy in OFFSET_STRATEGIES:
        schedule = resolve(modules, offsets=strategy)
        pattern = call_pattern(schedule)
        h = pattern.hyperperiod_ticks
        for p in schedule.periodics:
            ticks = [k for k, due in enumerate(pattern.ticks) if p.fun in due]
            assert len(ticks) == h // p.prescaler, (strategy, p)
            gaps = {b - a for a, b in itertools.pairwise(ticks)}
            assert gaps <= {p.prescaler}, f"{strategy}: {p.fun} calls not evenly spaced"
        # the running scheduler agrees: frequency over two hyperperiods, simulated time
        scheduler = Scheduler(schedule, noop_bindings(schedule))
        scheduler.init()
        for _ in range(2 * h + 1):
            scheduler.tick()
        report = scheduler.report()
        for p in schedule.periodics:
            achieved = report.function_freq[p.fun]
            assert achieved.calls == 2 * h // p.prescaler + (p.offset == 0)
            if achieved.calls > 1:
                assert achieved.freq_hz == pytest.approx(p.freq_hz), (strategy, p.fun)


@settings(max_examples=80, deadline=None)
@given(periodic_sets())
def test_property_balanced_peak_is_never_above_naive(modules: list[ModuleSpec]) -> None:
    naive = call_pattern(resolve(modules, offsets="naive"))
    balanced = call_pattern(resolve(modules, offsets="balanced"))
    assert balanced.peak <= naive.peak
    assert balanced.peak >= math.ceil(balanced.mean - 1e-9)


@settings(max_examples=60, deadline=None)
@given(periodic_sets(costs=True))
def test_property_balanced_peak_cost_is_never_above_naive(modules: list[ModuleSpec]) -> None:
    naive = call_pattern(resolve(modules, offsets="naive"))
    balanced = call_pattern(resolve(modules, offsets="balanced"))
    assert balanced.peak_cost <= naive.peak_cost + 1e-6


# ---------------------------------------------------------------------------------------
# The main loop


class Recorder:
    """Bindings that log calls and advance a fake host clock by each function's cost."""

    def __init__(self, schedule: ResolvedSchedule, cost_ns: dict[str, int] | None = None):
        self.calls: list[str] = []
        self.host_ns = 0
        self.cost_ns = cost_ns or {}
        funs = noop_bindings(schedule)
        self.bindings = {f: self._make(f) for f in funs}

    def _make(self, fun: str) -> Callable[[], None]:
        def call() -> None:
            self.calls.append(fun)
            self.host_ns += self.cost_ns.get(fun, 0)

        return call

    def timer(self) -> int:
        return self.host_ns


def test_tick_calls_due_functions_in_task_group_order() -> None:
    catalogue = [
        periodic_module("tlm", 100, group=G.TELEMETRY),
        periodic_module("mixer", 500, group=G.ACTUATORS),
        periodic_module("ctrl", 250, group=G.CONTROL),
        periodic_module("imu", 500, group=G.SENSORS),
    ]
    schedule = resolve(catalogue, offsets="naive")
    rec = Recorder(schedule)
    scheduler = Scheduler(schedule, rec.bindings)
    scheduler.init()
    results = [scheduler.tick() for _ in range(10)]
    assert [r.called for r in results] == [tuple(p.fun for p in schedule.due(k)) for k in range(10)]
    order = {p.fun: p.group.rank for p in schedule.periodics}
    for r in results:
        assert [order[f] for f in r.called] == sorted(order[f] for f in r.called)
    assert results[0].called == ("imu_0", "ctrl_0", "mixer_0", "tlm_0")


def test_init_functions_run_once_in_group_then_module_order() -> None:
    catalogue = [
        ModuleSpec("ctrl", G.CONTROL, depends=("ins",), inits=(InitSpec("ctrl_init"),)),
        ModuleSpec("ins", G.ESTIMATION, inits=(InitSpec("ins_init"),)),
        ModuleSpec("sys", G.MCU, inits=(InitSpec("mcu_init"), InitSpec("led_init"))),
    ]
    schedule = resolve(catalogue)
    rec = Recorder(schedule)
    scheduler = Scheduler(schedule, rec.bindings)
    with pytest.raises(SchedulerError, match="init"):
        scheduler.tick()
    scheduler.init()
    assert rec.calls == ["mcu_init", "led_init", "ins_init", "ctrl_init"]
    with pytest.raises(SchedulerError, match="already"):
        scheduler.init()


def test_event_functions_run_once_after_their_flag_is_set() -> None:
    catalogue = [
        ModuleSpec("datalink", G.DATALINK, events=(EventSpec("dl_parse"),)),
        ModuleSpec("gps", G.SENSORS, events=(EventSpec("gps_parse"),)),
    ]
    schedule = resolve(catalogue)
    rec = Recorder(schedule)
    scheduler = Scheduler(schedule, rec.bindings)
    scheduler.init()
    assert scheduler.tick().called == ()
    scheduler.set_event("dl_parse")
    scheduler.set_event("gps_parse")
    assert scheduler.tick().called == ("gps_parse", "dl_parse")  # group order
    assert scheduler.tick().called == ()
    scheduler.set_event("gps_parse")
    assert scheduler.poll_events() == ("gps_parse",)
    report = scheduler.report()
    assert report.event_calls == {"gps_parse": 2, "dl_parse": 1}
    with pytest.raises(BindingError, match="nope"):
        scheduler.set_event("nope")


def test_autorun_false_and_start_stop() -> None:
    module = ModuleSpec(
        "log",
        periodics=(
            PeriodicSpec("log_fast", freq_hz=500, autorun=False),
            PeriodicSpec("log_slow", freq_hz=250),
        ),
    )
    schedule = resolve([module], offsets="naive")
    rec = Recorder(schedule)
    scheduler = Scheduler(schedule, rec.bindings)
    scheduler.init()
    assert not scheduler.is_running("log_fast")
    assert [scheduler.tick().called for _ in range(2)] == [("log_slow",), ()]
    scheduler.start("log_fast")
    scheduler.stop("log_slow")
    assert [scheduler.tick().called for _ in range(2)] == [("log_fast",), ("log_fast",)]


def test_bindings_must_match_the_declared_functions() -> None:
    schedule = resolve([periodic_module("m", 50)])
    with pytest.raises(BindingError, match=r"missing \['m_0'\].*\['typo'\]"):
        Scheduler(schedule, {"typo": lambda: None})


def _imu_and_attitude() -> tuple[ResolvedSchedule, Recorder]:
    """A 500 Hz IMU (20 us a call) in the sensors group and a 250 Hz attitude loop (30 us)
    in the control group."""
    schedule = resolve([
        ModuleSpec("imu", G.SENSORS, periodics=(PeriodicSpec("imu", freq_hz=500),)),
        ModuleSpec("att", G.CONTROL, periodics=(PeriodicSpec("att", freq_hz=250),)),
    ])
    return schedule, Recorder(schedule, cost_ns={"imu": 20_000, "att": 30_000})


def test_duty_is_averaged_per_window_of_calls_in_microseconds() -> None:
    schedule, rec = _imu_and_attitude()
    scheduler = Scheduler(schedule, rec.bindings, host_timer=rec.timer, window_calls=1000)
    scheduler.init()
    for _ in range(2500):
        scheduler.tick()
    report = scheduler.report()
    sensors = report.group_duty[G.SENSORS]
    control = report.group_duty[G.CONTROL]
    assert len(sensors.windows) == 2 and sensors.calls == 2500
    assert (sensors.windows[0].avg_us, sensors.windows[0].min_us) == (20.0, 20.0)
    assert sensors.windows[0].max_us == 20.0 and sensors.windows[1].end_tick == 2000
    # a 250 Hz function in a group timed every tick: 30 us every other tick
    assert (control.windows[0].avg_us, control.windows[0].min_us) == (15.0, 0.0)
    assert control.windows[0].max_us == 30.0
    assert report.tick_duty.max_us == 50.0
    assert report.overruns == 0
    assert report.group_freq[G.CONTROL].freq_hz == pytest.approx(500.0)  # group calls
    assert report.function_freq["att"].freq_hz == pytest.approx(250.0)


def test_a_group_with_nothing_due_and_an_empty_event_poll_take_no_host_time() -> None:
    # every host-clock read moves the clock on by 1 ns, as a real read costs time: a group
    # is read only when it ran something, so an idle one shows 0, not the read's cost
    schedule, rec = _imu_and_attitude()
    reads = 0

    def timer() -> int:
        nonlocal reads
        reads += 1
        rec.host_ns += 1
        return rec.host_ns

    scheduler = Scheduler(schedule, rec.bindings, host_timer=timer, window_calls=10)
    scheduler.init()
    for _ in range(10):
        scheduler.tick()
    report = scheduler.report()
    control = report.group_duty[G.CONTROL].windows[0]
    assert control.min_us == 0.0  # the ticks without att
    assert control.max_us == pytest.approx(30.001)
    assert report.event_duty.max_us == 0.0  # no event functions: nothing polled
    assert reads == 10 + 10 + 5  # tick start, imu's group every tick, att's every other
    stopped = scheduler.tick_count
    scheduler.stop("att")
    assert [scheduler.tick().called for _ in range(2)] == [("imu",), ("imu",)]
    scheduler.start("att")
    assert {scheduler.tick().called for _ in range(2)} == {("imu",), ("imu", "att")}
    assert scheduler.tick_count == stopped + 4


def test_functions_started_or_stopped_during_a_tick_are_reported_as_they_ran() -> None:
    # "once" stops itself (a one-shot); "arm" starts "late", due later in the same tick,
    # and "early", whose turn has passed
    catalogue = [
        ModuleSpec("early", G.SENSORS, periodics=(PeriodicSpec("early", freq_hz=500),)),
        ModuleSpec("once", G.CORE, periodics=(PeriodicSpec("once", freq_hz=500),)),
        ModuleSpec("arm", G.ESTIMATION, periodics=(PeriodicSpec("arm", freq_hz=500),)),
        ModuleSpec("late", G.CONTROL, periodics=(PeriodicSpec("late", freq_hz=500),)),
    ]
    schedule = resolve(catalogue)
    ran: list[str] = []
    bindings = {
        "early": lambda: ran.append("early"),
        "once": lambda: (ran.append("once"), scheduler.stop("once")),
        "arm": lambda: (ran.append("arm"), scheduler.start("late"), scheduler.start("early")),
        "late": lambda: ran.append("late"),
    }
    scheduler = Scheduler(schedule, bindings)
    scheduler.init()
    scheduler.stop("early")
    scheduler.stop("late")
    first = scheduler.tick()
    assert ran == ["once", "arm", "late"]
    assert first.called == ("once", "arm", "late")  # "early" was stopped at its turn
    ran.clear()
    assert scheduler.tick().called == ("early", "arm", "late") == tuple(ran)


def test_ticks_longer_than_the_period_are_overruns() -> None:
    catalogue = [
        ModuleSpec("imu", G.SENSORS, periodics=(PeriodicSpec("imu", freq_hz=500),)),
        ModuleSpec("slam", G.DEFAULT, periodics=(PeriodicSpec("slam", freq_hz=50),)),
    ]
    schedule = resolve(catalogue)
    rec = Recorder(schedule, cost_ns={"imu": 100_000, "slam": 2_500_000})
    scheduler = Scheduler(schedule, rec.bindings, host_timer=rec.timer)
    scheduler.init()
    overran = [scheduler.tick().overrun for _ in range(100)]
    assert sum(overran) == scheduler.report().overruns == 10
    slam = next(p for p in schedule.periodics if p.fun == "slam")
    assert [k for k, o in enumerate(overran) if o] == list(range(slam.offset, 100, 10))


def test_injected_clock_drives_ticks_and_stamps_achieved_frequency() -> None:
    schedule = resolve([periodic_module("ctrl", 500, 100)])
    clock = ManualClock()
    scheduler = Scheduler(schedule, noop_bindings(schedule), clock=clock)
    scheduler.init()
    ran = 0
    for _ in range(1000):  # physics at 1 kHz: a main-loop tick every other step
        ran += scheduler.run_until(clock.now_us())
        clock.advance_us(1000)
    assert ran == scheduler.tick_count == 500  # ticks 0..499, released by t = 999 ms
    report = scheduler.report()
    assert report.function_freq["ctrl_0"].freq_hz == pytest.approx(500.0)
    assert report.function_freq["ctrl_0"].interval_std_us == pytest.approx(0.0, abs=1e-9)
    assert report.function_freq["ctrl_1"].freq_hz == pytest.approx(100.0)


def test_late_ticks_show_as_jitter_in_simulated_time() -> None:
    schedule = resolve([periodic_module("ctrl", 500)])
    clock = ManualClock()
    scheduler = Scheduler(schedule, noop_bindings(schedule), clock=clock)
    scheduler.init()
    for _ in range(1000):  # a 3 ms simulator step: ticks run late, some back to back
        clock.advance_us(3000)
        scheduler.run_until(clock.now_us())
    achieved = scheduler.report().function_freq["ctrl_0"]
    assert achieved.freq_hz == pytest.approx(500.0, rel=0.01)
    # 3 ticks per 6 ms, stamped 3000, 3000, 6000 us: intervals 0, 3000, 3000 us, whose
    # standard deviation is sqrt(2) ms
    assert achieved.interval_std_us == pytest.approx(math.sqrt(2) * 1000, rel=0.01)
    assert achieved.std_hz > 100.0



@pytest.mark.parametrize("spacing_us", [2000, 100_000_000])
def test_the_interval_jitter_is_exact_for_any_interval(spacing_us: int) -> None:
    """Intervals of 2 ms and of 100 s (a slow function: the sums of its squared intervals
    overflow 64-bit integers) both give the exact population standard deviation."""
    meter = _RateMeter()
    stamps = list(itertools.accumulate(spacing_us + k % 7 for k in range(3000)))
    for t in stamps:
        meter.record(t)
    intervals = [b - a for a, b in itertools.pairwise(stamps)]
    stats = meter.stats()
    assert stats.calls == len(stamps)
    assert stats.interval_std_us == pytest.approx(statistics.pstdev(intervals), rel=1e-12)


def test_a_tick_whose_function_raises_does_not_count_and_the_meters_go_on() -> None:
    schedule = resolve([periodic_module("ctrl", 500), periodic_module("log", 250)])
    failing = {"now": False}

    def ctrl() -> None:
        if failing["now"]:
            raise RuntimeError("sensor gone")

    bindings = noop_bindings(schedule) | {"ctrl_0": ctrl}
    scheduler = Scheduler(schedule, bindings, window_calls=4)
    scheduler.init()
    for _ in range(3):
        scheduler.tick()
    failing["now"] = True
    with pytest.raises(RuntimeError, match="sensor gone"):
        scheduler.tick()
    failing["now"] = False
    for _ in range(6):
        scheduler.tick()
    report = scheduler.report()
    assert report.ticks == scheduler.tick_count == 9
    assert report.tick_duty.calls == 9
    assert all(d.calls == 9 for d in report.group_duty.values())
    assert [w.calls for w in report.tick_duty.windows] == [4, 4]


def test_a_function_may_read_the_report_during_a_tick() -> None:
    schedule = resolve([periodic_module("ctrl", 500), periodic_module("monitor", 50)])
    reports: list[SchedulerReport] = []
    scheduler: Scheduler
    bindings = noop_bindings(schedule) | {"monitor_0": lambda: reports.append(scheduler.report())}
    scheduler = Scheduler(schedule, bindings, window_calls=7)
    scheduler.init()
    for _ in range(40):
        scheduler.tick()
    assert [r.ticks for r in reports] == [0, 10, 20, 30]  # monitor_0 at offset 0, 50 Hz
    assert [r.tick_duty.calls for r in reports] == [0, 10, 20, 30]  # finished ticks only
