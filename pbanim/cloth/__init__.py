"""Cloth (chapter 12): stiff systems at scale — a sheet, Baraff–Witkin conditions with sparse Jacobians, large
steps (implicit Euler by filtered CG), Newton, XPBD with substeps, sphere and ground colliders."""
from .sheet import Sheet
from .collide import Ground, Sphere
from .model import Cloth
from .large_steps import PCGResult, large_step, modified_pcg, newton_step
from .readable import condition_forces_loop
from .xpbd import xpbd_step

__all__ = ["Sheet", "Sphere", "Ground", "Cloth", "PCGResult", "large_step", "modified_pcg", "newton_step",
           "xpbd_step", "condition_forces_loop"]
