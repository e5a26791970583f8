"""Size and writing time of the HTML report of the demo, the UR5e and the Panda example.

Plans each job once (``dloplan demo``'s embedded job and ``examples/cells/*.yaml``, with the
robot checks, as ``dloplan plan`` does; not timed), writes its figures, then writes its report
three times and quotes the best wall time, the file's size and what it is made of: the vendored
three.js bundle, the viewer, the robot's meshes (base64), the plan's data without them, the
embedded PNG figures (base64) and the rest (markup, tables). The report must stay a single
offline file "under a few MB".

Measured on the 2 shared cores of the development machine (load average 11-13, other agents
running; the times move with the load, the sizes do not), sizes in MB:

    demo (YuMi): 1.52 MB = three.js 0.58 + viewer 0.02 + meshes 0.30 + plan 0.01 + figures 0.59
                 + rest 0.01; written in 0.07 s (best of 3)
    UR5e pair:   1.49 MB = three.js 0.58 + viewer 0.02 + meshes 0.28 + plan 0.01 + figures 0.58
                 + rest 0.01; written in 0.04 s (best of 3)
    Panda pair:  1.57 MB = three.js 0.58 + viewer 0.02 + meshes 0.34 + plan 0.01 + figures 0.60
                 + rest 0.01; written in 0.06 s (best of 3)

(run ``PYTHONPATH=tests python benchmarks/bench_report.py`` for the current numbers).
"""

from __future__ import annotations

import json
import re
import tempfile
import time
from importlib import resources
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
JOBS = {"demo (YuMi)": None, "UR5e pair": ROOT / "examples/cells/ur5e_pair_usb.yaml",
        "Panda pair": ROOT / "examples/cells/panda_pair_ethernet.yaml"}


def plan(path):
    """The job's plan document with its verified robot program (as ``dloplan plan``)."""
    from dloplan.app import load_scenario, run_job
    from dloplan.app.load import resolve_mapping
    from dloplan.io.scenario import read_mapping

    if path is None:
        with resources.as_file(resources.files("dloplan.data").joinpath("demo.yaml")) as demo:
            job = resolve_mapping(read_mapping(demo), "demo (embedded)")
    else:
        job = load_scenario(path)
    return run_job(job, verify=True)


def parts(page: str) -> dict[str, int]:
    """Bytes of the page by part."""
    scripts = re.findall(r"<script[^>]*>(.*?)</script>", page, flags=re.S)
    data, three, viewer = scripts
    meshes = len(json.dumps(json.loads(data.replace("<\\/", "</"))["meshes"],
                            separators=(",", ":")))
    figures = sum(len(m) for m in re.findall(r"data:image/png;base64,[^'\"]*", page))
    total = len(page.encode())
    sizes = {"three.js": len(three), "viewer": len(viewer), "meshes": meshes,
             "plan": len(data) - meshes, "figures": figures}
    sizes["rest"] = total - sum(sizes.values())
    return {"total": total, **sizes}


def main() -> None:
    from dloplan.app.writers import WRITERS, WriteOptions

    for name, path in JOBS.items():
        doc = plan(path)
        with tempfile.TemporaryDirectory() as folder:
            folder = Path(folder)
            WRITERS["figures"].write(doc, folder / "figures", WriteOptions())
            best = float("inf")
            for _ in range(3):
                start = time.perf_counter()
                (report,) = WRITERS["report"].write(doc, folder / "report.html", WriteOptions())
                best = min(best, time.perf_counter() - start)
            sizes = parts(report.read_text())
        detail = " + ".join(f"{k} {v / 1e6:.2f}" for k, v in sizes.items() if k != "total")
        print(f"{name}: {sizes['total'] / 1e6:.2f} MB = {detail}; written in {best:.2f} s "
              "(best of 3)")


if __name__ == "__main__":
    main()
