"""Multi-hop Drake simulation: each apex command is used for exactly one hop, in order."""
import drakeslip as ds
from drakeslip.simulation import simulate

FLAT = ds.Terrain.flat()


def test_a_list_of_angles_runs_one_hop_per_angle():
    result = simulate((0.0, 0.6, 2.0), [0.25, 0.2], FLAT)
    assert [e.kind for e in result.events] == ["touchdown", "liftoff", "apex"] * 2
    assert result.ok and result.leg_angles == [0.25, 0.2]
    assert [e.leg_angle for e in result.events if e.kind == "touchdown"] == [0.25, 0.2]


def test_the_callback_sees_each_hop_index_once():
    calls = []

    def policy(apex, hop):
        calls.append((hop, apex.x))
        return 0.25

    result = simulate((0.0, 0.6, 2.0), policy, FLAT, max_hops=2)
    assert [hop for hop, _ in calls] == [0, 1]  # max_hops ends the run before asking for hop 2
    assert calls[1][1] == result.apexes[0].x
    assert len(result.apexes) == 2


def test_drake_step_is_one_hop():
    """From this apex a second hop at the same angle slips; the step map must not run it."""
    result = ds.step((0.0, 0.6, 3.0), 0.6, FLAT, backend="drake")
    assert result.ok, result
    assert result.next_apex.z > 1.0
