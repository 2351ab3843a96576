"""Closed forms and limits for a linear spring-dashpot contact: what the tests check the core
against, and what the stability guard and ``configure`` are built on.

=================  ==========================================================================
module             what it holds
=================  ==========================================================================
``closed_forms``   m_eff, omega0, zeta, restitution, contact time, overlaps; the full contact
                   response with gravity and the no-tension clip (docs/physics.md section 3)
``limits``         each integrator's stability boundary, the guard's step, the mean energy gain
                   per collision (docs/physics.md sections 4 and 6)
=================  ==========================================================================

Units are whatever the caller uses consistently (SI in the examples): ``ks`` force per length,
``kd`` force per speed, ``m_eff`` mass. ``m_eff = m_i m_j / (m_i + m_j)`` for a pair of balls and
``m_eff = m_i`` for a ball against static terrain.
"""

from .closed_forms import *  # noqa: F403
from .closed_forms import __all__ as _closed
from .limits import *  # noqa: F403
from .limits import __all__ as _limits

__all__ = list(_closed) + [name for name in _limits if name not in _closed]
