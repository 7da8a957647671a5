"""A passive hop conserves mechanical energy: apex to apex, with z absolute, on flat and stepped terrain."""
import numpy as np
import pytest

import drakeslip as ds

PARAMS = ds.SlipParams()


def step_edge(height, at=0.3):
    """Ground at 0 up to ``at``, then at ``height``: a touchdown one level away from the start apex."""
    terrain = ds.Terrain.flat()
    heights = terrain.heights.copy()
    heights[round((at - terrain.x0) / terrain.cell):] = height
    return ds.Terrain(heights, terrain.cell, terrain.x0)


def apex_energy(apex, params=PARAMS):
    return params.mass * (params.gravity * apex[1] + 0.5 * apex[2] ** 2)


def generated_step_cases(n, seed=11):
    """Successful hops from random apexes on step worlds whose foothold is on a different level."""
    rng = np.random.default_rng(seed)
    cases = []
    while len(cases) < n:
        terrain = ds.step_world(int(rng.integers(1000)))
        x = rng.uniform(0.5, 8.0)
        apex = (x, terrain.height_at(x) + rng.uniform(0.55, 0.8), rng.uniform(0.5, 2.5))
        angle = rng.uniform(-0.2, 0.5)
        result = ds.step(apex, angle, terrain, PARAMS)
        if result.ok and terrain.height_at(result.touchdown_x) != terrain.height_at(x):
            cases.append((apex, angle, terrain))
    return cases


CASES = [
    ((0.0, 0.6, 2.0), 0.25, ds.Terrain.flat()),
    ((0.0, 0.7, 0.8), 0.1, ds.Terrain.flat(-0.2)),
    ((0.0, 0.65, 3.0), 0.35, ds.Terrain.flat()),
    ((0.0, 0.75, 1.5), 0.25, step_edge(0.15)),
    ((0.0, 0.6, 1.5), 0.25, step_edge(-0.2)),
    *generated_step_cases(3),
]


@pytest.mark.parametrize("backend", ["fast", "drake"])
@pytest.mark.parametrize("case", range(len(CASES)))
def test_passive_hop_conserves_energy(case, backend):
    apex, angle, terrain = CASES[case]
    result = ds.step(apex, angle, terrain, PARAMS, backend=backend)
    assert result.ok, result
    before, after = apex_energy(apex), apex_energy(result.next_apex)
    assert abs(after - before) <= 1e-5 * abs(before), (before, after)
    # The hop went somewhere: energy moved between height and speed.
    assert abs(result.next_apex.z - apex[1]) > 1e-3


def test_stepped_cases_land_on_another_level():
    for apex, angle, terrain in CASES[3:5]:
        result = ds.step(apex, angle, terrain, PARAMS)
        assert terrain.height_at(result.touchdown_x) != terrain.height_at(apex[0])


def test_energy_is_constant_along_the_drake_trajectory_in_flight_and_stance():
    """Between apexes too: the shared definition of the energy (spring included) is constant at every logged
    sample of a three-hop Drake run, so the stance equations and the reset maps agree with it."""
    from drakeslip.dynamics import mechanical_energy
    from drakeslip.slip_hopper import Mode
    from drakeslip.simulation import simulate

    sim = simulate((0.0, 0.6, 2.0), [0.25, 0.28, 0.22], ds.Terrain.flat(), PARAMS)
    assert sim.ok and len(sim.apexes) == 3, sim.failure
    p = PARAMS.as_array()
    energies, in_stance = [], []
    for (x, z, xdot, zdot), h in zip(sim.states, sim.hybrid):
        stance = int(h[0]) == Mode.STANCE
        energies.append(mechanical_energy(x, z, xdot, zdot, h[3], h[4], stance, p))
        in_stance.append(stance)
    energies = np.array(energies)
    assert sum(in_stance) > 10 and len(in_stance) - sum(in_stance) > 10  # both phases were logged
    assert np.ptp(energies) <= 1e-6 * energies[0], np.ptp(energies)
