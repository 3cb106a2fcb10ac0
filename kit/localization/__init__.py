"""Localization on a known map: Markov (histogram) localization and Monte Carlo localization
in the design of Nav2's AMCL.

* :mod:`~kit.localization.histogram` — 1-D sense/move on a corridor, a 3-D (x, y, θ) grid;
* :mod:`~kit.localization.particles` — the particle filter: resampling, KLD-sampling,
  augmented MCL's recovery, global initialisation, AMCL's pose estimate;
* :mod:`~kit.localization.likelihood_field` — the laser models: likelihood field, beam model;
* :mod:`~kit.localization.amcl` — the node with Nav2's parameters, and a bag's messages run
  through it.

The odometry motion model lives in :mod:`kit.models` (estimation and SLAM use it too). The
``kit localize`` command is :mod:`kit.localization.cli`.
"""

from kit.localization.amcl import (
    Amcl,
    AmclParameters,
    LocalizationStep,
    load_parameters,
    localize,
)
from kit.localization.histogram import GridLocalization, binary_likelihood, move, sense
from kit.localization.likelihood_field import (
    BeamModel,
    LikelihoodField,
    LikelihoodFieldModel,
    beam_endpoints,
    beam_model_weights,
    beam_probability,
    expected_ranges,
    likelihood_field_weight,
    likelihood_field_weights,
)
from kit.localization.particles import (
    ParticleFilter,
    cluster_labels,
    effective_sample_size,
    histogram_bins,
    kld_resample,
    kld_sample_limit,
    low_variance_resample,
    normalize_log_weights,
    pose_estimate,
    random_particle_share,
    uniform_free_poses,
    update_recovery_averages,
)

__all__ = [
    "Amcl",
    "AmclParameters",
    "BeamModel",
    "GridLocalization",
    "LikelihoodField",
    "LikelihoodFieldModel",
    "LocalizationStep",
    "ParticleFilter",
    "beam_endpoints",
    "beam_model_weights",
    "beam_probability",
    "binary_likelihood",
    "cluster_labels",
    "effective_sample_size",
    "expected_ranges",
    "histogram_bins",
    "kld_resample",
    "kld_sample_limit",
    "likelihood_field_weight",
    "likelihood_field_weights",
    "load_parameters",
    "localize",
    "low_variance_resample",
    "move",
    "normalize_log_weights",
    "pose_estimate",
    "random_particle_share",
    "sense",
    "uniform_free_poses",
    "update_recovery_averages",
]
