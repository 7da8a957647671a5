"""The options of a plan check (``verification.plan_check.check_plan``), for it and the scripts that call it: how
the plan is executed (``MODES``) and how far the run may miss it (``TOLERANCE``). Nothing is imported here, so a
script's ``--help`` that shows them starts no pydrake."""

MODES = ("angles", "footholds", "auto")
TOLERANCE = 0.01  # [m, m/s] a foothold or predicted apex the run misses by more is not the plan as written
