"""The two sample rates of Seyr & Jakubek §IV: navigation T_N and control T_C, with T_C/T_N in N+."""

from __future__ import annotations

import dataclasses as dc
import math

from slipnav.systems.ranges import require_in


@dc.dataclass(frozen=True)
class SampleRates:
    """Navigation period T_N and control period T_C (s); T_C must be a positive integer multiple of T_N.

    Args:
        T_N: navigation period, default 2 ms (Seyr & Jakubek §II).
        T_C: control period, default 20 ms (§IV).
    """

    T_N: float = 0.002
    T_C: float = 0.02

    def __post_init__(self):
        for name in ("T_N", "T_C"):
            require_in(name, getattr(self, name), "(0, 1] s")
        ratio = self.T_C / self.T_N
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ValueError(
                f"T_C={self.T_C!r} must be a positive integer multiple of T_N={self.T_N!r} "
                f"(T_C/T_N = {ratio:.6g}; allowed 1, 2, 3, ...)"
            )

    @property
    def batch_length(self) -> int:
        """T_C / T_N, the number of navigation samples per control sample (S(11)'s batch)."""
        return int(round(self.T_C / self.T_N))


def pt1_step(previous: float, value: float, time_constant: float, T_N: float) -> float:
    """One sample of a first-order lag (PT1), exact for an input held over T_N:
    y_k = y_k-1 + (1 - exp(-T_N / tau)) (u_k - y_k-1); tau = 0 passes u_k through."""
    if time_constant == 0.0:
        return value
    return previous + (1.0 - math.exp(-T_N / time_constant)) * (value - previous)
