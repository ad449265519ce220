"""Physical constants of the Earth, the Sun and time shared by the environment models and the plants."""
from __future__ import annotations

import math

MU_EARTH = 3.986004418e14
"""Earth's gravitational parameter, m^3/s^2 (WGS 84 / EGM 96)."""
EQUATORIAL_RADIUS = 6378137.0
"""Earth's equatorial radius, m (WGS 84): J2's reference radius and the altitude's sphere."""
J2 = 1.08262668e-3
"""Earth's J2 (EGM 96, unnormalized)."""
ERA_RATE = 2 * math.pi * 1.00273781191135448 / 86400.0
"""Earth rotation angle rate, rad/s (IERS 2010: 2 pi 1.00273781191135448 per UT1 day)."""
ASTRONOMICAL_UNIT = 1.495978707e11
"""m."""
SUN_RADIUS = 6.957e8
"""The Sun's nominal radius, m (IAU 2015)."""
