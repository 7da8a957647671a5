"""The spatial multibody hopper: a floating-base robot in Drake (``robot``), its controller (``controller``, aiming
its leg with ``aiming``), the height map as scene geometry (``terrain``), its Diagram (``diagram``) and its runs
(``gait``)."""
