"""Which options go together, and which stepping path runs a :class:`~.world.World`: the option
combinations the methods support (:func:`check_combinations`) and the path, the one asked for or
the fastest that applies (:func:`stepping_path`)."""

from __future__ import annotations

from typing import NamedTuple

from ..broadphase.grid import GRID_MIN_BALLS
from ..stepping.lanes import LANES_MAX_BALLS, LANES_MIN_WORLDS
from ..stepping.large import LARGE_WORLD_MIN_BALLS
from ..stepping.large_spin import LARGE_SPIN_MIN_BALLS

__all__ = ["Options", "check_combinations", "stepping_path", "EULERS"]

EULERS = ("symplectic_euler", "explicit_euler")


class Options(NamedTuple):
    """A World's checked options that decide what it can run, and how."""

    rotation: bool
    mu_r: float
    tangential: str
    events: bool
    integrator: str
    per_world: bool
    damping: str
    use_grid: bool
    broadphase: str
    motors: int  # how many

    @property
    def spinning(self) -> bool:
        """The rotating contact law: with rotation, or for the history model on balls that slide."""
        return self.rotation or self.tangential == "history"


def check_combinations(o: Options) -> None:
    """Refuse option combinations the methods do not support, naming them."""
    if not o.rotation and o.mu_r != 0.0:
        raise ValueError(
            f"mu_r={o.mu_r!r} needs rotation=True (rolling resistance acts on the balls' spin); pass "
            "rotation=True or leave mu_r at 0"
        )
    if o.spinning and o.events:
        raise ValueError("events=True does not support rotation=True or tangential='history' yet: use events=False")
    if o.tangential == "history" and o.integrator not in EULERS:  # (checked before the path)
        raise ValueError(
            f"tangential='history' advances each contact's spring once per step, which needs an integrator "
            f"with one force pass per step: symplectic_euler or explicit_euler (got {o.integrator!r})"
        )
    if o.per_world and o.events:
        raise ValueError("per_world=True does not support events=True yet: use events=False")
    if o.integrator == "implicit_euler" and o.damping == "no_tension":
        # its frozen-contact Jacobian cannot see the clip: the solve would pull separating
        # balls together, which is what no_tension exists to prevent
        raise ValueError(
            "damping='no_tension' is not supported with integrator='implicit_euler' (the linearised "
            "solve would reintroduce tension); use damping='linear' or an explicit integrator"
        )


def stepping_path(o: Options, stepping: str, B: int, n: int) -> str:
    """The stepping path: the one asked for (refused where it does not apply) or, for ``auto``,
    the fastest that applies (measured crossovers: ``python -m penalty_env.bench core``)."""
    euler = o.integrator in EULERS
    motors = o.motors > 0
    if o.per_world and stepping == "neighbour_list":
        raise ValueError(
            "per_world=True steps on the scalar and lanes paths only: use stepping='scalar', 'lanes' or 'auto'"
        )
    if o.spinning and stepping == "lanes":
        raise ValueError(
            "stepping='lanes' does not support rotation=True or tangential='history' yet: use "
            "stepping='scalar', 'neighbour_list' or 'auto'"
        )
    if motors and (o.events or stepping == "neighbour_list"):
        raise ValueError(
            "motors drive balls on the scalar and lanes paths only: use stepping='scalar', 'lanes' or "
            "'auto' and events=False"
        )
    if stepping == "auto":
        if o.events:
            return "scalar"
        large = LARGE_SPIN_MIN_BALLS if o.spinning else LARGE_WORLD_MIN_BALLS
        if n >= large and o.use_grid and euler and not motors and not o.per_world:
            return "neighbour_list"
        if o.spinning:
            return "scalar"
        if not o.use_grid and euler and n <= LANES_MAX_BALLS and B >= LANES_MIN_WORLDS:
            return "lanes"
        return "scalar"
    if o.events and stepping != "scalar":
        raise ValueError(
            f"stepping={stepping!r} cannot locate events; with events=True use stepping='scalar' or 'auto'"
        )
    if stepping == "lanes" and (o.use_grid or not euler):
        raise ValueError(
            f"stepping='lanes' needs broadphase='all_pairs' (got {o.broadphase!r}, "
            f"{'grid' if o.use_grid else 'all pairs'}) and symplectic or explicit Euler "
            f"(got {o.integrator!r})"
        )
    if stepping == "neighbour_list" and (not o.use_grid or not euler):
        raise ValueError(
            f"stepping='neighbour_list' needs the grid (broadphase='grid', or 'auto' from "
            f"{GRID_MIN_BALLS} balls; got {o.broadphase!r} with {n} balls) and symplectic or "
            f"explicit Euler (got {o.integrator!r})"
        )
    return stepping
