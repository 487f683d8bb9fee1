"""One name per option: the perception section's keys reach the trackers' parameter classes
under their own names, every one of them (issue 10)."""

from __future__ import annotations

import dataclasses

from humimic.perception.blobs.config import DetectionConfig, PerceptionConfig, StereoConfig
from humimic.perception.blobs.core import detection_params, em_params, stereo_params
from humimic.perception.blobs.detection import DetectionParams
from humimic.perception.blobs.em_blobs import EMParams
from humimic.perception.blobs.stereo import StereoParams

#: PerceptionConfig keys that are EM parameters.
EM_KEYS = {"roi_side", "roi_k_sigma", "em_iterations", "em_tol_px"}


def _fields(cls) -> set[str]:
    return {f.name for f in dataclasses.fields(cls)}


def test_every_tracker_key_is_a_parameter_of_the_same_name():
    assert set(DetectionConfig.model_fields) <= _fields(DetectionParams)
    assert EM_KEYS <= _fields(EMParams)
    assert set(StereoConfig.model_fields) - {"color_mask"} <= _fields(StereoParams)
    assert _fields(EMParams) & set(PerceptionConfig.model_fields) == EM_KEYS


def test_non_default_values_are_passed_through():
    cfg = PerceptionConfig(
        roi_side=33, roi_k_sigma=2.5, em_iterations=9, em_tol_px=0.25,
        detection=DetectionConfig(period=1.5, lam=0.5, restart_phase=1, hypotheses=40,
                                  score="density", proposal="uniform", refine_fit=False,
                                  sigma_min_px=2.0, sigma_max_px=20.0, min_fill=0.2, lost_frames=7,
                                  backoff_s=1.0, backoff_every=5),
        stereo=StereoConfig(template_half=5, prefilter_sigma=0.0, fine_steps=2,
                            template_sigma=2.0, min_zncc=0.7, box_sigma=2.5, mask_closing=2,
                            occlusion_check=False, occlusion_window_s=0.3,
                            occlusion_min_drop=0.25, occlusion_spread_k=2.0,
                            occlusion_min_asymmetry=0.1))
    for params, section in ((detection_params(cfg), cfg.detection), (em_params(cfg), cfg),
                            (stereo_params(cfg), cfg.stereo)):
        given = {k: getattr(section, k) for k in _fields(type(params))
                 if k in type(section).model_fields}
        assert given, type(params)
        for key, value in given.items():
            assert getattr(params, key) == value, key
            default = next(f.default for f in dataclasses.fields(params) if f.name == key)
            assert value != default, f"{key}: pick a non-default value for this test"


def test_slam_frontend_keys_are_passed_through():
    from humimic.estimation.ekf.frontend import FrontendParams
    from humimic.estimation.ekf.slam_config import SlamConfig
    from humimic.estimation.ekf.slam_stage import settings_from_config

    keys = {"patch_px", "search_sigma", "max_search_px", "min_zncc"}
    assert _fields(FrontendParams) & set(SlamConfig.model_fields) == keys
    cfg = SlamConfig(patch_px=15, search_sigma=2.5, max_search_px=30, min_zncc=0.9)
    fe = settings_from_config(cfg).frontend
    assert (fe.patch_px, fe.search_sigma, fe.max_search_px, fe.min_zncc) == (15, 2.5, 30, 0.9)


def test_slam_measurement_noise_keys_are_the_filters_parameter_names():
    from humimic.estimation.ekf.slam import SlamParams
    from humimic.estimation.ekf.slam_config import SlamConfig, SlamNoise
    from humimic.estimation.ekf.slam_stage import settings_from_config

    keys = {"sigma_accel", "sigma_gyro", "sigma_px"}
    assert _fields(SlamParams) & set(SlamNoise.model_fields) == keys
    cfg = SlamConfig(noise=SlamNoise(sigma_accel=0.7, sigma_gyro=0.02, sigma_px=1.5))
    slam = settings_from_config(cfg).slam
    assert (slam.sigma_accel, slam.sigma_gyro, slam.sigma_px) == (0.7, 0.02, 1.5)
    assert slam != SlamParams()


def test_background_odds_default_is_the_documented_constant():
    """``perception.background_odds``'s default is written as a literal (the schema cannot
    import ``auto_colors``: it imports the scenario loader): it must stay the constant whose
    docstring holds the measurements."""
    from humimic.perception.cues.auto_colors import BACKGROUND_ODDS

    assert PerceptionConfig.model_fields["background_odds"].default == BACKGROUND_ODDS
