"""The SLAM front end's settings (SI units), in one frozen dataclass; defaults follow SLAM
Toolbox's where it has the same setting, and every other is stated with its reason."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from kit.slam import scan_matching as sm

__all__ = ["CHI2_3DOF_999", "SlamConfig"]

CHI2_3DOF_999 = 16.27
"""χ² with 3 degrees of freedom that a consistent 3-vector exceeds with probability 0.1 %."""


@dataclass(frozen=True)
class SlamConfig:
    """Front-end settings (SI units). Defaults follow SLAM Toolbox's where they exist."""

    min_travel: float = 0.3
    """New node after this much travel [m] (SLAM Toolbox: ``minimum_travel_distance``)."""
    min_heading: float = 0.3
    """… or this much turning [rad] (``minimum_travel_heading``)."""
    local_map_nodes: int = 5
    """Scans in the local map matched against (``scan_buffer_size``)."""
    max_range: float = 25.0
    """Returns farther than this [m] are not used for matching."""
    point_spacing: float = 0.02
    """Scan points are thinned to one per cell of this size [m]."""
    icp: sm.IcpConfig = field(default_factory=sm.IcpConfig)
    min_inliers: float = 0.3
    """A match pairing fewer of its points than this fraction is not trusted."""
    poor_rmse: float = 0.08
    """A match whose residuals' RMS exceeds this [m] is not trusted."""
    match_gate: float = CHI2_3DOF_999
    """A match may move the prediction by at most this Mahalanobis distance² under the
    odometry's covariance, or it must be confirmed by the wider search."""
    far_match_gain: float = 0.1
    """A match far from the odometry is taken only if it puts this much larger a share of
    the scan's points within 0.1 m of the local map than the best fit near the odometry."""
    search_linear_window: float = 0.3
    """Half-width [m] of the correlative search around the prediction."""
    search_angular_window: float = math.radians(20.0)
    """Half-width [rad] of that search (odometry's heading can jump this much)."""
    search_prior_scale: float = 0.01
    """The odometry prior's information is scaled by this for the ICP after the search."""
    odometry_noise: tuple[float, float, float, float] = (0.1, 0.02, 0.2, math.radians(1.0))
    """(α_xy, σ_xy, α_θ, σ_θ): the odometry between two scans is trusted to
    ``α_xy d + σ_xy`` [m] and ``α_θ |Δθ| + σ_θ`` [rad] (d the distance driven); an assumption."""
    min_edge_sigma: tuple[float, float] = (0.005, math.radians(0.2))
    """Floor on an edge's standard deviation (m, rad): matches are not perfect."""
    match_covariance_scale: float = 10.0
    """ICP's covariance counts every point's residual as an independent measurement;
    neighbouring points on one wall are not, so a match's (and a closure's) covariance is
    scaled by this before it weighs an edge (an assumption: on the Intel log the matches err
    2.4–4 times the unscaled standard deviations)."""
    match_kernel_delta: float = 3.0
    """Cauchy kernel width on match edges (in √χ² units)."""
    odometry_kernel_delta: float = 3.0
    """Cauchy kernel width on the odometry's edges, which every pair of consecutive nodes
    has beside the match's (wheel odometry slips and jumps)."""
    match_chi2: float = 10 * CHI2_3DOF_999
    """After an optimisation a match edge whose χ² exceeds this is replaced by the
    odometry's edge."""
    dynamic_margin: float = 0.15
    """A return is taken for something moving when every cell within this [m] of it has
    been seen free by the last scans (0 turns the test off)."""
    dynamic_nodes: int = 20
    """Nodes whose beams make up the free space."""
    dynamic_range: float = 10.0
    """Beams clear free space up to this range [m]."""
    loop_search_radius: float = 4.0
    """Loop-closure candidates lie within this distance [m] (``loop_search_maximum_distance``)."""
    loop_min_travel: float = 10.0
    """… and were passed at least this much driving [m] ago."""
    loop_chain: int = 10
    """Nodes on each side of the candidate whose scans form the loop's reference."""
    loop_linear_window: float = 2.0
    """Half-width of the correlative search [m]: the drift since the candidate (SLAM
    Toolbox's ``loop_search_space_dimension`` of 8 m spans ±4 m)."""
    loop_angular_window: float = 0.3
    """Half-width of the correlative search [rad]."""
    loop_resolution: float = 0.05
    """Correlative grid cell [m]."""
    loop_min_response: float = 0.45
    """Minimum mean likelihood (``loop_match_minimum_response_fine``)."""
    loop_max_variance: float = 0.05
    """Maximum positional variance [m²] of an accepted match."""
    loop_min_support: float = 0.7
    """Share of the scan's points the refined match must put within 0.1 m of the reference,
    among those it puts within 1 m of it (the part the reference has seen)."""
    loop_min_overlap: float = 0.3
    """… and the share it puts within 1 m must reach this."""
    loop_recent_nodes: int = 4
    """Nodes before the new one whose scans must agree with the closure too."""
    loop_min_recent_support: float = 0.5
    """Share of their points the closure's correction must put within 0.1 m of the
    reference (among those within 1 m of it)."""
    loop_agreement: tuple[float, float] = (0.1, math.radians(2.0))
    """ICP from the correlative answer must stay within this (m, rad) of it."""
    loop_max_shift: tuple[float, float] = (0.3, 0.03)
    """A closure may move the node by at most ``a + b · d`` metres, ``d`` the driving [m]
    between the candidate and the node by the shortest way along the chain and across the
    closures accepted so far: the drift scan matching can have accumulated (an
    assumption)."""
    loop_max_turn: tuple[float, float] = (math.radians(3.0), math.radians(0.3))
    """… and turn it by at most ``a + b · d`` radians."""
    loop_gate: float = CHI2_3DOF_999
    """A closure whose Mahalanobis distance² from the graph's current estimate (under the
    graph's marginal covariance of the two nodes' relative pose plus the closure's own)
    exceeds this is *surprising*: it waits for another closure that agrees with it."""
    loop_consistency: tuple[float, float] = (0.15, math.radians(2.0))
    """Two closures agree when the loop they make with the graph's estimates between their
    new nodes and between their old ones closes within this (m, rad)."""
    loop_confirmations: int = 1
    """Agreeing closures a closure needs (one more when it is surprising) before all enter
    the graph together: one scan can look like another place, two in a row rarely do."""
    loop_pending_nodes: int = 25
    """Nodes a closure waits for its confirmation."""
    loop_kernel_delta: float = 3.0
    """Cauchy kernel width on loop edges (in √χ² units)."""
    closure_chi2: float = 2 * CHI2_3DOF_999
    """After an optimisation a closure whose χ² exceeds this is removed."""
    loop_every: int = 1
    """Look for a loop at every n-th node."""
    loop_cooldown: int = 10
    """Nodes after an accepted closure before the next is looked for."""

    def __post_init__(self) -> None:
        if self.min_travel <= 0 or self.min_heading <= 0 or self.local_map_nodes < 1:
            raise ValueError("min_travel, min_heading and local_map_nodes must be positive")
        if self.max_range <= 0 or self.point_spacing < 0 or not 0 <= self.min_inliers <= 1:
            raise ValueError("max_range must be positive, point_spacing >= 0, min_inliers in "
                             "[0, 1]")
        if self.match_gate <= 0 or self.match_chi2 <= 0 or self.closure_chi2 <= 0:
            raise ValueError("match_gate, match_chi2 and closure_chi2 must be positive")
        if self.dynamic_margin < 0 or self.dynamic_nodes < 1 or self.dynamic_range <= 0:
            raise ValueError("dynamic_margin must be >= 0, dynamic_nodes and dynamic_range "
                             "positive")


