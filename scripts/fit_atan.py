"""Fits the polynomial behind the fast CPU path's azimuth guess (`approx_atan2` in
src/projection/fast/lanes.rs) and prints its coefficients and worst error.

atan(t) ~ t * P(t^2) on |t| <= tan(pi/8), P of degree 6, by least squares weighted by t
(the error of atan, not of P) on 4000 Chebyshev nodes. The Rust unit test
`approx_atan2_is_within_its_bound` checks the bound independently against libm's atan2.

    python scripts/fit_atan.py
"""

import numpy as np

DEGREE = 6
T = np.tan(np.pi / 8)
n = 4000
s = (np.cos(np.pi * (np.arange(n) + 0.5) / n) + 1) / 2 * T * T
t = np.sqrt(s)
w = t
V = np.vander(s, DEGREE + 1, increasing=True)
c, *_ = np.linalg.lstsq(V * w[:, None], np.arctan(t) / t * w, rcond=None)

tt = np.linspace(0, T, 1_000_001)
p = np.zeros_like(tt)
for k in reversed(range(DEGREE + 1)):
    p = p * tt * tt + c[k]
print("coefficients of P (s^0 first):")
for k in c:
    print(f"    {float(k)!r},")
print(f"worst |t P(t^2) - atan t| on [0, tan(pi/8)]: {np.max(np.abs(tt * p - np.arctan(tt))):.3e}")
