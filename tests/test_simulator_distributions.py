"""The simulator's stated distributions, measured on its draws (issue 44): the mounting
misalignment (docs/simulation.md: random axis, half-normal angle, SD 10 deg), the sensors'
white noise (datasheet densities over fs/2) and constant biases (the datasheet tolerance as
3 SD), each against the number docs/simulation.md states. A unit slip (deg/s for rad/s, mg for
g) or a changed default fails here, not only in a regenerated table."""

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from aceval.data.contract import GRAVITY
from aceval.simulate.body import Anthropometry, kong_placements, random_mount
from aceval.simulate.engine import ImuErrorModel
from aceval.simulate.options import SimOptions

from .runner import REPO

DOC = (REPO / "docs" / "simulation.md").read_text()


def documented(parameter: str) -> str:
    """The value cell of a row of docs/simulation.md's parameter table."""
    row = next(line for line in DOC.splitlines() if line.startswith(f"| {parameter} |"))
    return row.split("|")[2]


def numbers(text: str) -> list[float]:
    return [float(x) for x in re.findall(r"\d+(?:\.\d+)?", text)]


def test_the_documented_parameters_are_the_simulators():
    assert "half-normal, SD 10 deg" in documented("mounting misalignment")
    assert SimOptions().misalignment_sd_deg == 10.0
    model = ImuErrorModel()
    noise = documented("IMU noise")  # accelerometer 300 ug/sqrt(Hz), gyroscope 0.01 deg/s/sqrt(Hz)
    assert numbers(noise)[:2] == [model.acc_noise_density_ug, model.gyr_noise_density_dps]
    assert "ug/sqrt(Hz)" in noise and "deg/s/sqrt(Hz)" in noise and "fs/2" in noise
    bias = documented("IMU bias")  # SD 20 mg and 1.67 deg/s: the +-60 mg and +-5 deg/s as 3 SD
    sd_mg, sd_dps, range_mg, range_dps = numbers(bias)[:4]
    assert (range_mg, range_dps) == (model.acc_bias_max_mg, model.gyr_bias_max_dps)
    assert sd_mg == pytest.approx(range_mg / 3) and sd_dps == pytest.approx(range_dps / 3, abs=0.01)
    assert "+-400 deg/s" in documented("ranges") and model.gyr_range_dps == 400.0


# --- mounting misalignment -----------------------------------------------------------------------


@settings(max_examples=3, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), sd_deg=st.sampled_from([2.0, 10.0, 20.0]))
def test_misalignment_is_half_normal_about_a_uniform_axis(seed, sd_deg):
    """3000 mountings: the angle from the nominal placement has the half-normal's RMS (= SD) and
    median (0.674 SD); the axis is uniform on the sphere (mean vector near 0, |z| uniform)."""
    rng = np.random.default_rng(seed)
    placement = kong_placements(Anthropometry(1.75))["frontal"]["thigh_r"]
    nominal = placement.nominal_mount()
    turns = Rotation.from_matrix(
        np.stack([random_mount(rng, placement, sd_deg) @ nominal.T for _ in range(3000)])
    ).as_rotvec()
    angle = np.degrees(np.linalg.norm(turns, axis=1))
    axis = turns / np.linalg.norm(turns, axis=1, keepdims=True)
    # 3000 draws: 1 SE is 1.3 % of the RMS and 2.1 % of the median; 5 and 8 % here
    assert np.sqrt(np.mean(angle**2)) == pytest.approx(sd_deg, rel=0.05)
    assert np.median(angle) == pytest.approx(0.6745 * sd_deg, rel=0.08)
    assert np.linalg.norm(axis.mean(axis=0)) < 0.07  # 1 SE about 0.011 per component
    assert np.mean(np.abs(axis[:, 2])) == pytest.approx(0.5, abs=0.03)
    # a proper rotation, the nominal placement's columns the sensor axes
    mount = random_mount(rng, placement, sd_deg)
    assert np.linalg.det(mount) == pytest.approx(1.0) and np.allclose(mount @ mount.T, np.eye(3))


# --- sensor noise and bias ----------------------------------------------------------------------


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), fs_hz=st.sampled_from([50.0, 100.0, 204.8]))
def test_white_noise_is_the_datasheet_density_over_half_the_rate(seed, fs_hz):
    model = ImuErrorModel()
    zeros = np.zeros((20000, 3))
    gyr, acc = model.apply(np.random.default_rng(seed), zeros, zeros, fs_hz, acc_range_g=8)
    acc_sd = 300e-6 * GRAVITY * np.sqrt(fs_hz / 2)  # m/s^2
    gyr_sd = np.radians(0.01) * np.sqrt(fs_hz / 2)  # rad/s
    # the bias is constant within a recording: the SD about each axis's mean is the noise's
    # (20000 samples: 1 SE is 0.5 %)
    np.testing.assert_allclose(acc.std(axis=0, ddof=1), acc_sd, rtol=0.03)
    np.testing.assert_allclose(gyr.std(axis=0, ddof=1), gyr_sd, rtol=0.03)


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_biases_are_the_datasheet_tolerance_as_three_sd(seed):
    """600 recordings: each one's mean error is its bias (the noise averages out over 500
    samples); their SD is 20 mg and 1.67 deg/s, and bias_scale scales the same draws."""
    model, rng = ImuErrorModel(), np.random.default_rng(seed)
    zeros = np.zeros((500, 3))
    biases = [model.apply(rng, zeros, zeros, 100.0, acc_range_g=8) for _ in range(600)]
    gyr_bias = np.array([g.mean(axis=0) for g, _ in biases])
    acc_bias = np.array([a.mean(axis=0) for _, a in biases])
    # 1800 draws each: 1 SE of an SD is 1.7 %
    assert acc_bias.std() == pytest.approx(0.020 * GRAVITY, rel=0.08)
    assert gyr_bias.std() == pytest.approx(np.radians(5.0 / 3), rel=0.08)
    assert np.abs(acc_bias.mean()) < 0.02 * GRAVITY * 0.1 and np.abs(gyr_bias.mean()) < 0.005
    half = model.apply(np.random.default_rng(seed), zeros, zeros, 100.0, 8, bias_scale=0.5)
    full = model.apply(np.random.default_rng(seed), zeros, zeros, 100.0, 8, bias_scale=1.0)
    for h, f in zip(half, full):  # the same draws: the noise equal, the bias halved
        step = f - h  # half the bias, on every sample
        np.testing.assert_allclose(step, np.broadcast_to(step[0], step.shape), atol=1e-12)
        noise = f - 2 * step  # the recording without its bias
        assert np.abs(noise.mean(axis=0)).max() < 5 * noise.std() / np.sqrt(len(noise))
        assert np.abs(step[0]).max() > 5 * noise.std() / np.sqrt(len(noise))


def test_ideal_sensors_are_untouched_and_the_ranges_saturate():
    model = ImuErrorModel()
    rng = np.random.default_rng(0)
    gyr = np.array([[0.1, -9.0, 8.0]])
    acc = np.array([[1.0, -100.0, 100.0]])
    ideal_gyr, ideal_acc = model.apply(rng, gyr, acc, 100.0, acc_range_g=4, enabled=False)
    assert ideal_gyr.tolist() == gyr.tolist() and ideal_acc.tolist() == acc.tolist()
    noisy_gyr, noisy_acc = model.apply(rng, gyr, acc, 100.0, acc_range_g=4)
    assert noisy_acc[0, 1] == -4 * GRAVITY and noisy_acc[0, 2] == 4 * GRAVITY
    assert noisy_gyr[0, 1] == -np.radians(400.0) and noisy_gyr[0, 2] == np.radians(400.0)
    assert abs(noisy_acc[0, 0] - 1.0) < 1.0 and abs(noisy_gyr[0, 0] - 0.1) < 0.5
