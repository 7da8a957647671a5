"""The hopper in three dimensions: height maps and their families, the spatial SLIP's equations, the ``SlipHopper3D``
Drake system and its compiled step map. The sagittal-plane toolkit (``drakeslip``) is unchanged by it: with no
lateral motion, no lateral leg angle and a map that does not vary across the path, a hop here is the planar hop."""
