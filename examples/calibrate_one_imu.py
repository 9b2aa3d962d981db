"""Calibrate one IMU from arrays with Kong's method (Kong et al. 2016, Eq. 1-6).

    python examples/calibrate_one_imu.py

A sensor is strapped on a segment with a known rotation; the segment stands still for 20 s, then
bows forward and back (a rotation about the body's right axis, y). From the two accelerometer
recordings, Kong's method returns R, the rotation from the sensor frame to the body frame
(x forward, y right, z down: d_body = R @ d_sensor). With your own data, pass your arrays
(specific force in m/s^2, as accelerometers report it) instead of the simulated ones.
"""

import numpy as np
from scipy.spatial.transform import Rotation

from aceval.data.rotations import error_angle_deg
from aceval.methods.kong import kong_calibrate

G = 9.81
rng = np.random.default_rng(1)

# the truth: how the sensor sits on the body (sensor -> body)
mounting = Rotation.from_euler("xyz", [15, -70, 30], degrees=True).as_matrix()

# quiet standing: the specific force points up (-z in the body frame), plus sensor noise
standing_body = np.tile([0.0, 0.0, -G], (2000, 1)) + rng.normal(0, 0.02, (2000, 3))

# a bow: the body pitches forward 60 deg and back about y, with a tangential acceleration along x
t = np.linspace(0, 2 * np.pi, 400)
pitch = np.radians(60) * (1 - np.cos(t)) / 2
bowing_body = Rotation.from_euler("y", -pitch[:, None]).inv().apply([0.0, 0.0, -G])
bowing_body[:, 0] += 1.5 * np.sin(t)

# what the sensor measures: the body-frame vectors in the sensor frame (d_sensor = R^T d_body)
standing_sensor = standing_body @ mounting
bowing_sensor = bowing_body @ mounting

# the sensor axis that points roughly to the subject's right as mounted (in a lab: how the sensor
# was strapped on; here: read off the truth, body y in sensor coordinates is mounting[1])
k = int(np.argmax(np.abs(mounting[1])))
right_axis = ("+" if mounting[1, k] > 0 else "-") + "xyz"[k]
result = kong_calibrate(standing_sensor, bowing_sensor, right_axis)
print(f"right_axis {right_axis}; R (sensor -> body):\n", np.round(result.R, 4))
print(
    f"planarity {abs(result.planarity):.4f}, normal/vertical angle {result.normal_vertical_angle_deg:.1f} deg"
)
print(f"error to the true mounting: {error_angle_deg(result.R, mounting):.3f} deg")
