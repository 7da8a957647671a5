"""The energy argument (planners/search/energy_graph.py, verification/energy_bound.py): its bounds hold hop by
hop on the fast step map, what it proves the search cannot cross either, the steps on either side of its landing
ceiling, and its pruning."""
import math

import numpy as np
import pytest

from drakeslip import SlipParams, Terrain, step_batch, step_world
from drakeslip.dynamics import FACE_TOLERANCE
from planners.base import Budget
from planners.search import energy_graph as eg
from verification import energy_bound as eb
from verification import model_check as mc

PARAMS = SlipParams(friction=0.8)
G = PARAMS.gravity
SMALL = Budget(max_nodes=50_000, max_time_s=30.0)
START = (0.0, 0.9, 1.5)        # energy height 0.9 + 1.5^2 / (2 g) = 1.0147 m: landing ceiling 0.626 m


def terrain(*features):
    """Ground at 0 over [-2, 8) m in 10 cm cells, with (start, end, height) features."""
    h = np.zeros(100)
    for a, b, level in features:
        h[int(round((a + 2) / 0.1)):int(round((b + 2) / 0.1))] = level
    return Terrain(h, 0.1, -2.0)


def test_the_slack_covers_the_models_contact_tolerance_and_the_ceiling_is_the_formula():
    assert eg.GEOMETRY_SLACK >= 10 * FACE_TOLERANCE
    H = 0.9 + 1.5 ** 2 / (2 * G)
    assert eg.energy_height(START, PARAMS) == pytest.approx(H)
    assert eg.landing_ceiling(START, PARAMS) == pytest.approx(
        H - 0.5 / math.sqrt(1 + 0.8 ** 2) + eg.ENERGY_SLACK + eg.GEOMETRY_SLACK)


def test_every_hop_of_the_fast_step_map_keeps_the_bounds():
    """(1)-(5) of the module docstring, on random two-hop sequences over a step world: apexes below H,
    footholds below the landing ceiling, foothold gaps within the range bound, the flight between them flown
    over by (5), the first touchdown among the graph's start cells, the next apex within reach of the foothold."""
    rng = np.random.default_rng(0)
    ground = step_world(7)
    n = 6000
    x = rng.uniform(-1.0, 8.0, n)
    z = ground.height_at(x) + rng.uniform(0.5, 1.0, n)
    v = rng.uniform(0.3, 3.0, n)
    H = z + v * v / (2 * G)
    angle = lambda k: rng.uniform(-0.1, PARAMS.max_leg_angle, k)
    one = step_batch(np.column_stack([x, z, v]), angle(n), ground, PARAMS)
    ok = np.flatnonzero(one.ok)
    two = step_batch(np.column_stack([one.next_x, one.next_z, one.next_xdot])[ok], angle(ok.size), ground, PARAMS)
    both = ok[two.ok]
    assert ok.size > 1000 and both.size > 300
    c = 0.5 / math.sqrt(1 + 0.8 ** 2)
    reach = 0.8 * c
    assert np.all(one.next_z[ok] <= H[ok] + 1e-7)
    ceiling = H - c
    assert np.all(ground.height_at(one.touchdown_x[ok]) < ceiling[ok])
    f1, f2 = one.touchdown_x[both], two.touchdown_x[two.ok]
    top1, top2 = ground.height_at(f1) + c, ground.height_at(f2) + c
    assert np.all(f2 - f1 <= 2 * reach + 2 * np.sqrt((H[both] - top1) * (H[both] - top2)) + 1e-9)
    assert np.all(one.next_x[ok] - one.touchdown_x[ok] <= reach + H[ok] - ground.height_at(one.touchdown_x[ok]) - c)
    for i, j in zip(both[:150], np.flatnonzero(two.ok)[:150]):
        graph = eg.CellGraph((x[i], z[i], v[i]), ground, 12.0, PARAMS)
        cell = lambda fx: int(np.flatnonzero((graph.lo <= fx) & (fx < graph.hi))[0])
        a, b = cell(one.touchdown_x[i]), cell(two.touchdown_x[j])
        assert graph.starts[a] and (a == b or graph.edges[a, b])   # a first-descent cell; range, back-step, (5)


def test_a_step_just_above_the_landing_ceiling_is_proved_and_the_search_finds_no_witness():
    ceiling = eg.landing_ceiling(START, PARAMS)
    step = terrain((1.5, 8.0, ceiling + 0.01))     # 6.5 m long: no flight passes over it
    proof = eb.prove_unreachable(START, step, 3.0, PARAMS)
    assert proof is not None and proof["landing_ceiling"] == pytest.approx(ceiling, abs=1e-6)
    assert proof["reach_x"] <= 1.5 + 1e-9 and "no touchdown is possible above 0.626 m" in proof["statement"]
    r = mc.model_check(START, step, 3.0, PARAMS, budget=SMALL, energy=False, drake_check=False)
    assert r["verdict"] == mc.NOT_TRAVERSABLE and all(p["stop"] == "exhausted" for p in r["passes"])


def test_below_the_ceiling_nothing_is_proved_and_a_half_metre_step_has_a_witness():
    """The bound is sound, not tight: just under the ceiling the argument proves nothing and the grid search
    finds no plan either, while a 0.5 m step (0.13 m lower) is climbed on Drake."""
    ceiling = eg.landing_ceiling(START, PARAMS)
    assert eb.prove_unreachable(START, terrain((1.5, 8.0, ceiling - 0.01)), 3.0, PARAMS) is None
    r = mc.model_check(START, terrain((1.5, 8.0, ceiling - 0.01)), 3.0, PARAMS, budget=SMALL, drake_check=False)
    assert r["verdict"] == mc.NOT_TRAVERSABLE
    r = mc.model_check(START, terrain((1.5, 8.0, 0.5)), 3.0, PARAMS, budget=SMALL)
    assert r["verdict"] == mc.TRAVERSABLE and r["drake"][-1]["ok"]


def test_a_flight_passes_over_a_narrow_high_wall_but_not_a_wide_one():
    # (5): at 0.9 m the parabola is above the wall for at most 2 (1.0147 + slack - 0.9) = 0.23 m
    graph = eg.CellGraph(START, terrain((2.0, 2.2, 0.9)), 6.0, PARAMS)
    assert graph.flies_over(1.9, 2.3)
    graph = eg.CellGraph(START, terrain((2.0, 2.3, 0.9)), 6.0, PARAMS)
    assert not graph.flies_over(1.9, 2.4) and graph.flies_over(1.9, 2.1)
    wall = eb.prove_unreachable(START, terrain((2.0, 2.1, 1.1)), 6.0, PARAMS)
    assert wall is not None and wall["reach_x"] is None and "1.100 m terrain at x = 2.00 m" in wall["statement"]


def test_the_pruning_keeps_every_apex_of_a_witness_and_finds_the_same_verdict():
    ground = terrain((1.5, 1.8, -1.0), (3.0, 3.6, 0.3), (4.5, 5.0, -1.0))
    free = mc.model_check((0.0, 1.0, 1.5), ground, 6.0, PARAMS, budget=SMALL, energy=False, drake_check=False)
    assert free["verdict"] == mc.TRAVERSABLE
    alive = eg.Coreach(eg.CellGraph((0.0, 1.0, 1.5), ground, 6.0, PARAMS)).alive
    assert alive(np.array(free["witness"]["apexes"])).all()
    pruned = mc.model_check((0.0, 1.0, 1.5), ground, 6.0, PARAMS, budget=SMALL, drake_check=False)
    assert pruned["verdict"] == mc.TRAVERSABLE


def blocking_stretch(apex, ground: Terrain, goal_x: float):
    """A run of cells between the start and the goal, all at or above the landing ceiling, too long for one flight to
    pass over, found from (2), (3) and (5) alone: no foot can land on it, so a body crossing it is in stance only
    within L0 s of its ends, and one flight above its lowest level l spans at most 2 (H - l) in x. Returns the
    run's (start, end) or None."""
    H = eg.energy_height(apex, PARAMS) + eg.ENERGY_SLACK
    ceiling, reach = eg.landing_ceiling(apex, PARAMS), PARAMS.leg_length * math.sin(math.atan(PARAMS.friction))
    lo = ground.x0 + np.arange(ground.heights.size) * ground.cell
    high = (ground.heights >= ceiling) & (lo + ground.cell > apex[0]) & (lo < goal_x)
    for start in np.flatnonzero(high & ~np.r_[False, high[:-1]]):
        end = start + int(np.argmin(np.r_[high[start:], False]))
        a, b = lo[start], min(lo[end - 1] + ground.cell, goal_x)
        if b - a - 2 * reach > 2 * (H - ground.heights[start:end].min()) + eg.GEOMETRY_SLACK:
            return a, b
    return None


# Low-energy starts on step worlds (apex 0.65-0.75 m above the ground, 0.8-1.5 m/s) that each meet a stretch of
# terrain above their landing ceiling too long to fly over (``blocking_stretch``): the argument must prove them.
MUST_PROVE = [(90004, 0.65, 0.8), (90004, 0.65, 1.5), (90004, 0.75, 0.8), (90007, 0.65, 0.8), (90007, 0.65, 1.5),
              (90007, 0.75, 0.8), (90011, 0.65, 0.8)]
# Low-energy starts the argument proves (apex 0.65 or 0.75 m above the ground, 0.8 or 1.5 m/s): some meet a
# blocking stretch, the others are proved only through its cell graph (the ways between footholds).
SEARCHED = [(90004, 0.65, 0.8), (90004, 0.65, 1.5), (90004, 0.75, 1.5), (90007, 0.65, 0.8), (90007, 0.65, 1.5),
            (90007, 0.75, 1.5), (90011, 0.65, 0.8), (90011, 0.65, 1.5)]


def start(seed: int, z: float, v: float):
    ground = step_world(seed)
    return (-1.0, z + ground.height_at(-1.0), v), ground


@pytest.mark.parametrize("seed, z, v", MUST_PROVE)
def test_a_stretch_above_the_landing_ceiling_too_long_to_fly_over_is_proved(seed, z, v):
    apex, ground = start(seed, z, v)
    assert blocking_stretch(apex, ground, 10.0) is not None
    proof = eb.prove_unreachable(apex, ground, 10.0, PARAMS)
    assert proof is not None and proof["landing_ceiling"] == pytest.approx(eg.landing_ceiling(apex, PARAMS), abs=1e-6)


def test_a_blocking_stretch_is_found_only_where_one_blocks():
    """The test's own premise: a fast start (more energy) meets no blocking stretch, and nothing is proved."""
    apex, ground = start(90004, 0.75, 2.2)
    assert blocking_stretch(apex, ground, 10.0) is None and eb.prove_unreachable(apex, ground, 10.0, PARAMS) is None
    assert blocking_stretch(START, terrain((1.5, 8.0, eg.landing_ceiling(START, PARAMS) + 0.01)), 3.0) is not None


@pytest.mark.slow
@pytest.mark.parametrize("seed, z, v", SEARCHED)
def test_the_search_finds_no_witness_where_the_energy_argument_proves_a_step_world_uncrossable(seed, z, v):
    """Where the argument proves the goal unreachable (each of these starts is proved), 60 s of search without it
    finds no witness either."""
    apex, ground = start(seed, z, v)
    assert eb.prove_unreachable(apex, ground, 10.0, PARAMS) is not None
    r = mc.model_check(apex, ground, 10.0, PARAMS, levels=(mc.COARSE,), budget=Budget(10 ** 6, max_time_s=60.0),
                       energy=False, drake_check=False)
    assert r["verdict"] != mc.TRAVERSABLE, (seed, z, v)
