"""The planar biped of chapter 08 among the canonical models (defined in :mod:`pbanim.control.biped`)."""

from __future__ import annotations

from ..control.biped import (BIPED_JOINTS, BIPED_SEGMENTS, biped_contact_points, planar_biped,  # noqa: F401
                             standing_state)

__all__ = ["planar_biped", "biped_contact_points", "BIPED_JOINTS", "BIPED_SEGMENTS", "standing_state"]
