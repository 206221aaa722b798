"""The Heaviside (top-hat) kernel: g = 1 within c = w of the node, 0 beyond - the
average of what lies within w. Not continuous at its edge: it gives values, not
gradients. Across slabs it counts the particles whose centres lie within w of the
node's plane."""

import math

from granavg.engine.smoothing.base import Kernel

KERNEL = Kernel("heaviside", 1.0, ((0.0, (1.0,)),),
                {1: 0.5, 2: 1.0 / math.pi, 3: 3.0 / (4.0 * math.pi)}, False, 0,
                help="top hat of radius w", width_is="the support radius")
