"""Warp math of the paper, installed as ``wqwarp.kernels``.

Each paper equation is one ``@wp.func``; kernels are thin loops over ``(world, item)`` that call them.
No torch and no Newton objects live here.
"""

from wqwarp import quiet_warp

quiet_warp()
