"""Physics: ``SimConfig`` (no physics imports), the ``Simulator`` of N robots and one backend class per engine."""
