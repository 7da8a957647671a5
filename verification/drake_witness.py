"""A model-checking witness (leg angles at each apex, with the fast step map's footholds and apexes) executed on
the Drake simulator in one continuous run, replanned on the fast map wherever Drake's apex drifted from the
prediction (``verification.model_check``'s module doc, "The Drake check")."""
from __future__ import annotations

from drakeslip import ApexState, SlipParams, Terrain
from drakeslip.rollout import rollout
from drakeslip.units import units_of

REPLAN_TOLERANCE = 1e-3  # m, m/s: Drake's apex this far from the predicted one is replanned from


def execute_on_drake(apex: ApexState, witness: dict, search_from, goal_x: float, terrain: Terrain,
                     params: SlipParams) -> dict:
    """Execute a witness on the Drake simulator, with its leg angles commanded at each apex, and replan when
    Drake's apex has drifted more than ``REPLAN_TOLERANCE`` from the fast map's prediction: ``search_from(apex)``
    must return a new witness from there, or None (open-loop replay drifts: see ``verification.model_check``'s
    module doc). It is one continuous, deterministic simulation, so the leg angles it ran re-check open-loop on
    Drake exactly.
    Returns {"ok", "replans", "hops_done", "failure", "final_x", "drift_hop", "leg_angles", "footholds",
    "apexes"}: ok when every hop succeeds and the last apex is at or past ``goal_x``; ``drift_hop`` is the first
    hop at whose start Drake had drifted (None if never)."""
    plan = {"start": 0, "from": tuple(apex), **witness}
    log = {"replans": 0, "drift_hop": None, "stuck": False}

    def policy(a, hop):
        j = hop - plan["start"]
        if j >= len(plan["leg_angles"]):
            return None   # the plan is done: its last apex is past the goal
        expected = plan["apexes"][j - 1] if j > 0 else plan["from"]
        if max(abs(u - v) for u, v in zip(a, expected)) > REPLAN_TOLERANCE:
            log["drift_hop"] = hop if log["drift_hop"] is None else log["drift_hop"]
            new = search_from(ApexState(*a))
            if new is None:
                log["stuck"] = True
                return None
            plan.update(start=hop, **{"from": tuple(a)}, **new)
            log["replans"] += 1
            j = 0
        return plan["leg_angles"][j]

    run = rollout(apex, terrain, params, leg_angles=policy, backend="drake",
                  max_time=units_of(params).hop_seconds * (len(witness["leg_angles"]) + 20))
    final_x = run.apexes[-1].x if run.apexes else apex.x
    return {"ok": run.ok and not log["stuck"] and final_x >= goal_x, "replans": log["replans"],
            "hops_done": len(run.apexes), "failure": run.failure.name if run.failure else None,
            "final_x": float(final_x), "drift_hop": log["drift_hop"],
            "leg_angles": [float(v) for v in run.leg_angles], "footholds": [float(v) for v in run.footholds],
            "apexes": [[float(v) for v in e] for e in run.apexes]}
