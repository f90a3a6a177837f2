"""The navigation's health during a run: a non-finite estimate or covariance stops the run (summary
``aborted``); the covariance's extreme eigenvalues and asymmetry are recorded."""

from __future__ import annotations

import math

import numpy as np
from slipnav.scenarios.log_drain import LogDrain


class NavigationHealth:
    """Checks the navigation after every simulator step: the logged estimate (fused pose, mixed estimate)
    of the new samples and the EKF covariance P (the navigation's ``covariance`` output) must be finite;
    records the extreme eigenvalues of P and its largest asymmetry |P - P^T| over the run (P as the steps
    end, every 0.1 s). ``aborted``: None, or why the run was stopped (the first non-finite value)."""

    ESTIMATE_SIGNALS = ("nav_pose", "nav_mixed_estimate")

    def __init__(self, diagram, context):
        self.aborted = None
        self.min_eigenvalue = self.max_eigenvalue = self.max_asymmetry = None
        try:
            nav = diagram.GetSubsystemByName("navigation")
        except RuntimeError:
            self._port = None  # no navigation in this diagram
            return
        self._port, self._context = nav.GetOutputPort("covariance"), nav.GetMyContextFromRoot(context)

    def check(self, drain: LogDrain, new: slice) -> str | None:
        """Check the samples ``new`` and the current P; returns (and keeps) the reason to stop, else
        None."""
        if self._port is None or self.aborted is not None:
            return self.aborted
        for name in self.ESTIMATE_SIGNALS:
            rows = drain.signal(name)[:, new]
            bad = np.argwhere(~np.isfinite(rows))
            if len(bad):
                row, k = bad[0]
                self.aborted = (
                    f"the navigation estimate became non-finite at t = {drain.t[new][k]:.3f} s "
                    f"({name} row {row} = {rows[row, k]})"
                )
                return self.aborted
        P = self._port.Eval(self._context).reshape(5, 5)
        if not np.all(np.isfinite(P)):
            t = drain.t[new][-1] if new.stop > new.start else math.nan
            self.aborted = f"the EKF covariance P became non-finite by t = {t:.3f} s"
            return self.aborted
        eigenvalues = np.linalg.eigvalsh(0.5 * (P + P.T))
        asymmetry = float(np.max(np.abs(P - P.T)))
        self.min_eigenvalue = _extreme(min, self.min_eigenvalue, float(eigenvalues[0]))
        self.max_eigenvalue = _extreme(max, self.max_eigenvalue, float(eigenvalues[-1]))
        self.max_asymmetry = _extreme(max, self.max_asymmetry, asymmetry)
        return None


def _extreme(pick, current, value):
    return value if current is None else pick(current, value)
