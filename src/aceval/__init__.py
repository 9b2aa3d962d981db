"""aceval: evaluation and statistics suite for anatomical (sensor-to-body) IMU calibration.

Conventions used everywhere in the package (Kong et al. 2016, Section 2.1):

* body frame {0}: x anterior, y right (medial-lateral), z down (vertical), right-handed;
* ``R`` (3x3) maps sensor-frame vectors into the body frame: ``d_body = R @ d_sensor`` (Kong Eq. 6);
* SI units inside the package: acceleration (specific force) in m/s^2, angular velocity in rad/s;
* accelerometers report specific force, which points *up* at rest.
"""

__version__ = "0.1.0"
