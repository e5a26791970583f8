"""The bounds every input of dloplan is held to, in one place (docs/scenario.md, "Limits").

A file can be endless (``/dev/zero``) and a count can be a billion: each bound keeps a run's time
and memory within what a workstation has, with room above any real job. The command line, the
scenario schema and the readers take them from here; ``tests/test_docs_agree.py`` checks the
table of docs/scenario.md against them. Nothing is imported here: the command line reads these
before it loads anything heavy.
"""

MIN_LINKS, MAX_LINKS = 4, 1000
"""n, the links of a cable: each clip holds two points, so n = 4 is the least with a free point;
n = 1000 plans in minutes at most."""

MAX_SHAPES = 500
"""S, the intermediate shapes of a plan."""

MAX_INPUT_BYTES = 10_000_000
"""Largest input file read [bytes]: a job, identification, shape, calibration or URDF file. 10 MB
is some 100 000 points, far more than any cable needs (a shape is resampled to n + 1 <= 1001
points), and loads in seconds."""

MAX_PLAN_BYTES = 256_000_000
"""Largest plan document read [bytes] (its size grows with (S + 2)(n + 1); a plan of the largest
n and S is of this order)."""

MAX_MESH_BYTES = 100_000_000
"""Largest mesh file a URDF may name for its collision capsules [bytes]."""

MAX_TRAJECTORY_SAMPLES = 1_000_000
"""Most samples of a sampled trajectory (CSV, ROS at a rate): 2.7 hours of motion at 100 Hz, as
CSV about 200 MB."""

MAX_RATE = 10_000.0
"""Highest sampling rate of an exported trajectory [Hz] (a robot controller's cycle is 0.25 ms
or longer)."""

SLOWEST = 1e-5
"""Least value of every motion limit (speed, acceleration, jerk, linear and angular) in SI units
(m/s, m/s^2, m/s^3, rad/s, ...): 0.01 mm/s moves a metre in 28 hours; 1e-300 m/s would leave
the time-optimal law's solver without a solution."""

WORKSPACE = 10.0
"""Largest distance [m] of any point of a job, a measured shape or a calibrated camera from the
origin of its frame: a dual-arm cell spans about a metre, so a coordinate beyond 10 m is a typo
(often metres written into a mm file)."""

MAX_STUDY_SAMPLES = 10_000_000
"""Most samples of a study."""

MAX_WORKERS = 256
"""Most local worker processes (--workers)."""

MAX_MEASURED_POINTS = 100_000
"""Most points of a measured shape in an experiment design or a study's correction."""

MAX_MODULUS_STEPS = 100
"""Most Gauss-Newton steps of a correction's E update (--modulus-steps)."""
