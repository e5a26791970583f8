"""Write examples/identify_ethernet.yaml: a synthetic identification experiment.

The Ethernet cable of thesis 7.2 (E = 7.5e6 Pa, n = 16, rod bending model) is held by the
first clip only, which tilts up by 45 degrees (a cantilever: its outcome is smooth in E, see
docs/identification.md); its final shape gets 1 mm of Gaussian noise and is resampled to 49
points. Run
``dloplan identify examples/identify_ethernet.yaml`` (or ``identify_youngs_modulus``) to
recover E.

    PYTHONPATH=src python examples/make_identify_ethernet.py
"""

from pathlib import Path

from dloplan.app.identification import dump_identification, experiment_to_dict
from dloplan.cable import catalogue_cable
from dloplan.identify import cantilever_manipulation, synthetic_experiment
from dloplan.output_files import atomic_write_text

cable = catalogue_cable("ethernet", n_links=16)
manipulation = cantilever_manipulation(cable, angle=45.0)
experiment = synthetic_experiment(cable, manipulation, noise=1e-3, seed=7)
data = experiment_to_dict(
    experiment, {"name": "ethernet", "n_links": 16, "youngs_modulus": "identify"},
    bounds=(1e5, 1e10), units="mm", decimals=3,
)
header = (
    "# Synthetic identification experiment (examples/make_identify_ethernet.py): the\n"
    "# Ethernet cable at E = 7.5e6 Pa (rod bending model) held by the first clip, tilted up\n"
    "# 45 deg; final shape with 1 mm noise, 49 points. Lengths in mm.\n"
)
target = Path(__file__).with_name("identify_ethernet.yaml")
atomic_write_text(target, header + dump_identification(data))
print(f"wrote {target}")
