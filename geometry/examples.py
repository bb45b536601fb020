"""The worked examples of Vessaz et al. (2013), as parameter values in configuration units.

* Table 4 / Fig. 4: a C2 design blade.
* Table 5 / Fig. 5: a G1 tool path with a cutter of radius R = 5 mm. The table prints d_s4 = d_p4 = 7 mm,
  which is the cutter-centre offset R + d_s4 of Eq. 15–16; millfoil's d_s4 is the machined trailing-edge
  half-thickness, 2 mm as in Table 6.

``configs/examples/`` holds the same blades as YAML files (a test keeps the two in step).
"""

from __future__ import annotations

TABLE4_C2_DESIGN: dict = {
    "mode": "design",
    "continuity": "C2",
    "parameters": {
        "L": 0.1, "alpha": 30.0, "beta1": 0.0, "beta1bar": 60.0,
        "u_s2": 0.3, "d_s1": 0.005, "d_s2": 0.015, "d_s3": 0.045, "d_s4": 0.002,
        "d_p3": 0.025, "d_p4": 0.002,
    },
}

TABLE5_G1_TOOLPATH: dict = {
    "mode": "toolpath",
    "continuity": "G1",
    "parameters": {
        "L": 0.1, "alpha": 30.0, "beta1": 0.0, "beta1bar": 60.0, "R": 0.005,
        "u_s2": 0.2, "d_s1": 0.013, "d_s2": 0.019, "d_s3": 0.020, "d_s4": 0.002,
        "u_p2": 0.25, "d_p1": 0.012, "d_p2": 0.014, "d_p3": 0.025, "d_p4": 0.002,
    },
}
