"""``SuctionCup``: the vacuum tool's valve and its vacuum switch.

The valve drives the arm's adhesion actuator (``suction``: on pulls a part within the
lip's reach against the cup). The vacuum switch is read from the touch sensor at the
cup face (``suction_touch``, N): a part held by the vacuum presses on the lip with
about the suction force, an open cup reads zero, just as a vacuum switch reads
atmospheric pressure when nothing seals the cup. Nothing else is known about the part:
whether one is held is measured, never assumed.
"""

from __future__ import annotations

import mujoco

__all__ = ["SuctionCup"]


class SuctionCup:
    """Valve and vacuum switch of the arm named ``prefix`` in ``model``/``data``."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, *,
                 seal_force: float = 1.0, prefix: str = "arm/") -> None:
        self.data = data
        self.seal_force = seal_force
        self._act = model.actuator(prefix + "suction").id
        self._adr = model.sensor(prefix + "suction_touch").adr[0]

    def on(self) -> None:
        """Open the vacuum valve."""
        self.data.ctrl[self._act] = 1.0

    def off(self) -> None:
        """Vent the cup (release)."""
        self.data.ctrl[self._act] = 0.0

    @property
    def is_on(self) -> bool:
        return bool(self.data.ctrl[self._act] > 0.5)

    def reading(self) -> float:
        """The cup's contact force (N): what the vacuum switch measures."""
        return float(self.data.sensordata[self._adr])

    def sealed(self) -> bool:
        """True when the vacuum is on and a part seals the cup (reading >= seal_force)."""
        return self.is_on and self.reading() >= self.seal_force
