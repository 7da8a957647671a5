"""The hopper as a robot: a multibody planar hopper in Drake (``robot``), terrain as scene-graph geometry
(``terrain``), its controller (``controller``) and its use of its leg actuator beyond the template's (``pump``),
failure detection (``failures``), the closed-loop diagram and footstep execution (``diagram``, ``execute``), Meshcat
replays and figures (``replay``) and the template fitted to it (``fit``)."""
