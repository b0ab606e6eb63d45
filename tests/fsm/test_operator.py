"""The operator's orienteering solver against brute force, and the greedy baseline."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsm.operator import (
    OperatorError,
    Problem,
    Tour,
    budget_s,
    leg_costs,
    solve_exact,
    solve_greedy,
)


def brute_force(problem: Problem) -> Tour:
    """Every order of every subset: the most points within the budget, then the cheapest,
    then the shortest."""
    best, key = Tour((), 0, 0.0), (0, -0.0, 0)
    for r in range(1, len(problem.pads) + 1):
        for order in itertools.permutations(problem.pads, r):
            cost = problem.tour_cost(order)
            points = problem.tour_points(order)
            if cost <= problem.budget and (points, -cost, -r) > key:
                best, key = Tour(order, points, cost), (points, -cost, -r)
    return best


@st.composite
def problems(draw: st.DrawFn, max_pads: int = 5) -> Problem:
    n = draw(st.integers(1, max_pads))
    pads = tuple(draw(st.permutations(range(1, 11)))[:n])
    points = tuple(draw(st.lists(st.integers(0, 50), min_size=n, max_size=n)))
    if draw(st.booleans()):  # places in the plane: costs obey the triangle inequality
        xy = np.array(draw(st.lists(st.tuples(st.integers(0, 20), st.integers(0, 14)),
                                    min_size=n + 1, max_size=n + 1)), dtype=float)
        lengths = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
        cost = leg_costs(lengths, speed=1.0, land_s=draw(st.integers(0, 20)),
                         takeoff_s=draw(st.integers(0, 10)))
    else:  # any non-negative matrix, asymmetric, some legs without a path
        cost = np.array(draw(st.lists(
            st.one_of(st.integers(0, 60).map(float), st.just(math.inf)),
            min_size=(n + 1) ** 2, max_size=(n + 1) ** 2))).reshape(n + 1, n + 1)
    budget = float(draw(st.integers(0, 150)))
    return Problem(pads, points, cost, budget)


@settings(max_examples=80, deadline=None)
@given(problems())
def test_the_exact_solver_scores_what_brute_force_scores(problem: Problem) -> None:
    exact, brute = solve_exact(problem), brute_force(problem)
    assert exact.points == brute.points
    assert exact.cost == pytest.approx(brute.cost)  # also the cheapest of the best
    assert len(exact.pads) == len(brute.pads)
    assert exact.fits(problem.budget)
    assert exact.cost == pytest.approx(problem.tour_cost(exact.pads))
    assert exact.points == problem.tour_points(exact.pads)
    assert len(set(exact.pads)) == len(exact.pads)


@settings(max_examples=50, deadline=None)
@given(problems())
def test_greedy_fits_the_budget_and_never_beats_the_exact_solver(problem: Problem) -> None:
    greedy = solve_greedy(problem)
    assert greedy.fits(problem.budget)
    assert greedy.points <= solve_exact(problem).points


def test_the_exact_solver_beats_greedy_where_the_rich_pad_is_a_trap() -> None:
    # pad 1 has the best points per second but sits far from pads 2 and 3, which together
    # are worth more and fit the budget only without pad 1
    lengths = np.array([[0, 10, 12, 13],
                        [10, 0, 30, 30],
                        [12, 30, 0, 1],
                        [13, 30, 1, 0]], dtype=float)
    problem = Problem((1, 2, 3), (30, 20, 20), leg_costs(lengths, speed=1.0, land_s=0.0,
                                                         takeoff_s=0.0), budget=14.0)
    assert solve_greedy(problem) == Tour((1,), 30, 10.0)
    assert solve_exact(problem) == Tour((2, 3), 40, 13.0)


def test_ten_pads_are_solved_exactly_with_the_contest_budget() -> None:
    rng = np.random.default_rng(3)
    xy = rng.uniform([0, 0], [20, 14], size=(11, 2))
    lengths = 1.3 * np.linalg.norm(xy[:, None] - xy[None, :], axis=2)
    problem = Problem(tuple(range(1, 11)), tuple(int(v) for v in rng.integers(5, 50, 10)),
                      leg_costs(lengths, speed=1.0, land_s=25.0, takeoff_s=8.0), budget=300.0)
    exact = solve_exact(problem)
    assert exact.fits(300.0)
    # no single pad added to the tour, anywhere, still fits (or the tour is not maximal)
    for pad in set(problem.pads) - set(exact.pads):
        for at in range(len(exact.pads) + 1):
            longer = (*exact.pads[:at], pad, *exact.pads[at:])
            assert problem.tour_cost(longer) > 300.0
    assert solve_greedy(problem).points <= exact.points


def test_nothing_fits_a_zero_budget_and_worthless_pads_are_visited_only_on_the_way() -> None:
    cost = leg_costs(np.ones((3, 3)), speed=1.0, land_s=0.0, takeoff_s=0.0)
    assert solve_exact(Problem((4, 5), (10, 10), cost, 0.0)).pads == ()
    assert solve_exact(Problem((4, 5), (0, 10), cost, 100.0)).pads == (5,)
    assert solve_greedy(Problem((4, 5), (0, 10), cost, 100.0)).pads == (5,)
    no_direct_path = cost.copy()
    no_direct_path[0, 2] = math.inf  # pad 5 only through pad 4
    assert solve_exact(Problem((4, 5), (0, 10), no_direct_path, 100.0)).pads == (4, 5)


def test_leg_costs_add_landing_everywhere_and_takeoff_from_pads() -> None:
    lengths = np.array([[0.0, 4.0], [4.0, 0.0]])
    cost = leg_costs(lengths, speed=2.0, land_s=10.0, takeoff_s=3.0)
    assert cost[0, 1] == 2.0 + 10.0  # from the air: fly, land
    assert cost[1, 0] == 2.0 + 10.0 + 3.0  # from a pad: take off, fly, land
    with pytest.raises(OperatorError, match="speed"):
        leg_costs(lengths, speed=0.0, land_s=1.0, takeoff_s=1.0)


def test_the_budget_is_the_lesser_of_time_and_charge() -> None:
    assert budget_s(time_left_s=500.0, battery_remaining=0.6, battery_reserve=0.2,
                    drain_per_s=0.001) == pytest.approx(400.0)
    assert budget_s(time_left_s=300.0, battery_remaining=0.6, battery_reserve=0.2,
                    drain_per_s=0.001) == 300.0
    assert budget_s(time_left_s=300.0, battery_remaining=0.1, battery_reserve=0.2,
                    drain_per_s=0.001) == 0.0


@pytest.mark.parametrize(("kwargs", "problem"), [
    ({"points": (1,)}, "1 points for 2 pads"),
    ({"pads": (1, 1)}, "twice"),
    ({"cost": np.zeros((2, 2))}, "expected (3, 3)"),
    ({"cost": -np.ones((3, 3))}, "non-negative"),
    ({"budget": -1.0}, "budget"),
])
def test_a_bad_problem_is_refused_naming_what_is_wrong(kwargs: dict[str, object],
                                                       problem: str) -> None:
    args: dict[str, object] = {"pads": (1, 2), "points": (1, 2), "cost": np.zeros((3, 3)),
                               "budget": 1.0} | kwargs
    with pytest.raises(OperatorError, match=problem.replace("(", r"\(").replace(")", r"\)")):
        Problem(**args)  # type: ignore[arg-type]
