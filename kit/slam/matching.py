"""Where is a scan, given the local map and the odometry's prediction — and when is a match
not to be trusted?

The SLAM front end's scan-to-map step (:func:`match_scan`), with its gates:

1. **ICP held by the odometry** (:func:`kit.slam.scan_matching.icp` with the odometry's
   prediction as a prior) is taken when it *fits* — enough of the scan's points paired,
   small residuals — and agrees with the odometry: the Mahalanobis distance² of
   ``match − prediction`` under the odometry's covariance is at most ``match_gate``.
2. Otherwise a **correlative search** (:mod:`kit.slam.correlative`, which a wrong start
   cannot trap) looks around the prediction — three times as far and four times as wide
   when its best lies on the window's edge, since wheel odometry can jump 0.7 m and 70°
   between two scans — and ICP refines its answer; the two matchers must agree.
3. A match away from the odometry must explain the scan clearly better than the odometry's
   own prediction does: its *support* (the share of the scan's points within 0.1 m of the
   local map) must exceed the prediction's by ``far_match_gain``, and the search's answer
   must beat ICP's by as much. Along a corridor, where a slid pose fits as well as the
   right one, the odometry's prediction stays (it is what broke the Intel map before: a
   search answer 5 % better than ICP's, 0.49 m along a corridor).
4. Otherwise the scan keeps the **odometry's prediction** and no match edge.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from kit import geometry
from kit.slam import correlative
from kit.slam import scan_matching as sm
from kit.slam.loops import support

if TYPE_CHECKING:
    from kit.slam.config import SlamConfig

__all__ = ["Match", "fits", "match_scan", "prior_information", "refine"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Match:
    """A scan's pose in ``map`` and how it was found."""

    pose: FloatArray
    covariance: FloatArray
    how: str
    """"icp", "search" or "odometry"."""
    prior: FloatArray | None = None
    """The odometry prior's information the match was held by (its covariance includes
    it)."""

    def scan_covariance(self) -> FloatArray:
        """The covariance of what the scan alone says: the prior's information taken back
        out of the match's (``(Σ⁻¹ − Ω_p)⁻¹``), kept positive definite."""
        info = np.linalg.inv(self.covariance)
        if self.prior is not None:
            info = info - self.prior
        info = 0.5 * (info + info.T)
        w, v = np.linalg.eigh(info)
        w = np.maximum(w, 1e-6)
        return np.asarray((v / w) @ v.T, dtype=np.float64)



def prior_information(step: FloatArray, odometry_noise: tuple[float, float, float, float]
                      ) -> FloatArray:
    """The information of an odometry step ``(dx, dy, dθ)``: standard deviations
    ``α_xy d + σ_xy`` [m] in x and y (isotropic, so the same in the map frame as in the
    robot's) and ``α_θ |dθ| + σ_θ`` [rad], ``d`` the distance driven."""
    a_xy, s_xy, a_th, s_th = odometry_noise
    d = float(np.hypot(step[0], step[1]))
    sd_xy, sd_th = a_xy * d + s_xy, a_th * abs(float(step[2])) + s_th
    return np.diag([1 / sd_xy**2, 1 / sd_xy**2, 1 / sd_th**2])


def fits(result: sm.MatchResult, cfg: SlamConfig) -> bool:
    """The fit gates: enough points paired, residuals small (an ICP that ends moving back
    and forth between two pairings by less than a millimetre still fits)."""
    return result.inlier_fraction >= cfg.min_inliers and result.rmse <= cfg.poor_rmse and \
        result.iterations > 0


def match_scan(points: FloatArray, predicted: FloatArray, omega: FloatArray,
               ref: sm.PointCloudReference | None,
               local_field: Callable[[], correlative.LikelihoodField | None], cfg: SlamConfig
               ) -> Match:
    """The pose ``T_map_base`` of a scan's ``points`` (``base``), through the gates above.

    Parameters
    ----------
    predicted : (3,)
        The odometry's prediction.
    omega : (3, 3)
        The odometry step's information (:func:`prior_information`).
    ref
        The local map as an ICP reference (``None``: nothing to match against).
    local_field
        Gives the local map's likelihood field, built only if the search needs it.
    """
    odometry = Match(predicted, np.asarray(np.linalg.inv(omega)), "odometry")
    if ref is None or len(points) < 10:
        return odometry
    near = sm.icp(points, ref, predicted, omega)
    d = near.pose - predicted
    d[2] = float(geometry.wrap_angle(d[2]))
    if fits(near, cfg) and float(d @ omega @ d) <= cfg.match_gate:
        return Match(near.pose, near.covariance, "icp", omega)
    field_ = local_field()
    if field_ is None:
        return odometry
    res = field_.resolution
    linear, angular = cfg.search_linear_window, cfg.search_angular_window
    coarse = correlative.correlative_match(points, field_, predicted, linear, angular,
                                           math.radians(0.5), penalty=0.1)
    off = coarse.pose - predicted
    if max(abs(off[0]), abs(off[1])) >= linear - 1.5 * res or \
            abs(float(geometry.wrap_angle(off[2]))) >= angular - math.radians(1.0):
        coarse = correlative.correlative_match(points, field_, predicted, 3 * linear,
                                               min(4 * angular, math.pi), math.radians(0.5),
                                               penalty=0.1)
    far = sm.icp(points, ref, coarse.pose, omega * cfg.search_prior_scale)
    apart = geometry.relative(coarse.pose, far.pose)
    if math.hypot(apart[0], apart[1]) > 2.5 * res or abs(apart[2]) > math.radians(2.0):
        # ICP walked off: a second correlative look where it ended must find it there
        coarse = correlative.correlative_match(points, field_, far.pose, 4 * res,
                                               math.radians(4.0), math.radians(0.5))
        apart = geometry.relative(coarse.pose, far.pose)
    agree = math.hypot(apart[0], apart[1]) <= 2.5 * res and abs(apart[2]) <= math.radians(2.0)
    gain = cfg.far_match_gain
    bar = support(points, ref, predicted) + gain
    s_near = support(points, ref, near.pose) if fits(near, cfg) else -1.0
    s_far = support(points, ref, far.pose) if fits(far, cfg) and agree else -1.0
    if s_far >= max(bar, s_near + gain):
        return Match(far.pose, far.covariance, "search", omega * cfg.search_prior_scale)
    if s_near >= bar:
        return Match(near.pose, near.covariance, "icp", omega)
    return odometry


def refine(points: FloatArray, match: Match, omega: FloatArray,
           ref: sm.PointCloudReference | None, cfg: SlamConfig) -> Match:
    """ICP again from ``match`` (once more of the scan's returns were found to move), held
    by the same prior; the match stays if the new one does not fit."""
    if match.how == "odometry" or ref is None or len(points) < 10:
        return match
    if match.how == "search":
        omega = omega * cfg.search_prior_scale
    result = sm.icp(points, ref, match.pose, omega)
    return Match(result.pose, result.covariance, match.how, omega) if fits(result, cfg) \
        else match
