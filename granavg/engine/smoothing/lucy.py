"""Lucy's kernel (Lucy 1977; MercuryCG's default): g(q) = (1 + 3q)(1 - q)^3 on the
support c = w, twice continuously differentiable, zero with its first two derivatives
at the edge."""

import math

from granavg.engine.smoothing.base import Kernel

#: (1 + 3q)(1 - q)^3 = 1 - 6q^2 + 8q^3 - 3q^4
KERNEL = Kernel("lucy", 1.0, ((0.0, (1.0, 0.0, -6.0, 8.0, -3.0)),),
                {1: 5.0 / 4.0, 2: 5.0 / math.pi, 3: 105.0 / (16.0 * math.pi)}, True, 3,
                help="Lucy's polynomial (1 + 3q)(1 - q)^3, support w",
                width_is="the support radius")
