"""The freewheel output of the rockers' speeds and its ripple: on samples of the crank angle
(sampled) and exactly, at the stationary points and crossings of the speeds (exact)."""
