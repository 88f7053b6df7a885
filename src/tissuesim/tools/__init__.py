"""The instruments: the pin-head (§8.2), the rigid probe, the grasper and the scalpel (§7), each a :class:`Tool`
(:mod:`.base`: press, move, release, the force on the tissue with one sign), made by kind with
:func:`~.base.tool_class`."""
