"""What the interop scripts share: a command run with its output kept for the error, the
ATE by `gfsvo eval`, and a Cyclone DDS configuration held to the loopback interface."""

import json
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent.parent
GFSVO = str(REPO / "target" / "release" / "gfsvo")


def sh(*args, **kw):
    """Runs a command, echoed; its standard output, or exit with the tail of its output."""
    print("+", " ".join(map(str, args)), flush=True)
    done = subprocess.run(list(map(str, args)), text=True, capture_output=True, **kw)
    if done.returncode != 0:
        raise SystemExit(f"{args[0]}: exit {done.returncode}:\n"
                         f"{done.stdout[-2000:]}{done.stderr[-3000:]}")
    return done.stdout


def ate(groundtruth, trajectory):
    """ATE RMSE in metres of a TUM trajectory against the ground truth, by `gfsvo eval`."""
    out = sh(GFSVO, "eval", "--gt", groundtruth, "--est", trajectory, "--json")
    return json.loads(out)["ate_rmse_m"]


def loopback_cyclone(work):
    """Writes a Cyclone DDS configuration on the loopback interface into `work`; its URI."""
    path = Path(work) / "cyclone.xml"
    path.write_text(
        '<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface name="lo"/>'
        "</Interfaces></General></Domain></CycloneDDS>\n")
    return f"file://{path}"
